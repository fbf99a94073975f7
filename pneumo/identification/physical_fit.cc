#include "identification/physical_fit.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>
#include <utility>

#include <ceres/ceres.h>

#include "pneumatic/pneumatic.h"
#include "simulation/parallel_for.h"
#include "simulation/rollout.h"

namespace pneumatic::identification {
namespace {

using ModelPtr = std::unique_ptr<mjModel, void (*)(mjModel*)>;

std::string Format(const char* format, double a) {
  char text[64];
  std::snprintf(text, sizeof(text), format, a);
  return text;
}

std::string BaseKey(const std::string& key) {
  return key.rfind("P.", 0) == 0 || key.rfind("N.", 0) == 0 ? key.substr(2) : key;
}

const ParameterDoc* FindDoc(const std::string& base) {
  for (const ParameterDoc& doc : Parameters()) {
    if (doc.key == base) return &doc;
  }
  return nullptr;
}

// the word a choice key holds ("thin_plate"), from its index among the documented choices
std::string Choice(const mjModel* m, const std::string& cylinder, const std::string& key) {
  std::string ignored;
  std::optional<double> index = GetParameter(m, cylinder, key, &ignored);
  const ParameterDoc* doc = FindDoc(BaseKey(key));
  if (!index || !doc) return "";
  std::istringstream words(doc->valid);
  std::string word;
  for (int i = 0; words >> word; ++i) {
    if (i == static_cast<int>(*index)) return word;
  }
  return "";
}

// A FitKey checked against the model: where the optimiser may move it and in which unit.
struct ResolvedKey {
  FitKey key;
  std::string unit;
  double initial = 0;
  double s = 1;                 // the optimiser's variable is z = value / s
  double lower = 0, upper = 0;  // closed bounds on the value (open MJCF bounds moved inside by 1e-6 s)
};

// the model's value of a key; for a chamber key without prefix, the common value of P and N
std::optional<double> InitialValue(const mjModel* m, const FitKey& k, const ParameterDoc& doc, std::string* error) {
  bool chamber_key = doc.scope.rfind("chamber", 0) == 0;  // "chamber" or "chamber, flow=..."
  if (!chamber_key || BaseKey(k.key) != k.key) return GetParameter(m, k.cylinder, k.key, error);
  std::optional<double> p = GetParameter(m, k.cylinder, "P." + k.key, error);
  std::optional<double> n = GetParameter(m, k.cylinder, "N." + k.key, error);
  if (!p || !n) return std::nullopt;
  if (*p != *n) {
    *error = "cylinder '" + k.cylinder + "': key '" + k.key + "': P." + k.key + " = " + Format("%.6g", *p) +
             " and N." + k.key + " = " + Format("%.6g", *n) +
             " differ: fit them as two keys, or give them one value in the model first";
    return std::nullopt;
  }
  return p;
}

std::optional<ResolvedKey> Resolve(const mjModel* m, const FitKey& k, std::string* error) {
  auto fail = [&](const std::string& message) -> std::optional<ResolvedKey> {
    *error = "cylinder '" + k.cylinder + "': key '" + k.key + "': " + message;
    return std::nullopt;
  };
  const ParameterDoc* doc = FindDoc(BaseKey(k.key));
  if (!doc) return fail("unknown key (see plugin/README.md or 'pneumo params')");
  if (doc->is_choice) return fail("a choice (" + doc->valid + "), not a number: it cannot be fitted");
  if (!(k.scale >= 0) || !std::isfinite(k.scale)) return fail("the scale must be finite and >= 0");
  std::optional<double> initial = InitialValue(m, k, *doc, error);
  if (!initial) return std::nullopt;  // GetParameter's message names cylinder and key
  ResolvedKey r;
  r.key = k;
  r.unit = doc->unit;
  r.initial = *initial;
  r.s = std::max(std::fabs(*initial), k.scale);
  if (!(r.s > 0)) return fail("its value is 0: give the key a scale (its typical magnitude, " + doc->unit + ")");
  r.lower = doc->min + (doc->min_open ? 1e-6 * r.s : 0.0);
  r.upper = doc->max - (doc->max_open ? 1e-6 * r.s : 0.0);
  return r;
}

// The log the rollouts follow: the input with a velocity column for every cylinder that has
// none, v_i = (x_{i+1} - x_{i-1}) / (t_{i+1} - t_{i-1}) (central differences, second order in the
// row period; one-sided at the first and last rows).
std::optional<log::Log> MotionLog(const log::Log& in, const std::vector<CylinderInfo>& cylinders,
                                  std::vector<std::string>* warnings, std::string* error) {
  log::Log out = in;
  const size_t n = in.rows();
  for (const CylinderInfo& c : cylinders) {
    int x = in.FindColumn(c.name, "x");
    if (x < 0) {
      *error = "the log has no column '" + c.name + ".x': the fit moves cylinder '" + c.name +
               "' along its measured position";
      return std::nullopt;
    }
    if (in.FindColumn(c.name, "v") >= 0) continue;
    const std::vector<double>& position = in.values[static_cast<size_t>(x)];
    std::vector<double> velocity(n, 0.0);
    for (size_t i = 0; i < n && n >= 2; ++i) {
      size_t a = i == 0 ? 0 : i - 1, b = i + 1 == n ? n - 1 : i + 1;
      velocity[i] = (position[b] - position[a]) / (in.time[b] - in.time[a]);
    }
    out.columns.push_back({c.name, "v"});
    out.values.push_back(std::move(velocity));
    warnings->push_back("the log has no '" + c.name + ".v': the fit uses central differences of '" + c.name + ".x'");
  }
  return out;
}

// One pressure series of the residuals: a chamber signal of a fitted cylinder.
struct Series {
  std::string cylinder;
  const char* signal;               // "p_P" or "p_N"
  const std::vector<double>* measured;
};

// Runs follow-motion rollouts of m with some keys changed, and turns them into residuals.
class Simulator {
 public:
  Simulator(const mjModel* m, log::Log log, std::vector<ResolvedKey> keys, std::vector<Series> series)
      : m_(m), log_(std::move(log)), keys_(std::move(keys)), series_(std::move(series)) {
    for (Series& s : series_) s.measured = &log_.values[static_cast<size_t>(log_.FindColumn(s.cylinder, s.signal))];
  }

