// Helpers shared by the tests: MJCF from a string, a model that detaches and
// frees itself, and a fixture that turns MuJoCo warnings into failures.
#ifndef PNEUMATIC_TESTS_TEST_UTIL_H_
#define PNEUMATIC_TESTS_TEST_UTIL_H_

#include <cstring>
#include <fstream>
#include <iomanip>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "pneumatic/pneumatic.h"

namespace pneumatic::testing {

// compiles MJCF text through MuJoCo's virtual file system; null and *error on failure
inline mjModel* LoadModelFromString(const std::string& xml, std::string* error) {
  auto vfs = std::make_unique<mjVFS>();
  mj_defaultVFS(vfs.get());
  mj_makeEmptyFileVFS(vfs.get(), "model.xml", static_cast<int>(xml.size()));
  std::memcpy(vfs->filedata[0], xml.data(), xml.size());
  char buffer[1000] = "";
  mjModel* m = mj_loadXML("model.xml", vfs.get(), buffer, sizeof(buffer));
  mj_deleteVFS(vfs.get());
  if (!m && error) *error = buffer;
  return m;
}

// a model with the extension attached, released in the right order
class AttachedModel {
 public:
  AttachedModel() = default;
  AttachedModel(const AttachedModel&) = delete;
  AttachedModel& operator=(const AttachedModel&) = delete;
  ~AttachedModel() { Reset(); }

  // loads (from a string, or a file when from_file) and attaches; false and error() on failure
  bool Load(const std::string& xml_or_path, bool from_file = false) {
    Reset();
    error_.clear();
    if (from_file) {
      char buffer[1000] = "";
      model_ = mj_loadXML(xml_or_path.c_str(), nullptr, buffer, sizeof(buffer));
      if (!model_) error_ = buffer;
    } else {
      model_ = LoadModelFromString(xml_or_path, &error_);
    }
    if (!model_) return false;
    if (!Attach(model_, &error_)) return false;
    data_ = mj_makeData(model_);
    return true;
  }

  void Reset() {
    if (data_) mj_deleteData(data_);
    if (model_) {
      Detach(model_);
      mj_deleteModel(model_);
    }
    data_ = nullptr, model_ = nullptr;
  }

  mjModel* m() const { return model_; }
  mjData* d() const { return data_; }
  const std::string& error() const { return error_; }
  CylinderInfo cylinder(size_t i = 0) const { return Cylinders(model_).at(i); }
  int actuator(const std::string& name) const { return mj_name2id(model_, mjOBJ_ACTUATOR, name.c_str()); }

 private:
  mjModel* model_ = nullptr;
  mjData* data_ = nullptr;
  std::string error_;
};

// an attached model loaded from MJCF text, with accessors by actuator name: the tests of the
// effects' physics (effects_physics_test, valve_delay_test)
class LoadedModel : public AttachedModel {
 public:
  explicit LoadedModel(const std::string& xml) { ok_ = Load(xml); }
  bool ok() const { return ok_; }
  int Id(const std::string& name) const { return actuator(name); }
  // act of a state actuator (MuJoCo puts the activations of the last na actuators in act)
  double& Act(const std::string& name) const { return d()->act[Id(name) - (m()->nu - m()->na)]; }
  double& Ctrl(const std::string& name) const { return d()->ctrl[Id(name)]; }
  double P(Chamber k) const { return ChamberPressure(m(), d(), cylinder(), k); }
  void StepUntil(double t) const {
    while (d()->time < t - 1e-9) mj_step(m(), d());
  }

 private:
  bool ok_ = false;
};

// the integrated state of a run, in one vector: time, qpos, qvel, act
inline std::vector<double> State(const mjModel* m, const mjData* d) {
  std::vector<double> s{d->time};
  s.insert(s.end(), d->qpos, d->qpos + m->nq);
  s.insert(s.end(), d->qvel, d->qvel + m->nv);
  s.insert(s.end(), d->act, d->act + m->na);
  return s;
}

// bitwise equality of two arrays, naming the first difference
inline ::testing::AssertionResult SameBits(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return ::testing::AssertionFailure() << "sizes " << a.size() << " and " << b.size();
  if (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0) {
    return ::testing::AssertionSuccess();
  }
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::memcmp(&a[i], &b[i], sizeof(double)) != 0) {
      return ::testing::AssertionFailure() << std::setprecision(17) << "entry " << i << ": " << a[i] << " vs " << b[i];
    }
  }
  return ::testing::AssertionFailure();
}

// the shipped rig models
inline const char* const kShippedRigs[] = {"rig_onoff.xml", "rig_proportional.xml", "rig_per_chamber.xml",
                                           "rig_proportional_full.xml"};

// a text file's contents (a failure if it is empty or missing)
inline std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_FALSE(text.str().empty()) << "cannot read " << path;
  return text.str();
}

// text with every occurrence of `from` replaced; `from` must occur
inline std::string ReplaceAll(std::string text, const std::string& from, const std::string& to) {
  size_t count = 0;
  for (size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size())) {
    text.replace(at, from.size(), to);
    ++count;
  }
  EXPECT_GT(count, 0u) << "'" << from << "' not found";
  return text;
}

