#include "cli/identify_command.h"

#include <cstdio>
#include <memory>
#include <string>

namespace pneumatic {
namespace {

int Fail(const std::string& message) {
  std::fprintf(stderr, "pneumo identify: %s\n", message.c_str());
  return 1;
}

void Say(const std::string& message) { std::fprintf(stderr, "pneumo identify: %s\n", message.c_str()); }

}  // namespace

int RunIdentify(const IdentifyOptions& options) {
  if (std::string e = CheckIdentifyOptions(options); !e.empty()) return Fail(e);
  IdentifyResult result = IdentifyLog(options, Say);
  if (!result.error.empty()) return Fail(result.error);
  if (std::string e = WriteIdentifyOutputs(options, result, Say); !e.empty()) return Fail(e);
  return 0;
}

}  // namespace pneumatic

namespace pneumatic::cli {

Command AddIdentifyCommand(CLI::App& app) {
  struct Arguments {
    pneumatic::IdentifyOptions identify_options;
    bool skip_parametric = false, skip_physical = false;
  };
  auto arguments = std::make_shared<Arguments>();
  pneumatic::IdentifyOptions& identify_options = arguments->identify_options;
  CLI::App* identify = app.add_subcommand(
      "identify", "fit paper 000's parametric pressure model and the physical parameters of the model to a log");
  identify->add_option("model", identify_options.model_path, "MJCF model with pneumatic cylinders")->required();
  identify->add_option("log", identify_options.log_path, "training log (docs/log_format.md)")->required();
  identify->add_option("--out", identify_options.out_path, "PARAMS.json to write")->required();
  identify->add_option("--heldout", identify_options.heldout_path,
                       "held-out log: one-step fit % and the 2 s drift of paper 000 Fig. 13 (JSON and PNG)");
  identify->add_option("--plot", identify_options.plot_path, "drift PNG (default: PARAMS.json's name + .drift.png)");
  identify->add_option("--write-model", identify_options.write_model_path,
                       "write a copy of the MJCF with the fitted physical parameters");
  identify->add_option("--write-identified-model", identify_options.write_identified_model_path,
                       "write a copy of the MJCF with pressure_model=identified and the fitted c1..c9");
  identify->add_option("--fit", identify_options.fit_keys,
                       "physical parameter to fit, <cylinder>:<key> (repeatable; default: each cylinder's usual set)");
  bool &skip_parametric = arguments->skip_parametric, &skip_physical = arguments->skip_physical;
  identify->add_option("--refine-horizon", identify_options.refine_horizon_s,
                       "refine each chamber's c1..c9 on the model's own predictions over sequences this long, s "
                       "(output error; 0: paper 000's one-step fit alone)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 10.0));
  identify->add_flag("--skip-parametric", skip_parametric, "do not fit paper 000's c1..c9");
  identify->add_flag("--skip-physical", skip_physical, "do not fit the physical parameters");
  identify->add_option("--threads", identify_options.threads, "threads for the fits")->capture_default_str()
      ->check(CLI::Range(1, 64));
  identify->footer(
      "Parametric model (paper 000 eqs. 7-10): per chamber, c1..c9 by bounded least squares (Ceres) on the next-step\n"
      "prediction of the pressure, Table I's bounds, c_gamma = 0.1 V, c_b and c_s from p_supply and p_exhaust; v is the\n"
      "logged x, its rate the forward difference (x[t+1] - x[t]) / h. Needs valve=proportional_per_chamber.\n"
      "--refine-horizon S then refines each chamber's c1..c9 on the model's own predictions (eq. 7 run from the measured\n"
      "p for S seconds, from starts every S/2), the quantity paper 000's drift measures (the project's own addition).\n"
      "Physical parameters: the model's pressures simulated along the measured motion (pneumo rollout --follow-motion)\n"
      "fitted to the measured ones; standard errors from the covariance at the optimum (Newey-West for residuals\n"
      "correlated in time), with a flag on each poorly determined parameter naming the reason.");
  return {identify, [arguments] {
    arguments->identify_options.parametric = !arguments->skip_parametric;
    arguments->identify_options.physical = !arguments->skip_physical;
    return pneumatic::RunIdentify(arguments->identify_options);
  }};
}

}  // namespace pneumatic::cli
