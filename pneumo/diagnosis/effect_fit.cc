#include "diagnosis/effect_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <limits>
#include <memory>

#include <ceres/ceres.h>
#include <glog/logging.h>

#include "identification/uncertainty.h"

namespace pneumatic::diagnosis {
namespace {

// Applies `values` (one per parameter of c) on top of the scenario's own values.
std::string ApplyValues(const Candidate& c, const std::vector<double>& values, mjModel* m, SignalModel* sensors) {
  for (size_t i = 0; i < c.parameters.size(); ++i) {
    if (std::string e = c.parameters[i].apply(m, sensors, values[i]); !e.empty()) return c.parameters[i].name + ": " + e;
  }
  return "";
}

// the optimiser's variable z of a parameter and back: value = nominal + scale z, or scale e^z
double ToValue(const EffectParameter& p, double z) { return p.logarithmic ? p.scale * std::exp(z) : p.nominal + p.scale * z; }
double ToVariable(const EffectParameter& p, double value) {
  return p.logarithmic ? std::log(value / p.scale) : (value - p.nominal) / p.scale;
}

// Ceres' view of a candidate's fit: one block z (ToValue: value = nominal + scale z, or scale e^z),
// the normalised residuals of the valid rows. Every point is given as z, and the points simulated
// last are remembered by z, exactly: Ceres evaluates a step's residuals and then, once it accepts
// it, residuals and Jacobian at the same point; the fit starts at the point the scan chose; and the
// standard errors want residuals, gap and (for the linear parameters, whose steps are Ceres') the
// Jacobian where Ceres accepted its last step. Each would otherwise be a simulation of the log.
class EffectCost : public ceres::CostFunction {
 public:
  EffectCost(const mjModel* base, const SignalModel& sensors, const Candidate& c, const Measurements& meas,
             const FitOptions& options)
      : base_(base), sensors_(sensors), c_(c), meas_(meas), options_(options),
        scratch_(mj_copyModel(nullptr, base), mj_deleteModel) {
    mutable_parameter_block_sizes()->push_back(static_cast<int>(c.parameters.size()));
  }

  // the residual count, from the first point's evaluation (a later point must predict as many rows)
  void SetResidualCount(int residuals) { set_num_residuals(residuals); }

  // the values (in units) of the optimiser's point z
  std::vector<double> Values(const std::vector<double>& z) const {
    std::vector<double> values(z.size());
    for (size_t i = 0; i < z.size(); ++i) values[i] = ToValue(c_.parameters[i], z[i]);
    return values;
  }

  // residuals and gap (Evaluated::gap) at the point z; "" or why not
  std::string Residuals(const std::vector<double>& z, Eigen::VectorXd* r, double* gap = nullptr) const {
    for (auto it = remembered_.begin(); it != remembered_.end(); ++it) {
      if (it->z != z) continue;
      *r = it->r;
      if (gap) *gap = it->gap;
      return "";
    }
    ++evaluations_;
    mj_copyModel(scratch_.get(), base_);
    SignalModel sensors = sensors_;
    if (std::string e = ApplyValues(c_, Values(z), scratch_.get(), &sensors); !e.empty()) return e;
    Evaluated ev = diagnosis::Evaluate(scratch_.get(), sensors, meas_, options_.gap);
    if (!ev.error.empty()) return ev.error;
    if (num_residuals() > 0 && ev.residuals.size() != num_residuals()) return "the number of predicted rows changed";
    if (series_starts_.empty()) series_starts_ = ev.series_starts;
    Remember(z, ev.residuals, ev.gap);
    *r = std::move(ev.residuals);
    if (gap) *gap = ev.gap;
    return "";
  }

