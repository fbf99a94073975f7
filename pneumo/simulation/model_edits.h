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
#include <utility>
#include <vector>

#include <mujoco/mujoco.h>
#include <nlohmann/json.hpp>

namespace pneumatic {

// Sets the value at `key` in m (attached). "" or the error naming the key; m is unchanged on error.
std::string SetModelValue(mjModel* m, const std::string& key, double value);

// "" if `key` has one of the forms above (whether m has that cylinder, body or joint is not
// checked), else why not: for plan files, before any model is loaded.
std::string CheckModelKeyForm(const std::string& key);

// A named set of values by key: one entry of `pneumo rollout --variations FILE`, whose text is
// [{"name": "heavy", "set": {"body:piston:mass": 2.0, "cyl:p_supply": 550000}}, ...].
struct Variation {
  std::string name;  // a part of the runs' file names: non-empty, no '/', unique in its file
  std::vector<std::pair<std::string, double>> parameters;  // key -> value, in the file's order
};

// Reads a variations file's JSON (ReadJsonFile or ParseJson give it; its keys' forms and values are
// checked when they are set). "" or the error naming `source`; *out is filled only on success.
std::string ReadVariations(const nlohmann::json& list, const std::string& source, std::vector<Variation>* out);

// Sets a variation's values on m (a run's own copy). "" or the error naming the variation and key.
std::string ApplyVariation(const Variation& variation, mjModel* m);

}  // namespace pneumatic

#endif  // PNEUMATIC_MODEL_EDITS_H_