  int residual_count() const { return static_cast<int>(series_.size() * (log_.rows() - 1)); }
  std::vector<int> series_starts() const {
    std::vector<int> starts;
    for (size_t i = 0; i < series_.size(); ++i) starts.push_back(static_cast<int>(i * (log_.rows() - 1)));
    return starts;
  }
  const std::vector<ResolvedKey>& keys() const { return keys_; }
  long rollouts() const { return rollouts_.load(); }

  // residuals p_sim - p_meas (Pa) of the model with `values` (one per key), rows 1..n-1 of each
  // series; "" or why the simulation failed (a value the model refuses, a divergence)
  std::string Residuals(const std::vector<double>& values, Eigen::VectorXd* r) const {
    ++rollouts_;
    ModelPtr copy(mj_copyModel(nullptr, m_), mj_deleteModel);
    if (!copy) return "mj_copyModel failed";
    std::string error;
    for (size_t i = 0; i < keys_.size(); ++i) {
      if (!SetParameter(copy.get(), keys_[i].key.cylinder, keys_[i].key.key, values[i], &error)) return error;
    }
    RolloutOptions options;
    options.follow_motion = true;
    RolloutResult run = Rollout(copy.get(), &log_, options);
    if (!run.log) return run.error;
    const size_t n = log_.rows();
    if (run.log->rows() != n) return "the rollout returned " + std::to_string(run.log->rows()) + " rows of " + std::to_string(n);
    r->resize(residual_count());
    Eigen::Index at = 0;
    for (const Series& s : series_) {
      const std::vector<double>& simulated = run.log->values[static_cast<size_t>(run.log->FindColumn(s.cylinder, s.signal))];
      for (size_t i = 1; i < n; ++i) (*r)[at++] = simulated[i] - (*s.measured)[i];
    }
    if (!r->allFinite()) return "the simulated pressures are not finite";
    return "";
  }

