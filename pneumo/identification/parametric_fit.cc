#include "identification/parametric_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <ceres/ceres.h>
#include <Eigen/Dense>

#include "identification/drift.h"
#include "identification/uncertainty.h"
#include "simulation/parallel_for.h"

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

// The intermediate quantities of eqs. 7-10 at one sample, shared by the prediction with and
// without derivatives so that both give the same bits (the fit's trial steps use the latter)
struct Step {
  double u_hat, u_hat2, a, root_a, root_u, k, denominator, s, r, E, predicted;
};

inline Step ComputeStep(const ParametricModel& m, double p, double u, double x, double x_rate, double h) {
  // eq. 7 with the unclamped r of eq. 10e: p^ = s + (p - s) E, E = e^(-r h)
  Step st;
  st.u_hat = u - m.c[0];                                                       // 10a
  st.u_hat2 = st.u_hat * st.u_hat;
  st.a = m.c[1] * st.u_hat + m.c[2] * st.u_hat2 * st.u_hat;                   // 10b
  st.root_a = std::sqrt(st.a * st.a + 1);
  st.root_u = std::sqrt(st.u_hat2 + m.c_gamma * m.c_gamma);
  st.k = st.root_u - m.c_gamma + m.c[8] + m.c[7] * st.u_hat;                  // 9, 10d
  st.denominator = 1 + m.c[5] * x;
  st.s = m.c_b + m.c_s * (st.a / st.root_a) + m.c[3] * x_rate;                // 8, 10c
  st.r = (m.c[6] * st.k + m.c[4] * x_rate) / st.denominator;                 // 10e
  st.E = std::exp(-st.r * h);
  st.predicted = st.s + (p - st.s) * st.E;                                    // 7
  return st;
}

// The next-step predictions a fit is made of: row t of a series (p_t, u_t, x_t, x'_t) and the
// pressure p_{t+1} it predicts, for every row or for every k-th row (the coarse stage)
struct Samples {
  std::vector<double> p, u, x, x_rate, p_next;
  double period = 0;
  size_t size() const { return p.size(); }
};

Samples TakeSamples(const ChamberSeries& s, size_t stride) {
  Samples d;
  d.period = s.period;
  for (size_t t = 0; t + 1 < s.p.size(); t += stride) {
    d.p.push_back(s.p[t]);
    d.u.push_back(s.u[t]);
    d.x.push_back(s.x[t]);
    d.x_rate.push_back(s.x_rate[t]);
    d.p_next.push_back(s.p[t + 1]);
  }
  return d;
}

// The residuals (p_{t+1} - p^_{t+1}) / c_s of samples [begin, end) into r[0 .. end-begin), and if
// J is not null their derivatives d r / d c_k into column k of the column-major J of leading
// dimension ld. Scaling by 1/c_s makes the residuals O(1). False if a residual is not finite.
bool ScaledResiduals(const ParametricModel& m, const Samples& d, size_t begin, size_t end, double* r, double* J,
                     size_t ld) {
  const double inv_cs = 1 / m.c_s;
  std::array<double, 9> dp{};
  for (size_t t = begin; t < end; ++t) {
    const size_t i = t - begin;
    const double predicted =
        J ? PredictNextWithJacobian(m, d.p[t], d.u[t], d.x[t], d.x_rate[t], d.period, &dp)
          : ComputeStep(m, d.p[t], d.u[t], d.x[t], d.x_rate[t], d.period).predicted;  // no derivatives: half the work
    r[i] = (d.p_next[t] - predicted) * inv_cs;
    if (!std::isfinite(r[i])) return false;
    if (J) {
      for (size_t k = 0; k < 9; ++k) J[k * ld + i] = -dp[k] * inv_cs;
    }
  }
  return true;
}

