#include "identification/output_error_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <ceres/ceres.h>

#include "simulation/parallel_for.h"

namespace pneumatic::identification {
namespace {

// one sequence's residuals p^(t_j + k h) - p(t_j + k h), k = 1..steps (output_error_fit.h), in units
// of p_supply - p_exhaust (the drift's scale, paper 000 Fig. 13)
struct SequenceResiduals {
  const ChamberSeries* series;
  ParametricModel model;  // c_gamma, c_b, c_s of the series; c replaced by the parameters
  int start, steps;
  double scale;           // Pa: p_supply - p_exhaust
  bool operator()(const double* c, double* residual) const {
    ParametricModel m = model;
    std::copy(c, c + 9, m.c.begin());
    const ChamberSeries& s = *series;
    double p = s.p[start];
    for (int k = 0; k < steps; ++k) {
      const int row = start + k;
      p = PredictNext(m, p, s.u[row], s.x[row], s.x_rate[row], s.period);
      residual[k] = (p - s.p[row + 1]) / scale;
      if (!std::isfinite(residual[k])) return false;  // Ceres rejects the step
    }
    return true;
  }
};

}  // namespace

OutputErrorFit RefineOutputError(const ChamberSeries& series, const ParametricModel& start,
                                 const OutputErrorOptions& options) {
  OutputErrorFit fit;
  fit.name = series.name;
  fit.model = start;
  if (std::string e = CheckSeries(series); !e.empty()) {
    fit.error = e;
    return fit;
  }
  const int entries = static_cast<int>(series.p.size());
  const int steps = static_cast<int>(std::lround(options.horizon_s / series.period));
  // p[row + 1] is read for row = start + steps - 1: a sequence needs steps + 1 entries
  if (steps < 2 || steps + 1 > entries) {
    char message[200];
    std::snprintf(message, sizeof(message), "the output-error horizon of %g s is not 2 to %d rows of the series (%d rows, "
                  "one every %g s)", options.horizon_s, entries - 1, entries, series.period);
    fit.error = message;
    return fit;
  }

  std::array<double, 9> c = start.c;
  const ParameterBounds bounds = BoundsFor(series);
  for (int i = 0; i < 9; ++i) c[i] = std::clamp(c[i], bounds.lower[i], bounds.upper[i]);
  const double scale = series.p_supply - series.p_exhaust;
  ceres::Problem problem;
  const int stride = std::max(steps / 2, 1);
  for (int first = 0; first + steps + 1 <= entries; first += stride) {
    auto* cost = new ceres::NumericDiffCostFunction<SequenceResiduals, ceres::CENTRAL, ceres::DYNAMIC, 9>(
        new SequenceResiduals{&series, start, first, steps, scale}, ceres::TAKE_OWNERSHIP, steps);
    problem.AddResidualBlock(cost, nullptr, c.data());
    ++fit.sequences;
  }
  for (int i = 0; i < 9; ++i) {
    problem.SetParameterLowerBound(c.data(), i, bounds.lower[i]);
    problem.SetParameterUpperBound(c.data(), i, bounds.upper[i]);
  }
  ceres::Solver::Options solver;
  solver.max_num_iterations = options.max_iterations;
  solver.num_threads = 1;  // chambers run in parallel instead (RefineOutputErrors): the same bits either way
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  if (!std::isfinite(summary.initial_cost)) {
    fit.error = "the model's prediction from the one-step fit is not finite on this series";
    return fit;
  }
  const double residuals = static_cast<double>(fit.sequences) * steps;
  // Ceres' cost is half the sum of squares
  fit.rms_before_pa = scale * std::sqrt(2 * summary.initial_cost / residuals);
  fit.rms_after_pa = scale * std::sqrt(2 * summary.final_cost / residuals);
  fit.iterations = static_cast<int>(summary.iterations.size());
  fit.converged = summary.termination_type == ceres::CONVERGENCE;
  fit.model.c = c;
  if (!fit.converged) fit.warnings.push_back("not converged: " + summary.message);
  for (std::string& w : ModelWarnings(series, bounds, fit.model)) fit.warnings.push_back(std::move(w));
  return fit;
}

std::vector<OutputErrorFit> RefineOutputErrors(const std::vector<ChamberSeries>& series,
                                               const std::vector<ParametricModel>& starts,
                                               const OutputErrorOptions& options, int threads) {
  std::vector<OutputErrorFit> fits(series.size());
  ParallelFor(series.size(), threads, [&](size_t i) { fits[i] = RefineOutputError(series[i], starts[i], options); });
  return fits;
}

}  // namespace pneumatic::identification