// a deterministic command pattern for any valve arrangement: push (chamber P fills, N vents) for
// 40 ms, then pull for 40 ms, with a staircase on the proportional commands
inline void PatternCommand(const CylinderInfo& c, mjData* d, int step) {
  bool push = (step / 160) % 2 == 0;
  double stair = (step % 97) / 50.0;
  for (const auto& [signal, id] : c.command_actuators) {
    double u = 0;
    if (signal == "u1" || signal == "u4") u = push;
    if (signal == "u2" || signal == "u3") u = !push;
    if (signal == "u") u = push ? 2 + stair : -2 - stair;
    if (signal == "uP") u = push ? 6 + stair : 3.5;
    if (signal == "uN") u = push ? 3.5 : 6 + stair;
    if (signal == "duty") u = push ? 0.6 : -0.4;
    d->ctrl[id] = u;
  }
}

inline void RunPattern(const mjModel* m, mjData* d, const CylinderInfo& c, int first_step, int steps) {
  for (int i = first_step; i < first_step + steps; ++i) {
    PatternCommand(c, d, i);
    mj_step(m, d);
  }
}

// path of a model shipped in models_mjcf/
inline std::string ShippedModel(const std::string& file) { return std::string(PNEUMATIC_MODELS_DIR) + "/" + file; }

// rig A with its valves driven by one duty command at `frequency` (0: the averaged model)
inline std::string RigAOnPwm(double frequency) {
  return R"(<mujoco><size nuser_actuator="128"/><option timestep="0.00025" gravity="0 0 0"/>
    <worldbody><body><inertial pos="0 0 0" mass="0.9" diaginertia="1e-4 1e-4 1e-4"/>
      <joint name="x" type="slide" axis="1 0 0" limited="true" range="-0.05 0.05" damping="50"/></body></worldbody>
    <actuator>
      <general name="cyl.duty" joint="x" gaintype="user" ctrllimited="true" ctrlrange="-1 1"/>
      <general name="cyl.P" joint="x" dyntype="user" gaintype="user"/>
      <general name="cyl.N" joint="x" dyntype="user" gaintype="user"/>
    </actuator>
    <custom><text name="pneumatic:cyl" data="valve=onoff input=pwm pwm_frequency=)" +
         std::to_string(frequency) + R"( stroke=0.1 area=1.814e-4 dead_volume=2e-6 p_supply=3e5 p_exhaust=1e5
      temperature=296 polytropic_index=1.2 sonic_conductance=3.4e-9 critical_ratio=0.433"/></custom></mujoco>)";
}

// any MuJoCo warning during a test is a failure (as in MuJoCo's own tests)
class MujocoTest : public ::testing::Test {
 protected:
  void SetUp() override { previous_ = mju_user_warning, mju_user_warning = OnWarning; }
  void TearDown() override { mju_user_warning = previous_; }

 private:
  static void OnWarning(const char* message) { ADD_FAILURE() << "MuJoCo warning: " << message; }
  void (*previous_)(const char*) = nullptr;
};

// rig C with both chambers on the identified model; the piston is fixed (a 1e6 kg load) so v' = 0
inline std::string IdentifiedRig() {
  return R"(<mujoco><size nuser_actuator="128"/><option timestep="0.001" gravity="0 0 0"/>
    <worldbody><body><inertial pos="0 0 0" mass="1e6" diaginertia="1 1 1"/>
      <joint name="x" type="slide" axis="1 0 0"/></body></worldbody>
    <actuator>
      <general name="cyl.uP" joint="x" gaintype="user"/><general name="cyl.uN" joint="x" gaintype="user"/>
      <general name="cyl.P" joint="x" dyntype="user" gaintype="user"/>
      <general name="cyl.N" joint="x" dyntype="user" gaintype="user"/>
    </actuator>
    <custom><text name="pneumatic:cyl" data="valve=proportional_per_chamber stroke=0.1 P.area=7.854e-5
      N.area=6.597e-5 dead_volume=1e-6 p_supply=6.2e5 p_exhaust=1e5 pressure_model=identified
      c1=5 c2=1.5 c3=0.2 c4=0 c5=0 c6=0 c7=40 c8=0.1 c9=0.05"/></custom></mujoco>)";
}

// one step of length h of the classical fourth-order Runge-Kutta method (Kutta, 1901) for
// x' = rate(x) with N states, x updated in place: the tests' independent fine-step references
template <int N, class Rate>
void Rk4Step(const Rate& rate, double h, double x[N]) {
  double k1[N], k2[N], k3[N], k4[N], y[N];
  rate(x, k1);
  for (int j = 0; j < N; ++j) y[j] = x[j] + h / 2 * k1[j];
  rate(y, k2);
  for (int j = 0; j < N; ++j) y[j] = x[j] + h / 2 * k2[j];
  rate(y, k3);
  for (int j = 0; j < N; ++j) y[j] = x[j] + h * k3[j];
  rate(y, k4);
  for (int j = 0; j < N; ++j) x[j] += h / 6 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]);
}

}  // namespace pneumatic::testing

#endif  // PNEUMATIC_TESTS_TEST_UTIL_H_
