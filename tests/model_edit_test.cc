// Models that users edit after Attach, as domain randomisation does: writing mjModel's fields
// (a joint's frictionloss, an actuator's gear, the timestep, the integrator) between steps. The
// extension decodes what it needs from the model; an edit of a field it decoded must give the same
// physics on the thread that stepped before, on a fresh thread, and in a model attached anew with the
// edited values, bit for bit. An edit that makes the model invalid (RK4, a timestep longer than the
// PWM carrier allows) gets one MuJoCo warning naming cylinder and key, and every thread then holds the
// pneumatic states alike, until the edit is undone.
#include <cmath>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util.h"

namespace pneumatic {
namespace {

using ::testing::HasSubstr;
using testing::LoadModelFromString;
using testing::MujocoTest;
using testing::ReadText;
using testing::RunPattern;
using testing::SameBits;
using testing::ShippedModel;
using testing::State;

mjModel* LoadAttached(const std::string& xml, const std::function<void(mjModel*)>& before_attach = nullptr) {
  std::string error;
  mjModel* m = LoadModelFromString(xml, &error);
  EXPECT_NE(m, nullptr) << error;
  if (!m) return nullptr;
  if (before_attach) before_attach(m);
  if (!Attach(m, &error)) {
    ADD_FAILURE() << "Attach: " << error;
    mj_deleteModel(m);
    return nullptr;
  }
  return m;
}

// the state after `steps` more steps of the pattern, from a copy of d
std::vector<double> Continue(const mjModel* m, const mjData* d, const CylinderInfo& c, int first_step, int steps) {
  mjData* copy = mj_copyData(nullptr, m, d);
  RunPattern(m, copy, c, first_step, steps);
  std::vector<double> state = State(m, copy);
  mj_deleteData(copy);
  return state;
}

// the same, on a thread that has never stepped a pneumatic model
std::vector<double> ContinueOnAFreshThread(const mjModel* m, const mjData* d, const CylinderInfo& c, int first_step,
                                           int steps) {
  std::vector<double> state;
  std::thread fresh([&] { state = Continue(m, d, c, first_step, steps); });
  fresh.join();
  return state;
}

struct Edit {
  std::string name;
  std::string model;                    // a shipped model
  std::function<void(mjModel*)> apply;  // the edit, written into mjModel's fields
};

void PrintTo(const Edit& edit, std::ostream* os) { *os << edit.name; }

// every actuator of cylinder "cyl" (its transmission: chambers, friction, valve actuators alike)
void ScaleGear(mjModel* m, double factor) {
  for (int id = 0; id < m->nu; ++id) {
    if (std::string(mj_id2name(m, mjOBJ_ACTUATOR, id)).rfind("cyl.", 0) == 0) m->actuator_gear[6 * id] *= factor;
  }
}

void SetGear(mjModel* m, double gear) {
  for (int id = 0; id < m->nu; ++id) {
    if (std::string(mj_id2name(m, mjOBJ_ACTUATOR, id)).rfind("cyl.", 0) == 0) m->actuator_gear[6 * id] = gear;
  }
}

class EditedModel : public MujocoTest, public ::testing::WithParamInterface<Edit> {};

TEST_P(EditedModel, StepsAlikeOnEveryThreadAndAsAttachedAnew) {
  constexpr int kBefore = 2000, kAfter = 4000;
  const Edit& edit = GetParam();
  const std::string xml = ReadText(ShippedModel(edit.model));
  mjModel* m = LoadAttached(xml);
  ASSERT_NE(m, nullptr);
  const CylinderInfo c = Cylinders(m).at(0);
  mjData* d = mj_makeData(m);
  RunPattern(m, d, c, 0, kBefore);  // this thread has decoded the model
  const std::vector<double> unedited = Continue(m, d, c, kBefore, kAfter);

  edit.apply(m);
  const std::vector<double> here = Continue(m, d, c, kBefore, kAfter);
  const std::vector<double> fresh = ContinueOnAFreshThread(m, d, c, kBefore, kAfter);
  mjModel* anew = LoadAttached(xml, edit.apply);
  ASSERT_NE(anew, nullptr);
  const std::vector<double> attached_anew = Continue(anew, d, c, kBefore, kAfter);

  EXPECT_TRUE(SameBits(here, attached_anew)) << "the thread that stepped before, against the model attached anew";
  EXPECT_TRUE(SameBits(fresh, attached_anew)) << "a fresh thread, against the model attached anew";
  EXPECT_FALSE(SameBits(here, unedited)) << "the edit should change the motion";
  for (double value : here) ASSERT_TRUE(std::isfinite(value));
  ASSERT_EQ(Cylinders(m).size(), 1u) << "the edited model is still attached";
  mj_deleteModel(anew);
  mj_deleteData(d);
  mj_deleteModel(m);
}

INSTANTIATE_TEST_SUITE_P(
    Fields, EditedModel,
    ::testing::Values(
        // the static seal friction is the joint's frictionloss over the gear (the diagnosis' friction candidates edit it so)
        Edit{"frictionloss", "rig_proportional_full.xml", [](mjModel* m) { m->dof_frictionloss[0] *= 1.5; }},
        Edit{"gear", "rig_proportional_full.xml", [](mjModel* m) { ScaleGear(m, 1.25); }},
        Edit{"gear_without_friction", "rig_per_chamber.xml", [](mjModel* m) { ScaleGear(m, 0.8); }},
        Edit{"damping", "rig_proportional_full.xml", [](mjModel* m) { m->dof_damping[0] *= 2; }},
        Edit{"timestep", "rig_proportional_full.xml", [](mjModel* m) { m->opt.timestep *= 2; }},
        Edit{"integrator", "rig_onoff.xml", [](mjModel* m) { m->opt.integrator = mjINT_IMPLICIT; }}),
    [](const ::testing::TestParamInfo<Edit>& info) { return info.param.name; });

// MuJoCo's warnings, collected from every thread
class Warnings {
 public:
  Warnings() { previous_ = mju_user_warning, mju_user_warning = Collect; }
  ~Warnings() { mju_user_warning = previous_; }
  std::vector<std::string> Take() {
    std::lock_guard<std::mutex> lock(Mutex());
    std::vector<std::string> all;
    all.swap(Collected());
    return all;
  }

