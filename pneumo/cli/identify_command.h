// `pneumo identify MODEL.xml LOG.csv --out PARAMS.json [--heldout LOG2.csv] ...`: the command line of
// identification/identify_log.h (paper 000's parametric pressure model and the physical parameters of
// the nominal model, fitted to a log and validated on a held-out one, issue 13).
#ifndef PNEUMATIC_CLI_IDENTIFY_COMMAND_H_
#define PNEUMATIC_CLI_IDENTIFY_COMMAND_H_

#include <CLI/CLI.hpp>

#include "cli/command_support.h"
#include "identification/identify_log.h"

namespace pneumatic {

// Runs the command; progress and a summary go to stderr. Returns the exit code: 0, or 1 with a
// message naming the input at fault. Outputs are written whole or not at all.
int RunIdentify(const IdentifyOptions& options);

}  // namespace pneumatic

namespace pneumatic::cli {

// Adds `pneumo identify` to app.
Command AddIdentifyCommand(CLI::App& app);

}  // namespace pneumatic::cli

#endif  // PNEUMATIC_CLI_IDENTIFY_COMMAND_H_