  // Residuals of several value sets, on up to `threads` threads; each task writes only its own
  // slot and depends only on its own values, so the results do not depend on the thread count.
  std::vector<std::string> ResidualsOfAll(const std::vector<std::vector<double>>& sets, int threads,
                                          std::vector<Eigen::VectorXd>* out) const {
    out->assign(sets.size(), Eigen::VectorXd());
    std::vector<std::string> errors(sets.size());
    ParallelFor(sets.size(), threads, [&](size_t i) { errors[i] = Residuals(sets[i], &(*out)[i]); });
    return errors;
  }

 private:
  const mjModel* m_;
  log::Log log_;
  std::vector<ResolvedKey> keys_;
  std::vector<Series> series_;
  mutable std::atomic<long> rollouts_{0};
};

// The forward-difference Jacobian dr/dz (z = value / s) at `values`, given the residuals r there:
// column i from a rollout with value_i + h_i, h_i = relative_step s_i, or value_i - h_i where the
// forward step would leave the upper bound.
std::string Jacobian(const Simulator& sim, const std::vector<double>& values, const Eigen::VectorXd& r,
                     double relative_step, int threads, Eigen::MatrixXd* J) {
  const std::vector<ResolvedKey>& keys = sim.keys();
  std::vector<std::vector<double>> sets;
  std::vector<double> dz;
  for (size_t i = 0; i < keys.size(); ++i) {
    double h = relative_step * keys[i].s;
    if (values[i] + h > keys[i].upper) h = -h;
    if (values[i] + h < keys[i].lower) {
      return "cylinder '" + keys[i].key.cylinder + "': key '" + keys[i].key.key +
             "': its range is narrower than the finite-difference step " + Format("%.3g", std::fabs(h));
    }
    sets.push_back(values);
    sets.back()[i] = values[i] + h;
    dz.push_back((sets.back()[i] - values[i]) / keys[i].s);  // the step actually taken, after rounding
  }
  std::vector<Eigen::VectorXd> perturbed;
  std::vector<std::string> errors = sim.ResidualsOfAll(sets, threads, &perturbed);
  J->resize(r.size(), static_cast<Eigen::Index>(keys.size()));
  for (size_t i = 0; i < keys.size(); ++i) {
    if (!errors[i].empty()) return "finite difference of " + keys[i].key.name() + ": " + errors[i];
    J->col(static_cast<Eigen::Index>(i)) = (perturbed[i] - r) / dz[i];
  }
  return "";
}

// Ceres' view of the fit: one parameter block z, the pressure residuals. Remembers the last
// residuals and Jacobian, because Ceres evaluates the residuals of a candidate step and then,
// once it accepts it, residuals and Jacobian at the same point.
class PressureCost : public ceres::CostFunction {
 public:
  PressureCost(const Simulator& sim, const PhysicalFitOptions& options) : sim_(sim), options_(options) {
    set_num_residuals(sim.residual_count());
    mutable_parameter_block_sizes()->push_back(static_cast<int32_t>(sim.keys().size()));
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const size_t p = sim_.keys().size();
    std::vector<double> values(p);
    for (size_t i = 0; i < p; ++i) values[i] = parameters[0][i] * sim_.keys()[i].s;
    const Eigen::VectorXd* r = ResidualsAt(values);
    if (!r) return false;
    Eigen::Map<Eigen::VectorXd>(residuals, r->size()) = *r;
    if (jacobians && jacobians[0]) {
      if (jacobian_values_ != values) {
        std::string error = Jacobian(sim_, values, *r, options_.relative_step, options_.threads, &jacobian_);
        if (!error.empty()) {
          last_error_ = error;
          return false;
        }
        jacobian_values_ = values;
      }
      // Ceres wants the Jacobian row-major
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
          jacobians[0], jacobian_.rows(), jacobian_.cols()) = jacobian_;
    }
    return true;
  }

