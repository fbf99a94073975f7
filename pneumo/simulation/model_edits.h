// A model's values set by key, as parameter studies and `pneumo rollout --variations` name them:
//   "<cylinder>:<key>"        a cylinder's parameter (SetParameter: checked as the MJCF is), e.g.
//                             "cyl:dead_volume", "cyl:P.area"
//   "body:<name>:mass"        a body's mass, kg (> 0); its inertia is scaled with it, so the body
//                             keeps its shape and density distribution
//   "joint:<name>:damping"    a joint's damping (>= 0), on each of its degrees of freedom
//   "joint:<name>:frictionloss"  a joint's dry friction (>= 0; not below a cylinder's
//                             coulomb_friction on the joint it drives: such a model is refused)
// Call between runs, on the run's own copy of the model.
#ifndef PNEUMATIC_MODEL_EDITS_H_
#define PNEUMATIC_MODEL_EDITS_H_

#include <string>

#include <mujoco/mujoco.h>

namespace pneumatic {

// Sets the value at `key` in m (attached). "" or the error naming the key; m is unchanged on error.
std::string SetModelValue(mjModel* m, const std::string& key, double value);

// "" if `key` has one of the forms above (whether m has that cylinder, body or joint is not
// checked), else why not: for plan files, before any model is loaded.
std::string CheckModelKeyForm(const std::string& key);

}  // namespace pneumatic

#endif  // PNEUMATIC_MODEL_EDITS_H_
