// payload (docs/effects.md): a moving mass the model does not have. One form: the driven body's
// mass.
#include <string>

#include "diagnosis/effects/effect_form_helpers.h"

namespace pneumatic::diagnosis::effects {

void PayloadForms(FormLibrary* library) {
  const mjModel* m = library->m;
  // payload: a moving mass different from the model's, on the body the cylinder's joint moves. Fitted
  // as the body's mass on a log scale: a payload may be several times the body's own mass, which a
  // linear step from the nominal mass would crawl towards
  library->PerCylinder("payload", "a different moving mass on the driven body", [&](const CylinderSeries& cyl, Candidate* c) {
    const int body = m->jnt_bodyid[cyl.joint];
    const double mass = m->body_mass[body];
    EffectParameter p;
    p.name = cyl.info.name + ":body " + std::string(m->names + m->name_bodyadr[body]) + " mass";
    p.unit = "kg";
    p.initial = mass, p.lower = 0.2 * mass, p.upper = 20 * mass, p.scale = mass, p.logarithmic = true;
    const double inertia[3] = {m->body_inertia[3 * body], m->body_inertia[3 * body + 1], m->body_inertia[3 * body + 2]};
    p.apply = [body, mass, inertia](mjModel* model, SignalModel*, double value) {
      // the inertia scales with the mass: the added mass is spread like the body's own
      model->body_mass[body] = value;
      for (int i = 0; i < 3; ++i) model->body_inertia[3 * body + i] = inertia[i] * value / mass;
      return RefreshMassConstants(model);
    };
    c->parameters.push_back(p);
  });
}

}  // namespace pneumatic::diagnosis::effects
