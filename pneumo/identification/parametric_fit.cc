#include "identification/parametric_fit.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <ceres/ceres.h>
#include <Eigen/Dense>

#include "identification/drift.h"
#include "identification/uncertainty.h"

namespace pneumatic::identification {
namespace {

const std::vector<std::string> kNames = {"c1", "c2", "c3", "c4", "c5", "c6", "c7", "c8", "c9"};

std::string Format(const char* format, double a) {
  char text[64];
  std::snprintf(text, sizeof(text), format, a);
  return text;
}

// +1 for chamber P, whose volume grows with x, -1 for N (ChamberSeries::name ends in .P / .N)
double VolumeSign(const ChamberSeries& s) {
  return s.name.size() >= 2 && s.name.compare(s.name.size() - 2, 2, ".N") == 0 ? -1.0 : 1.0;
}

// |c6| < 2 / stroke keeps 1 + c6 x > 0 for |x| <= stroke/2 (paper 000 eq. 10e's denominator, the
// volume in units of the volume-sensor bias); the bound leaves 1 + c6 x >= 1e-3
double C6Limit(const ChamberSeries& s) {
  double limit = s.stroke > 0 ? (1 - 1e-3) * 2 / s.stroke : 1e4;
  return std::min(limit, 1e4);  // the MJCF's range of c6
}

// Residuals (p_{t+1} - p^_{t+1}) / c_s of samples [begin, end) of one series, with the analytic
// Jacobian: one Ceres block of a few thousand samples (one block per sample costs more in Ceres's
// bookkeeping than the model itself). Scaling by 1/c_s makes the residuals O(1).
class BlockCost : public ceres::CostFunction {
 public:
  BlockCost(const ChamberSeries& s, size_t begin, size_t end) : s_(s), begin_(begin), end_(end) {
    set_num_residuals(static_cast<int>(end - begin));
    mutable_parameter_block_sizes()->push_back(9);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    ParametricModel model = ModelFor(s_, {});
    std::copy(parameters[0], parameters[0] + 9, model.c.begin());
    const double inv_cs = 1 / model.c_s;
    std::array<double, 9> dp{};
    for (size_t t = begin_; t < end_; ++t) {
      const size_t i = t - begin_;
      double predicted = PredictNextWithJacobian(model, s_.p[t], s_.u[t], s_.x[t], s_.x_rate[t], s_.period, &dp);
      residuals[i] = (s_.p[t + 1] - predicted) * inv_cs;
      if (!std::isfinite(residuals[i])) return false;  // Ceres rejects the step
      if (jacobians && jacobians[0]) {
        for (int k = 0; k < 9; ++k) jacobians[0][i * 9 + static_cast<size_t>(k)] = -dp[static_cast<size_t>(k)] * inv_cs;
      }
    }
    return true;
  }

