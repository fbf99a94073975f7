// Pistons moved along a measured motion while only the pressures are simulated: paper 000's
// multi-step pressure prediction (Section V.D), which separates the pressure model from the
// mechanics (Section II.5). Shared by `pneumo rollout --follow-motion` and the diagnosis'
// pneumatic-side prediction.
#ifndef PNEUMATIC_PRESCRIBED_MOTION_H_
#define PNEUMATIC_PRESCRIBED_MOTION_H_

#include <mujoco/mujoco.h>

namespace pneumatic {

// The cubic Hermite curve through position x0 with velocity v0 at the start of a row of `period`
// seconds and x1, v1 at its end, at the fraction s in [0, 1] of the row (the project's own
// interpolation between logged rows: it matches the logged velocities at both ends).
double HermitePosition(double x0, double v0, double x1, double v1, double period, double s);

// One mj_step with the prescribed qpos and qvel already written: the smooth forces (passive, bias
// and actuator) are cancelled through qfrc_applied, so that MuJoCo's semi-implicit step moves each
// joint by exactly qvel h and the chambers' step sees that motion. qfrc_applied is zero afterwards.
void StepAlongPrescribedMotion(const mjModel* m, mjData* d);

}  // namespace pneumatic

#endif  // PNEUMATIC_PRESCRIBED_MOTION_H_
