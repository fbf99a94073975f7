// `pneumo info MODEL.xml`: a model's cylinders, their log signals and the controller configurations
// it carries.
#ifndef PNEUMATIC_CLI_INFO_COMMAND_H_
#define PNEUMATIC_CLI_INFO_COMMAND_H_

#include <CLI/CLI.hpp>

#include "cli/command_support.h"

namespace pneumatic::cli {

// Adds `pneumo info` to app.
Command AddInfoCommand(CLI::App& app);

}  // namespace pneumatic::cli

#endif  // PNEUMATIC_CLI_INFO_COMMAND_H_
