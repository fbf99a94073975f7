// `pneumo study PLAN.json --out DIR`: a parameter study (studies/study.h, docs/study.md): every point
// of the plan on threads (--jobs), or through a Dask scheduler (scripts/study_dask.py, which runs
// `pneumo study ... --point K` on the workers and `--collect` at the end); resumable, Ctrl-C stops
// starting new points.
#ifndef PNEUMATIC_CLI_STUDY_COMMAND_H_
#define PNEUMATIC_CLI_STUDY_COMMAND_H_

#include <CLI/CLI.hpp>

#include "cli/command_support.h"

namespace pneumatic::cli {

// Adds `pneumo study` to app.
Command AddStudyCommand(CLI::App& app);

}  // namespace pneumatic::cli

#endif  // PNEUMATIC_CLI_STUDY_COMMAND_H_