  // keeps the point among the remembered ones, the most recent first (a point remembered already
  // moves to the front)
  void Remember(const std::vector<double>& z, const Eigen::VectorXd& r, double gap) const {
    remembered_.erase(std::remove_if(remembered_.begin(), remembered_.end(), [&](const Point& p) { return p.z == z; }), remembered_.end());
    remembered_.push_front({z, r, gap});
    if (remembered_.size() > Capacity()) remembered_.pop_back();
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const size_t k = c_.parameters.size();
    const std::vector<double> z(parameters[0], parameters[0] + k);
    Eigen::VectorXd r;
    if (std::string e = Residuals(z, &r); !e.empty()) {
      last_error_ = e;
      return false;
    }
    Eigen::Map<Eigen::VectorXd>(residuals, num_residuals()) = r;
    if (!jacobians || !jacobians[0]) return true;
    if (!SecantUpdate(z, r)) {
      jacobian_.resize(r.size(), static_cast<Eigen::Index>(k));
      for (size_t i = 0; i < k; ++i) {
        const std::vector<double> shifted = Shifted(z, i);
        Eigen::VectorXd rh;
        if (std::string e = Residuals(shifted, &rh); !e.empty()) {
          last_error_ = "finite difference of " + c_.parameters[i].name + ": " + e;
          return false;
        }
        jacobian_.col(static_cast<Eigen::Index>(i)) = (rh - r) / (shifted[i] > z[i] ? options_.relative_step : -options_.relative_step);
      }
      secant_updates_ = 0, exact_next_ = false;
    }
    jacobian_z_ = z, jacobian_r_ = r;
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(jacobians[0], num_residuals(),
                                                                                     static_cast<Eigen::Index>(k)) = jacobian_;
    return true;
  }

  // Broyden's update of the last Jacobian to the point z (Broyden, Math. Comp. 19, 1965, eq. 2.9;
  // Nocedal and Wright, Numerical Optimization, 2nd ed., eq. 11.27): with the step s from the
  // last Jacobian's point and the change y of the residuals along it, J + (y - J s) s^T / s^T s,
  // the least change of J that predicts y exactly. Used for at most FitOptions::secant_updates
  // Jacobians in a row, and only while J predicted the step's change well (the part of y it
  // missed below half of y); otherwise, or when asked (RequireExactJacobian), false: the caller
  // takes finite differences
  bool SecantUpdate(const std::vector<double>& z, const Eigen::VectorXd& r) const {
    if (exact_next_ || secant_updates_ >= options_.secant_updates || jacobian_z_.empty() || jacobian_.rows() != r.size()) return false;
    const Eigen::VectorXd s = Eigen::Map<const Eigen::VectorXd>(z.data(), static_cast<Eigen::Index>(z.size())) -
                              Eigen::Map<const Eigen::VectorXd>(jacobian_z_.data(), static_cast<Eigen::Index>(z.size()));
    const double ss = s.squaredNorm();
    if (ss == 0) return false;
    const Eigen::VectorXd y = r - jacobian_r_;
    const Eigen::VectorXd missed = y - jacobian_ * s;
    if (missed.norm() > 0.5 * y.norm()) return false;
    jacobian_ += missed * (s.transpose() / ss);
    ++secant_updates_;
    return true;
  }

  // z with its i-th variable moved by the finite-difference step, backwards where forwards would
  // leave the parameter's range
  std::vector<double> Shifted(const std::vector<double>& z, size_t i) const {
    const EffectParameter& p = c_.parameters[i];
    std::vector<double> shifted = z;
    shifted[i] = z[i] + options_.relative_step;
    if (ToValue(p, shifted[i]) > p.upper) shifted[i] = z[i] - options_.relative_step;
    return shifted;
  }

  // the next Jacobian by finite differences; whether the last one was
  void RequireExactJacobian() { exact_next_ = true; }
  bool last_jacobian_exact() const { return secant_updates_ == 0; }

  int evaluations() const { return evaluations_; }
  const std::string& last_error() const { return last_error_; }
  const std::vector<int>& series_starts() const { return series_starts_; }

 private:
  struct Point {
    std::vector<double> z;
    Eigen::VectorXd r;
    double gap;
  };
  // a point, its Jacobian's shifted points and the step tried after it, twice over
  size_t Capacity() const { return 2 * (c_.parameters.size() + 2); }

