#include "identification/identify_log.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <optional>

#include <mujoco/mujoco.h>
#include <nlohmann/json.hpp>

#include "formats/log_csv.h"
#include "formats/model_file.h"
#include "formats/output_file.h"
#include "formats/report_files.h"
#include "identification/chamber_series.h"
#include "identification/drift.h"
#include "identification/output_error_fit.h"
#include "identification/parametric_fit.h"
#include "identification/physical_fit.h"
#include "pneumatic/pneumatic.h"
#include "simulation/rollout.h"

namespace pneumatic {
namespace {

using nlohmann::json;
namespace id = identification;

// paper 000 V.D, Fig. 13: drift "less than 10 % of the difference between chamber and room
// pressure, and usually less than 4 %", from 48 starts over 2 s
constexpr int kDriftStarts = 48;
constexpr double kDriftHorizon = 2.0;  // s

using ModelPtr = IdentifiedModelPtr;

ModelPtr LoadAttached(const std::string& path, std::string* error) {
  char buffer[1000] = "";
  ModelPtr m(mj_loadXML(path.c_str(), nullptr, buffer, sizeof(buffer)));
  if (!m) {
    *error = path + ": " + buffer;
    return nullptr;
  }
  if (!Attach(m.get(), error)) {
    *error = path + ": " + *error;
    return nullptr;
  }
  if (Cylinders(m.get()).empty()) {
    *error = path + ": the model has no pneumatic cylinder";
    return nullptr;
  }
  return m;
}

std::optional<log::Log> ReadLogFor(const mjModel* m, const std::string& path, std::string* error) {
  log::ReadOptions read;
  for (const CylinderInfo& c : Cylinders(m)) read.cylinders.insert(c.name);
  log::ReadResult r = log::ReadLog(path, read);
  if (!r.log) {
    *error = r.error;
  } else if (std::string problem = CheckMeasurements(m, *r.log); !problem.empty()) {
    *error = problem;
    return std::nullopt;
  }
  return r.log;
}

// JSON numbers must be finite: an undetermined standard error is written as null
json Number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json ChamberJson(const id::ParametricFit& fit) {
  json c = json::array(), se = json::array();
  for (int i = 0; i < 9; ++i) {
    c.push_back(fit.model.c[i]);
    se.push_back(Number(fit.standard_error[i]));
  }
  return {{"c", c},
          {"c_gamma", fit.model.c_gamma},
          {"c_b", fit.model.c_b},
          {"c_s", fit.model.c_s},
          {"standard_error", se},
          {"rms_residual_pa", fit.rms_residual},
          {"one_step_fit_pct", fit.one_step_fit_pct},
          {"iterations", fit.iterations},
          {"converged", fit.converged},
          {"warnings", fit.warnings}};
}

json DriftJson(const id::DriftCurve& curve) {
  return {{"horizon_s", curve.horizon_s}, {"std_pct", curve.std_pct}, {"rms_pct", curve.rms_pct},
          {"sequences", curve.sequences}};
}

// each one-step fit replaced by its output-error refinement (identification/output_error_fit.h); the
// chamber's JSON keeps the one-step c and says what the refinement did. Standard errors are the
// one-step fit's covariance, which does not hold at the refined c: they become null
std::string RefineFits(const std::vector<id::ChamberSeries>& series, double horizon_s, int threads, const IdentifySay& say,
                       std::vector<id::ParametricFit>* fits, json* chambers) {
  char line[120];
  std::snprintf(line, sizeof(line), "refining each chamber's fit on its own predictions over %g s sequences (output error)",
                horizon_s);
  say(line);
  std::vector<id::ParametricModel> starts;
  for (const id::ParametricFit& fit : *fits) starts.push_back(fit.model);
  id::OutputErrorOptions options;
  options.horizon_s = horizon_s;
  const std::vector<id::OutputErrorFit> refined = id::RefineOutputErrors(series, starts, options, threads);
  for (size_t i = 0; i < refined.size(); ++i) {
    const id::OutputErrorFit& r = refined[i];
    if (!r.error.empty()) return r.name + ": output-error refinement: " + r.error;
    id::ParametricFit& fit = (*fits)[i];
    const std::array<double, 9> one_step = fit.model.c;
    fit.model = r.model;
    const id::OneStepScore score = id::ScoreOneStep(series[i], fit.model);
    fit.rms_residual = score.rms_residual;
    fit.one_step_fit_pct = score.fit_pct;
    fit.standard_error.fill(std::nan(""));
    for (std::string& w : fit.warnings) w = "one-step fit: " + w;
    for (const std::string& w : r.warnings) fit.warnings.push_back("output-error refinement: " + w);
    json entry = ChamberJson(fit);
    entry["output_error"] = {{"horizon_s", horizon_s},
                             {"sequences", r.sequences},
                             {"rms_before_pa", r.rms_before_pa},
                             {"rms_after_pa", r.rms_after_pa},
                             {"iterations", r.iterations},
                             {"converged", r.converged},
                             {"one_step_c", one_step}};
    (*chambers)[fit.name] = entry;
  }
  return "";
}

// the parametric model per chamber: fit on the training log (refined on its own predictions if
// refine_horizon_s > 0), scored on the held-out one
std::string FitParametric(const mjModel* m, const log::Log& train, const log::Log* heldout, double refine_horizon_s,
                          int threads, const IdentifySay& say, std::vector<id::ParametricFit>* fits, json* report) {
  std::vector<id::ChamberSeries> series;
  if (std::string e = id::ExtractChambers(m, train, &series); !e.empty()) return e;
  say("fitting paper 000's model (eqs. 7-10) to " + std::to_string(series.size()) + " chambers, " +
      std::to_string(series[0].u.size()) + " samples each");
  *fits = id::FitChambers(series, id::ParametricFitOptions{}, threads);
  json chambers = json::object();
  for (const id::ParametricFit& fit : *fits) {
    if (!fit.error.empty()) return fit.name + ": " + fit.error;
    chambers[fit.name] = ChamberJson(fit);
  }
  if (refine_horizon_s > 0) {
    if (std::string e = RefineFits(series, refine_horizon_s, threads, say, fits, &chambers); !e.empty()) return e;
  }
  for (const id::ParametricFit& fit : *fits) {
    for (const std::string& w : fit.warnings) say("warning: " + fit.name + ": " + w);
  }
  (*report)["chambers"] = chambers;
  if (!heldout) return "";

  std::vector<id::ChamberSeries> held;
  if (std::string e = id::ExtractChambers(m, *heldout, &held); !e.empty()) return "held-out log: " + e;
  if (held.size() != series.size()) return "the held-out log does not have the training log's chambers";
  std::vector<id::ParametricModel> models;
  json per_chamber = json::object();
  for (size_t i = 0; i < held.size(); ++i) {
    if (held[i].name != (*fits)[i].name) return "the held-out log does not have the training log's chambers";
    models.push_back((*fits)[i].model);
    id::OneStepScore score = id::ScoreOneStep(held[i], models.back());
    id::DriftCurve drift = id::Drift(held[i], models.back(), kDriftStarts, kDriftHorizon);
    if (!drift.error.empty()) return "held-out log: " + held[i].name + ": " + drift.error;
    per_chamber[held[i].name] = {{"one_step_fit_pct", score.fit_pct},
                                 {"rms_residual_pa", score.rms_residual},
                                 {"drift", DriftJson(drift)},
                                 {"drift_std_pct_at_horizon", drift.std_pct.back()}};
  }
  id::DriftCurve pooled = id::PoolDrift(held, models, kDriftStarts, kDriftHorizon);
  if (!pooled.error.empty()) return "held-out log: " + pooled.error;
  (*report)["heldout"]["parametric"] = {
      {"chambers", per_chamber},
      {"pooled_drift", DriftJson(pooled)},
      {"pooled_drift_std_pct_at_horizon", pooled.std_pct.back()},
      {"method", "paper 000 V.D: from 48 evenly spaced starts, p^ = p measured, then eq. 7 along the measured u, x "
                 "and x rate for 2 s; standard deviation of p^ - p over the starts, in % of p_supply - p_exhaust"},
      {"paper", {{"usually_below_pct", 4}, {"below_pct", 10}}}};
  return "";
}

// the follow-motion RMS pressure error of m on a log (Pa), both chambers of every cylinder
std::optional<double> FollowMotionRms(const mjModel* m, const log::Log& log, std::string* error) {
  RolloutOptions options;
  options.follow_motion = true;
  RolloutResult sim = Rollout(m, &log, options);
  if (!sim.log) {
    *error = sim.error;
    return std::nullopt;
  }
  double sum = 0;
  long count = 0;
  for (const CylinderInfo& c : Cylinders(m)) {
    for (const char* signal : {"p_P", "p_N"}) {
      int measured = log.FindColumn(c.name, signal), simulated = sim.log->FindColumn(c.name, signal);
      if (measured < 0 || simulated < 0) continue;
      for (size_t row = 1; row < sim.log->rows(); ++row) {
        double e = sim.log->values[simulated][row] - log.values[measured][row];
        sum += e * e;
        ++count;
      }
    }
  }
  return count ? std::sqrt(sum / static_cast<double>(count)) : 0.0;
}

std::string FitPhysical(const mjModel* m, const log::Log& train, const log::Log* heldout,
                        const std::vector<std::string>& key_texts, int threads, const IdentifySay& say, ModelPtr* fitted,
                        json* report) {
  id::PhysicalFitOptions options;
  options.threads = threads;
  std::string error;
  if (key_texts.empty()) {
    for (const CylinderInfo& c : Cylinders(m)) {
      std::vector<id::FitKey> keys = id::DefaultPhysicalKeys(m, c.name, &error);
      if (!error.empty()) return error;
      options.keys.insert(options.keys.end(), keys.begin(), keys.end());
    }
  } else {
    for (const std::string& text : key_texts) {
      std::optional<id::FitKey> key = id::ParseFitKey(text, &error);
      if (!key) return "--fit '" + text + "': " + error;
      options.keys.push_back(*key);
    }
  }
  std::string names;
  for (const id::FitKey& k : options.keys) names += (names.empty() ? "" : ", ") + k.name();
  say("fitting the physical parameters " + names + " by simulating the pressures along the measured motion");
  options.progress = [&say](const std::string& line) { say("  " + line); };
  id::PhysicalFit fit = id::FitPhysical(m, train, options);
  if (!fit.error.empty()) return fit.error;
  for (const std::string& w : fit.warnings) say("warning: " + w);

  json parameters = json::object();
  for (const id::FittedParameter& p : fit.parameters) {
    parameters[p.cylinder][p.key] = {{"value", p.value},
                                     {"standard_error", Number(p.standard_error)},
                                     {"unit", p.unit},
                                     {"initial", p.initial},
                                     {"poorly_determined", p.poorly_determined.empty() ? json(nullptr)
                                                                                      : json(p.poorly_determined)}};
    if (!p.poorly_determined.empty()) say("warning: " + p.cylinder + ":" + p.key + " poorly determined: " + p.poorly_determined);
  }
  (*report)["physical"] = {{"parameters", parameters},
                           {"rms_before_pa", fit.rms_before_pa},
                           {"rms_after_pa", fit.rms_after_pa},
                           {"residuals", fit.residuals},
                           {"newey_west_lag_rows", fit.lag_window},
                           {"iterations", fit.iterations},
                           {"rollouts", fit.rollouts},
                           {"converged", fit.converged},
                           {"warnings", fit.warnings},
                           {"method", "pressures simulated along the measured motion (paper 000 II.5, pneumo rollout "
                                      "--follow-motion), least squares in Pa over both chambers; standard errors from "
                                      "the sandwich covariance with a Newey-West estimate of the residuals' "
                                      "covariance at the optimum"}};

  fitted->reset(mj_copyModel(nullptr, m));
  if (std::string e = id::ApplyPhysicalFit(fitted->get(), fit); !e.empty()) return e;
  if (heldout) {
    std::optional<double> before = FollowMotionRms(m, *heldout, &error);
    std::optional<double> after = before ? FollowMotionRms(fitted->get(), *heldout, &error) : std::nullopt;
    if (!after) return "held-out log: " + error;
    (*report)["heldout"]["physical"] = {{"rms_before_pa", *before}, {"rms_after_pa", *after}};
  }
  return "";
}

// the shortest text that reads back to the same double
std::string Exact(double v) {
  char buffer[32];
  auto [end, error] = std::to_chars(buffer, buffer + sizeof(buffer), v);
  return error == std::errc() ? std::string(buffer, end) : std::string("nan");
}

// the identified model: pressure_model=identified with the fitted c1..c9 of each chamber
std::string WriteIdentifiedModel(const IdentifyOptions& options, const mjModel* m,
                                 const std::vector<id::ParametricFit>& fits) {
  ModelPtr copy(mj_copyModel(nullptr, m));
  std::map<std::string, std::vector<std::pair<std::string, std::string>>> values;
  for (const id::ParametricFit& fit : fits) {
    const std::string cylinder = fit.name.substr(0, fit.name.size() - 2);
    const std::string chamber = fit.name.substr(fit.name.size() - 1);  // "P" or "N"
    auto& v = values[cylinder];
    v.emplace_back(chamber + ".pressure_model", "identified");
    for (int i = 0; i < 9; ++i) v.emplace_back(chamber + ".c" + std::to_string(i + 1), Exact(fit.model.c[i]));
    v.emplace_back(chamber + ".c_gamma", Exact(fit.model.c_gamma));
  }
  for (const auto& [cylinder, v] : values) {
    std::string error;
    if (!SetParameters(copy.get(), cylinder, v, &error)) return error;
  }
  return WriteModelWithParameters(options.model_path, copy.get(), options.write_identified_model_path,
                                  "pressure_model=identified: paper 000's c1..c9 fitted by pneumo identify to " +
                                      options.log_path);
}

// the drift PNG, drawn by scripts/plot_drift.py (matplotlib) from PARAMS.json
std::string PlotDrift(const std::string& json_path, const std::string& png_path) {
  if (std::string e = RunPlotScript("plot_drift.py", {json_path, png_path}); !e.empty()) return png_path + ": " + e;
  return "";
}

}  // namespace

void IdentifiedModelDeleter::operator()(mjModel* m) const {
  Detach(m);
  mj_deleteModel(m);
}

std::string CheckIdentifyOptions(const IdentifyOptions& options) {
  if (!options.parametric && !options.physical) return "nothing to fit: both fits are switched off";
  if (options.write_identified_model_path.size() && !options.parametric) {
    return "--write-identified-model needs the parametric fit";
  }
  if (options.write_model_path.size() && !options.physical) return "--write-model needs the physical fit";
  // the outputs, checked before the fits (minutes on a large model) rather than after
  for (const auto& [path, kind] : {std::pair{options.out_path, "a JSON file"}, std::pair{options.plot_path, "a PNG image"},
                                   std::pair{options.write_model_path, "a model file"},
                                   std::pair{options.write_identified_model_path, "a model file"}}) {
    if (path.empty()) continue;
    if (std::string e = CheckOutputPath(path, kind); !e.empty()) return e;
  }
  return "";
}

IdentifyResult IdentifyLog(const IdentifyOptions& options, const IdentifySay& say) {
  IdentifyResult result;
  std::string& error = result.error;
  result.model = LoadAttached(options.model_path, &error);
  if (!result.model) return result;
  const mjModel* model = result.model.get();
  std::optional<log::Log> train = ReadLogFor(model, options.log_path, &error);
  if (!train) return result;
  std::optional<log::Log> heldout;
  if (!options.heldout_path.empty()) {
    heldout = ReadLogFor(model, options.heldout_path, &error);
    if (!heldout) return result;
  }
  const log::Log* held = heldout ? &*heldout : nullptr;

  json& report = result.report;
  report = {{"model", options.model_path}, {"log", options.log_path}};
  if (held) report["heldout"]["log"] = options.heldout_path;
  if (options.parametric) {
    if (std::string e = FitParametric(model, *train, held, options.refine_horizon_s, options.threads, say, &result.fits,
                                      &report);
        !e.empty()) {
      error = options.log_path + ": " + e;
      return result;
    }
  }
  if (options.physical) {
    if (std::string e = FitPhysical(model, *train, held, options.fit_keys, options.threads, say, &result.fitted, &report);
        !e.empty()) {
      error = options.log_path + ": " + e;
      return result;
    }
  }
  return result;
}

std::string WriteIdentifyOutputs(const IdentifyOptions& options, const IdentifyResult& result, const IdentifySay& say) {
  const json& report = result.report;
  const bool held = !options.heldout_path.empty();
  if (std::string e = WriteOutput(options.out_path, report.dump(2) + "\n", "a JSON file"); !e.empty()) return e;
  say("wrote " + options.out_path);
  if (held && options.parametric) {
    std::string png = options.plot_path;
    if (png.empty()) {
      png = options.out_path;
      if (png.size() > 5 && png.compare(png.size() - 5, 5, ".json") == 0) png.resize(png.size() - 5);
      png += ".drift.png";
    }
    if (std::string e = PlotDrift(options.out_path, png); !e.empty()) return e;
    const json& pooled = report["heldout"]["parametric"];
    char line[200];
    std::snprintf(line, sizeof(line), "held-out drift after %.0f s: %.2f %% of p_supply - p_exhaust (paper 000: usually "
                  "< 4 %%, always < 10 %%); wrote %s", kDriftHorizon, pooled["pooled_drift_std_pct_at_horizon"].get<double>(),
                  png.c_str());
    say(line);
  }
  if (!options.write_model_path.empty()) {
    if (std::string e = WriteModelWithParameters(options.model_path, result.fitted.get(), options.write_model_path,
                                                 "physical parameters fitted by pneumo identify to " + options.log_path);
        !e.empty()) {
      return e;
    }
    say("wrote " + options.write_model_path);
  }
  if (!options.write_identified_model_path.empty()) {
    if (std::string e = WriteIdentifiedModel(options, result.model.get(), result.fits); !e.empty()) return e;
    say("wrote " + options.write_identified_model_path);
  }
  return "";
}

}  // namespace pneumatic