 private:
  static std::mutex& Mutex() {
    static std::mutex mutex;
    return mutex;
  }
  static std::vector<std::string>& Collected() {
    static std::vector<std::string> collected;
    return collected;
  }
  static void Collect(const char* message) {
    std::lock_guard<std::mutex> lock(Mutex());
    Collected().push_back(message);
  }
  void (*previous_)(const char*) = nullptr;
};

// the model's pneumatic states (every act) over `steps` steps from a copy of d: each step's act, in order
std::vector<double> ActsOverSteps(const mjModel* m, const mjData* d, const CylinderInfo& c, int first_step, int steps) {
  mjData* copy = mj_copyData(nullptr, m, d);
  std::vector<double> acts;
  for (int i = 0; i < steps; ++i) {
    RunPattern(m, copy, c, first_step + i, 1);
    acts.insert(acts.end(), copy->act, copy->act + m->na);
  }
  mj_deleteData(copy);
  return acts;
}

struct InvalidEdit {
  std::string name;
  std::string xml;
  std::function<void(mjModel*)> apply, undo;
  std::string key;  // the key the warning names
};

void PrintTo(const InvalidEdit& edit, std::ostream* os) { *os << edit.name; }

class InvalidatingEdit : public ::testing::TestWithParam<InvalidEdit> {};

TEST_P(InvalidatingEdit, WarnsOnceAndHoldsTheStatesOnEveryThread) {
  constexpr int kBefore = 1000, kAfter = 400;
  const InvalidEdit& edit = GetParam();
  Warnings warnings;
  mjModel* m = LoadAttached(edit.xml);
  ASSERT_NE(m, nullptr);
  const CylinderInfo c = Cylinders(m).at(0);
  mjData* d = mj_makeData(m);
  RunPattern(m, d, c, 0, kBefore);
  ASSERT_TRUE(warnings.Take().empty());
  std::vector<double> held(d->act, d->act + m->na);

  edit.apply(m);
  const std::vector<double> here = ActsOverSteps(m, d, c, kBefore, kAfter);
  const std::vector<double> fresh = [&] {
    std::vector<double> acts;
    std::thread t([&] { acts = ActsOverSteps(m, d, c, kBefore, kAfter); });
    t.join();
    return acts;
  }();
  EXPECT_TRUE(SameBits(here, fresh)) << "the thread that stepped before, against a fresh thread";
  // every pneumatic state holds: each step's act is the act before the edit
  for (int i = 0; i < kAfter; ++i) {
    std::vector<double> step(here.begin() + i * m->na, here.begin() + (i + 1) * m->na);
    ASSERT_TRUE(SameBits(step, held)) << "step " << i << " after the edit";
  }
  std::vector<std::string> said = warnings.Take();
  ASSERT_EQ(said.size(), 1u) << "one warning for the edit, whichever threads step the model";
  EXPECT_THAT(said[0], HasSubstr("cylinder 'cyl'"));
  EXPECT_THAT(said[0], HasSubstr(edit.key));
  EXPECT_TRUE(Cylinders(m).empty()) << "an invalid model is not attached while the edit stands";

  // undone: the model steps again, as one that was never edited would from this state
  edit.undo(m);
  ASSERT_EQ(Cylinders(m).size(), 1u);
  mjModel* original = LoadAttached(edit.xml);
  ASSERT_NE(original, nullptr);
  EXPECT_TRUE(SameBits(Continue(m, d, c, kBefore, kAfter), Continue(original, d, c, kBefore, kAfter)));
  EXPECT_TRUE(SameBits(ContinueOnAFreshThread(m, d, c, kBefore, kAfter), Continue(original, d, c, kBefore, kAfter)));
  EXPECT_TRUE(warnings.Take().empty());
  mj_deleteModel(original);
  mj_deleteData(d);
  mj_deleteModel(m);
}

INSTANTIATE_TEST_SUITE_P(
    Fields, InvalidatingEdit,
    ::testing::Values(
        InvalidEdit{"rk4", ReadText(ShippedModel("rig_onoff.xml")),
                    [](mjModel* m) { m->opt.integrator = mjINT_RK4; },
                    [](mjModel* m) { m->opt.integrator = mjINT_EULER; }, "integrator"},
        // 1 kHz PWM: at most 8 carrier periods a step allows steps up to 8 ms
        InvalidEdit{"timestep_beyond_pwm", testing::RigAOnPwm(1000), [](mjModel* m) { m->opt.timestep = 0.01; },
                    [](mjModel* m) { m->opt.timestep = 0.00025; }, "pwm_frequency"},
        InvalidEdit{"gear_zero", ReadText(ShippedModel("rig_per_chamber.xml")),
                    [](mjModel* m) { ScaleGear(m, 0); }, [](mjModel* m) { SetGear(m, 1); }, "gear"},
        // the seal's static friction (40 N) below its Coulomb level (20 N)
        InvalidEdit{"frictionloss_below_coulomb", ReadText(ShippedModel("rig_proportional_full.xml")),
                    [](mjModel* m) { m->dof_frictionloss[0] = 10; }, [](mjModel* m) { m->dof_frictionloss[0] = 40; },
                    "coulomb_friction"}),
    [](const ::testing::TestParamInfo<InvalidEdit>& info) { return info.param.name; });

}  // namespace
}  // namespace pneumatic