  const mjModel* base_;
  SignalModel sensors_;
  const Candidate& c_;
  const Measurements& meas_;
  const FitOptions& options_;
  ModelPtr scratch_;
  mutable int evaluations_ = 0;
  mutable std::deque<Point> remembered_;
  mutable std::vector<int> series_starts_;
  mutable std::string last_error_;
  // the last Jacobian Ceres was given, with its point and residuals, and the secant updates since
  // the last finite-difference one (SecantUpdate)
  mutable Eigen::MatrixXd jacobian_;
  mutable std::vector<double> jacobian_z_;
  mutable Eigen::VectorXd jacobian_r_;
  mutable int secant_updates_ = 0;
  mutable bool exact_next_ = false;
};

// A point of a fit with its residuals, gap and sum of squares: where a scan starts and what it returns.
struct FitPoint {
  std::vector<double> z;  // the optimiser's variables (EffectCost)
  Eigen::VectorXd r;
  double gap = 0, ss = 0;
};

// `trial` in place of *best if the model predicts it with a smaller sum of squares; a point the
// model refuses counts as no better
void KeepIfBetter(const EffectCost& cost, const std::vector<double>& trial, FitPoint* best) {
  FitPoint p{trial, {}, 0, 0};
  if (!cost.Residuals(trial, &p.r, &p.gap).empty()) return;
  p.ss = p.r.squaredNorm();
  if (p.ss < best->ss) *best = std::move(p);
}

// The coarse scan of FitOptions::scan_points: the logarithmic parameters at `points` positions
// t = (j + 1/2) / points along their log ranges (value = lower (upper / lower)^t). Parameters of
// one kind (one unit, such as a candidate's three leak areas) move together; kinds are scanned on
// a grid of `grid_points` per kind (a tank's volume and its line's conductance: 6 x 6), since a
// volume says nothing about the conductance it goes with; then each parameter of a kind of several
// alone, from the best point. The others are held. Returns the start for the fit: the best point,
// or `initial` where no point improves its sum of squares.
FitPoint ScanLogarithmic(const EffectCost& cost, const Candidate& c, const FitPoint& initial, int points, int grid_points) {
  std::vector<std::string> kinds;       // the units of the logarithmic parameters, in order
  std::vector<int> kind_of(c.parameters.size(), -1);
  for (size_t i = 0; i < c.parameters.size(); ++i) {
    if (!c.parameters[i].logarithmic || !c.parameters[i].scanned) continue;
    auto it = std::find(kinds.begin(), kinds.end(), c.parameters[i].unit);
    kind_of[i] = static_cast<int>(it - kinds.begin());
    if (it == kinds.end()) kinds.push_back(c.parameters[i].unit);
  }
  if (kinds.empty() || points <= 0) return initial;  // no scan
  if (kinds.size() > 1) points = grid_points;
  if (points <= 0) return initial;
  FitPoint best = initial;
  // the optimiser's variable at the j-th of the `points` positions along p's log range
  auto position = [points](const EffectParameter& p, int j) {
    return ToVariable(p, p.lower * std::pow(p.upper / p.lower, (j + 0.5) / points));
  };
  int grid = 1;
  for (size_t k = 0; k < kinds.size(); ++k) grid *= points;
  for (int g = 0; g < grid; ++g) {
    std::vector<double> trial = initial.z;
    for (size_t i = 0; i < c.parameters.size(); ++i) {
      if (kind_of[i] < 0) continue;
      int j = g;  // the digit of kind_of[i] in base `points`
      for (int k = 0; k < kind_of[i]; ++k) j /= points;
      trial[i] = position(c.parameters[i], j % points);
    }
    KeepIfBetter(cost, trial, &best);
  }
  // then each parameter of a kind that has several alone, at the same points, from the best so far
  // (one sweep): an effect need not act alike in every place (one chamber's leak to the
  // atmosphere, none from the other), and the joint scan sets them all alike
  for (size_t i = 0; i < c.parameters.size(); ++i) {
    if (kind_of[i] < 0 || std::count(kind_of.begin(), kind_of.end(), kind_of[i]) < 2) continue;
    const std::vector<double> from = best.z;
    for (int j = 0; j < points; ++j) {
      std::vector<double> trial = from;
      trial[i] = position(c.parameters[i], j);
      KeepIfBetter(cost, trial, &best);
    }
  }
  return best;
}

// The grid scan of EffectParameter::scan_step: the parameters that have one at the same offset
// from their lower bounds, in steps of the first one's scan_step up to its upper bound; the others
// held. Returns the best point, or `start` where none improves on its sum of squares.
FitPoint ScanGrid(const EffectCost& cost, const Candidate& c, const FitPoint& start) {
  std::vector<size_t> scanned;
  for (size_t i = 0; i < c.parameters.size(); ++i) {
    if (c.parameters[i].scan_step > 0) scanned.push_back(i);
  }
  if (scanned.empty()) return start;
  const EffectParameter& first = c.parameters[scanned[0]];
  FitPoint best = start;
  for (int j = 0; first.lower + j * first.scan_step <= first.upper; ++j) {
    std::vector<double> trial = start.z;
    for (size_t i : scanned) {
      const EffectParameter& p = c.parameters[i];
      trial[i] = ToVariable(p, std::min(p.lower + j * first.scan_step, p.upper));
    }
    KeepIfBetter(cost, trial, &best);
  }
  return best;
}

class ProgressLine : public ceres::IterationCallback {
 public:
  ProgressLine(const Candidate& c, const FitOptions& o, const double* z) : c_(c), o_(o), z_(z) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (o_.progress) {
      std::string text = "  " + c_.effect + " iteration " + std::to_string(s.iteration);
      char value[64];
      for (size_t i = 0; i < c_.parameters.size(); ++i) {
        std::snprintf(value, sizeof(value), " %s=%.4g", c_.parameters[i].name.c_str(), ToValue(c_.parameters[i], z_[i]));
        text += value;
      }
      o_.progress(text);
    }
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const Candidate& c_;
  const FitOptions& o_;
  const double* z_;
};

// Stops Ceres where a step taken on a secant Jacobian (EffectCost::SecantUpdate) was refused:
// Levenberg-Marquardt would damp the next step on the same, possibly poor, Jacobian; the fit
// instead starts again from the point with a finite-difference one (FitCandidate), as levmar does
// after a failed step on a Broyden Jacobian (Lourakis, levmar, 2004, dlevmar_dif)
class SecantStepGuard : public ceres::IterationCallback {
 public:
  explicit SecantStepGuard(const EffectCost& cost) : cost_(cost) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    return s.iteration > 0 && !s.step_is_successful && !cost_.last_jacobian_exact() ? ceres::SOLVER_TERMINATE_SUCCESSFULLY
                                                                                    : ceres::SOLVER_CONTINUE;
  }

