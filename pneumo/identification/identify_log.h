// What `pneumo identify` computes: paper 000's parametric pressure model and the physical
// parameters of the nominal model, fitted to a log and validated on a held-out one (issue 13).
// Reads the inputs, runs the fitting layer (identification/), and writes PARAMS.json, the drift plot
// and the fitted models; `pneumo identify` parses its arguments and calls these.
#ifndef PNEUMATIC_IDENTIFY_LOG_H_
#define PNEUMATIC_IDENTIFY_LOG_H_

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>
#include <nlohmann/json.hpp>

#include "identification/parametric_fit.h"

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

// a model of an identification, attached to the extension: detached and freed with its owner
struct IdentifiedModelDeleter {
  void operator()(mjModel* m) const;
};
using IdentifiedModelPtr = std::unique_ptr<mjModel, IdentifiedModelDeleter>;

// What an identification computes, before anything is written.
struct IdentifyResult {
  std::string error;           // "" or the message naming the input at fault
  nlohmann::json report;       // the document of PARAMS.json
  IdentifiedModelPtr model;    // the model as loaded from options.model_path
  IdentifiedModelPtr fitted;   // a copy with the fitted physical parameters (options.physical)
  std::vector<identification::ParametricFit> fits;  // paper 000's model per chamber (options.parametric)
};

// Hears the progress and the warnings, a line each (without a prefix).
using IdentifySay = std::function<void(const std::string&)>;

// The checks made before the fits (minutes on a large model) rather than after: a fit switched off
// that an output needs, and every output path (CheckOutputPath). "" or the message.
std::string CheckIdentifyOptions(const IdentifyOptions& options);

// Loads the model, reads the logs and runs the fits of `options`, progress and warnings to `say`.
// Writes nothing; result.error is "" or the message naming the input at fault.
IdentifyResult IdentifyLog(const IdentifyOptions& options, const IdentifySay& say);

// Writes PARAMS.json (options.out_path), the drift PNG (with a held-out log and the parametric
// fit) and the models asked for, each whole or not at all, saying what it wrote. "" or the message.
std::string WriteIdentifyOutputs(const IdentifyOptions& options, const IdentifyResult& result, const IdentifySay& say);

}  // namespace pneumatic

#endif  // PNEUMATIC_IDENTIFY_LOG_H_
