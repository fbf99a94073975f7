// The documents of a sim-to-real diagnosis (issue 14): its JSON (verdict, ranking per round, where
// the gap lies) and its HTML report with the plots scripts/plot_diagnosis.py draws; and the whole of
// what `pneumo diagnose` computes: the logs read, the diagnosis run (diagnosis/diagnose.h), its
// verdict graded on a test log, the report written. `pneumo diagnose` parses its arguments, prints
// the JSON and reports progress.
#ifndef PNEUMATIC_DIAGNOSIS_REPORT_H_
#define PNEUMATIC_DIAGNOSIS_REPORT_H_

#include <string>

#include <nlohmann/json.hpp>

#include "diagnosis/diagnose.h"

namespace pneumatic {

struct DiagnoseLogOptions {
  std::string model_path, train_path, heldout_path, report_dir;
  // a test log the diagnosis does not see, on which the verdict is graded (GradeOnLog): "" none
  std::string test_path;
  diagnosis::DiagnoseOptions diagnose;  // with its progress, if set, told each step
};

// The JSON of a diagnosis (README, "Diagnosis": verdict, ranking per round, where the gap lies).
nlohmann::json DiagnosisJson(const diagnosis::Diagnosis& d);

// "" if the report may go into `dir` (a folder, or nothing there yet), else why not
std::string ReportDirProblem(const std::string& dir);

// Writes the report of d into o.report_dir, created if missing: diagnosis.json (j), series.csv (per
// held-out row: each signal measured, before and after, the estimated velocities, the regimes), the
// PNG plots of scripts/plot_diagnosis.py and index.html. "" or the error.
std::string WriteReport(const diagnosis::Diagnosis& d, const nlohmann::json& j, const DiagnoseLogOptions& o);

// Reads the logs (the training log, and the held-out and test logs when given), diagnoses the model
// against them, grades the verdict's model on the test log (the JSON's "test") and, with a
// report_dir, writes the report there. "" or the message naming the input at fault; on "",
// *result is the diagnosis and *document its JSON.
std::string DiagnoseLog(const DiagnoseLogOptions& options, diagnosis::Diagnosis* result, nlohmann::json* document);

}  // namespace pneumatic

#endif  // PNEUMATIC_DIAGNOSIS_REPORT_H_