 private:
  const EffectCost& cost_;
};

}  // namespace

std::vector<double> SignalScales(const Measurements& meas) {
  std::vector<double> scales;
  for (int s = 0; s < meas.signals(); ++s) {
    const std::vector<double>& y = meas.Signal(s);
    double mean = 0, magnitude = 0;
    for (double v : y) mean += v, magnitude += std::fabs(v);
    mean /= static_cast<double>(y.size());
    double var = 0;
    for (double v : y) var += (v - mean) * (v - mean);
    scales.push_back(std::max(std::sqrt(var / static_cast<double>(y.size())), 1e-9 * magnitude / static_cast<double>(y.size()) + 1e-12));
  }
  return scales;
}

ModelPtr BuildScenario(const std::string& model_path, const Scenario& s, const Measurements& meas, SignalModel* sensors,
                       std::string* error) {
  ModelPtr m = LoadEditedModel(model_path, s.edits, error);
  if (!m) return m;
  *sensors = SignalModel::Identity(meas);
  for (const auto& [apply, value] : s.values) {
    if (std::string e = apply(m.get(), sensors, value); !e.empty()) {
      *error = e;
      return ModelPtr(nullptr, mj_deleteModel);
    }
  }
  return m;
}

Scenario WithCandidate(const Scenario& base, const Candidate& c, const std::vector<double>& values) {
  Scenario s = base;
  s.edits.insert(s.edits.end(), c.edits.begin(), c.edits.end());
  for (size_t i = 0; i < c.parameters.size(); ++i) s.values.emplace_back(c.parameters[i].apply, values[i]);
  return s;
}

