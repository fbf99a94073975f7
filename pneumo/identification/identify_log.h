// pneumo identify: paper 000's parametric pressure model and the physical parameters of the
// nominal model, fitted to a log and validated on a held-out one (issue 13). The command-line
// layer: reads the inputs, runs the fitting layer (identification/), writes PARAMS.json, the
// drift plot and the fitted models.
#ifndef PNEUMATIC_IDENTIFY_COMMAND_H_
#define PNEUMATIC_IDENTIFY_COMMAND_H_

#include <string>
#include <vector>

namespace pneumatic {

struct IdentifyOptions {
  std::string model_path;       // MJCF with pneumatic cylinders
  std::string log_path;         // training log (docs/log_format.md)
  std::string out_path;         // PARAMS.json
  std::string heldout_path;     // optional held-out log: one-step fit and drift (paper 000 Figs. 11-13)
  std::string plot_path;        // drift PNG; default: PARAMS.json's path with ".drift.png"
  std::string write_model_path;             // optional: the MJCF with the fitted physical values
  std::string write_identified_model_path;  // optional: the MJCF with pressure_model=identified, c1..c9
  std::vector<std::string> fit_keys;        // "<cyl>:<key>"; empty: the defaults of each cylinder
  bool parametric = true;       // fit paper 000's c1..c9 per chamber
  // > 0: refine each chamber's one-step fit on its own predictions over sequences this long, s
  // (identification/output_error_fit.h); 0: paper 000's one-step fit alone
  double refine_horizon_s = 0;
  bool physical = true;         // fit the physical parameters
  int threads = 2;
};

// Runs the command; progress and a summary go to stderr. Returns the exit code: 0, or 1 with a
// message naming the input at fault. Outputs are written whole or not at all.
int RunIdentify(const IdentifyOptions& options);

}  // namespace pneumatic

#endif  // PNEUMATIC_IDENTIFY_COMMAND_H_
