// An output-error refinement of paper 000's one-step fit (the project's own addition to V.C).
//
// Paper 000 fits c1..c9 to the pressure one step ahead, p_{t+h} from the MEASURED p_t (V.C, an
// equation-error fit), and judges the result by how far the model drifts when it runs on its own
// predictions for 2 s (V.D, Fig. 13). The two can disagree: where a chamber's data explores little
// of the model (a chamber held near supply, a valve that rarely opens), many c fit the next step
// equally well, and the one the fit picks may drift far; noise on the measured p_t, which is also
// the fit's input, biases the one-step fit too. The refinement starts from the one-step fit and
// minimizes the error of the model's OWN prediction over short sequences, the quantity the drift
// measures (a simulation-error fit by multiple shooting):
//   cost(c) = sum over sequences j, steps k = 1..K of (p^_j(t_j + k h; c) - p_{t_j + k h})^2,
//   p^_j(t_j) = p_{t_j} measured, p^_j(t + h) = PredictNext(p^_j(t), u_t, x_t, x rate_t; c) (eq. 7),
// with sequences of K = horizon / h steps starting every K/2 rows (so that every row is in two),
// within the bounds of the one-step fit (paper 000 Table I and the MJCF's ranges). Ceres'
// Levenberg-Marquardt with central-difference Jacobians (eq. 7 with r clamped at 0, as the
// extension steps it, is not smooth where r = 0; differences see the clamp the simulator has).
#ifndef PNEUMATIC_IDENTIFICATION_OUTPUT_ERROR_FIT_H_
#define PNEUMATIC_IDENTIFICATION_OUTPUT_ERROR_FIT_H_

#include <string>
#include <vector>

#include "identification/chamber_series.h"
#include "identification/parametric_fit.h"

namespace pneumatic::identification {

struct OutputErrorOptions {
  double horizon_s = 0.5;   // length of each sequence, s (at least 2 rows of the series)
  int max_iterations = 100;
};

struct OutputErrorFit {
  std::string name;            // the series' name
  ParametricModel model;       // refined (the start if error is set)
  double rms_before_pa = 0;    // rms of p^ - p over the sequences, at the start
  double rms_after_pa = 0;     // the same at the refined c (never above rms_before_pa)
  int sequences = 0;
  int iterations = 0;
  bool converged = false;      // Ceres ended on a convergence criterion
  std::vector<std::string> warnings;  // ModelWarnings of the refined c, and "not converged"
  std::string error;
};

// Refines `start` (usually FitChamber's model) on `series`. Deterministic: the same inputs give
// the same bits.
OutputErrorFit RefineOutputError(const ChamberSeries& series, const ParametricModel& start,
                                 const OutputErrorOptions& options);

// Every chamber, series[i] from starts[i], over `threads` worker threads (< 1: 1); each result is
// the one RefineOutputError gives, whatever `threads`.
std::vector<OutputErrorFit> RefineOutputErrors(const std::vector<ChamberSeries>& series,
                                               const std::vector<ParametricModel>& starts,
                                               const OutputErrorOptions& options, int threads);

}  // namespace pneumatic::identification

#endif  // PNEUMATIC_IDENTIFICATION_OUTPUT_ERROR_FIT_H_