Evaluated Evaluate(const mjModel* m, const SignalModel& sensors, const Measurements& meas, const GapOptions& options) {
  Evaluated ev;
  ev.prediction = Predict(m, meas, sensors, options.windows, PredictionKind::kFull, options.threads);
  if (!ev.prediction.error.empty()) {
    ev.error = ev.prediction.error;
    return ev;
  }
  std::vector<double> r;
  double total = 0;
  for (int s = 0; s < meas.signals(); ++s) {
    const std::vector<double>& sim = ev.prediction.simulated[s];
    const std::vector<double>& y = meas.Signal(s);
    double sum = 0;
    int n = 0;
    for (int start : options.windows.starts) {
      ev.series_starts.push_back(static_cast<int>(r.size()));
      for (int row = start + 1; row <= start + options.windows.horizon_rows && row < meas.rows(); ++row) {
        if (std::isnan(sim[row])) continue;
        const double e = sim[row] - y[row];
        if (!std::isfinite(e)) {
          ev.error = "the prediction of " + meas.SignalLabel(s) + " is not finite at t = " + std::to_string(meas.time[row]) + " s";
          return ev;
        }
        r.push_back(e / options.signal_scale[s]);
        sum += e * e, ++n;
      }
    }
    const double rms = n ? std::sqrt(sum / n) : 0;
    ev.signal_rms.push_back(rms);
    ev.signal_gap.push_back(rms / options.signal_scale[s]);
    total += ev.signal_gap.back() * ev.signal_gap.back();
  }
  ev.gap = std::sqrt(total / std::max(meas.signals(), 1));
  ev.residuals = Eigen::Map<Eigen::VectorXd>(r.data(), static_cast<Eigen::Index>(r.size()));
  return ev;
}

