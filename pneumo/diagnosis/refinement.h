// Which richer forms of the effects (Candidate::refinement) a round of the diagnosis fits: the two
// effects it refines, and the fits that settle a richer form before it is tried. The rules of
// diagnose.cc's rounds, apart so that they are tested on rankings made by hand.
#ifndef PNEUMATIC_DIAGNOSIS_REFINEMENT_H_
#define PNEUMATIC_DIAGNOSIS_REFINEMENT_H_

#include <set>
#include <string>
#include <vector>

#include "diagnosis/diagnose.h"

namespace pneumatic::diagnosis {

// A richer form of an effect is fitted only for two effects, the best two by the dIC of their
// simpler forms among the effects that have a richer form to fit: the first, and the runner-up,
// whose simpler forms must also explain the gap by themselves. The first is the round's leader
// unless the leader has one form (heat_transfer, payload, sensor_bias) and nothing to refine: in
// either place such an effect would leave the slot unused while one that can be refined waits
// behind it (on the independent suite's C09, a command delay of 7.3 ms logged at 100 Hz, heat
// transfer at the upper bound of its conductance led line_dynamics by a dIC of 0.9, valve_delay
// came third, and its dead time was never fitted: line_dynamics was named). It refines a verdict
// or its closest contender, and costs no fit otherwise. The runner-up is refined because a simple
// form can be a poor stand-in for its own effect while another effect leads: on rig A driven open
// loop, commands 8 ms late, the armature delays lose every pulse shorter than their opening delay
// and explained 14.7 % of the gap, a tube 28.2 %; the tube was accepted, and the exact latency,
// fitted only after it, found half the dead time. Two, not every effect that explains, bounds the
// cost: a richer form may simulate the whole log (a supply tank, a valve's delay line over the
// history), and on a 20 s rig C log of a leak (bench_diagnose --speed) the tank of the fourth
// effect cost 37 s of a 124 s diagnosis. An effect ranked lower is refined in a later round if it
// is among the two best there.
struct RefinedEffects {
  std::string leader;     // the effect whose simpler form has the best dIC; "" if none was scored
  std::string first;      // the best of the effects with a richer form to fit; "" if none
  std::string runner_up;  // the next of those whose simpler form explains the gap; "" if none
};

// The round's leader and the two refined effects, from the round's results of the simpler forms
// (`ranking`: those with a NaN dIC, failed fits, do not count) and the effects with a richer form
// still to fit. Ties go to the effect first by name.
RefinedEffects ChooseRefinedEffects(const std::vector<CandidateResult>& ranking, const std::set<std::string>& refinable);

// No richer form after a form that leaves nothing to explain (the rule that ends the search, within
// the round): it could at most shrink a residual already within the floor's margin and
// unstructured, no more than a diagnosis can show from this log. The richer forms of a refined
// effect other than the round's leader are not fitted once a form of another effect leaves that;
// the leader's own are, and any effect's after its own simpler forms, until one of its own richer
// forms does, since the verdict takes its effect's best form and a form within the margin can still
// be a cruder stand-in for the richer one (the orifice leak for a laminar one: bench_diagnose
// --speed, rig A at 100 Hz, 73.3 % of the gap as given against 81.0 %; on bench_diagnose --rig C's
// laminar leak, the runner-up's deadband with a slope left the margin first, the leak's laminar
// form was skipped, and the deadband fitted with the calibration beat the orifice leak by a dIC of
// 39: valve_deadband, wrong). On rig A's 20 s leak at 1 kHz (bench_diagnose --speed, 084ed7b) the
// orifice and the laminar leak left the held-out gap at the floor, unstructured; the leak's laws
// side by side (20.1 s) and the runner-up's supply tank (34.8 s) came after them, 55 of the
// diagnosis' 108.5 s.
// Returns the first result of `ranking` that settles a richer form of `effect` so, or null.
const CandidateResult* SettledBefore(const std::string& effect, const std::vector<CandidateResult>& ranking, const std::string& leader);

}  // namespace pneumatic::diagnosis

#endif  // PNEUMATIC_DIAGNOSIS_REFINEMENT_H_
