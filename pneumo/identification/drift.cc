#include "identification/drift.h"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace pneumatic::identification {
namespace {

// the errors p^ - p of one sequence, in % of P_c - P_r, at j = 0..H
std::vector<double> SequenceErrorPct(const ChamberSeries& s, const ParametricModel& model, size_t start,
                                     size_t steps) {
  const double scale = 100 / (s.p_supply - s.p_exhaust);
  std::vector<double> error(steps + 1, 0.0);
  double predicted = s.p[start];  // paper 000 V.D: p^_0 = p_0, the measured pressure
  for (size_t j = 1; j <= steps; ++j) {
    const size_t t = start + j - 1;
    predicted = PredictNext(model, predicted, s.u[t], s.x[t], s.x_rate[t], s.period);
    error[j] = (predicted - s.p[t + 1]) * scale;
  }
  return error;
}

// the sequences' errors of one chamber, appended to *errors; "" or why not
std::string AppendSequences(const ChamberSeries& s, const ParametricModel& model, int starts, double horizon_s,
                            std::vector<std::vector<double>>* errors, size_t* steps_out) {
  if (starts < 1) return "at least one start is needed";
  if (!(horizon_s > 0)) return "the horizon must be positive";
  if (std::string invalid = CheckSeries(s); !invalid.empty()) return invalid;
  const size_t steps = static_cast<size_t>(std::lround(horizon_s / s.period));
  const size_t n = s.p.size();
  if (n < steps + 1) {
    char text[200];
    std::snprintf(text, sizeof(text), ": %zu samples (%g s) are shorter than the drift horizon of %g s (%zu samples)",
                  n, static_cast<double>(n) * s.period, horizon_s, steps + 1);
    return s.name + text;
  }
  const size_t last_start = n - 1 - steps;  // its sequence ends on the last entry
  for (int i = 0; i < starts; ++i) {
    size_t start = starts == 1 ? 0
                               : static_cast<size_t>(std::lround(static_cast<double>(i) *
                                                                 static_cast<double>(last_start) / (starts - 1)));
    errors->push_back(SequenceErrorPct(s, model, start, steps));
  }
  *steps_out = steps;
  return "";
}

DriftCurve Statistics(const std::vector<std::vector<double>>& errors, size_t steps, double period) {
  DriftCurve curve;
  curve.sequences = static_cast<int>(errors.size());
  const double n = static_cast<double>(errors.size());
  for (size_t j = 0; j <= steps; ++j) {
    double sum = 0, sum_sq = 0;
    for (const auto& e : errors) sum += e[j], sum_sq += e[j] * e[j];
    const double mean = sum / n;
    double deviation_sq = 0;
    for (const auto& e : errors) deviation_sq += (e[j] - mean) * (e[j] - mean);
    curve.horizon_s.push_back(static_cast<double>(j) * period);
    curve.std_pct.push_back(errors.size() > 1 ? std::sqrt(deviation_sq / (n - 1)) : 0.0);
    curve.rms_pct.push_back(std::sqrt(sum_sq / n));
  }
  return curve;
}

}  // namespace

OneStepScore ScoreOneStep(const ChamberSeries& s, const ParametricModel& model) {
  OneStepScore score;
  const size_t n = s.p.size();
  if (n < 2) return score;
  double mean = 0;
  for (size_t t = 1; t < n; ++t) mean += s.p[t];
  mean /= static_cast<double>(n - 1);
  double residual_sq = 0, spread_sq = 0;
  for (size_t t = 0; t + 1 < n; ++t) {
    const double y = s.p[t + 1];
    const double e = y - PredictNext(model, s.p[t], s.u[t], s.x[t], s.x_rate[t], s.period);
    residual_sq += e * e;
    spread_sq += (y - mean) * (y - mean);
  }
  score.samples = static_cast<int>(n - 1);
  score.rms_residual = std::sqrt(residual_sq / static_cast<double>(n - 1));
  // a constant y has no spread to explain: 0 % unless predicted exactly
  score.fit_pct = spread_sq > 0 ? 100 * (1 - std::sqrt(residual_sq / spread_sq)) : (residual_sq == 0 ? 100 : 0);
  return score;
}

DriftCurve Drift(const ChamberSeries& series, const ParametricModel& model, int starts, double horizon_s) {
  return PoolDrift({series}, {model}, starts, horizon_s);
}

DriftCurve PoolDrift(const std::vector<ChamberSeries>& series, const std::vector<ParametricModel>& models,
                     int starts, double horizon_s) {
  DriftCurve failed;
  if (series.empty() || series.size() != models.size()) {
    failed.error = "need one model per series (" + std::to_string(series.size()) + " series, " +
                   std::to_string(models.size()) + " models)";
    return failed;
  }
  std::vector<std::vector<double>> errors;
  size_t steps = 0;
  for (size_t i = 0; i < series.size(); ++i) {
    if (series[i].period != series[0].period) {
      failed.error = series[i].name + ": period differs from " + series[0].name + "'s";
      return failed;
    }
    if (std::string error = AppendSequences(series[i], models[i], starts, horizon_s, &errors, &steps);
        !error.empty()) {
      failed.error = error;
      return failed;
    }
  }
  return Statistics(errors, steps, series[0].period);
}

}  // namespace pneumatic::identification
