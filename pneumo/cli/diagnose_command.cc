#include "cli/diagnose_command.h"

#include <cstdio>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

namespace pneumatic {

int RunDiagnose(const DiagnoseCommandOptions& options) {
  auto fail = [](const std::string& message) {
    std::fprintf(stderr, "pneumo diagnose: %s\n", message.c_str());
    return 1;
  };
  DiagnoseLogOptions o = options;
  if (!options.quiet) o.diagnose.progress = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  diagnosis::Diagnosis d;
  nlohmann::json j;
  if (std::string e = DiagnoseLog(o, &d, &j); !e.empty()) return fail(e);
  if (!options.report_dir.empty() && !options.quiet) std::fprintf(stderr, "report: %s/index.html\n", options.report_dir.c_str());
  std::printf("%s\n", j.dump(2).c_str());
  return 0;
}

}  // namespace pneumatic

namespace pneumatic::cli {

Command AddDiagnoseCommand(CLI::App& app) {
  auto arguments = std::make_shared<pneumatic::DiagnoseCommandOptions>();
  pneumatic::DiagnoseCommandOptions& diagnose_options = *arguments;
  CLI::App* diagnose = app.add_subcommand(
      "diagnose", "find where a model and a measured log part, which unmodelled effect explains it, and how far the gap shrinks");
  diagnose->add_option("model", diagnose_options.model_path, "MJCF model with pneumatic cylinders")->required();
  diagnose->add_option("log", diagnose_options.train_path, "training log (docs/log_format.md), closed loop, no v needed; a p_S column, if any, is used as the supply pressure measured")
      ->required();
  diagnose->add_option("--heldout", diagnose_options.heldout_path,
                       "held-out log (default: the last 30 % of the training log is held out)");
  diagnose->add_option("--test", diagnose_options.test_path,
                       "a third log the diagnosis does not see: the verdict's model is graded on it (JSON \"test\")");
  diagnose->add_option("--report", diagnose_options.report_dir, "directory for the HTML report and its PNG plots");
  diagnose->add_option("--calibration-iterations", diagnose_options.diagnose.calibration_iterations,
                       "iterations of the calibration of the model's nominal parameters before the effects (0: none)")
      ->capture_default_str()->check(CLI::Range(0, 200));
  diagnose->add_flag("--search-unstructured", diagnose_options.diagnose.search_unstructured,
                     "search the effects even where the calibrated model's (or the found effects') residual is within the floor's margin and "
                     "depends on no state beyond noise (default: not searched, or no further round)");
  diagnose->add_option("--horizon", diagnose_options.diagnose.horizon_s, "prediction window, s")->capture_default_str()
      ->check(CLI::Range(0.005, 10.0));
  diagnose->add_option("--max-effects", diagnose_options.diagnose.max_effects, "effects searched one after the other")
      ->capture_default_str()->check(CLI::Range(1, 5));
  diagnose->add_option("--threads", diagnose_options.diagnose.threads, "threads for the predictions")->capture_default_str()
      ->check(CLI::Range(1, 64));
  diagnose->add_flag("--quiet", diagnose_options.quiet, "no progress on stderr");
  diagnose->footer(
      "Prints JSON: verdict.{effect (an effect, none or unexplained), effects, params, calibration, noise_floor,\n"
      "unexplained, alternatives, search, heldout_gap_before, heldout_gap_after}, the ranking of every\n"
      "candidate (score = the information criterion dIC), where the gap lies (per signal, regime, over time).\n"
      "README, \"Diagnosis\", defines the gap and the verdict rule.");
  return {diagnose, [arguments] { return pneumatic::RunDiagnose(*arguments); }};
}

}  // namespace pneumatic::cli
