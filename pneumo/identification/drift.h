// How well an identified parametric model predicts pressures: its one-step fit (paper 000 V.C,
// Fig. 11) and its multi-step drift (V.D, Figs. 12-13). For the drift, the prediction starts at
// the measured pressure, p^_0 = p_0, and is integrated with eq. 7 (r held at >= 0, as the
// extension does) along the measured u, x and x rate, so it may diverge from the measured p.
#ifndef PNEUMATIC_IDENTIFICATION_DRIFT_H_
#define PNEUMATIC_IDENTIFICATION_DRIFT_H_

#include <string>
#include <vector>

#include "identification/chamber_series.h"
#include "identification/parametric_fit.h"

namespace pneumatic::identification {

// One-step prediction on a series (training or held out): y = p_{t+1}, y^ = PredictNext(p_t, ...).
struct OneStepScore {
  double rms_residual = 0;  // Pa: rms of y - y^
  double fit_pct = 0;       // 100 (1 - ||y - y^|| / ||y - mean(y)||); 100 is perfect, 0 the mean's
  int samples = 0;          // predictions scored (entries - 1)
};
OneStepScore ScoreOneStep(const ChamberSeries& series, const ParametricModel& model);

struct DriftCurve {
  // one entry per horizon j h, j = 0..H (H = round(horizon_s / h)); at j = 0 the error is 0
  std::vector<double> horizon_s;  // s
  // over the sequences: standard deviation (about their mean, N - 1 in the denominator) and rms of
  // p^ - p, each sequence's error in % of its chamber's P_c - P_r (paper 000 Fig. 13's scale)
  std::vector<double> std_pct;
  std::vector<double> rms_pct;
  int sequences = 0;
  std::string error;  // non-empty: no curve (e.g. the data is shorter than the horizon)
};

// `starts` sequences of horizon_s each, starting at rows round(i (n - 1 - H) / (starts - 1)),
// i = 0..starts-1 (evenly spaced from the first row to the last start whose sequence fits in the n
// entries of the series; one start: row 0). Paper 000 V.D: 48 starts, 2 s.
DriftCurve Drift(const ChamberSeries& series, const ParametricModel& model, int starts = 48, double horizon_s = 2);

// The sequences of every chamber pooled (paper 000 Fig. 13's 3648 = 76 x 48): series[i] with
// models[i]; all series must have the same period.
DriftCurve PoolDrift(const std::vector<ChamberSeries>& series, const std::vector<ParametricModel>& models,
                     int starts = 48, double horizon_s = 2);

}  // namespace pneumatic::identification

#endif  // PNEUMATIC_IDENTIFICATION_DRIFT_H_
