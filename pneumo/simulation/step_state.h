// The mjData arrays mj_step advances from, but for the mocap poses and userdata: time, qpos, qvel, act,
// ctrl, the constraint solver's warm start (qacc_warmstart) and the applied forces. A closed-loop run
// carries them from one tick to the next (ClosedLoopState::mujoco); the diagnosis' warm-up restores
// them, with the mocap poses and userdata (prediction.cc, CopyState).
#ifndef PNEUMATIC_STEP_STATE_H_
#define PNEUMATIC_STEP_STATE_H_

#include <utility>
#include <vector>

#include <mujoco/mujoco.h>

namespace pneumatic {

// (array, length) of each, in a fixed order; Data is mjData or const mjData
template <typename Data>
auto StepStateArrays(const mjModel* m, Data* d) {
  return std::vector<std::pair<decltype(&d->time), int>>{{&d->time, 1},
                                                         {d->qpos, m->nq},
                                                         {d->qvel, m->nv},
                                                         {d->act, m->na},
                                                         {d->ctrl, m->nu},
                                                         {d->qacc_warmstart, m->nv},
                                                         {d->qfrc_applied, m->nv},
                                                         {d->xfrc_applied, 6 * m->nbody}};
}

}  // namespace pneumatic

#endif  // PNEUMATIC_STEP_STATE_H_
