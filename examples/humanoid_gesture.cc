// Writes the scripted gesture of the pneumatic humanoid as a reference log for
// `pneumo rollout --controller pid --reference`: a wave of the right arm, the head turning to it.
//
// The gesture is written in joint angles (keyframes below, smoothstep between them) and turned into
// each cylinder's piston position x by the model's own kinematics (mj_forward, then
// pneumatic::PistonPosition), because the controller's reference is x (docs/log_format.md: `ref`, the
// reference for x). Joints the gesture does not name stay at 0 rad.
//
// usage: example_humanoid_gesture [models_mjcf/humanoid_pneumatic.xml] [models_mjcf/humanoid_wave.csv]
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "formats/log_csv.h"
#include "pneumatic/pneumatic.h"

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;
constexpr double kPeriod = 0.02;  // s between reference rows (linear in between, in the rollout)

// joint angles (degrees) at key times (s); between keys a smoothstep, after the last key the last
struct Key {
  double time;
  std::map<std::string, double> degrees;
};

std::map<std::string, double> Raised(double shoulder_yaw) {
  return {{"r_shoulder_roll", 75}, {"r_elbow", -95}, {"r_shoulder_yaw", shoulder_yaw}, {"neck_yaw", -25},
          {"neck_pitch", 8}};
}

const std::vector<Key> kGesture = {
    {0.0, {}},  // hold still while the chambers fill
    {1.0, {}},
    {2.2, Raised(0)},  // raise the arm, bend the elbow, look at the hand
    {2.7, Raised(25)},  // wave: the forearm swings through shoulder yaw, 1 Hz
    {3.2, Raised(-25)},
    {3.7, Raised(25)},
    {4.2, Raised(-25)},
    {4.7, Raised(25)},
    {5.2, Raised(0)},
    {6.4, {}},  // and back down
    {7.5, {}},
};

double Angle(const Key& key, const std::string& joint) {
  auto it = key.degrees.find(joint);
  return it == key.degrees.end() ? 0 : it->second * kDeg;
}

double AngleAt(double t, const std::string& joint) {
  for (size_t k = 0; k + 1 < kGesture.size(); ++k) {
    if (t <= kGesture[k + 1].time) {
      double s = (t - kGesture[k].time) / (kGesture[k + 1].time - kGesture[k].time);
      s = s * s * (3 - 2 * s);  // smoothstep: no velocity jump at the keys
      return Angle(kGesture[k], joint) + s * (Angle(kGesture[k + 1], joint) - Angle(kGesture[k], joint));
    }
  }
  return Angle(kGesture.back(), joint);
}

}  // namespace

int main(int argc, char** argv) {
  const char* model_path = argc > 1 ? argv[1] : "models_mjcf/humanoid_pneumatic.xml";
  const std::string out_path = argc > 2 ? argv[2] : "models_mjcf/humanoid_wave.csv";
  char error[1000] = "";
  mjModel* m = mj_loadXML(model_path, nullptr, error, sizeof(error));
  std::string why;
  if (!m || !pneumatic::Attach(m, &why)) {
    std::fprintf(stderr, "%s: %s%s\n", model_path, error, why.c_str());
    if (m) mj_deleteModel(m);
    return 1;
  }
  mjData* d = mj_makeData(m);
  const std::vector<pneumatic::CylinderInfo> cylinders = pneumatic::Cylinders(m);
  pneumatic::log::Log log;
  log.comments = {"the wave gesture of " + std::string(model_path) + ": the reference x of every cylinder",
                  "written by examples/humanoid_gesture.cc from joint-angle keyframes"};
  for (const auto& c : cylinders) log.columns.push_back({c.name, "ref"});
  log.values.assign(cylinders.size(), {});
  for (int row = 0; row * kPeriod <= kGesture.back().time + 1e-9; ++row) {
    const double t = row * kPeriod;
    for (int j = 0; j < m->njnt; ++j) {
      if (m->jnt_type[j] == mjJNT_HINGE) d->qpos[m->jnt_qposadr[j]] = AngleAt(t, mj_id2name(m, mjOBJ_JOINT, j));
    }
    mj_forward(m, d);
    log.time.push_back(t);
    for (size_t i = 0; i < cylinders.size(); ++i) log.values[i].push_back(pneumatic::PistonPosition(m, d, cylinders[i]));
  }
  const std::string write_error = pneumatic::log::WriteLog(out_path, log);
  mj_deleteData(d);
  pneumatic::Detach(m);
  mj_deleteModel(m);
  if (!write_error.empty()) {
    std::fprintf(stderr, "%s\n", write_error.c_str());
    return 1;
  }
  std::printf("wrote %s: %zu rows, %zu cylinders\n", out_path.c_str(), log.rows(), cylinders.size());
  return 0;
}
