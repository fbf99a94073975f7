// Pistons moved along a measured motion while only the pressures are simulated: paper 000's
// multi-step pressure prediction (Section V.D), which separates the pressure model from the
// mechanics (Section II.5). Shared by `pneumo rollout --follow-motion` and the diagnosis'
// pneumatic-side prediction.
#ifndef PNEUMATIC_PRESCRIBED_MOTION_H_
#define PNEUMATIC_PRESCRIBED_MOTION_H_

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <mujoco/mujoco.h>

#include "pneumatic/pneumatic.h"

namespace pneumatic {

// The cubic Hermite curve through position x0 with velocity v0 at the start of a row of `period`
// seconds and x1, v1 at its end, at the fraction s in [0, 1] of the row (the project's own
// interpolation between logged rows: it matches the logged velocities at both ends).
double HermitePosition(double x0, double v0, double x1, double v1, double period, double s);

// Joint coordinates that put pistons where a log has them: (qpos or qvel address, value), gathered for
// every cylinder before any is written, since a mount=hinge_sites hinge is solved on d's present pose.
struct JointState {
  std::vector<std::pair<int, double>> qpos, qvel;
  void WriteTo(mjData* d) const;
};

// Adds to *out what puts cylinder c's piston at x (if given), moving at v (if given). A piston driven by
// a slide or hinge joint: q = (x + x_mid) / gear, q' = v / gear. A mount=hinge_sites piston: its hinge at
// the angle nearest d's present one where the sites are x + x_mid apart (HingeAngleAt, which needs d's
// kinematics current), turning at v / (dL/dq), or, with x_next, at the rate that turns it to x_next's
// angle in `timestep` (a joint-driven piston takes v, whatever x_next). "" or why not: a tendon or a
// slider-crank, v without x between sites, an x no angle gives, a dead point.
std::string PistonJointState(const mjModel* m, const mjData* d, const CylinderInfo& c, std::optional<double> x,
                             std::optional<double> v, std::optional<double> x_next, double timestep,
                             JointState* out);

// A copy of m (attached, as m is) that StepAlongPrescribedMotion may edit: a private model for
// stepping along a prescribed motion. Null if MuJoCo cannot copy m.
std::unique_ptr<mjModel, void (*)(mjModel*)> PrescribedMotionModel(const mjModel* m);

// One mj_step with the prescribed qpos and qvel already written, on m (a PrescribedMotionModel): the
// smooth forces (passive, bias and actuator) are cancelled through qfrc_applied, so that MuJoCo's
// semi-implicit step moves each joint by exactly qvel h and the chambers' step sees that motion.
// MuJoCo's constraints are disabled for the step (m->opt.disableflags, put back after it): where the
// motion is prescribed, a joint limit, a contact or a frictionloss would push the joints off it, and
// the chambers, which follow the motion MuJoCo's constraint solve gives, with them. qfrc_applied is
// zero afterwards.
void StepAlongPrescribedMotion(mjModel* m, mjData* d);

}  // namespace pneumatic

#endif  // PNEUMATIC_PRESCRIBED_MOTION_H_
