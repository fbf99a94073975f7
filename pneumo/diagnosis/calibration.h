// Parameters before effects (issue 55, item 2): the model's own nominal physical parameters,
// re-fitted on the training log before any effect is tried. A real rig's discharge coefficients,
// dead volumes or damping are off by 10-30 % of any datasheet; a gap that re-fitting them removes
// is a calibration, not an unmodelled effect, and an effect is diagnosed on top of the calibrated
// model (diagnose.cc).
//
// Per cylinder: the valve's flow coefficient (discharge_coefficient, or an ISO 6358 valve's
// sonic_conductance, both chambers by one value), its critical pressure ratio where the flow law
// has one as a key (iso6358, sanville), each chamber's dead volume, the polytropic index (both
// chambers), and the viscous damping of the driven joint (mjModel dof_damping). Not the moving
// mass: a different mass is the effect `payload`.
//
// Each is fitted as a deviation from the model's value (EffectParameter::nominal) within a
// plausible range around it: +-30 % for the flow coefficient and the critical ratio (within the
// key's own range), +-45 % for the dead volumes and the damping, half as much again as the spread
// the issue expects of a real rig (+-20 %, +-30 %). A value at its bound says that the data ask
// for more than a calibration (diagnose.cc, Calibrate). The polytropic index is fitted over its
// physical range instead, from 1 (isothermal) to the gas' ratio of specific heats (adiabatic), and
// a value at either end is kept.
#ifndef PNEUMATIC_DIAGNOSIS_CALIBRATION_H_
#define PNEUMATIC_DIAGNOSIS_CALIBRATION_H_

#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "diagnosis/candidates.h"
#include "diagnosis/measurements.h"

namespace pneumatic::diagnosis {

// The calibration as a candidate ("calibration", not a docs/effects.md name): its parameters start at
// the model's values. Empty parameters if the model has none of them.
Candidate CalibrationCandidate(const mjModel* m, const Measurements& meas);

// One calibrated parameter: the model's value, the fitted one and its standard error, in its unit.
struct CalibratedParameter {
  std::string name, unit;
  double nominal = 0, value = 0, standard_error = 0;
  bool at_bound = false;  // within 1 % of its range from a bound of its plausible range
};

}  // namespace pneumatic::diagnosis

#endif  // PNEUMATIC_DIAGNOSIS_CALIBRATION_H_