 private:
  const ChamberSeries& s_;
  size_t begin_, end_;  // predictions from samples begin..end-1
};

struct StartResult {
  std::array<double, 9> c{};
  double cost = std::numeric_limits<double>::infinity();
  int iterations = 0;
  bool converged = false;
  std::string message;
};

std::array<double, 9> Clip(std::array<double, 9> c, const ParameterBounds& b) {
  for (size_t k = 0; k < 9; ++k) c[k] = std::clamp(c[k], b.lower[k], b.upper[k]);
  return c;
}

StartResult SolveFrom(const ChamberSeries& s, const ParameterBounds& bounds, const std::array<double, 9>& guess,
                      const ParametricFitOptions& options) {
  StartResult result;
  result.c = Clip(guess, bounds);
  ceres::Problem problem;
  const size_t pairs = s.p.size() - 1;
  const size_t block = static_cast<size_t>(std::max(options.samples_per_block, 1));
  for (size_t begin = 0; begin < pairs; begin += block) {
    problem.AddResidualBlock(new BlockCost(s, begin, std::min(begin + block, pairs)), nullptr, result.c.data());
  }
  for (int k = 0; k < 9; ++k) {
    problem.SetParameterLowerBound(result.c.data(), k, bounds.lower[static_cast<size_t>(k)]);
    problem.SetParameterUpperBound(result.c.data(), k, bounds.upper[static_cast<size_t>(k)]);
  }
  ceres::Solver::Options solver;
  solver.minimizer_type = ceres::TRUST_REGION;
  solver.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver.linear_solver_type = ceres::DENSE_QR;  // normal equations square the conditioning: a start misconverged with them
  solver.num_threads = 1;  // determinism and the caller's threads: one problem per thread
  solver.max_num_iterations = options.max_iterations;
  solver.function_tolerance = options.function_tolerance;
  solver.parameter_tolerance = options.parameter_tolerance;
  solver.gradient_tolerance = options.gradient_tolerance;
  solver.logging_type = ceres::SILENT;
  solver.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  result.cost = summary.final_cost;
  result.iterations = static_cast<int>(summary.iterations.size());
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.message = summary.message;
  if (!summary.IsSolutionUsable() || !std::isfinite(result.cost)) {
    result.cost = std::numeric_limits<double>::infinity();
  }
  return result;
}

// the scaled residuals and their Jacobian over the whole series, for the standard errors
void ResidualsAndJacobian(const ChamberSeries& s, const ParametricModel& model, Eigen::MatrixXd* J,
                          Eigen::VectorXd* r) {
  const Eigen::Index pairs = static_cast<Eigen::Index>(s.p.size() - 1);
  J->resize(pairs, 9);
  r->resize(pairs);
  std::array<double, 9> dp{};
  for (Eigen::Index i = 0; i < pairs; ++i) {
    const size_t t = static_cast<size_t>(i);
    (*r)(i) = (s.p[t + 1] - PredictNextWithJacobian(model, s.p[t], s.u[t], s.x[t], s.x_rate[t], s.period, &dp)) /
              model.c_s;
    for (Eigen::Index k = 0; k < 9; ++k) (*J)(i, k) = -dp[static_cast<size_t>(k)] / model.c_s;
  }
}

// the magnitude below which a parameter's own value is not the reference of its relative
// standard error: 1/100 of the width of its typical range (the project's own choice)
std::vector<double> UncertaintyScales(const ChamberSeries& s) {
  const double h = s.period;
  return {
      6.0 / 100,                              // c1: Table I's 2..8 V
      10.0 / 100,                             // c2: 1/V
      10.0 / 100,                             // c3: 1/V^3
      (s.p_supply - s.p_exhaust) / 2 / 100,   // c4: c_s's shift of s per m/s of rate
      1 / h / 100,                            // c5: a change of r by 1/h per m/s
      2 * C6Limit(s) / 100,                   // c6: its bounds
      1 / h / 100,                            // c7: r = 1/h at 1 V from the centre
      2.0 / 100,                              // c8: (-1, 1)
      1.0 / 100,                              // c9: V
  };
}

// the warnings on a fit: poorly determined parameters, parameters on a bound, negative rates
void AddWarnings(const ChamberSeries& s, const ParameterBounds& bounds, const StartResult& best,
                 ParametricFit* fit) {
  if (!best.converged) fit->warnings.push_back("not converged: " + best.message);
  for (size_t k = 0; k < 9; ++k) {
    const double c = fit->model.c[k];
    if (c == bounds.lower[k] || c == bounds.upper[k]) {
      fit->warnings.push_back(kNames[k] + " = " + Format("%.6g", c) + " is on its " +
                              (c == bounds.lower[k] ? "lower" : "upper") + " bound (paper 000 Table I / MJCF range)");
    }
  }
  size_t negative = 0;
  for (size_t t = 0; t + 1 < s.p.size(); ++t) {
    if (EvaluateModel(fit->model, s.u[t], s.x[t], s.x_rate[t]).r < 0) ++negative;
  }
  const double fraction = static_cast<double>(negative) / static_cast<double>(s.p.size() - 1);
  if (fraction > 0.01) {
    fit->warnings.push_back("the fitted rate r of eq. 10e is negative on " + Format("%.1f", 100 * fraction) +
                            " % of the samples (the prediction holds the pressure there, r clamped at 0)");
  }
}

void AddUncertainty(const ChamberSeries& s, ParametricFit* fit) {
  Eigen::MatrixXd J;
  Eigen::VectorXd r;
  ResidualsAndJacobian(s, fit->model, &J, &r);
  UncertaintyOptions options;
  options.lag_window = 0;  // one-step residuals: the textbook covariance
  std::vector<double> values(fit->model.c.begin(), fit->model.c.end());
  Uncertainty u = EstimateUncertainty(J, r, kNames, values, UncertaintyScales(s), options);
  fit->standard_error.fill(std::numeric_limits<double>::infinity());
  if (!u.error.empty()) {
    fit->warnings.push_back("standard errors unavailable, parameters not all determined by the data: " + u.error);
    return;
  }
  std::string names, reasons;
  for (size_t k = 0; k < 9 && k < u.standard_error.size(); ++k) {
    fit->standard_error[k] = u.standard_error[k];
    if (k < u.poorly_determined.size() && !u.poorly_determined[k].empty()) {
      names += (names.empty() ? "" : ", ") + kNames[k];
      reasons += (reasons.empty() ? "" : "; ") + kNames[k] + ": " + u.poorly_determined[k];
    }
  }
  if (!names.empty()) fit->warnings.push_back(names + " poorly determined: " + reasons);
}

}  // namespace

ParametricModel ModelFor(const ChamberSeries& s, const std::array<double, 9>& c) {
  ParametricModel model;
  model.c = c;
  model.c_gamma = 0.1;                            // V, paper 000 IV
  model.c_b = (s.p_supply + s.p_exhaust) / 2;     // Pa abs, Table I
  model.c_s = (s.p_supply - s.p_exhaust) / 2;     // Pa, Table I
  return model;
}

SteadyStateRate EvaluateModel(const ParametricModel& m, double u, double x, double x_rate) {
  // paper 000 eqs. 10a-10e with g of eq. 8 and k of eq. 9, as plugin/src/chamber.cc IdentifiedModel
  const double u_hat = u - m.c[0];                                              // 10a, V
  const double a = m.c[1] * u_hat + m.c[2] * u_hat * u_hat * u_hat;
  const double g = a / std::sqrt(a * a + 1);                                    // 8, 10b
  const double k = std::sqrt(u_hat * u_hat + m.c_gamma * m.c_gamma) - m.c_gamma + m.c[8] + m.c[7] * u_hat;  // 9, 10d
  SteadyStateRate out;
  out.s = m.c_b + m.c_s * g + m.c[3] * x_rate;                                  // 10c, Pa abs
  out.r = (m.c[6] * k + m.c[4] * x_rate) / (1 + m.c[5] * x);                    // 10e, 1/s
  return out;
}

double PredictNext(const ParametricModel& model, double p, double u, double x, double x_rate, double h) {
  // paper 000 eq. 7; r held at >= 0 as plugin/src/chamber.cc IdentifiedPressureStep does
  const SteadyStateRate sr = EvaluateModel(model, u, x, x_rate);
  const double r = std::max(sr.r, 0.0);
  return sr.s + (p - sr.s) * std::exp(-r * h);
}

double PredictNextWithJacobian(const ParametricModel& m, double p, double u, double x, double x_rate, double h,
                               std::array<double, 9>* jacobian) {
  // eq. 7 with the unclamped r of eq. 10e: p^ = s + (p - s) E, E = e^(-r h)
  const double u_hat = u - m.c[0];
  const double u_hat2 = u_hat * u_hat;
  const double a = m.c[1] * u_hat + m.c[2] * u_hat2 * u_hat;
  const double root_a = std::sqrt(a * a + 1);
  const double g = a / root_a;
  const double dg_da = 1 / (root_a * root_a * root_a);  // g'(a) = (a^2 + 1)^(-3/2)
  const double root_u = std::sqrt(u_hat2 + m.c_gamma * m.c_gamma);
  const double k = root_u - m.c_gamma + m.c[8] + m.c[7] * u_hat;
  const double denominator = 1 + m.c[5] * x;
  const double s = m.c_b + m.c_s * g + m.c[3] * x_rate;
  const double r = (m.c[6] * k + m.c[4] * x_rate) / denominator;
  const double E = std::exp(-r * h);
  const double predicted = s + (p - s) * E;

  // chain rule: dp^/ds = 1 - E, dp^/dr = -(p - s) h E
  const double dp_ds = 1 - E;
  const double dp_dr = -(p - s) * h * E;
  const double ds_da = m.c_s * dg_da;
  const double da_du_hat = m.c[1] + 3 * m.c[2] * u_hat2;
  const double dk_du_hat = u_hat / root_u + m.c[7];
  std::array<double, 9>& J = *jacobian;
  // c1 enters through u^ = u - c1 in both s and r
  J[0] = dp_ds * (-ds_da * da_du_hat) + dp_dr * (-m.c[6] * dk_du_hat / denominator);
  J[1] = dp_ds * ds_da * u_hat;                      // c2
  J[2] = dp_ds * ds_da * u_hat2 * u_hat;             // c3
  J[3] = dp_ds * x_rate;                             // c4
  J[4] = dp_dr * x_rate / denominator;               // c5
  J[5] = dp_dr * (-r * x / denominator);             // c6
  J[6] = dp_dr * k / denominator;                    // c7
  J[7] = dp_dr * m.c[6] * u_hat / denominator;       // c8
  J[8] = dp_dr * m.c[6] / denominator;               // c9
  return predicted;
}

ParameterBounds BoundsFor(const ChamberSeries& s) {
  constexpr double kOpen = 1e-6;  // margin that keeps a value on an open bound inside it
  const double c6 = C6Limit(s);
  ParameterBounds b;
  //          c1        c2     c3          c4    c5    c6   c7     c8          c9
  b.lower = {{2 + kOpen, -1e3, -1 + kOpen, -1e9, -1e6, -c6, 1e-9, -1 + kOpen, 1e-9}};
  b.upper = {{8 - kOpen, 1e3, 1e3, 1e9, 1e6, c6, 1e6, 1 - kOpen, 100}};
  return b;
}

std::array<double, 9> DefaultInitialGuess(const ChamberSeries& s) {
  // c1: the valve's centre (U_c + U_r)/2 (Table I) if the model gives its seal voltages, else 5 V,
  //     the middle of the 0..10 V MPYE range
  const double c1 = std::isfinite(s.u_seal_centre) ? std::clamp(s.u_seal_centre, 2.5, 7.5) : 5.0;
  // c2: s reaches g(1) = 71 % of c_s at 1 V from the centre; c3: no kink; c4, c5: no rate terms
  // c6: 1 + c6 x is the chamber volume over its volume at x = 0 (paper 000 III.C), c6 = +-1/(stroke/2
  //     + V0/A) for a dead volume V0 and piston area A; the guess +-1/stroke is a dead volume of half
  //     the swept volume. +: P's volume grows with x, -: N's shrinks
  const double c6 = VolumeSign(s) * std::min(1 / std::max(s.stroke, 1e-9), C6Limit(s) / 2);
  // c7: r h = 1 at 1 V from the centre: one step covers 63 % of the way to s
  const double c7 = 1 / s.period;
  // c8: symmetric ports; c9: leakage rate 1 % of the 1 V rate
  return {c1, 1.0, 0.0, 0.0, 0.0, c6, c7, 0.0, 0.01};
}

ParametricFit FitChamber(const ChamberSeries& s, const ParametricFitOptions& options) {
  ParametricFit fit;
  fit.name = s.name;
  fit.standard_error.fill(std::numeric_limits<double>::infinity());
  if (std::string invalid = CheckSeries(s); !invalid.empty()) {
    fit.error = invalid;
    return fit;
  }
  fit.model = ModelFor(s, DefaultInitialGuess(s));
  const auto [u_low, u_high] = std::minmax_element(s.u.begin(), s.u.end() - 1);
  if (*u_high - *u_low < 1e-3) {
    fit.error = s.name + ": the valve command never varies (u = " + Format("%.6g", *u_low) + " .. " +
                Format("%.6g", *u_high) +
                " V): the chamber was never excited, and c1..c9 (the valve's voltage dependence) cannot be "
                "identified from it";
    return fit;
  }
  const ParameterBounds bounds = BoundsFor(s);
  std::vector<std::array<double, 9>> guesses;
  if (options.use_default_guess) guesses.push_back(DefaultInitialGuess(s));
  guesses.insert(guesses.end(), options.initial_guesses.begin(), options.initial_guesses.end());
  StartResult best;
  std::string last_message;
  for (const auto& guess : guesses) {
    StartResult start = SolveFrom(s, bounds, guess, options);
    fit.iterations += start.iterations;
    last_message = start.message;
    if (start.cost < best.cost) {
      const int iterations = fit.iterations;
      best = start;
      fit.iterations = iterations;
    }
  }
  if (guesses.empty()) {
    fit.error = s.name + ": no initial guess (use_default_guess is false and initial_guesses is empty)";
    return fit;
  }
  if (!std::isfinite(best.cost)) {
    fit.error = s.name + ": no start gave a usable solution (" + last_message + ")";
    return fit;
  }
  fit.model = ModelFor(s, best.c);
  fit.converged = best.converged;
  const OneStepScore score = ScoreOneStep(s, fit.model);
  fit.rms_residual = score.rms_residual;
  fit.one_step_fit_pct = score.fit_pct;
  AddUncertainty(s, &fit);
  AddWarnings(s, bounds, best, &fit);
  return fit;
}

std::vector<ParametricFit> FitChambers(const std::vector<ChamberSeries>& series, const ParametricFitOptions& options,
                                       int threads) {
  std::vector<ParametricFit> fits(series.size());
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t i = next++; i < series.size(); i = next++) fits[i] = FitChamber(series[i], options);
  };
  const size_t workers = std::min(static_cast<size_t>(std::max(threads, 1)), std::max<size_t>(series.size(), 1));
  std::vector<std::thread> pool;
  for (size_t w = 1; w < workers; ++w) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  return fits;
}

}  // namespace pneumatic::identification