  // residuals at `values` (cached), or null and last_error()
  const Eigen::VectorXd* ResidualsAt(const std::vector<double>& values) const {
    if (values != residual_values_ || residual_values_.empty()) {
      std::string error = sim_.Residuals(values, &residuals_);
      if (!error.empty()) {
        last_error_ = error;
        residual_values_.clear();
        return nullptr;
      }
      residual_values_ = values;
    }
    return &residuals_;
  }
  // the Jacobian dr/dz at `values` (cached), or "" and why not
  std::string JacobianAt(const std::vector<double>& values, Eigen::MatrixXd* J) const {
    const Eigen::VectorXd* r = ResidualsAt(values);
    if (!r) return last_error_;
    if (jacobian_values_ != values) {
      std::string error = Jacobian(sim_, values, *r, options_.relative_step, options_.threads, &jacobian_);
      if (!error.empty()) return error;
      jacobian_values_ = values;
    }
    *J = jacobian_;
    return "";
  }
  const std::string& last_error() const { return last_error_; }

 private:
  const Simulator& sim_;
  const PhysicalFitOptions& options_;
  mutable std::vector<double> residual_values_, jacobian_values_;
  mutable Eigen::VectorXd residuals_;
  mutable Eigen::MatrixXd jacobian_;
  mutable std::string last_error_;
};

double Rms(const Eigen::VectorXd& r) { return r.size() ? std::sqrt(r.squaredNorm() / static_cast<double>(r.size())) : 0; }

std::string ValuesText(const std::vector<ResolvedKey>& keys, const double* z) {
  std::string text;
  for (size_t i = 0; i < keys.size(); ++i) {
    text += (i ? ", " : "") + keys[i].key.key + " " + Format("%.6g", z[i] * keys[i].s);
  }
  return text;
}

// one progress line per Levenberg-Marquardt iteration
class Progress : public ceres::IterationCallback {
 public:
  Progress(const PhysicalFitOptions& options, const std::vector<ResolvedKey>& keys, const double* z, int residuals)
      : options_(options), keys_(keys), z_(z), residuals_(residuals) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (options_.progress) {
      // Ceres' cost is half the sum of squares
      options_.progress("iteration " + std::to_string(s.iteration) + ": rms " +
                        Format("%.1f", std::sqrt(2 * s.cost / residuals_)) + " Pa" +
                        (s.iteration > 0 && !s.step_is_successful ? " (step rejected)" : "") + "; " +
                        ValuesText(keys_, z_));
    }
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const PhysicalFitOptions& options_;
  const std::vector<ResolvedKey>& keys_;
  const double* z_;
  int residuals_;
};

// the cylinders whose pressures are residuals (those with fitted keys, in model order), and checks
std::string FittedSeries(const std::vector<CylinderInfo>& cylinders, const std::vector<ResolvedKey>& keys,
                         const log::Log& log, std::vector<Series>* series) {
  for (const CylinderInfo& c : cylinders) {
    bool fitted = std::any_of(keys.begin(), keys.end(), [&](const ResolvedKey& k) { return k.key.cylinder == c.name; });
    if (!fitted) continue;
    for (const char* signal : {"p_P", "p_N"}) {
      if (log.FindColumn(c.name, signal) < 0) {
        return "the log has no column '" + c.name + "." + signal + "': the fit compares the simulated pressures of cylinder '" +
               c.name + "' with it";
      }
      series->push_back({c.name, signal, nullptr});
    }
  }
  return "";
}

std::string CheckFitOptions(const PhysicalFitOptions& options) {
  if (options.keys.empty()) return "no keys to fit";
  if (options.threads < 1) return "threads must be at least 1";
  if (options.max_iterations < 0) return "max_iterations must be >= 0";
  if (!(options.relative_step > 0 && options.relative_step < 0.1)) return "relative_step must be in (0, 0.1)";
  return "";
}

// the keys, checked against the model, each once
std::string ResolveKeys(const mjModel* m, const std::vector<FitKey>& fit_keys, std::vector<ResolvedKey>* keys) {
  for (const FitKey& k : fit_keys) {
    std::string error;
    std::optional<ResolvedKey> r = Resolve(m, k, &error);
    if (!r) return error;
    for (const ResolvedKey& other : *keys) {
      bool same = other.key.cylinder == k.cylinder &&
                  (other.key.key == k.key || BaseKey(other.key.key) == k.key || BaseKey(k.key) == other.key.key);
      if (same) return "cylinder '" + k.cylinder + "': key '" + k.key + "' is fitted twice (with '" + other.key.key + "')";
    }
    keys->push_back(*r);
  }
  return "";
}

// the log: a velocity where missing (*motion), the pressure series, enough rows
std::string PrepareLog(const log::Log& log, const std::vector<CylinderInfo>& cylinders,
                       const std::vector<ResolvedKey>& keys, PhysicalFit* fit, std::optional<log::Log>* motion,
                       std::vector<Series>* series) {
  if (std::string problem = log::ValidateLog(log, /*uniform_time=*/true); !problem.empty()) return "log: " + problem;
  *motion = MotionLog(log, cylinders, &fit->warnings, &fit->error);
  if (!*motion) return fit->error;
  if (std::string problem = FittedSeries(cylinders, keys, **motion, series); !problem.empty()) return problem;
  // at least 10 rows of residuals per fitted key and 20 in all: fewer leave the estimates and
  // the Newey-West covariance of their errors to a handful of samples
  const size_t needed = std::max<size_t>(20, 10 * keys.size()) + 1;
  if (log.rows() < needed) {
    return "the log has " + std::to_string(log.rows()) + " rows: fitting " + std::to_string(keys.size()) +
           " keys needs at least " + std::to_string(needed);
  }
  return "";
}

// Levenberg-Marquardt's settings
ceres::Solver::Options SolverOptions(const PhysicalFitOptions& options) {
  ceres::Solver::Options solver;
  solver.minimizer_type = ceres::TRUST_REGION;
  solver.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = options.max_iterations;
  solver.num_threads = 1;  // the rollouts are the parallel part, and one thread keeps Ceres deterministic
  // Stop when the sum of squares S changes by less than 1e-7 of itself: moving a parameter by one
  // standard error changes S by about S / N (N residuals, 1e-3 S for a 5 s log), so this is
  // about 0.01 standard error; or when a step changes z (of order 1) by less than 1e-8. Tighter
  // tolerances only make Levenberg-Marquardt reject steps in the rollouts' round-off.
  solver.parameter_tolerance = 1e-8;
  solver.function_tolerance = 1e-7;
  solver.gradient_tolerance = 1e-12;
  // no projected line search at the bounds: it asks for the Jacobian (p rollouts) at every
  // candidate, rejected ones included; a candidate beyond a bound is refused by SetParameter and
  // Levenberg-Marquardt shrinks its step instead
  solver.max_num_line_search_step_size_iterations = 0;
  solver.logging_type = ceres::SILENT;
  solver.update_state_every_iteration = true;
  return solver;
}

// standard errors, correlations, flags: the fitted parameters at the optimum `values`, whose
// residuals are r and Jacobian J (the keys' own units), into *fit
void ReportParameters(const std::vector<ResolvedKey>& keys, const std::vector<double>& values, const Eigen::VectorXd& r,
                      Eigen::MatrixXd J, const Simulator& sim, const PhysicalFitOptions& options, PhysicalFit* fit) {
  const size_t p = keys.size();
  std::vector<std::string> names;
  std::vector<double> scales;
  for (const ResolvedKey& k : keys) names.push_back(k.key.name()), scales.push_back(k.key.scale);
  UncertaintyOptions uncertainty_options = options.uncertainty;
  uncertainty_options.series_starts = sim.series_starts();
  Uncertainty u = EstimateUncertainty(J, r, names, values, scales, uncertainty_options);
  if (!u.error.empty()) fit->warnings.push_back("standard errors: " + u.error);
  fit->correlation = u.correlation;
  fit->lag_window = u.lag_window;
  for (size_t i = 0; i < p; ++i) {
    FittedParameter f;
    f.cylinder = keys[i].key.cylinder, f.key = keys[i].key.key, f.unit = keys[i].unit;
    f.initial = keys[i].initial, f.value = values[i];
    f.standard_error = i < u.standard_error.size() ? u.standard_error[i] : std::numeric_limits<double>::infinity();
    f.poorly_determined = i < u.poorly_determined.size() ? u.poorly_determined[i] : "not determined";
    // a value held by its bound is not a least-squares optimum: the data push it further
    double margin = 1e-6 * keys[i].s;
    if (values[i] <= keys[i].lower + margin || values[i] >= keys[i].upper - margin) {
      fit->warnings.push_back(keys[i].key.name() + " ended at its bound " + Format("%.6g", values[i]) +
                              ": the data push it beyond (a missing effect, or a wrong fixed parameter?)");
    }
    fit->parameters.push_back(f);
  }
  fit->final_residuals = r;
  fit->series_starts = uncertainty_options.series_starts;
  fit->jacobian = std::move(J);
  fit->rollouts = static_cast<int>(sim.rollouts());
}

}  // namespace