// One Ceres residual block: the residuals of samples [begin, end), with the analytic Jacobian: a
// few thousand samples (one block per sample costs more in Ceres's bookkeeping than the model).
//
// Compressed (the full-data stage after a coarse one, see SolveFrom): the block hands Ceres its
// QR-compressed form. With the block's n x 10 matrix [J | r] = Q T (Householder QR, T upper
// triangular) it returns the min(n, 10) residuals q = T(:, 9) = Q^T r and the Jacobian
// T(:, 0..8) = [R; 0]. Q being orthogonal, ||q||^2 = ||r||^2 (the cost), R^T R = J^T J,
// [R; 0]^T q = J^T r (the gradient), ||[R; 0] d + q||^2 = ||J d + r||^2 for every step d
// (Levenberg-Marquardt's subproblem, Ceres's model cost change) and R's column norms are J's
// (Ceres's Jacobi scaling): the iterations are those on the n residuals in exact arithmetic, and
// QR does not square the conditioning as the normal equations do (Golub and Van Loan, Matrix
// Computations, 4th ed., ch. 5), while Ceres handles 10 rows per block instead of 2000 (its
// per-residual bookkeeping and its QR of the 10^5 x 9 Jacobian, which leaves the cache, were
// half of the fit's time). A cost-only evaluation returns (||r||, 0, ...): the same cost.
// The rounding of the steps differs, though, and a start far from the optimum, whose path runs
// along the bounds, is sensitive to it: the recovery test's start 3 ends on c3's bound with
// compressed blocks (as it did with DENSE_NORMAL_CHOLESKY). Far starts therefore use the blocks
// as they are.
//
// Each block keeps its last evaluation and gives it back when Ceres asks for the same parameters
// again, which it does twice per iteration: its projected line search (the bounds) evaluates the
// trial point with its gradient (hence the Jacobian), then the trust region evaluates the same
// point's cost and, once the step is accepted, its residuals and Jacobian. The numbers are those
// a new evaluation would give, to the bit; only the repeated work goes.
class BlockCost : public ceres::CostFunction {
 public:
  static constexpr size_t kCompressed = 10;  // rows of a compressed block: c1..c9 and the residuals

  BlockCost(const ChamberSeries& series, const Samples& d, size_t begin, size_t end, bool compressed)
      : series_(series), d_(d), begin_(begin), end_(end), compressed_(compressed) {
    set_num_residuals(static_cast<int>(compressed ? std::min(end - begin, kCompressed) : end - begin));
    mutable_parameter_block_sizes()->push_back(9);
    last_c_.fill(std::numeric_limits<double>::quiet_NaN());  // no evaluation yet
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const bool jacobian = jacobians && jacobians[0];
    if (std::memcmp(parameters[0], last_c_.data(), sizeof(last_c_)) != 0 || (jacobian && !last_has_jacobian_)) {
      std::copy(parameters[0], parameters[0] + 9, last_c_.begin());
      last_valid_ = Compute(jacobian);
      last_has_jacobian_ = jacobian;
    }
    if (!last_valid_) return false;  // Ceres rejects the step
    const size_t rows = static_cast<size_t>(num_residuals());
    std::copy(out_r_.begin(), out_r_.begin() + rows, residuals);
    if (jacobian) std::copy(out_J_.begin(), out_J_.begin() + rows * 9, jacobians[0]);
    return true;
  }

 private:
  // the residuals (and Jacobian, row-major) at last_c_ into out_r_ (out_J_), compressed or not;
  // false if not finite
  bool Compute(bool jacobian) const {
    const size_t n = end_ - begin_, rows = static_cast<size_t>(num_residuals());
    A_.resize(static_cast<Eigen::Index>(n), 10);  // [J | r], column-major
    if (!ScaledResiduals(ModelFor(series_, last_c_), d_, begin_, end_, A_.col(9).data(),
                         jacobian ? A_.data() : nullptr, n)) {
      return false;
    }
    out_r_.assign(rows, 0.0);
    out_J_.resize(jacobian ? rows * 9 : 0);
    if (compressed_ && !jacobian) {
      out_r_[0] = A_.col(9).norm();
      return true;
    }
    if (compressed_) {
      Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(A_);  // in place: T in A_'s upper triangle
    }
    for (size_t i = 0; i < rows; ++i) {
      const auto row = static_cast<Eigen::Index>(i);
      out_r_[i] = A_(row, 9);
      for (size_t k = 0; jacobian && k < 9; ++k) {
        out_J_[i * 9 + k] = compressed_ && k < i ? 0.0 : A_(row, static_cast<Eigen::Index>(k));
      }
    }
    return !compressed_ || A_.topRows(static_cast<Eigen::Index>(rows)).allFinite();
  }

