// `pneumo generate MODEL.xml --duration S --seed N --out LOG.csv`: a closed-loop identification log
// of rig C, as paper 000 V.C recorded its data (simulation/generate.h).
#ifndef PNEUMATIC_CLI_GENERATE_COMMAND_H_
#define PNEUMATIC_CLI_GENERATE_COMMAND_H_

#include <CLI/CLI.hpp>

#include "cli/command_support.h"

namespace pneumatic::cli {

// Adds `pneumo generate` to app.
Command AddGenerateCommand(CLI::App& app);

}  // namespace pneumatic::cli

#endif  // PNEUMATIC_CLI_GENERATE_COMMAND_H_
