// `pneumo params [--markdown]`: the MJCF parameter table of the extension (docs/parameters.md is its
// Markdown).
#ifndef PNEUMATIC_CLI_PARAMS_COMMAND_H_
#define PNEUMATIC_CLI_PARAMS_COMMAND_H_

#include <CLI/CLI.hpp>

#include "cli/command_support.h"

namespace pneumatic::cli {

// Adds `pneumo params` to app.
Command AddParamsCommand(CLI::App& app);

}  // namespace pneumatic::cli

#endif  // PNEUMATIC_CLI_PARAMS_COMMAND_H_
