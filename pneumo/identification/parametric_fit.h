// Paper 000's parametric pressure model of one valve-chamber system (eqs. 6-10) and its
// identification from a log (Section V.C): c* = argmin sum_t (p_{t+h} - p^_{t+h}(p_t, u_t, v_t,
// v'_t; c))^2 within the bounds of Table I, by Ceres Solver's Levenberg-Marquardt with analytic
// derivatives.
//
// The model (paper 000 eqs. 8, 9, 10a-10e; v = the logged piston position x in m, v' its rate):
//   u^ = u - c1,  g(a) = a / sqrt(a^2 + 1),
//   s  = c_b + c_s g(c2 u^ + c3 u^3) + c4 v'                          (Pa abs)
//   k  = sqrt(u^2 + c_gamma^2) - c_gamma + c9 + c8 u^                 (V)
//   r  = (c7 k + c5 v') / (1 + c6 v)                                  (1/s)
// and its exact step over h with s and r held (eq. 7): p(t + h) = s + (p(t) - s) e^(-r h).
// c_gamma = 0.1 V (paper 000 IV), c_b = (P_c + P_r)/2, c_s = (P_c - P_r)/2 (Table I).
#ifndef PNEUMATIC_IDENTIFICATION_PARAMETRIC_FIT_H_
#define PNEUMATIC_IDENTIFICATION_PARAMETRIC_FIT_H_

#include <array>
#include <string>
#include <vector>

#include "identification/chamber_series.h"

namespace pneumatic::identification {

// c[0..8] are the paper's c1..c9, in the units of plugin/README.md: c1 V, c2 1/V, c3 1/V^3,
// c4 Pa s/m, c5 1/m, c6 1/m, c7 1/(V s), c8 1, c9 V
struct ParametricModel {
  std::array<double, 9> c{};
  double c_gamma = 0.1;  // V
  double c_b = 0;        // Pa abs
  double c_s = 0;        // Pa
};

// the model of a series' chamber with c_b and c_s from its supply and exhaust pressures (Table I)
ParametricModel ModelFor(const ChamberSeries& series, const std::array<double, 9>& c);

// s (Pa abs) and r (1/s, unclamped) of eq. 10 at command u (V), position x (m) and rate x_rate (m/s)
struct SteadyStateRate {
  double s = 0;
  double r = 0;
};
SteadyStateRate EvaluateModel(const ParametricModel& model, double u, double x, double x_rate);

// p(t + h) (Pa abs) from p(t) by eq. 7, with r held at >= 0 as the extension does
// (plugin/src/chamber.cc IdentifiedPressureStep): the same number the simulator computes.
double PredictNext(const ParametricModel& model, double p, double u, double x, double x_rate, double h);

// The prediction with the UNCLAMPED r of eq. 10e, and its derivatives d p(t+h) / d c_i (i = 0..8
// for c1..c9, in Pa per unit of c_i), which the fit uses (a clamp would zero the gradient).
double PredictNextWithJacobian(const ParametricModel& model, double p, double u, double x, double x_rate, double h,
                               std::array<double, 9>* jacobian);

// The bounds of the fit: paper 000 Table I (2 < c1 < 8 V, c3 > -1, -1 < c8 < 1, c9 > 0), and what
// the extension's MJCF accepts (plugin/src/config.cc: c7 > 0, 1 + c6 x > 0 for |x| <= stroke/2,
// and its ranges of c2, c4, c5, c7, c9). Open bounds are closed in by a margin so that a value on
// the bound is still accepted.
struct ParameterBounds {
  std::array<double, 9> lower{}, upper{};
};
ParameterBounds BoundsFor(const ChamberSeries& series);

// What a fitted model's c1..c9 say about the fit on this series: each parameter on a bound, and the
// share of samples where eq. 10e's rate r is negative (the prediction holds the pressure there),
// when over 1 %.
std::vector<std::string> ModelWarnings(const ChamberSeries& series, const ParameterBounds& bounds,
                                       const ParametricModel& model);

// The documented default initial guess, from physics and the series (see parametric_fit.cc).
std::array<double, 9> DefaultInitialGuess(const ChamberSeries& series);

struct ParametricFitOptions {
  // Extra initial guesses (c1..c9): the fit runs from the default guess and then from each of
  // these (clipped into the bounds), and keeps the lowest cost; on a tie the earlier start wins.
  std::vector<std::array<double, 9>> initial_guesses;
  // false: only initial_guesses (at least one), e.g. to check that each start reaches the same fit
  bool use_default_guess = true;
  int max_iterations = 200;  // per stage (coarse, full data) and start
  // samples per Ceres residual block: large enough that per-block overhead is negligible, small
  // enough that a block's Jacobian stays in cache
  int samples_per_block = 2000;
  // Coarse-to-fine (the project's own acceleration; parametric_fit.cc SolveFrom): on a series of
  // at least 4 coarse_samples pairs, each start first runs to convergence on every k-th pair,
  // k = pairs / coarse_samples (the same objective in expectation, k times cheaper), and the fit
  // then continues on ALL pairs from there (each block of samples_per_block handed to Ceres
  // QR-compressed) until the full-data convergence criteria hold, so the result is the full-data
  // optimum. 0: every iteration on the full data (10^5 pairs: about 2.7x slower).
  int coarse_samples = 6000;
  double function_tolerance = 1e-10;  // Ceres: relative decrease of the cost at convergence
  double parameter_tolerance = 1e-10;
  double gradient_tolerance = 1e-12;
};

struct ParametricFit {
  std::string name;           // the series' name, "<cyl>.P" / "<cyl>.N"
  ParametricModel model;
  std::array<double, 9> standard_error{};  // c1..c9, own units (textbook covariance, independent residuals)
  double rms_residual = 0;    // Pa: of p_{t+1} - p^_{t+1} on the training data (clamped prediction)
  // on the training data, 100 (1 - ||y - y^|| / ||y - mean(y)||), y = p_{t+1}
  double one_step_fit_pct = 0;
  int iterations = 0;         // Ceres iterations on the full data, summed over the starts
  int coarse_iterations = 0;  // Ceres iterations on the coarse subsample, summed over the starts
  bool converged = false;     // the kept start ended on a convergence criterion
  std::vector<std::string> warnings;  // e.g. "c2, c3 poorly determined: ..."
  std::string error;          // non-empty: no fit (model is the initial guess)
};

// Fits one chamber. Deterministic: the same series and options give the same bits.
ParametricFit FitChamber(const ChamberSeries& series, const ParametricFitOptions& options);

// Fits every chamber, chambers distributed over `threads` worker threads (< 1: 1); each result is
// the one FitChamber gives (one Ceres thread per problem), whatever `threads`.
std::vector<ParametricFit> FitChambers(const std::vector<ChamberSeries>& series, const ParametricFitOptions& options,
                                       int threads);

}  // namespace pneumatic::identification

#endif  // PNEUMATIC_IDENTIFICATION_PARAMETRIC_FIT_H_
