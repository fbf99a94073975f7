#include "velocity_prediction.h"

namespace pneumatic {
namespace {

// L' D L factorization of M + h diag(damping) in MuJoCo's tree-sparse layout (dof_Madr,
// dof_parentid), in place in ld; port of mj_factorI of MuJoCo 2.2.2 (engine_core_smooth.c,
// Apache-2.0), which the public API does not expose
void FactorTreeSparse(const mjModel* m, mjtNum* ld, mjtNum* diag_inverse) {
  int nv = m->nv;
  for (int k = nv - 1; k >= 0; --k) {
    int kk = m->dof_Madr[k];
    if (ld[kk] < mjMINVAL) ld[kk] = mjMINVAL;
    if (m->dof_simplenum[k]) continue;
    // eliminate k from its ancestors i
    int ki = kk + 1;
    for (int i = m->dof_parentid[k]; i >= 0; i = m->dof_parentid[i], ++ki) {
      mjtNum ratio = ld[ki] / ld[kk];
      int count = (i + 1 < nv ? m->dof_Madr[i + 1] : m->nM) - m->dof_Madr[i];
      mju_addToScl(ld + m->dof_Madr[i], ld + ki, -ratio, count);
      ld[ki] = ratio;
    }
  }
  for (int i = 0; i < nv; ++i) diag_inverse[i] = 1 / ld[m->dof_Madr[i]];
}

// x <- (L' D L)^-1 x; port of mj_solveLD of MuJoCo 2.2.2 for one vector
void SolveTreeSparse(const mjModel* m, const mjtNum* ld, const mjtNum* diag_inverse, mjtNum* x) {
  int nv = m->nv;
  for (int i = nv - 1; i >= 0; --i) {
    if (m->dof_simplenum[i] || x[i] == 0) continue;
    int ij = m->dof_Madr[i] + 1;
    for (int j = m->dof_parentid[i]; j >= 0; j = m->dof_parentid[j]) x[j] -= ld[ij++] * x[i];
  }
  for (int i = 0; i < nv; ++i) x[i] *= diag_inverse[i];
  for (int i = 0; i < nv; ++i) {
    if (m->dof_simplenum[i]) continue;
    int ij = m->dof_Madr[i] + 1;
    for (int j = m->dof_parentid[i]; j >= 0; j = m->dof_parentid[j]) x[i] -= ld[ij++] * x[j];
  }
}

bool AnyDamping(const mjModel* m) {
  for (int i = 0; i < m->nv; ++i) {
    if (m->dof_damping[i] > 0) return true;
  }
  return false;
}

// MuJoCo's constraint solve for this pass (mj_fwdAcceleration, then mj_fwdConstraint), run ahead
// of MuJoCo's own so that the prediction sees the constraint forces (a frictionloss holding the
// piston, a joint limit, a contact). The solve is warm-started from qacc_warmstart (efc_force too,
// for PGS), which it overwrites: both are put back, so that MuJoCo's own solve, after act_dot,
// starts from the same numbers and ends at the same qacc, bit for bit. Returns false, with nothing
// changed, when the model has no constraint rows this step.
bool SolveConstraintsAhead(const mjModel* m, mjData* d) {
  if (d->nefc == 0) return false;
  mjtNum* warmstart = mj_stackAlloc(d, m->nv);
  mjtNum* efc_force = mj_stackAlloc(d, d->nefc);
  mju_copy(warmstart, d->qacc_warmstart, m->nv);
  mju_copy(efc_force, d->efc_force, d->nefc);
  mj_fwdAcceleration(m, d);
  mj_fwdConstraint(m, d);
  mju_copy(d->qacc_warmstart, warmstart, m->nv);
  mju_copy(d->efc_force, efc_force, d->nefc);
  return true;
}

}  // namespace

void PredictEndOfStepVelocity(const mjModel* m, mjData* d, mjtNum* velocity) {
  int nv = m->nv;
  double h = m->opt.timestep;
  mjMARKSTACK;
  bool constrained = SolveConstraintsAhead(m, d);
  bool damped = AnyDamping(m);
  mjtNum* qacc = mj_stackAlloc(d, nv);
  if (constrained && !damped) {
    // the acceleration MuJoCo's Euler step will use, as its constraint solve gives it
    mju_copy(qacc, d->qacc, nv);
  } else {
    // every force on the dofs, summed as mj_EulerSkip sums them when constrained
    if (constrained) {
      mju_add(qacc, d->qfrc_smooth, d->qfrc_constraint, nv);
    } else {
      for (int i = 0; i < nv; ++i) {
        qacc[i] = d->qfrc_passive[i] - d->qfrc_bias[i] + d->qfrc_applied[i] + d->qfrc_actuator[i];
      }
      for (int b = 1; b < m->nbody; ++b) {
        mjtNum* wrench = d->xfrc_applied + 6 * b;
        bool zero = true;
        for (int i = 0; i < 6; ++i) zero &= wrench[i] == 0;
        if (!zero) mj_applyFT(m, d, wrench, wrench + 3, d->xipos + 3 * b, b, qacc);
      }
    }
    if (damped) {
      // (M + h B) qacc = force, as mj_EulerSkip solves it
      mjtNum* ld = mj_stackAlloc(d, m->nM);
      mjtNum* diag_inverse = mj_stackAlloc(d, nv);
      mju_copy(ld, d->qM, m->nM);
      for (int i = 0; i < nv; ++i) ld[m->dof_Madr[i]] += h * m->dof_damping[i];
      FactorTreeSparse(m, ld, diag_inverse);
      SolveTreeSparse(m, ld, diag_inverse, qacc);
    } else {
      // M qacc = force with the factor mj_fwdPosition made
      mj_solveM(m, d, qacc, qacc, 1);
    }
  }
  // semi-implicit Euler: qvel(t + h) = qvel + h qacc
  for (int i = 0; i < nv; ++i) velocity[i] = d->qvel[i] + h * qacc[i];
  mjFREESTACK;
}

}  // namespace pneumatic
