// `pneumo reproduce karpenko2006|hodgson2012|laib2021 [--out DIR]`: a paper's experiment rerun on its rig
// (reproductions/), its headline figures printed as JSON next to the paper's.
#ifndef PNEUMATIC_CLI_REPRODUCE_COMMAND_H_
#define PNEUMATIC_CLI_REPRODUCE_COMMAND_H_

#include <CLI/CLI.hpp>

#include "cli/command_support.h"

namespace pneumatic::cli {

// Adds `pneumo reproduce` to app.
Command AddReproduceCommand(CLI::App& app);

}  // namespace pneumatic::cli

#endif  // PNEUMATIC_CLI_REPRODUCE_COMMAND_H_
