// `pneumo diagnose MODEL.xml LOG.csv [--heldout LOG2.csv] [--test LOG3.csv] [--report DIR]`: the
// command line of diagnosis/report.h (the sim-to-real diagnosis of a model against a measured log,
// issue 14): JSON on stdout, progress on stderr, the HTML report with its plots in DIR.
#ifndef PNEUMATIC_CLI_DIAGNOSE_COMMAND_H_
#define PNEUMATIC_CLI_DIAGNOSE_COMMAND_H_

#include <CLI/CLI.hpp>

#include "cli/command_support.h"
#include "diagnosis/report.h"

namespace pneumatic {

struct DiagnoseCommandOptions : DiagnoseLogOptions {
  bool quiet = false;  // no progress on stderr
};

// Runs the command: JSON on stdout, progress on stderr, the report in report_dir when given.
// Returns the exit code: 0, or 1 with a message naming the input at fault.
int RunDiagnose(const DiagnoseCommandOptions& options);

}  // namespace pneumatic

namespace pneumatic::cli {

// Adds `pneumo diagnose` to app.
Command AddDiagnoseCommand(CLI::App& app);

}  // namespace pneumatic::cli

#endif  // PNEUMATIC_CLI_DIAGNOSE_COMMAND_H_
