#include "diagnosis/effects/effect_form_helpers.h"

#include <cstdio>
#include <utility>

#include "pneumatic/pneumatic.h"

namespace pneumatic::diagnosis::effects {

void FormLibrary::PerCylinder(const std::string& effect, const std::string& form,
                              const std::function<void(const CylinderSeries&, Candidate*)>& add, bool refinement) {
  Candidate c{effect, form, {}, {}, refinement};
  for (const CylinderSeries& cyl : meas.cylinders) add(cyl, &c);
  if (!c.parameters.empty()) candidates.push_back(std::move(c));
}

std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.6g", value);
  return text;
}

std::string KeyUnit(const std::string& key) {
  std::string base = key.size() > 2 && key[1] == '.' ? key.substr(2) : key;
  for (const ParameterDoc& doc : Parameters()) {
    if (doc.key == base) return doc.unit;
  }
  return "";
}

double Parameter(const mjModel* m, const std::string& cylinder, const std::string& key, double fallback) {
  std::string ignored;
  return GetParameter(m, cylinder, key, &ignored).value_or(fallback);
}

std::string Choice(const mjModel* m, const std::string& cylinder, const std::string& key) {
  std::string ignored;
  return GetChoice(m, cylinder, key, &ignored).value_or("");
}

EffectParameter KeyParameter(const std::string& cylinder, const std::string& key, double initial, double lower, double upper,
                             double scale, bool logarithmic) {
  EffectParameter p;
  p.logarithmic = logarithmic;
  p.name = cylinder + ":" + key;
  p.unit = KeyUnit(key);
  p.initial = initial, p.lower = lower, p.upper = upper, p.scale = scale;
  p.apply = [cylinder, key](mjModel* m, SignalModel*, double value) {
    std::string error;
    return SetParameter(m, cylinder, key, value, &error) ? std::string() : error;
  };
  return p;
}

void EstimatedOverTheHistory(EffectParameter* p) {
  p->apply = [set = p->apply](mjModel* model, SignalModel* signals, double value) {
    signals->history_estimate = true;
    return set(model, signals, value);
  };
}

void AddDelayLine(const mjModel* m, const std::string& cylinder, const std::string& key, const std::string& initial,
                  ModelEdit* edit) {
  if (Parameter(m, cylinder, "spool_dead_time", 0) + Parameter(m, cylinder, "line_delay", 0) != 0) return;
  const std::vector<std::string> states = DelayLineStates(Choice(m, cylinder, "valve"));
  edit->state_actuators.insert(edit->state_actuators.end(), states.begin(), states.end());
  edit->keys.push_back({key, initial});
}

bool ProportionalValve(const mjModel* m, const std::string& cylinder) {
  return !DelayLineStates(Choice(m, cylinder, "valve")).empty();
}

}  // namespace pneumatic::diagnosis::effects
