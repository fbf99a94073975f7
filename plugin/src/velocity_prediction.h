// The joint velocities at the end of the current step, as MuJoCo's integrator
// will compute them, predicted while act_dot is being computed: the chamber
// volumes follow the piston along that path.
#ifndef PNEUMATIC_VELOCITY_PREDICTION_H_
#define PNEUMATIC_VELOCITY_PREDICTION_H_

#include <mujoco/mujoco.h>

namespace pneumatic {

// Writes qvel(t + h) = qvel + h qacc to velocity (nv numbers), with
//   (M + h B) qacc = qfrc_smooth + qfrc_constraint
// where B = diag(dof_damping): MuJoCo 2.2.2's Euler integrator treats joint damping
// implicitly this way (mj_EulerSkip), and its implicit integrator includes the same
// term in qDeriv. When the model has constraint rows this step (frictionloss, limits,
// contacts), MuJoCo's own constraint solve is run ahead of MuJoCo and its warm start put
// back, so the prediction is the velocity MuJoCo will produce: while a frictionloss holds
// the piston, the chambers see the piston held. Left out: the implicit integrator's other
// velocity derivatives (Coriolis forces, affine actuator gains). Requires mj_fwdActuation's
// forces to be current (MuJoCo 2.2.2 computes them before act_dot) and mj_fwdPosition's and
// mj_fwdVelocity's constraint rows.
void PredictEndOfStepVelocity(const mjModel* m, mjData* d, mjtNum* velocity);

}  // namespace pneumatic

#endif  // PNEUMATIC_VELOCITY_PREDICTION_H_
