// What the effect families of the candidate library share (docs/effect_forms.md): the library a
// family adds its forms to, and the helpers its forms are declared with (a fitted key of a
// cylinder's "pneumatic:" text, the model's own values, the command delay line). Each family is a
// file of this folder; registry.cc lists them.
#ifndef PNEUMATIC_DIAGNOSIS_EFFECTS_EFFECT_FORM_HELPERS_H_
#define PNEUMATIC_DIAGNOSIS_EFFECTS_EFFECT_FORM_HELPERS_H_

#include <functional>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "diagnosis/candidates.h"
#include "diagnosis/measurements.h"

namespace pneumatic::diagnosis::effects {

// The candidates declared for one model (attached, loaded from its file) and one measured log, in
// the order the families add them.
struct FormLibrary {
  FormLibrary(const mjModel* model, const Measurements& measurements) : m(model), meas(measurements) {}

  // A form of `effect` made of each cylinder's part: `add` gives a cylinder's parameters and edits
  // (and may set the form's text, e.g. by the cylinder's valve). Kept if some cylinder gave it a
  // parameter: a form no cylinder admits is not offered.
  void PerCylinder(const std::string& effect, const std::string& form,
                   const std::function<void(const CylinderSeries&, Candidate*)>& add, bool refinement = false);

  const mjModel* const m;
  const Measurements& meas;
  std::vector<Candidate> candidates;
};

// An effect family: adds its forms to the library, in the order they are tried (registry.cc).
using FamilyForms = void(FormLibrary* library);

// a value as MJCF text (std::to_string's %f would write a dead volume of 4e-7 m^3 as 0.000000)
std::string Number(double value);

// the unit of a key of a cylinder's text ("P.area" as "area"), from the extension's Parameters()
std::string KeyUnit(const std::string& key);

// the cylinder's value of a key, or `fallback` where the key does not apply or the model lacks it
double Parameter(const mjModel* m, const std::string& cylinder, const std::string& key, double fallback);

// the cylinder's choice of a key ("valve" -> "proportional_per_chamber"), "" where it has none
std::string Choice(const mjModel* m, const std::string& cylinder, const std::string& key);

// a key of the cylinder's "pneumatic:" text, fitted
EffectParameter KeyParameter(const std::string& cylinder, const std::string& key, double initial, double lower, double upper,
                             double scale, bool logarithmic = false);

// p, whose value also has the prediction estimate the model's unmeasured states over the log's
// history (SignalModel::history_estimate) instead of from each window's warm-up alone
void EstimatedOverTheHistory(EffectParameter* p);

// Adds to `edit` what gives the cylinder its command delay line (DelayLineStates) with `key`
// (spool_dead_time or line_delay) at `initial` seconds, unless the model has the line already: its
// delay spool_dead_time + line_delay is not 0. The valve must be a proportional one.
void AddDelayLine(const mjModel* m, const std::string& cylinder, const std::string& key, const std::string& initial,
                  ModelEdit* edit);

// true for a proportional valve, the valves with a command delay line (DelayLineStates)
bool ProportionalValve(const mjModel* m, const std::string& cylinder);

}  // namespace pneumatic::diagnosis::effects

#endif  // PNEUMATIC_DIAGNOSIS_EFFECTS_EFFECT_FORM_HELPERS_H_
