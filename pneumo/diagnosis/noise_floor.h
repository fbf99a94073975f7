// The noise floor of a diagnosis (issue 55, item 1): the gap a model without any error would
// still leave on this log, from the log's sensor noise and the model's own discretisation. A
// gap within a small multiple of it is explained (verdict `none`); a structured gap well above it
// that no candidate removes is `unexplained`.
//
// The project's own estimate, per signal s, in the signal's unit:
//   sigma_s      the sensor noise, from the log itself: the second differences of the measured
//                signal, d_i = y_{i+1} - 2 y_i + y_{i-1}, have the standard deviation sqrt(6) sigma
//                for white noise; a moving signal adds its curvature, which only ever widens them,
//                so the estimate is taken from their lower quartile, where the rows at rest and
//                sealed lie: sigma = Q_25(|d|) / (0.3186 sqrt(6)), 0.3186 being the lower quartile
//                of |z| for a standard normal z. It overstates sigma where fewer than half the rows
//                are that quiet (a pressure under a valve switched at every row, as a closed loop
//                at 500 Hz does), so a second estimate bounds it too: the error of the first row
//                each window predicts, e = n_start - n_next + (what the model gets wrong over one
//                row), whose median |e| is 0.6745 sqrt(2) sigma where the model is right over a
//                row; it too only overstates sigma, and sigma is the smaller of the two;
//   carried_s    the noise carried through each prediction window: the window starts from the
//                measured state and its velocity is fitted to the noisy positions of the warm-up,
//                so noise there moves the whole window. Measured, not modelled: the same
//                prediction on the log with a second draw of noise of the estimated sigma added to
//                every measured signal (a fixed seed), RMS of the change (the change is linear in
//                small noise, so a second draw of it carries as much as the first);
//   floor_s      sqrt(sigma_s^2 + carried_s^2) / scale_s, normalised as the gap is (effect_fit.h);
// and for the log, in the gap's units, floor = sqrt(mean_s floor_s^2 + discretisation_gap^2).
//
// A model's gap is weighed against the floor signal by signal (GapOverFloor): each signal's gap
// over its own floor, as a Gaussian likelihood weighs each residual by its own standard deviation,
//   ratio = sqrt(mean_s gap_s^2 / (floor_s^2 + discretisation_gap^2)).
// The plain gap / floor is a ratio of two means over the signals, in which the signal with the
// largest floor outweighs the others: a position residual four times its floor beside two
// pressures at theirs read 1.6 in it, 2.8 signal by signal. The project's own form.
#ifndef PNEUMATIC_DIAGNOSIS_NOISE_FLOOR_H_
#define PNEUMATIC_DIAGNOSIS_NOISE_FLOOR_H_

#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "diagnosis/effect_fit.h"
#include "diagnosis/measurements.h"
#include "diagnosis/prediction.h"

namespace pneumatic::diagnosis {

// sigma_s of every measured signal (Pa, m or rad), in Measurements' signal order, by the
// second-difference estimate alone
std::vector<double> SensorNoise(const Measurements& meas);

// sigma of one series (the second-difference estimate above); 0 for fewer than 8 rows
double SensorNoise(const std::vector<double>& y);

// sigma of every signal from the first row each window of `p` predicts (the first-row estimate
// above); infinity for a signal with fewer than 8 windows
std::vector<double> FirstRowNoise(const Measurements& meas, const Windows& windows, const Prediction& p);

// `meas` with independent Gaussian noise of standard deviation sigma[s] added to each measured
// signal, and the velocity estimate moved accordingly; deterministic for a seed
Measurements WithAddedNoise(const Measurements& meas, const std::vector<double>& sigma, unsigned long long seed);

struct NoiseFloor {
  std::vector<double> sensor_noise;  // sigma_s, in the signal's unit
  std::vector<double> carried;       // carried_s, in the signal's unit
  std::vector<double> signal_floor;  // floor_s, normalised
  double discretisation_gap = 0;     // the model's (diagnose.cc), 0 if not known
  double floor = 0;                  // in the gap's units
  std::string error;                 // non-empty: the noisy prediction failed; the floor is the sensor noise alone
};

// A model's gap over the floor, signal by signal (the header's ratio), from its gap per signal
// (Evaluated::signal_gap); NaN where some signal's floor is not positive or not known.
double GapOverFloor(const std::vector<double>& signal_gap, const NoiseFloor& floor);

// The floor of `meas` for model m, whose prediction of it is `base` (Evaluate with the same
// options); one more prediction.
NoiseFloor EstimateNoiseFloor(const mjModel* m, const SignalModel& sensors, const Measurements& meas, const GapOptions& g,
                              const Evaluated& base, double discretisation_gap);

}  // namespace pneumatic::diagnosis

#endif  // PNEUMATIC_DIAGNOSIS_NOISE_FLOOR_H_
