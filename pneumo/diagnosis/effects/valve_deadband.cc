// valve_deadband (docs/effects.md): no flow for small commands, for the proportional valves. Two
// forms: the band alone, and the band with the valve's slope beyond it.
#include <string>
#include <utility>
#include <vector>

#include "diagnosis/effects/effect_form_helpers.h"
#include "pneumatic/pneumatic.h"

namespace pneumatic::diagnosis::effects {
namespace {

// valve_deadband: no flow for small spool displacements; the band is cut out of the opening, as
// an overlapped spool's lands do, and the opening beyond it grows with the model's slope
void AddDeadband(const mjModel* m, const CylinderSeries& cyl, Candidate* c) {
  const std::string& n = cyl.info.name;
  const std::string valve = Choice(m, n, "valve");
  if (valve == "proportional_5_3") {
    c->form = "spool deadband (fraction of the spool range)";
    c->parameters.push_back(KeyParameter(n, "deadband", Parameter(m, n, "deadband", 0), 0, 0.5, 0.05));
  } else if (valve == "proportional_per_chamber") {
    c->form = "a voltage band added to each port's sealed band";
    c->parameters.push_back(KeyParameter(n, "deadband_voltage", Parameter(m, n, "deadband_voltage", 0), 0, 3, 0.1));
  }
}

// valve_deadband, second form, a refinement (candidates.h): the band and the valve's slope beyond
// it. A valve modelled from its rated flow reaches that flow at full command; if the real valve has
// a band, its opening grows more steeply beyond it (for a band b of a command range U, by
// U / (U - b)), which the first form, keeping the model's slope, leaves as a flow error at every
// large command. The project's own form: the first form's band, and a factor on the model's
// spool_gain (5/3; the band, a fraction of the spool range, keeps its width in volts) or on each
// chamber's area_gain (per chamber; paper 000 eq. 3's B), from 1
void DeadbandAndSlope(FormLibrary* library) {
  const mjModel* m = library->m;
  library->PerCylinder("valve_deadband", "", [&](const CylinderSeries& cyl, Candidate* c) {
    const std::string& n = cyl.info.name;
    const std::string valve = Choice(m, n, "valve");
    std::vector<std::string> keys;
    if (valve == "proportional_5_3") keys = {"spool_gain"};
    if (valve == "proportional_per_chamber") keys = {"P.area_gain", "N.area_gain"};
    if (keys.empty()) return;
    AddDeadband(m, cyl, c);  // the band, and the first form's text, which this form extends
    c->form += keys.size() == 1 ? ", and the valve's slope beyond it (a factor on spool_gain)"
                                : ", and the valve's slope beyond it (a factor on area_gain)";
    std::vector<std::pair<std::string, double>> gains;
    for (const std::string& key : keys) gains.push_back({key, Parameter(m, n, key, 0)});
    EffectParameter p;
    p.name = n + ":valve_gain_factor";
    p.unit = "1";
    p.initial = p.nominal = 1, p.lower = 0.5, p.upper = 2, p.scale = 0.02;
    p.apply = [n, gains](mjModel* model, SignalModel*, double factor) {
      std::string error;
      for (const auto& [key, gain] : gains) {
        if (!SetParameter(model, n, key, factor * gain, &error)) return error;
      }
      return std::string();
    };
    c->parameters.push_back(p);
  }, true);
}

}  // namespace

void ValveDeadbandForms(FormLibrary* library) {
  const mjModel* m = library->m;
  library->PerCylinder("valve_deadband", "", [m](const CylinderSeries& cyl, Candidate* c) { AddDeadband(m, cyl, c); });
  DeadbandAndSlope(library);
}

}  // namespace pneumatic::diagnosis::effects