namespace pneumatic {
namespace {

// A program that installs its own mjcb_act_dyn after Attach: the extension finds it at its next call
// (an API call, or a pass whose first callback is still ours), puts its own back in front, passes the
// actuators that are not pneumatic to it, and warns once. The motion is the same as with no foreign
// callback, whether it handles the pneumatic actuators wrongly (returns 0) or passes them on to ours.
mjfAct saved_dyn = nullptr;
mjtNum ZeroDynamics(const mjModel*, const mjData*, int) { return 0; }
mjtNum ChainingDynamics(const mjModel* m, const mjData* d, int id) { return saved_dyn ? saved_dyn(m, d, id) : 0; }

struct Foreign {
  std::string name;
  std::string model;
  mjfAct callback;
  bool api_call;  // the program calls Cylinders(m) after installing it (else only mj_step runs)
};
void PrintTo(const Foreign& f, std::ostream* os) { *os << f.name; }

class ForeignCallback : public ::testing::TestWithParam<Foreign> {};

TEST_P(ForeignCallback, IsChainedBehindOursAndSaidOnce) {
  constexpr int kSteps = 2000;
  const Foreign& foreign = GetParam();
  Warnings warnings;
  const std::string xml = ReadText(ShippedModel(foreign.model));
  mjModel* m = LoadAttached(xml);
  ASSERT_NE(m, nullptr);
  const CylinderInfo c = Cylinders(m).at(0);
  mjData* d = mj_makeData(m);
  RunPattern(m, d, c, 0, kSteps);
  const std::vector<double> reference = Continue(m, d, c, kSteps, kSteps);

  saved_dyn = mjcb_act_dyn;
  mjcb_act_dyn = foreign.callback;
  if (foreign.api_call) EXPECT_EQ(Cylinders(m).size(), 1u);
  const std::vector<double> with_foreign = Continue(m, d, c, kSteps, kSteps);
  EXPECT_TRUE(SameBits(with_foreign, reference));
  // said once per process: by the first of these tests that a process runs (ctest runs each alone)
  static bool said_before = false;
  std::vector<std::string> said = warnings.Take();
  ASSERT_EQ(said.size(), said_before ? 0u : 1u);
  if (!said.empty()) EXPECT_THAT(said[0], HasSubstr("mjcb_act_dyn was replaced after Attach"));
  said_before = true;
  EXPECT_NE(mjcb_act_dyn, foreign.callback) << "the extension's callback is back in front";
  mj_deleteData(d);
  mj_deleteModel(m);
}

INSTANTIATE_TEST_SUITE_P(
    Programs, ForeignCallback,
    ::testing::Values(
        // the friction actuator's bias callback is the first of each pass: it finds the foreign one
        Foreign{"zero_seen_by_the_pass", "rig_proportional_full.xml", ZeroDynamics, false},
        Foreign{"chaining_seen_by_the_pass", "rig_proportional_full.xml", ChainingDynamics, false},
        // no friction: the dynamics callback is the first, and the program's API call finds it
        Foreign{"zero_seen_by_an_api_call", "rig_onoff.xml", ZeroDynamics, true},
        Foreign{"chaining_seen_by_an_api_call", "rig_onoff.xml", ChainingDynamics, true}),
    [](const ::testing::TestParamInfo<Foreign>& info) { return info.param.name; });

}  // namespace
}  // namespace pneumatic
