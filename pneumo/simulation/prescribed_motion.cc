#include "simulation/prescribed_motion.h"

#include <cmath>

namespace pneumatic {

double HermitePosition(double x0, double v0, double x1, double v1, double period, double s) {
  const double s2 = s * s, s3 = s2 * s;
  return (2 * s3 - 3 * s2 + 1) * x0 + (s3 - 2 * s2 + s) * period * v0 + (-2 * s3 + 3 * s2) * x1 + (s3 - s2) * period * v1;
}

void JointState::WriteTo(mjData* d) const {
  for (const auto& [address, value] : qpos) d->qpos[address] = value;
  for (const auto& [address, value] : qvel) d->qvel[address] = value;
}

std::string PistonJointState(const mjModel* m, const mjData* d, const CylinderInfo& c, std::optional<double> x,
                             std::optional<double> v, std::optional<double> x_next, double timestep,
                             JointState* out) {
  if (!x && !v) return "";
  if (c.rod_site < 0) {
    const int joint = DrivenJoint(m, c);
    if (joint < 0) return "cylinder '" + c.name + "' drives a tendon or slider-crank: its x and v cannot be set from the log";
    const double gear = m->actuator_gear[6 * (c.chamber_actuator[0] >= 0 ? c.chamber_actuator[0] : c.chamber_actuator[1])];
    if (x) out->qpos.push_back({m->jnt_qposadr[joint], (*x + c.x_mid) / gear});
    if (v) out->qvel.push_back({m->jnt_dofadr[joint], *v / gear});
    return "";
  }
  if (!x) return "cylinder '" + c.name + "' is mounted between sites: its v needs its x (column '" + c.name + ".x')";
  double lever_arm = 0;
  std::string error;
  const std::optional<double> angle = HingeAngleAt(m, d, c, *x, &lever_arm, &error);
  if (!angle) return error;
  out->qpos.push_back({m->jnt_qposadr[c.hinge], *angle});
  if (x_next) {
    const std::optional<double> next_angle = HingeAngleAt(m, d, c, *x_next, &lever_arm, &error);
    if (!next_angle) return error;
    out->qvel.push_back({m->jnt_dofadr[c.hinge], (*next_angle - *angle) / timestep});
  } else if (v) {
    if (lever_arm == 0) {
      return "cylinder '" + c.name + "': at x = " + std::to_string(*x) +
             " m its hinge is at a dead point (lever arm 0): its v cannot be set";
    }
    out->qvel.push_back({m->jnt_dofadr[c.hinge], *v / lever_arm});
  }
  return "";
}

std::unique_ptr<mjModel, void (*)(mjModel*)> PrescribedMotionModel(const mjModel* m) {
  return std::unique_ptr<mjModel, void (*)(mjModel*)>(mj_copyModel(nullptr, m), mj_deleteModel);
}

void StepAlongPrescribedMotion(mjModel* m, mjData* d) {
  const int flags = m->opt.disableflags;
  m->opt.disableflags |= mjDSBL_CONSTRAINT;
  mju_zero(d->qfrc_applied, m->nv);
  mj_forward(m, d);
  for (int i = 0; i < m->nv; ++i) d->qfrc_applied[i] = -(d->qfrc_passive[i] - d->qfrc_bias[i] + d->qfrc_actuator[i]);
  mj_step(m, d);
  mju_zero(d->qfrc_applied, m->nv);
  m->opt.disableflags = flags;
}

}  // namespace pneumatic