std::optional<FitKey> ParseFitKey(const std::string& text, std::string* error) {
  size_t colon = text.find(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == text.size() || text.find(':', colon + 1) != std::string::npos) {
    *error = "'" + text + "': a fitted key is written <cylinder>:<key>, e.g. cyl:P.dead_volume";
    return std::nullopt;
  }
  return FitKey{text.substr(0, colon), text.substr(colon + 1), 0};
}

std::vector<FitKey> DefaultPhysicalKeys(const mjModel* m, const std::string& cylinder, std::string* error) {
  std::vector<CylinderInfo> cylinders;
  if (std::string problem = AttachedCylinders(m, &cylinders); !problem.empty()) {
    *error = problem;
    return {};
  }
  if (std::none_of(cylinders.begin(), cylinders.end(), [&](const CylinderInfo& c) { return c.name == cylinder; })) {
    *error = "the model has no cylinder '" + cylinder + "'";
    return {};
  }
  auto key = [&](const std::string& k) { return FitKey{cylinder, k, 0}; };
  std::vector<FitKey> keys;
  if (Choice(m, cylinder, "P.pressure_model") == "identified" || Choice(m, cylinder, "N.pressure_model") == "identified") {
    *error = "cylinder '" + cylinder + "': pressure_model=identified has no physical parameters of its own (fit c1..c9 instead)";
    return {};
  }
  const std::string flow = Choice(m, cylinder, "P.flow");
  if (flow == "iso6358") {
    keys.push_back(key("P.sonic_conductance"));
    keys.push_back(key("N.sonic_conductance"));
  } else {
    keys.push_back(key("P.discharge_coefficient"));
    keys.push_back(key("N.discharge_coefficient"));
  }
  if (flow == "iso6358" || flow == "sanville") keys.push_back(key("critical_ratio"));
  keys.push_back(key("polytropic_index"));
  keys.push_back(key("P.dead_volume"));
  keys.push_back(key("N.dead_volume"));
  std::string ignored;
  if (Choice(m, cylinder, "valve") == "proportional_5_3") {
    std::optional<double> tau = GetParameter(m, cylinder, "spool_time_constant", &ignored);
    if (tau && *tau > 0) keys.push_back(key("spool_time_constant"));
  }
  return keys;
}

