// line_dynamics (docs/effects.md): the tubes between the valve and the chambers, which the model
// leaves out. Two forms: each tube's volume with its restriction, and the same with the tubes'
// transport delay.
#include <string>

#include "diagnosis/effects/effect_form_helpers.h"

namespace pneumatic::diagnosis::effects {
namespace {

// line_dynamics: a tube volume and its restriction between the valve and each chamber, each
// chamber's own (a valve seldom sits as near one chamber as the other: on a rig C log of tubes of
// unequal length, one tube for both left half the gap and lost to a heat transfer). Volumes and
// conductances are two kinds for the scan: alike on its grid, then each chamber's alone
void AddLine(const mjModel* m, const std::string& n, ModelEdit* edit, Candidate* c) {
  if (Parameter(m, n, "P.line_volume", 0) == 0) {
    edit->state_actuators.insert(edit->state_actuators.end(), {"LP", "LN"});
    edit->keys.push_back({"line_volume", Number(Parameter(m, n, "P.dead_volume", 1e-6))});
    edit->keys.push_back({"line_conductance", "1e-8"});
  }
  // bounds: a line of 0.1 to 100 dead volumes; a restriction from 1e-10 kg/(s Pa) (a hair-thin
  // tube) to 1e-7 (an orifice of about 9 mm): wider restrictions make the line stiff beyond what a
  // diagnosis can afford to simulate, and act as no restriction at all
  for (const std::string chamber : {"P.", "N."}) {
    const double v0 = Parameter(m, n, chamber + "dead_volume", 1e-6);
    c->parameters.push_back(KeyParameter(n, chamber + "line_volume", v0, 0.1 * v0, 100 * v0, v0, true));
  }
  for (const std::string chamber : {"P.", "N."}) {
    c->parameters.push_back(KeyParameter(n, chamber + "line_conductance", 1e-8, 1e-10, 1e-7, 1e-8, true));
    c->parameters.back().absent = c->parameters.back().upper;  // an unrestricted line
  }
}

}  // namespace

void LineDynamicsForms(FormLibrary* library) {
  const mjModel* m = library->m;
  library->PerCylinder("line_dynamics", "a tube volume between the valve and each chamber, with its restriction",
                       [&](const CylinderSeries& cyl, Candidate* c) {
    ModelEdit edit{cyl.info.name, {}, {}, {}, {}};
    AddLine(m, cyl.info.name, &edit, c);
    if (!edit.state_actuators.empty()) c->edits.push_back(edit);
  });
  // line_dynamics, second form: the same tube with its transport delay L/c (effects.md: "extra volume
  // and transport delay"; about 3 ms per metre), through line_delay's Pade delay line (proportional
  // valves: plugin/src/config.cc). A refinement (candidates.h): the first form is its limit of a
  // vanishing delay. The delay on a linear scale, not scanned: the scan keeps its grid of two kinds
  library->PerCylinder("line_dynamics", "a tube volume between the valve and each chamber, with its restriction, and the tubes' transport delay",
                       [&](const CylinderSeries& cyl, Candidate* c) {
    const std::string& n = cyl.info.name;
    if (!ProportionalValve(m, n)) return;
    ModelEdit edit{n, {}, {}, {}, {}};
    AddLine(m, n, &edit, c);
    AddDelayLine(m, n, "line_delay", "0.001", &edit);
    if (!edit.state_actuators.empty()) c->edits.push_back(edit);
    const double delay = Parameter(m, n, "line_delay", 0);
    c->parameters.push_back(KeyParameter(n, "line_delay", delay > 0 ? delay : 0.001, 1e-4, 0.02, 1e-3));
  }, true);
}

}  // namespace pneumatic::diagnosis::effects
