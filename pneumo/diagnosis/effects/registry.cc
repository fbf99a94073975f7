#include "diagnosis/effects/registry.h"

#include <utility>

#include "diagnosis/effects/effect_form_helpers.h"

namespace pneumatic::diagnosis::effects {

// The families, each defined in the file of its name in this folder (valve_delay.cc, ...)
FamilyForms ValveDelayForms, ValveDeadbandForms, FrictionForms, LeakageForms, HeatTransferForms, SupplyDropForms,
    LineDynamicsForms, PayloadForms, SensorBiasForms;

namespace {

// The registry: one line a family, in the order of docs/effects.md's names (EffectNames). It is the
// library's order, in which the diagnosis fits the forms of a round and which its ranking keeps
// among equal scores (diagnose.cc): a family's place is part of the library's behaviour.
FamilyForms* const kFamilies[] = {
    ValveDelayForms,
    ValveDeadbandForms,
    FrictionForms,
    LeakageForms,
    HeatTransferForms,
    SupplyDropForms,
    LineDynamicsForms,
    PayloadForms,
    SensorBiasForms,
};

}  // namespace

std::vector<Candidate> RegisteredForms(const mjModel* m, const Measurements& meas) {
  FormLibrary library(m, meas);
  for (FamilyForms* family : kFamilies) family(&library);
  return std::move(library.candidates);
}

}  // namespace pneumatic::diagnosis::effects
