// sensor_bias (docs/effects.md): a measured signal that reads off the truth. One form per measured
// signal: its offset and gain.
#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "diagnosis/effects/effect_form_helpers.h"

namespace pneumatic::diagnosis::effects {

void SensorBiasForms(FormLibrary* library) {
  const Measurements& meas = library->meas;
  // sensor_bias: offset and gain of one measured signal (a measurement model, not physics; a
  // pressure sensor's gain acts about the atmosphere, SignalModel)
  for (int s = 0; s < meas.signals(); ++s) {
    const std::vector<double>& y = meas.Signal(s);
    const auto [lo, hi] = std::minmax_element(y.begin(), y.end());
    const double span = std::max(*hi - *lo, 1e-12);
    Candidate c{"sensor_bias", "offset and gain of " + meas.SignalLabel(s), {}, {}};
    EffectParameter offset;
    offset.name = meas.SignalLabel(s) + ":offset";
    offset.unit = s % 3 == kPosition ? "m" : "Pa";
    offset.initial = 0, offset.lower = -span, offset.upper = span, offset.scale = 0.01 * span;
    offset.apply = [s](mjModel*, SignalModel* sensors, double value) {
      sensors->offset[s] = value;
      return std::string();
    };
    EffectParameter gain;
    gain.name = meas.SignalLabel(s) + ":gain";
    gain.unit = "1";
    // a sensor's gain error is a few per cent when calibrated and rarely beyond 10 % when not (a
    // transducer's tolerance, a supply voltage off); beyond 20 % it is a wrong unit or a wrong
    // sensor, not a bias, so a fit that needs more is taking up other physics (on rig C with a
    // spring, a position gain of 0.51 stood in for the spring's stiffness) and stops at a bound
    gain.initial = gain.nominal = 1, gain.lower = 0.8, gain.upper = 1.25, gain.scale = 0.01;
    gain.apply = [s](mjModel*, SignalModel* sensors, double value) {
      sensors->gain[s] = value;
      return std::string();
    };
    c.parameters = {offset, gain};
    library->candidates.push_back(std::move(c));
  }
}

}  // namespace pneumatic::diagnosis::effects
