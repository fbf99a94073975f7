#include "simulation/model_edits.h"

#include <cmath>
#include <cstdio>
#include <vector>

#include "pneumatic/pneumatic.h"

namespace pneumatic {
namespace {

// the parts of key between ':'
std::vector<std::string> Split(const std::string& key) {
  std::vector<std::string> parts;
  size_t start = 0;
  for (size_t colon = key.find(':'); colon != std::string::npos; colon = key.find(':', start)) {
    parts.push_back(key.substr(start, colon - start));
    start = colon + 1;
  }
  parts.push_back(key.substr(start));
  return parts;
}

std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

}  // namespace

std::string CheckModelKeyForm(const std::string& key) {
  const std::vector<std::string> parts = Split(key);
  for (const std::string& part : parts) {
    if (part.empty()) return "'" + key + "': an empty name between ':'";
  }
  if (parts.size() == 2 && parts[0] != "body" && parts[0] != "joint") return "";
  if (parts.size() == 3 && parts[0] == "body" && parts[2] == "mass") return "";
  if (parts.size() == 3 && parts[0] == "joint" && (parts[2] == "damping" || parts[2] == "frictionloss")) return "";
  return "'" + key + "' is not <cylinder>:<key>, body:<name>:mass, joint:<name>:damping or joint:<name>:frictionloss";
}

std::string SetModelValue(mjModel* m, const std::string& key, double value) {
  if (std::string e = CheckModelKeyForm(key); !e.empty()) return e;
  const std::vector<std::string> parts = Split(key);
  if (parts.size() == 2) {
    std::string error;
    if (!SetParameter(m, parts[0], parts[1], value, &error)) return "'" + key + "': " + error;
    return "";
  }
  if (!std::isfinite(value)) return "'" + key + "': " + Number(value) + " is not a finite number";
  if (parts[0] == "body") {
    const int body = mj_name2id(m, mjOBJ_BODY, parts[1].c_str());
    if (body < 0) return "'" + key + "': the model has no body '" + parts[1] + "'";
    if (!(value > 0)) return "'" + key + "': a mass must be positive, not " + Number(value);
    const double scale = m->body_mass[body] > 0 ? value / m->body_mass[body] : 1;
    m->body_mass[body] = value;
    for (int i = 0; i < 3; ++i) m->body_inertia[3 * body + i] *= scale;
    return "";
  }
  const int joint = mj_name2id(m, mjOBJ_JOINT, parts[1].c_str());
  if (joint < 0) return "'" + key + "': the model has no joint '" + parts[1] + "'";
  if (!(value >= 0)) return "'" + key + "': must be zero or positive, not " + Number(value);
  const int type = m->jnt_type[joint];
  const int dofs = type == mjJNT_FREE ? 6 : type == mjJNT_BALL ? 3 : 1;
  const bool damping = parts[2] == "damping";
  std::vector<double> before(static_cast<size_t>(dofs));
  double* field = damping ? m->dof_damping : m->dof_frictionloss;
  const int first = m->jnt_dofadr[joint];
  for (int i = 0; i < dofs; ++i) before[i] = field[first + i], field[first + i] = value;
  if (!damping) {
    // a frictionloss below a cylinder's seal friction makes the model unsteppable (docs/cylinder.md,
    // "Editing a model after Attach"): refused here, and the field set back
    const size_t cylinders = Cylinders(m).size();
    mjData* d = mj_makeData(m);
    mj_forward(m, d);
    mj_deleteData(d);
    if (!IsAttached(m) || Cylinders(m).size() != cylinders) {
      for (int i = 0; i < dofs; ++i) field[first + i] = before[i];
      return "'" + key + "': " + Number(value) +
             " leaves the model unsteppable (MuJoCo's warning says why: below a cylinder's coulomb_friction?)";
    }
  }
  return "";
}

std::string ReadVariations(const nlohmann::json& list, const std::string& source, std::vector<Variation>* out) {
  if (!list.is_array() || list.empty()) return source + ": expected a non-empty array of {\"name\", \"set\"}";
  std::vector<Variation> variations;
  for (const nlohmann::json& item : list) {
    if (!item.is_object() || !item.contains("name") || !item["name"].is_string() || !item.contains("set") ||
        !item["set"].is_object()) {
      return source + ": every variation needs \"name\" (text) and \"set\" ({\"cyl:key\": number})";
    }
    Variation v{item["name"].get<std::string>(), {}};
    // the name goes into the output file names ({run}): a plain, unique file name part
    if (v.name.empty() || v.name.find_first_of("/\\") != std::string::npos || v.name == "." || v.name == "..") {
      return source + ": variation name '" + v.name + "' must be a non-empty file name part, without '/'";
    }
    for (const Variation& earlier : variations) {
      if (earlier.name == v.name) return source + ": two variations are named '" + v.name + "' (their outputs would collide)";
    }
    for (const auto& [key, value] : item["set"].items()) {
      if (!value.is_number()) return source + ": variation '" + v.name + "': '" + key + "' must be a number";
      v.parameters.emplace_back(key, value.get<double>());
    }
    variations.push_back(std::move(v));
  }
  *out = std::move(variations);
  return "";
}

std::string ApplyVariation(const Variation& variation, mjModel* m) {
  for (const auto& [key, value] : variation.parameters) {
    if (std::string e = SetModelValue(m, key, value); !e.empty()) return "variation '" + variation.name + "': " + e;
  }
  return "";
}

}  // namespace pneumatic
