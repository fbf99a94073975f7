#include "prescribed_motion.h"

namespace pneumatic {

double HermitePosition(double x0, double v0, double x1, double v1, double period, double s) {
  const double s2 = s * s, s3 = s2 * s;
  return (2 * s3 - 3 * s2 + 1) * x0 + (s3 - 2 * s2 + s) * period * v0 + (-2 * s3 + 3 * s2) * x1 + (s3 - s2) * period * v1;
}

void StepAlongPrescribedMotion(const mjModel* m, mjData* d) {
  mju_zero(d->qfrc_applied, m->nv);
  mj_forward(m, d);
  for (int i = 0; i < m->nv; ++i) d->qfrc_applied[i] = -(d->qfrc_passive[i] - d->qfrc_bias[i] + d->qfrc_actuator[i]);
  mj_step(m, d);
  mju_zero(d->qfrc_applied, m->nv);
}

}  // namespace pneumatic
