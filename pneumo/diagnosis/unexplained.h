// What a model leaves unexplained on a log (issue 55, item 1): the residual of its short-horizon
// predictions, per signal, against the noise floor (noise_floor.h), its dependence on the states
// (where to look for the missing physics), the regimes it is largest in, and which side of the
// model fails: the mechanics (the motion predicted from the measured pressures), the pneumatics
// (the pressures predicted along the measured motion), or neither, so the sensors.
//
// A residual is structured when its systematic part exceeds its floor: per signal, the part of its
// mean square that its mean and the best state's bins explain,
//   systematic^2 = mean^2 + max(0, eta^2 - eta^2_noise) var,
// eta^2 the correlation ratio (residual_tests.h) over the state's bins at the lag that explains
// most, and eta^2_noise its level where the residual does not depend on the state: the mean eta^2
// against the state shifted circularly by 1/7 to 6/7 of the log, which keeps both series'
// autocorrelations and breaks their alignment. For n independent samples it is (bins - 1) / (n - 1)
// (Fisher 1925); residuals of multi-step predictions are correlated within a window and the states
// over the motion, so fewer effective samples fall into bins unevenly by chance. The project's own
// criterion.
#ifndef PNEUMATIC_DIAGNOSIS_UNEXPLAINED_H_
#define PNEUMATIC_DIAGNOSIS_UNEXPLAINED_H_

#include <string>
#include <utility>
#include <vector>

#include <mujoco/mujoco.h>

#include "diagnosis/effect_fit.h"
#include "diagnosis/measurements.h"
#include "diagnosis/noise_floor.h"
#include "diagnosis/residual_tests.h"

namespace pneumatic::diagnosis {

// a signal's residual against one state at the lag that explains most of it
struct StateDependence {
  std::string state;       // "cyl.x", "cyl.v", "cyl.a", "cyl.p_P", "cyl.p_N", or a command "cyl.uP"
  double lag_s = 0;        // the residual at t against the state at t - lag_s
  double eta2 = 0;         // correlation ratio
  double excess = 0;       // eta2 - eta2_noise, at least 0
  BinnedDependence bins;   // mean residual per bin, in the signal's unit
};

struct ResidualStructure {
  std::string signal;
  double gap = 0, floor = 0;        // normalised (effect_fit.h)
  double rms = 0, mean = 0;         // of the residual, in the signal's unit
  double effective_samples = 0;
  double systematic = 0;            // normalised (the header's formula)
  bool structured = false;          // systematic > floor
  std::vector<StateDependence> dependences;  // one per state of the signal's cylinder, strongest first
};

struct Unexplained {
  bool above_floor = false;   // ratio > floor_multiple
  bool structured = false;    // some signal's residual is (ResidualStructure::structured)
  bool present = false;       // both: a structured residual well above the floor
  double gap = 0, floor = 0;  // the log's, normalised
  double ratio = 0;           // the gap over the floor, each signal against its own (GapOverFloor, noise_floor.h)
  std::vector<ResidualStructure> signals;
  std::vector<std::pair<std::string, double>> regimes;  // regimes whose gap is over 1.25 times the whole's: (name, ratio)
  // "mechanical", "pneumatic", "mechanical and pneumatic", "sensors", or "" (every side within its floor)
  std::string side;
  // the worst signal's gap over its floor (a side fails above floor_multiple): the motion from the
  // measured pressures (x), the pressures along the measured motion (p_P, p_N), the full
  // prediction (every signal); NaN if not predicted
  double mechanical_ratio = 0, pneumatic_ratio = 0, full_ratio = 0;
  std::string summary;  // in words, for the report and the JSON
};

// The verdict where no effect is established (the definitions, docs/effects.md): `none`
// when the gap is within floor_multiple times the floor (Unexplained::ratio), `unexplained` above
// it, whether or not the
// residual depends on the states (a drift in time or a disturbance need not).
std::string VerdictWithoutEffect(const Unexplained& u);

// What `full`, `pneumatic_gap` and `mechanical_gap` (a model's predictions of `meas`: Assessment,
// diagnose.h) leave, against `floor`. regime_names and regime_gap: ClassifyRegimes' names and
// the model's gap in each.
Unexplained DescribeResidual(const Measurements& meas, const GapOptions& g, const Evaluated& full, const std::vector<double>& pneumatic_gap,
                             const std::vector<double>& mechanical_gap, const std::vector<std::string>& regime_names,
                             const std::vector<double>& regime_gap, const NoiseFloor& floor, double floor_multiple);

}  // namespace pneumatic::diagnosis

#endif  // PNEUMATIC_DIAGNOSIS_UNEXPLAINED_H_
