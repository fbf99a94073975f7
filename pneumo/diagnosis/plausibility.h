// Whether a fitted candidate may explain a gap at all (issue 55, item 1), whatever its scores: not
// with an implausible value, nor with a parameter the data do not determine.
#ifndef PNEUMATIC_DIAGNOSIS_PLAUSIBILITY_H_
#define PNEUMATIC_DIAGNOSIS_PLAUSIBILITY_H_

#include <string>
#include <vector>

#include "diagnosis/candidates.h"

namespace pneumatic::diagnosis {

// "" if `value` is inside p's range, else "at its lower bound" or "at its upper bound": within 1 %
// of the range (of its logarithm, for a logarithmic parameter) from the bound
std::string BoundReached(const EffectParameter& p, double value);

// The value of p that is the model without the effect: EffectParameter::absent where set, else the
// nominal of a linear parameter fitted as a deviation from it, else the lower bound.
double AbsentValue(const EffectParameter& p);

// The first parameter of c whose value in `values` lies at the bound of its range away from the
// model without the effect (a physically absurd magnitude, or one the range cuts short), as
// "name at its lower bound (value unit)"; "" if none. Implausible's first rule.
std::string ValueAtAFarBound(const Candidate& c, const std::vector<double>& values);

// Why candidate c, fitted to `values` with `standard_errors` (per parameter, in its unit: the
// diagnosis passes the conditional ones, CandidateFit::conditional_standard_errors, so that two
// parameters that trade off are not each called undetermined), may not explain a gap; "" if it
// may. Not when a value lies at the bound of its range away from the model without the effect (a
// physically absurd magnitude, or one the range cuts short), nor when no parameter is determined
// by the data away from the model without the effect (each one's standard error larger than its
// deviation from it, or each one at it). A parameter at the bound that is the model without it (a
// leak area at its floor, a delay at 0) is absent, not implausible, and so is one within its
// standard error of that value beside a parameter the data do determine: a leak across the piston
// found with a leak to the atmosphere of 2e-12 +- 4e-12 kg/(s Pa) is a leak across the piston (on
// rig A, refusing the whole effect for that path refused the laminar leak of bench_diagnose). (On
// a rig C log of LuGre friction, before this rule, a valve dead time of 0.1 ms +- 12 ms at its
// lower bound, its only parameter, was accepted after the friction.) A nuisance parameter
// (EffectParameter::nuisance) is held to the first rule only, and a form whose parameters are all
// nuisances is the effect by itself.
std::string Implausible(const Candidate& c, const std::vector<double>& values, const std::vector<double>& standard_errors);

}  // namespace pneumatic::diagnosis

#endif  // PNEUMATIC_DIAGNOSIS_PLAUSIBILITY_H_
