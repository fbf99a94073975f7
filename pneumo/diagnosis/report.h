// pneumo diagnose: the sim-to-real diagnosis of a model against a measured log (issue 14). The
// command-line layer: reads the logs, runs diagnosis/diagnose.h, prints the JSON and writes the
// HTML report with its plots.
#ifndef PNEUMATIC_DIAGNOSE_COMMAND_H_
#define PNEUMATIC_DIAGNOSE_COMMAND_H_

#include <string>

#include <nlohmann/json.hpp>

#include "diagnosis/diagnose.h"

namespace pneumatic {

struct DiagnoseCommandOptions {
  std::string model_path, train_path, heldout_path, report_dir;
  // a test log the diagnosis does not see, on which the verdict is graded (GradeOnLog): "" none
  std::string test_path;
  diagnosis::DiagnoseOptions diagnose;
  bool quiet = false;  // no progress on stderr
};

// The JSON of a diagnosis (README, "Diagnosis": verdict, ranking per round, where the gap lies).
nlohmann::json DiagnosisJson(const diagnosis::Diagnosis& d);

// Runs the command: JSON on stdout, progress on stderr, the report in report_dir when given.
// Returns the exit code: 0, or 1 with a message naming the input at fault.
int RunDiagnose(const DiagnoseCommandOptions& options);

}  // namespace pneumatic

#endif  // PNEUMATIC_DIAGNOSE_COMMAND_H_
