// The registered effect families of the candidate library (docs/effect_forms.md): each family is
// a file of this folder that declares its forms, listed once, in registry.cc.
#ifndef PNEUMATIC_DIAGNOSIS_EFFECTS_REGISTRY_H_
#define PNEUMATIC_DIAGNOSIS_EFFECTS_REGISTRY_H_

#include <vector>

#include <mujoco/mujoco.h>

#include "diagnosis/candidates.h"
#include "diagnosis/measurements.h"

namespace pneumatic::diagnosis::effects {

// Every registered family's forms for m (attached, loaded from its file) and the measurements, the
// families in the registry's order and each family's forms in its own: CandidateLibrary.
std::vector<Candidate> RegisteredForms(const mjModel* m, const Measurements& meas);

}  // namespace pneumatic::diagnosis::effects

#endif  // PNEUMATIC_DIAGNOSIS_EFFECTS_REGISTRY_H_