  const ChamberSeries& series_;  // c_b, c_s
  const Samples& d_;
  size_t begin_, end_;  // samples begin..end-1
  bool compressed_;
  // the last evaluation: its parameters (NaN: none yet) and what was handed to Ceres
  mutable std::array<double, 9> last_c_;
  mutable bool last_has_jacobian_ = false, last_valid_ = false;
  mutable std::vector<double> out_r_, out_J_;
  mutable Eigen::MatrixXd A_;
};

struct StartResult {
  std::array<double, 9> c{};
  double cost = std::numeric_limits<double>::infinity();
  int iterations = 0;         // on the full data
  int coarse_iterations = 0;  // on the coarse subsample
  bool converged = false;
  std::string message;
};

std::array<double, 9> Clip(std::array<double, 9> c, const ParameterBounds& b) {
  for (size_t k = 0; k < 9; ++k) c[k] = std::clamp(c[k], b.lower[k], b.upper[k]);
  return c;
}

// Ceres's Levenberg-Marquardt on samples d from c (within the bounds) to convergence
StartResult Minimize(const ChamberSeries& s, const Samples& d, bool compressed, const ParameterBounds& bounds,
                     const std::array<double, 9>& c, const ParametricFitOptions& options) {
  StartResult result;
  result.c = c;
  ceres::Problem problem;
  const size_t block = static_cast<size_t>(std::max(options.samples_per_block, 1));
  for (size_t begin = 0; begin < d.size(); begin += block) {
    problem.AddResidualBlock(new BlockCost(s, d, begin, std::min(begin + block, d.size()), compressed), nullptr,
                             result.c.data());
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

// One start, coarse to fine (the project's own acceleration): Levenberg-Marquardt to convergence
// on the coarse subsample if any (every k-th pair: the same objective in expectation, 1/k of its
// cost per iteration), then on all pairs from there, with compressed blocks (BlockCost), until
// the full-data convergence criteria hold. The result is the full-data optimum; the full-data
// stage starts within a few standard errors of it. A coarse stage without a usable solution is
// skipped: the full data from the guess, as without a coarse stage.
StartResult SolveFrom(const ChamberSeries& s, const Samples& full, const Samples* coarse, const ParameterBounds& bounds,
                      const std::array<double, 9>& guess, const ParametricFitOptions& options) {
  std::array<double, 9> from = Clip(guess, bounds);
  StartResult first;
  if (coarse) first = Minimize(s, *coarse, false, bounds, from, options);
  const bool near = coarse && std::isfinite(first.cost);
  StartResult result = Minimize(s, full, near, bounds, near ? first.c : from, options);
  result.coarse_iterations = first.iterations;
  return result;
}

// the scaled residuals and their Jacobian over the whole series, for the standard errors
void ResidualsAndJacobian(const Samples& d, const ParametricModel& model, Eigen::MatrixXd* J, Eigen::VectorXd* r) {
  const Eigen::Index pairs = static_cast<Eigen::Index>(d.size());
  J->resize(pairs, 9);
  r->resize(pairs);
  if (!ScaledResiduals(model, d, 0, d.size(), r->data(), J->data(), d.size())) {
    r->setConstant(std::numeric_limits<double>::quiet_NaN());  // EstimateUncertainty says so
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

// the warnings on a fit: not converged, and ModelWarnings
void AddWarnings(const ChamberSeries& s, const ParameterBounds& bounds, const StartResult& best,
                 ParametricFit* fit) {
  if (!best.converged) fit->warnings.push_back("not converged: " + best.message);
  for (std::string& w : ModelWarnings(s, bounds, fit->model)) fit->warnings.push_back(std::move(w));
}

void AddUncertainty(const ChamberSeries& s, const Samples& full, ParametricFit* fit) {
  Eigen::MatrixXd J;
  Eigen::VectorXd r;
  ResidualsAndJacobian(full, fit->model, &J, &r);
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

std::vector<std::string> ModelWarnings(const ChamberSeries& s, const ParameterBounds& bounds, const ParametricModel& model) {
  std::vector<std::string> warnings;
  for (size_t k = 0; k < 9; ++k) {
    const double c = model.c[k];
    if (c == bounds.lower[k] || c == bounds.upper[k]) {
      warnings.push_back(kNames[k] + " = " + Format("%.6g", c) + " is on its " +
                         (c == bounds.lower[k] ? "lower" : "upper") + " bound (paper 000 Table I / MJCF range)");
    }
  }
  size_t negative = 0;
  for (size_t t = 0; t + 1 < s.p.size(); ++t) {
    if (EvaluateModel(model, s.u[t], s.x[t], s.x_rate[t]).r < 0) ++negative;
  }
  const double fraction = static_cast<double>(negative) / static_cast<double>(s.p.size() - 1);
  if (fraction > 0.01) {
    warnings.push_back("the fitted rate r of eq. 10e is negative on " + Format("%.1f", 100 * fraction) +
                       " % of the samples (the prediction holds the pressure there, r clamped at 0)");
  }
  return warnings;
}

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
  const Step st = ComputeStep(m, p, u, x, x_rate, h);
  // chain rule: dp^/ds = 1 - E, dp^/dr = -(p - s) h E
  const double dp_ds = 1 - st.E;
  const double dp_dr = -(p - st.s) * h * st.E;
  const double dg_da = 1 / (st.root_a * st.root_a * st.root_a);  // g'(a) = (a^2 + 1)^(-3/2)
  const double ds_da = m.c_s * dg_da;
  const double da_du_hat = m.c[1] + 3 * m.c[2] * st.u_hat2;
  const double dk_du_hat = st.u_hat / st.root_u + m.c[7];
  const double denominator = st.denominator;
  std::array<double, 9>& J = *jacobian;
  // c1 enters through u^ = u - c1 in both s and r
  J[0] = dp_ds * (-ds_da * da_du_hat) + dp_dr * (-m.c[6] * dk_du_hat / denominator);
  J[1] = dp_ds * ds_da * st.u_hat;                      // c2
  J[2] = dp_ds * ds_da * st.u_hat2 * st.u_hat;          // c3
  J[3] = dp_ds * x_rate;                                // c4
  J[4] = dp_dr * x_rate / denominator;                  // c5
  J[5] = dp_dr * (-st.r * x / denominator);             // c6
  J[6] = dp_dr * st.k / denominator;                    // c7
  J[7] = dp_dr * m.c[6] * st.u_hat / denominator;       // c8
  J[8] = dp_dr * m.c[6] / denominator;                  // c9
  return st.predicted;
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
  const Samples full = TakeSamples(s, 1);
  const size_t stride = options.coarse_samples > 0 ? full.size() / static_cast<size_t>(options.coarse_samples) : 0;
  const Samples coarse = stride >= 4 ? TakeSamples(s, stride) : Samples{};
  StartResult best;
  std::string last_message;
  for (const auto& guess : guesses) {
    const StartResult start = SolveFrom(s, full, stride >= 4 ? &coarse : nullptr, bounds, guess, options);
    fit.iterations += start.iterations;
    fit.coarse_iterations += start.coarse_iterations;
    last_message = start.message;
    if (start.cost < best.cost) best = start;
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
  AddUncertainty(s, full, &fit);
  AddWarnings(s, bounds, best, &fit);
  return fit;
}

std::vector<ParametricFit> FitChambers(const std::vector<ChamberSeries>& series, const ParametricFitOptions& options,
                                       int threads) {
  std::vector<ParametricFit> fits(series.size());
  ParallelFor(series.size(), threads, [&](size_t i) { fits[i] = FitChamber(series[i], options); });
  return fits;
}

}  // namespace pneumatic::identification