PhysicalFit FitPhysical(const mjModel* m, const log::Log& log, const PhysicalFitOptions& options) {
  PhysicalFit fit;
  auto fail = [&](const std::string& message) {
    fit.error = message;
    fit.parameters.clear();
    return fit;
  };
  std::vector<CylinderInfo> cylinders;
  if (std::string problem = AttachedCylinders(m, &cylinders); !problem.empty()) return fail(problem);
  if (std::string problem = CheckFitOptions(options); !problem.empty()) return fail(problem);
  std::vector<ResolvedKey> keys;
  if (std::string problem = ResolveKeys(m, options.keys, &keys); !problem.empty()) return fail(problem);
  std::optional<log::Log> motion;
  std::vector<Series> series;
  if (std::string problem = PrepareLog(log, cylinders, keys, &fit, &motion, &series); !problem.empty()) {
    return fail(problem);
  }
  Simulator sim(m, std::move(*motion), keys, std::move(series));
  fit.residuals = sim.residual_count();

  // Levenberg-Marquardt on z = value / s, from the model's values (z = +-1 or initial / scale)
  const size_t p = keys.size();
  std::vector<double> z(p), initial(p);
  for (size_t i = 0; i < p; ++i) initial[i] = keys[i].initial, z[i] = keys[i].initial / keys[i].s;
  auto* cost = new PressureCost(sim, options);  // owned by the problem
  const Eigen::VectorXd* r0 = cost->ResidualsAt(initial);
  if (!r0) return fail("the model's own values: " + cost->last_error());
  fit.rms_before_pa = Rms(*r0);
  ceres::Problem problem;
  problem.AddResidualBlock(cost, nullptr, z.data());
  for (size_t i = 0; i < p; ++i) {
    problem.SetParameterLowerBound(z.data(), static_cast<int>(i), keys[i].lower / keys[i].s);
    problem.SetParameterUpperBound(z.data(), static_cast<int>(i), keys[i].upper / keys[i].s);
  }
  ceres::Solver::Options solver = SolverOptions(options);
  Progress progress(options, keys, z.data(), fit.residuals);
  solver.callbacks.push_back(&progress);
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  if (summary.termination_type == ceres::FAILURE || summary.termination_type == ceres::USER_FAILURE) {
    return fail("the fit failed: " + (cost->last_error().empty() ? summary.message : cost->last_error()));
  }
  fit.iterations = static_cast<int>(summary.iterations.size()) - 1;  // the first entry is the start
  fit.converged = summary.termination_type == ceres::CONVERGENCE;
  if (!fit.converged) fit.warnings.push_back("not converged: " + summary.message);

  // the optimum, its residuals and Jacobian in the keys' own units
  std::vector<double> values(p);
  for (size_t i = 0; i < p; ++i) values[i] = z[i] * keys[i].s;
  Eigen::MatrixXd J;
  if (std::string error = cost->JacobianAt(values, &J); !error.empty()) return fail("at the optimum: " + error);
  const Eigen::VectorXd r = *cost->ResidualsAt(values);
  for (size_t i = 0; i < p; ++i) J.col(static_cast<Eigen::Index>(i)) /= keys[i].s;
  fit.rms_after_pa = Rms(r);
  ReportParameters(keys, values, r, std::move(J), sim, options, &fit);
  return fit;
}

std::string ApplyPhysicalFit(mjModel* m, const PhysicalFit& fit) {
  // all on a copy first, so that m is unchanged if any value is refused
  ModelPtr copy(mj_copyModel(nullptr, m), mj_deleteModel);
  if (!copy) return "mj_copyModel failed";
  for (mjModel* target : {copy.get(), m}) {
    for (const FittedParameter& f : fit.parameters) {
      std::string error;
      if (!SetParameter(target, f.cylinder, f.key, f.value, &error)) return error;
    }
  }
  return "";
}

}  // namespace pneumatic::identification
