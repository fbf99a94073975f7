// The joint velocities at the end of the current step, as MuJoCo's integrator
// will compute them, predicted while act_dot is being computed: the chamber
// volumes follow the piston along that path.
#ifndef PNEUMATIC_VELOCITY_PREDICTION_H_
#define PNEUMATIC_VELOCITY_PREDICTION_H_

#include <mujoco/mujoco.h>

namespace pneumatic {

// Writes qvel(t + h) = qvel + h qacc to velocity (nv numbers), with
//   (M + h B) qacc = qfrc_passive - qfrc_bias + qfrc_applied + J' xfrc_applied + qfrc_actuator
// where B = diag(dof_damping): MuJoCo 2.2.2's Euler integrator treats joint damping
// implicitly this way (mj_EulerSkip), and its implicit integrator includes the same
// term in qDeriv. Left out: constraint forces (limits, contacts, frictionloss; not yet
// computed when act_dot is), and the implicit integrator's other velocity derivatives
// (Coriolis forces, affine actuator gains). One factorization and one solve per call,
// on d's scratch stack. Requires mj_fwdActuation's forces to be current (MuJoCo 2.2.2
// computes them before act_dot).
void PredictEndOfStepVelocity(const mjModel* m, mjData* d, mjtNum* velocity);

}  // namespace pneumatic

#endif  // PNEUMATIC_VELOCITY_PREDICTION_H_