CandidateFit FitCandidate(const std::string& model_path, const Scenario& base, const Candidate& c, const Measurements& meas,
                          const FitOptions& options) {
  // Ceres logs an evaluation that fails (a trial step the model refuses) through glog on stderr; the
  // fit reports its own failures, so only fatal glog messages are let through
  static const bool quiet_glog = [] {
    FLAGS_minloglevel = google::GLOG_FATAL;
    return true;
  }();
  (void)quiet_glog;
  CandidateFit fit;
  SignalModel sensors;
  Scenario with_edits = base;
  with_edits.edits.insert(with_edits.edits.end(), c.edits.begin(), c.edits.end());
  ModelPtr m = BuildScenario(model_path, with_edits, meas, &sensors, &fit.error);
  if (!m) return fit;
  const size_t k = c.parameters.size();
  auto owned = std::make_unique<EffectCost>(m.get(), sensors, c, meas, options);
  EffectCost* cost = owned.get();
  FitPoint initial;
  for (const EffectParameter& p : c.parameters) initial.z.push_back(ToVariable(p, p.initial));
  if (std::string e = cost->Residuals(initial.z, &initial.r, &initial.gap); !e.empty()) {
    fit.error = "the initial values: " + e;
    return fit;
  }
  fit.train_gap_before = initial.gap;
  if (initial.r.size() == 0) {
    fit.error = "no predicted rows";
    return fit;
  }
  cost->SetResidualCount(static_cast<int>(initial.r.size()));  // the rows the initial point predicts
  initial.ss = initial.r.squaredNorm();
  FitPoint start = ScanLogarithmic(*cost, c, initial, options.scan_points, options.scan_grid_points);
  if (options.scan_points > 0) start = ScanGrid(*cost, c, start);
  cost->Remember(start.z, start.r, start.gap);  // where Ceres starts
  std::vector<double> z = start.z;
  {
    ceres::Problem problem;
    problem.AddResidualBlock(owned.release(), nullptr, z.data());
    for (size_t i = 0; i < k; ++i) {
      problem.SetParameterLowerBound(z.data(), static_cast<int>(i), ToVariable(c.parameters[i], c.parameters[i].lower));
      problem.SetParameterUpperBound(z.data(), static_cast<int>(i), ToVariable(c.parameters[i], c.parameters[i].upper));
    }
    ceres::Solver::Options solver;
    solver.minimizer_type = ceres::TRUST_REGION;
    solver.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    solver.linear_solver_type = ceres::DENSE_QR;
    solver.max_num_iterations = options.max_iterations;
    // Levenberg-Marquardt's first step with damping equal to the (Jacobi-scaled) curvature, the
    // classic Marquardt start for a starting point that may be far off (the scan's coarse grid):
    // Ceres' default radius, 1e4, makes the first step in effect a Gauss-Newton step, which from
    // a tank-and-line scan point jumps to a corner of the box where the fit stalls (README)
    solver.initial_trust_region_radius = 1.0;
    solver.function_tolerance = 1e-4;
    solver.parameter_tolerance = 1e-4;
    // with bounds, Ceres follows each trust-region step with a projected line search whose default
    // (cubic interpolation, up to 20 steps) evaluates the Jacobian at every trial point: here, a
    // simulation per parameter per trial. One bisection step (values only) keeps the projection
    // and costs no Jacobian
    solver.line_search_interpolation_type = ceres::BISECTION;
    solver.max_num_line_search_step_size_iterations = 1;
    solver.num_threads = 1;
    solver.logging_type = ceres::SILENT;
    solver.update_state_every_iteration = true;
    ProgressLine progress(c, options, z.data());
    solver.callbacks.push_back(&progress);
    SecantStepGuard secant_guard(*cost);
    solver.callbacks.push_back(&secant_guard);
    // a fit converges only on a finite-difference Jacobian: where Ceres stops on a secant one
    // (EffectCost::SecantUpdate), converged or after a refused step (SecantStepGuard), it goes on
    // from there with finite differences, in what is left of the iterations (steps: each Solve's
    // iteration 0 is its start point's evaluation)
    ceres::Solver::Summary summary;
    fit.iterations = 0;
    for (;;) {
      ceres::Solve(solver, &problem, &summary);
      fit.iterations += std::max(0, static_cast<int>(summary.iterations.size()) - 1);  // none where Ceres refused to start
      solver.max_num_iterations = options.max_iterations - fit.iterations;
      const bool stopped_on_secant = (summary.termination_type == ceres::CONVERGENCE || summary.termination_type == ceres::USER_SUCCESS) &&
                                     !cost->last_jacobian_exact();
      if (!stopped_on_secant || solver.max_num_iterations <= 0) break;
      cost->RequireExactJacobian();
    }
    fit.evaluations = cost->evaluations();
    if (summary.termination_type == ceres::FAILURE || summary.termination_type == ceres::USER_FAILURE ||
        !std::isfinite(summary.final_cost)) {
      fit.error = "the fit failed: " + (cost->last_error().empty() ? summary.message : cost->last_error());
      return fit;
    }
    fit.converged = summary.termination_type == ceres::CONVERGENCE;
    fit.values = cost->Values(z);
    // residuals, gap and Jacobian at the optimum (in the parameters' units), for the standard
    // errors: a linear parameter with Ceres' step (remembered where Ceres accepted its last step),
    // a logarithmic one with a step of its scale (its fit's step is a fraction of its value)
    Eigen::VectorXd r;
    if (std::string e = cost->Residuals(z, &r, &fit.train_gap_after); !e.empty()) {
      fit.error = "at the fitted values: " + e;
      return fit;
    }
    Eigen::MatrixXd J(r.size(), static_cast<Eigen::Index>(k));
    std::vector<std::string> names;
    std::vector<double> scales;
    for (size_t i = 0; i < k; ++i) {
      const EffectParameter& p = c.parameters[i];
      std::vector<double> shifted = cost->Shifted(z, i);
      if (p.logarithmic) {
        const double h = options.relative_step * p.scale;
        shifted[i] = ToVariable(p, fit.values[i] + h > p.upper ? fit.values[i] - h : fit.values[i] + h);
      }
      Eigen::VectorXd rh;
      if (std::string e = cost->Residuals(shifted, &rh); !e.empty()) {
        fit.error = "Jacobian at the fitted values: " + e;
        return fit;
      }
      J.col(static_cast<Eigen::Index>(i)) = (rh - r) / (ToValue(p, shifted[i]) - fit.values[i]);
      names.push_back(p.name);
      scales.push_back(p.scale);
    }
    identification::UncertaintyOptions uo;
    uo.series_starts = cost->series_starts();
    identification::Uncertainty u = identification::EstimateUncertainty(J, r, names, fit.values, scales, uo);
    fit.standard_errors = u.error.empty() ? u.standard_error : std::vector<double>(k, std::numeric_limits<double>::infinity());
    fit.poorly_determined = u.error.empty() ? u.poorly_determined : std::vector<std::string>(k, u.error);
    // each parameter's standard error with the others held at their values: the same estimate on
    // its Jacobian column alone (CandidateFit)
    for (size_t i = 0; i < k; ++i) {
      const identification::Uncertainty alone = identification::EstimateUncertainty(
          J.col(static_cast<Eigen::Index>(i)), r, {names[i]}, {fit.values[i]}, {scales[i]}, uo);
      fit.conditional_standard_errors.push_back(alone.error.empty() ? alone.standard_error[0] : std::numeric_limits<double>::infinity());
    }
    fit.evaluations = cost->evaluations();
  }
  return fit;
}

}  // namespace pneumatic::diagnosis
