// The extension inside MuJoCo's engine: all state lives in mjData (reset, copy,
// keyframes, finite differences), the callbacks are pure functions of (m, d),
// several models and foreign user actuators coexist, and stepping different
// mjData from several threads gives the serial results bit for bit.
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "test_util.h"

namespace pneumatic {
namespace {

using testing::AttachedModel;
using testing::LoadModelFromString;
using testing::MujocoTest;
using testing::SameBits;
using testing::State;
using testing::PatternCommand;
using testing::RunPattern;
using testing::kShippedRigs;
using testing::ReadText;
using testing::ReplaceAll;

// constant commands, different for each k = 0..7
void ConstantCommand(const CylinderInfo& c, mjData* d, int k) {
  for (const auto& [signal, id] : c.command_actuators) {
    double u = 0;
    if (signal == "u1") u = k & 1;
    if (signal == "u2") u = !(k & 1);
    if (signal == "u3") u = (k >> 1) & 1;
    if (signal == "u4") u = (k >> 2) & 1;
    if (signal == "u") u = -4 + k;
    if (signal == "uP") u = 3 + 0.5 * k;
    if (signal == "uN") u = 7 - 0.5 * k;
    if (signal == "duty") u = -1 + k / 4.0;
    d->ctrl[id] = u;
  }
}

using testing::ShippedModel;


// rig A with switching delays (paper 002: 1.3 ms opening, 0.2 ms closing): u1..u4 hold the armatures
std::string OnOffWithDelays() {
  std::string xml = ReadText(ShippedModel("rig_onoff.xml"));
  xml = ReplaceAll(xml, "critical_ratio=0.433\"", "critical_ratio=0.433 delay_open=1.3e-3 delay_close=2e-4\"");
  for (const char* valve : {"u1", "u2", "u3", "u4"}) {
    xml = ReplaceAll(xml, "name=\"cyl." + std::string(valve) + "\" joint=\"x\"",
                     "name=\"cyl." + std::string(valve) + "\" joint=\"x\" dyntype=\"user\"");
  }
  return xml;
}



std::vector<double> Array(const mjtNum* p, int n) { return std::vector<double>(p, p + n); }

bool AllFinite(const std::vector<double>& v) {
  for (double x : v) {
    if (!std::isfinite(x)) return false;
  }
  return true;
}

// user callbacks of "someone else", installed before the extension: distinctive constant values
// for any actuator, recording which actuators they were asked about
constexpr double kForeignActDot = 42.5, kForeignGain = 3.0, kForeignBias = 0.25;
std::set<int> foreign_ids;
mjtNum ForeignDyn(const mjModel*, const mjData*, int id) { return foreign_ids.insert(id), kForeignActDot; }
mjtNum ForeignGain(const mjModel*, const mjData*, int id) { return foreign_ids.insert(id), kForeignGain; }
mjtNum ForeignBias(const mjModel*, const mjData*, int id) { return foreign_ids.insert(id), kForeignBias; }

// restores MuJoCo's actuator callbacks as they were at construction
class CallbackGuard {
 public:
  CallbackGuard() : dyn_(mjcb_act_dyn), gain_(mjcb_act_gain), bias_(mjcb_act_bias) {}
  ~CallbackGuard() { mjcb_act_dyn = dyn_, mjcb_act_gain = gain_, mjcb_act_bias = bias_; }
  CallbackGuard(const CallbackGuard&) = delete;
  CallbackGuard& operator=(const CallbackGuard&) = delete;
  bool Unchanged() const { return mjcb_act_dyn == dyn_ && mjcb_act_gain == gain_ && mjcb_act_bias == bias_; }

 private:
  mjfAct dyn_, gain_, bias_;
};

class EngineState : public MujocoTest {};

TEST_F(EngineState, ResetStartsAtAtmosphere) {
  // after filling and venting, mj_resetData puts every chamber back at p_atm (act = 0), and the run
  // from there repeats the run of a fresh mjData bit for bit: nothing survives outside mjData
  for (const char* file : kShippedRigs) {
    SCOPED_TRACE(file);
    AttachedModel rig;
    ASSERT_TRUE(rig.Load(ShippedModel(file), true)) << rig.error();
    const mjModel* m = rig.m();
    mjData* d = rig.d();
    CylinderInfo cyl = rig.cylinder();
    RunPattern(m, d, cyl, 0, 200);
    ASSERT_NE(ChamberPressure(m, d, cyl, Chamber::kP), cyl.p_atm) << "the valves did not move the pressure";
    mj_resetData(m, d);
    for (int i = 0; i < m->na; ++i) EXPECT_EQ(d->act[i], 0.0) << "act " << i;
    EXPECT_EQ(ChamberPressure(m, d, cyl, Chamber::kP), cyl.p_atm);
    EXPECT_EQ(ChamberPressure(m, d, cyl, Chamber::kN), cyl.p_atm);

    mjData* fresh = mj_makeData(m);
    RunPattern(m, d, cyl, 0, 200);
    RunPattern(m, fresh, cyl, 0, 200);
    EXPECT_TRUE(SameBits(State(m, d), State(m, fresh)));
    mj_deleteData(fresh);
  }
}

TEST_F(EngineState, CopyDataContinuesBitForBit) {
  // rig B (spool position in act) and rig A with valve delays (armatures in act): 0.3 s, copy,
  // 0.3 s more on both with the same commands
  struct Case {
    std::string name, xml;
  };
  for (const Case& c : {Case{"rig_proportional", ReadText(ShippedModel("rig_proportional.xml"))},
                        Case{"rig_onoff with delays", OnOffWithDelays()}}) {
    SCOPED_TRACE(c.name);
    AttachedModel rig;
    ASSERT_TRUE(rig.Load(c.xml)) << rig.error();
    const mjModel* m = rig.m();
    mjData* d = rig.d();
    CylinderInfo cyl = rig.cylinder();
    ASSERT_GT(m->na, 2) << "the valves should carry state";
    RunPattern(m, d, cyl, 0, 1200);
    mjData* copy = mj_copyData(nullptr, m, d);
    RunPattern(m, d, cyl, 1200, 1200);
    RunPattern(m, copy, cyl, 1200, 1200);
    EXPECT_TRUE(SameBits(Array(d->qpos, m->nq), Array(copy->qpos, m->nq)));
    EXPECT_TRUE(SameBits(Array(d->qvel, m->nv), Array(copy->qvel, m->nv)));
    EXPECT_TRUE(SameBits(Array(d->act, m->na), Array(copy->act, m->na)));
    // the valve state did move: the armature/spool is not stuck at its reset value
    bool valve_state_moved = false;
    for (int i = 0; i < m->na - 2; ++i) valve_state_moved |= d->act[i] != 0;
    EXPECT_TRUE(valve_state_moved);
    mj_deleteData(copy);
  }
}

// The pass steps the chambers of batchable cylinders together (LinearizedChambers, between each
// cylinder's BeginStep and EndStep) where the mjData stack has room for their inputs, and each
// cylinder by its own Step otherwise: the two give the same states, bit for bit. Rig C as shipped
// (its two voltages are all it reads), with a laminar leak to the atmosphere, and with a lag on its
// valves (openings that move over the step, read through the general valve pass).
TEST_F(EngineState, BatchedChambersStepAsEachCylinderAlone) {
  const std::string shipped = ReadText(ShippedModel("rig_per_chamber.xml"));
  std::string lagged = ReplaceAll(shipped, "area_smoothing=1e-6", "area_smoothing=1e-6 spool_time_constant=3e-3");
  for (const char* command : {"uP", "uN"}) {
    lagged = ReplaceAll(lagged, "name=\"cyl." + std::string(command) + "\" joint=\"x\"",
                        "name=\"cyl." + std::string(command) + "\" joint=\"x\" dyntype=\"user\"");
  }
  const std::string variants[] = {
      shipped, ReplaceAll(shipped, "area_smoothing=1e-6", "area_smoothing=1e-6 atmosphere_leak_conductance=2e-9"),
      lagged};
  for (const std::string& xml : variants) {
    AttachedModel rig;
    ASSERT_TRUE(rig.Load(xml)) << rig.error();
    const CylinderInfo c = rig.cylinder();
    // the stack the batched pass takes at its peak; one word less leaves no room for the batch's inputs,
    // and MuJoCo's own steps still fit (rig C: 24 of 33 words)
    RunPattern(rig.m(), rig.d(), c, 0, 400);
    mjModel* small = mj_copyModel(nullptr, rig.m());
    small->nstack = rig.d()->maxuse_stack - 1;
    mjData* one_by_one = mj_makeData(small);
    mjData* batched = mj_makeData(rig.m());
    for (int i = 0; i < 3000; ++i) {
      PatternCommand(c, batched, i);
      PatternCommand(c, one_by_one, i);
      mj_step(rig.m(), batched);
      mj_step(small, one_by_one);
      ASSERT_TRUE(SameBits(State(rig.m(), batched), State(small, one_by_one))) << "step " << i;
    }
    EXPECT_LT(one_by_one->maxuse_stack, batched->maxuse_stack) << "the small stack took the batch";
    mj_deleteData(batched);
    mj_deleteData(one_by_one);
    mj_deleteModel(small);
  }
}

TEST_F(EngineState, KeyframeSetsPressures) {
  // <key act> holds the gauge pressures (and valve states) in the order of the stateful actuators;
  // mj_resetDataKeyframe then stepping equals writing the same act by hand then stepping
  struct Case {
    std::string file, act;
    std::vector<double> values;
  };
  for (const Case& c : {Case{"rig_onoff.xml", "150000 -20000", {150000, -20000}},
                        Case{"rig_proportional.xml", "1e-4 200000 -30000", {1e-4, 200000, -30000}}}) {
    SCOPED_TRACE(c.file);
    std::string xml = ReplaceAll(ReadText(ShippedModel(c.file)), "</mujoco>",
                                 "  <keyframe><key name=\"charged\" act=\"" + c.act + "\"/></keyframe>\n</mujoco>");
    AttachedModel rig;
    ASSERT_TRUE(rig.Load(xml)) << rig.error();
    const mjModel* m = rig.m();
    ASSERT_EQ(m->nkey, 1);
    ASSERT_EQ(m->na, static_cast<int>(c.values.size()));
    CylinderInfo cyl = rig.cylinder();
    mjData* keyed = rig.d();
    mj_resetDataKeyframe(m, keyed, 0);
    double gauge_p = c.values[c.values.size() - 2], gauge_n = c.values.back();
    EXPECT_EQ(ChamberPressure(m, keyed, cyl, Chamber::kP), cyl.p_atm + gauge_p);
    EXPECT_EQ(ChamberPressure(m, keyed, cyl, Chamber::kN), cyl.p_atm + gauge_n);

    mjData* by_hand = mj_makeData(m);
    for (int i = 0; i < m->na; ++i) by_hand->act[i] = c.values[i];
    RunPattern(m, keyed, cyl, 0, 400);
    RunPattern(m, by_hand, cyl, 0, 400);
    EXPECT_TRUE(SameBits(State(m, keyed), State(m, by_hand)));
    mj_deleteData(by_hand);
  }
}

TEST_F(EngineState, ForwardIsPure) {
  // act_dot and actuator_force depend on the state only: mj_forward twice gives the same bits, and
  // a second mjData given the same state (not the derived quantities) computes the same
  for (const char* file : kShippedRigs) {
    SCOPED_TRACE(file);
    AttachedModel rig;
    ASSERT_TRUE(rig.Load(ShippedModel(file), true)) << rig.error();
    const mjModel* m = rig.m();
    mjData* d = rig.d();
    CylinderInfo cyl = rig.cylinder();
    RunPattern(m, d, cyl, 0, 300);
    PatternCommand(cyl, d, 300);
    mj_forward(m, d);
    std::vector<double> act_dot = Array(d->act_dot, m->na), force = Array(d->actuator_force, m->nu);
    mj_forward(m, d);
    EXPECT_TRUE(SameBits(act_dot, Array(d->act_dot, m->na)));
    EXPECT_TRUE(SameBits(force, Array(d->actuator_force, m->nu)));

    mjData* other = mj_makeData(m);
    other->time = d->time;
    mju_copy(other->qpos, d->qpos, m->nq);
    mju_copy(other->qvel, d->qvel, m->nv);
    mju_copy(other->act, d->act, m->na);
    mju_copy(other->ctrl, d->ctrl, m->nu);
    mj_forward(m, other);
    EXPECT_TRUE(SameBits(act_dot, Array(other->act_dot, m->na)));
    EXPECT_TRUE(SameBits(force, Array(other->actuator_force, m->nu)));
    mj_deleteData(other);
  }
}

TEST_F(EngineState, FiniteDifferencesOfActDot) {
  // rig A, chamber P filling from supply through U1 (subsonic by now): more pressure, less inflow,
  // so d(act_dot_P)/d(act_P) < 0; both one-sided differences agree in sign and roughly in size
  AttachedModel rig;
  ASSERT_TRUE(rig.Load(ShippedModel("rig_onoff.xml"), true)) << rig.error();
  const mjModel* m = rig.m();
  mjData* d = rig.d();
  CylinderInfo cyl = rig.cylinder();
  d->ctrl[cyl.CommandActuator("u1")] = 1;
  while (ChamberPressure(m, d, cyl, Chamber::kP) < 2e5 && d->time < 0.1) mj_step(m, d);
  ASSERT_GE(ChamberPressure(m, d, cyl, Chamber::kP), 2e5);
  int p = cyl.chamber_actuator[0] - (m->nu - m->na);
  mj_forward(m, d);
  double center = d->act_dot[p];
  ASSERT_GT(center, 0) << "chamber P should still be filling";
  for (double eps : {1.0, 10.0, 100.0}) {
    SCOPED_TRACE("eps = " + std::to_string(eps));
    double act = d->act[p];
    d->act[p] = act + eps;
    mj_forward(m, d);
    double plus = d->act_dot[p];
    d->act[p] = act - eps;
    mj_forward(m, d);
    double minus = d->act_dot[p];
    d->act[p] = act;
    ASSERT_TRUE(std::isfinite(plus) && std::isfinite(minus));
    double forward = (plus - center) / eps, backward = (center - minus) / eps, central = (plus - minus) / (2 * eps);
    EXPECT_LT(central, 0);
    EXPECT_LT(forward, 0);
    EXPECT_LT(backward, 0);
    EXPECT_GT(forward / backward, 0.5);
    EXPECT_LT(forward / backward, 2.0);
  }
  // the perturbations left nothing behind
  mj_forward(m, d);
  EXPECT_EQ(d->act_dot[p], center);
}

TEST_F(EngineState, TransitionFDIsFiniteAndLeavesTheStateAlone) {
  // MuJoCo 2.2.2's mjd_transitionFD on rig B mid-transient (spool, chambers and piston moving)
  AttachedModel rig;
  ASSERT_TRUE(rig.Load(ShippedModel("rig_proportional.xml"), true)) << rig.error();
  const mjModel* m = rig.m();
  mjData* d = rig.d();
  CylinderInfo cyl = rig.cylinder();
  RunPattern(m, d, cyl, 0, 200);
  PatternCommand(cyl, d, 200);
  mjData* before = mj_copyData(nullptr, m, d);
  int n = 2 * m->nv + m->na;
  std::vector<double> a(static_cast<size_t>(n * n), std::nan("")), b(static_cast<size_t>(n * m->nu), std::nan(""));
  for (mjtByte centered : {0, 1}) {
    mjd_transitionFD(m, d, 1e-6, centered, a.data(), b.data(), nullptr, nullptr);
    // MuJoCo 2.2.2's mjd_transitionFD restores qpos, qvel, act and the warm start but not d->time,
    // which each of its nudged steps advances: put it back (a MuJoCo matter, not the extension's)
    d->time = before->time;
    EXPECT_TRUE(AllFinite(a)) << "centered = " << int{centered};
    EXPECT_TRUE(AllFinite(b)) << "centered = " << int{centered};
  }
  EXPECT_TRUE(SameBits(State(m, d), State(m, before)));
  // the chambers' own entries d act_next / d act are near 1 (a step of 0.25 ms changes little);
  // not necessarily below 1: a chamber being compressed gains pressure faster the higher it is
  for (int k = 0; k < 2; ++k) {
    int i = 2 * m->nv + cyl.chamber_actuator[k] - (m->nu - m->na);
    EXPECT_NEAR(a[static_cast<size_t>(i * n + i)], 1, 0.05) << "chamber " << k;
  }
  // the spool lag is exact: d spool_next / d spool = exp(-h / tau_v), tau_v = 4.2 ms
  EXPECT_NEAR(a[static_cast<size_t>(2 * m->nv * n + 2 * m->nv)], std::exp(-m->opt.timestep / 4.2e-3), 1e-6);
  // and the run goes on as if no derivatives had been taken
  RunPattern(m, d, cyl, 200, 100);
  RunPattern(m, before, cyl, 200, 100);
  EXPECT_TRUE(SameBits(State(m, d), State(m, before)));
  mj_deleteData(before);
}

class Registry : public MujocoTest {};

TEST_F(Registry, TwoModelsAttachedAtOnce) {
  CallbackGuard guard;
  // each rig alone, with only its model attached
  std::vector<double> alone_a, alone_b_half, alone_b;
  {
    AttachedModel a;
    ASSERT_TRUE(a.Load(ShippedModel("rig_onoff.xml"), true)) << a.error();
    RunPattern(a.m(), a.d(), a.cylinder(), 0, 800);
    alone_a = State(a.m(), a.d());
  }
  {
    AttachedModel b;
    ASSERT_TRUE(b.Load(ShippedModel("rig_proportional.xml"), true)) << b.error();
    RunPattern(b.m(), b.d(), b.cylinder(), 0, 800);
    alone_b_half = State(b.m(), b.d());
    RunPattern(b.m(), b.d(), b.cylinder(), 800, 800);
    alone_b = State(b.m(), b.d());
  }

  // both attached, stepped interleaved
  AttachedModel a, b;
  ASSERT_TRUE(a.Load(ShippedModel("rig_onoff.xml"), true)) << a.error();
  ASSERT_TRUE(b.Load(ShippedModel("rig_proportional.xml"), true)) << b.error();
  EXPECT_TRUE(IsAttached(a.m()));
  EXPECT_TRUE(IsAttached(b.m()));
  CylinderInfo cyl_a = a.cylinder(), cyl_b = b.cylinder();
  for (int i = 0; i < 800; ++i) {
    RunPattern(a.m(), a.d(), cyl_a, i, 1);
    RunPattern(b.m(), b.d(), cyl_b, i, 1);
  }
  EXPECT_TRUE(SameBits(State(a.m(), a.d()), alone_a));
  EXPECT_TRUE(SameBits(State(b.m(), b.d()), alone_b_half));

  // detach one: the other goes on exactly as alone
  Detach(a.m());
  EXPECT_FALSE(IsAttached(a.m()));
  EXPECT_TRUE(IsAttached(b.m()));
  EXPECT_TRUE(Cylinders(a.m()).empty());
  RunPattern(b.m(), b.d(), cyl_b, 800, 800);
  EXPECT_TRUE(SameBits(State(b.m(), b.d()), alone_b));
  Detach(b.m());
  EXPECT_FALSE(IsAttached(b.m()));
}

TEST_F(Registry, AttachTakesBackCallbacksReplacedMeanwhileAndChainsToThem) {
  // someone installs callbacks after the extension did: the next Attach puts the extension's back
  // in front, and they pass every actuator that is not pneumatic on to the ones found there
  CallbackGuard guard;
  AttachedModel a;
  ASSERT_TRUE(a.Load(ShippedModel("rig_onoff.xml"), true)) << a.error();
  mjcb_act_dyn = ForeignDyn, mjcb_act_bias = ForeignBias;
  AttachedModel b;
  ASSERT_TRUE(b.Load(ShippedModel("rig_per_chamber.xml"), true)) << b.error();
  EXPECT_NE(mjcb_act_dyn, ForeignDyn);
  EXPECT_NE(mjcb_act_bias, ForeignBias);
  // rig A's pressures still rise under the extension, and no pneumatic actuator reached ForeignDyn
  foreign_ids.clear();
  a.d()->ctrl[a.cylinder().CommandActuator("u1")] = 1;
  for (int i = 0; i < 10; ++i) mj_step(a.m(), a.d());
  EXPECT_GT(ChamberPressure(a.m(), a.d(), a.cylinder(), Chamber::kP), a.cylinder().p_atm + 1e3);
  EXPECT_TRUE(foreign_ids.empty());
  // a detached model is served by the callbacks found at Attach
  int chamber_p = a.cylinder().chamber_actuator[0];
  Detach(a.m());
  mj_forward(a.m(), a.d());
  EXPECT_EQ(a.d()->act_dot[chamber_p - (a.m()->nu - a.m()->na)], kForeignActDot);
}

TEST_F(Registry, NonPneumaticUserActuatorKeepsItsCallbacks) {
  // rig A plus a sled on its own slide joint driven by a user actuator of someone else's, placed
  // among the stateful actuators in front of the chambers
  std::string xml = ReadText(ShippedModel("rig_onoff.xml"));
  xml = ReplaceAll(xml, "  </worldbody>", R"(    <body name="sled" pos="0 0.1 0">
      <inertial pos="0 0 0" mass="1" diaginertia="1e-3 1e-3 1e-3"/>
      <joint name="y" type="slide" axis="0 1 0"/>
    </body>
  </worldbody>)");
  xml = ReplaceAll(xml, "<general name=\"cyl.P\"",
                   "<general name=\"other\" joint=\"y\" dyntype=\"user\" gaintype=\"user\" biastype=\"user\"/>\n"
                   "    <general name=\"cyl.P\"");
  std::string error;
  mjModel* m = LoadModelFromString(xml, &error);
  ASSERT_NE(m, nullptr) << error;
  CallbackGuard guard;  // installed after loading: the compiler may call mjcb_act_gain
  mjcb_act_dyn = ForeignDyn, mjcb_act_gain = ForeignGain, mjcb_act_bias = ForeignBias;
  foreign_ids.clear();
  ASSERT_TRUE(Attach(m, &error)) << error;
  mjData* d = mj_makeData(m);
  CylinderInfo cyl = Cylinders(m).at(0);
  int other = mj_name2id(m, mjOBJ_ACTUATOR, "other");
  int other_act = other - (m->nu - m->na);
  int p = cyl.chamber_actuator[0] - (m->nu - m->na);
  ASSERT_EQ(other_act, 0);
  ASSERT_EQ(p, 1);

  d->act[other_act] = 2;
  d->ctrl[cyl.CommandActuator("u1")] = 1;  // fill chamber P
  mj_forward(m, d);
  EXPECT_EQ(d->act_dot[other_act], kForeignActDot);
  EXPECT_EQ(d->actuator_force[other], kForeignGain * 2 + kForeignBias);
  EXPECT_GT(d->act_dot[p], 0) << "chamber P should fill";
  EXPECT_EQ(foreign_ids, std::set<int>{other}) << "the extension passed its own actuators on";

  for (int i = 0; i < 100; ++i) mj_step(m, d);
  mj_forward(m, d);  // actuator_force of the current act (mj_step left the one before integration)
  EXPECT_GT(ChamberPressure(m, d, cyl, Chamber::kP), cyl.p_atm + 1e4);
  EXPECT_DOUBLE_EQ(d->actuator_force[cyl.chamber_actuator[0]], 1.814e-4 * d->act[p]);
  EXPECT_NEAR(d->act[other_act], 2 + 100 * m->opt.timestep * kForeignActDot, 1e-9);
  EXPECT_EQ(foreign_ids, std::set<int>{other});

  mj_deleteData(d);
  mj_deleteModel(m);  // without Detach: nothing outside the model refers to it
  EXPECT_EQ(mjcb_act_gain, ForeignGain);  // chamber gains are fixed: the gain callback is not the extension's
}

TEST_F(EngineState, PwmStateIsTime) {
  // switched PWM at 50 Hz, duty 0.5: U1 and U4 open for the first 10 ms of each 20 ms period, so
  // d->time is state; with the same time the two mjData agree bit for bit
  AttachedModel rig;
  ASSERT_TRUE(rig.Load(testing::RigAOnPwm(50))) << rig.error();
  const mjModel* m = rig.m();
  CylinderInfo cyl = rig.cylinder();
  mjData* on = rig.d();
  on->ctrl[cyl.CommandActuator("duty")] = 0.5;
  on->act[0] = 3e4, on->act[1] = 6e4;
  on->time = 0.003;  // within the on-time of the period
  mjData* off = mj_copyData(nullptr, m, on);
  off->time = 0.013;  // within the off-time
  mj_forward(m, on);
  mj_forward(m, off);
  EXPECT_GT(on->act_dot[0], 0) << "P fills while U1 is on";
  EXPECT_NE(on->act_dot[0], off->act_dot[0]);
  EXPECT_NE(on->act_dot[1], off->act_dot[1]);
  off->time = on->time;
  mj_forward(m, off);
  EXPECT_TRUE(SameBits(Array(on->act_dot, m->na), Array(off->act_dot, m->na)));
  // and a run across several periods from either copy is the same
  RunPattern(m, on, cyl, 0, 300);
  RunPattern(m, off, cyl, 0, 300);
  EXPECT_TRUE(SameBits(State(m, on), State(m, off)));
  mj_deleteData(off);
}

// MuJoCo zeroes bad controls and warns: no MujocoTest fixture here; warnings are silenced while
// MuJoCo still counts them in d->warning
class CountWarnings {
 public:
  CountWarnings() : previous_(mju_user_warning) { mju_user_warning = [](const char*) {}; }
  ~CountWarnings() { mju_user_warning = previous_; }
  CountWarnings(const CountWarnings&) = delete;
  CountWarnings& operator=(const CountWarnings&) = delete;

 private:
  void (*previous_)(const char*);
};

TEST(BadCommands, NoNaNFromBadCommands) {
  CountWarnings quiet;
  const double kNaN = std::nan(""), kInf = HUGE_VAL;
  // rig A also without ctrllimited, so that MuJoCo sees an infinite command unclamped
  std::string unlimited = ReplaceAll(ReadText(ShippedModel("rig_onoff.xml")), " ctrllimited=\"true\" ctrlrange=\"0 1\"", "");
  struct Case {
    std::string name, xml, signal;
    double value;
    bool mujoco_warns;  // MuJoCo 2.2 clamps first: an infinite command within ctrlrange is clamped, not bad
  };
  for (const Case& c : {Case{"rig_onoff u1 = NaN", ReadText(ShippedModel("rig_onoff.xml")), "u1", kNaN, true},
                        Case{"rig_onoff u2 = +inf", ReadText(ShippedModel("rig_onoff.xml")), "u2", kInf, false},
                        Case{"unlimited rig_onoff u1 = +inf", unlimited, "u1", kInf, true},
                        Case{"unlimited rig_onoff u4 = -inf", unlimited, "u4", -kInf, true},
                        Case{"rig_proportional u = NaN", ReadText(ShippedModel("rig_proportional.xml")), "u", kNaN, true},
                        Case{"rig_proportional u = -inf", ReadText(ShippedModel("rig_proportional.xml")), "u", -kInf, false},
                        Case{"rig_per_chamber uP = NaN", ReadText(ShippedModel("rig_per_chamber.xml")), "uP", kNaN, true},
                        Case{"rig_per_chamber uN = +inf", ReadText(ShippedModel("rig_per_chamber.xml")), "uN", kInf, false},
                        Case{"pwm duty = NaN", testing::RigAOnPwm(50), "duty", kNaN, true}}) {
    SCOPED_TRACE(c.name);
    AttachedModel rig;
    ASSERT_TRUE(rig.Load(c.xml)) << rig.error();
    const mjModel* m = rig.m();
    mjData* d = rig.d();
    CylinderInfo cyl = rig.cylinder();
    for (int i = 0; i < 400; ++i) {
      PatternCommand(cyl, d, i);
      d->ctrl[cyl.CommandActuator(c.signal)] = c.value;
      mj_step(m, d);
    }
    EXPECT_TRUE(AllFinite(State(m, d)));
    EXPECT_TRUE(AllFinite(Array(d->act_dot, m->na)));
    EXPECT_TRUE(AllFinite(Array(d->actuator_force, m->nu)));
    for (Chamber k : {Chamber::kP, Chamber::kN}) {
      double p = ChamberPressure(m, d, cyl, k);
      EXPECT_GE(p, 0.5 * cyl.p_exhaust);
      EXPECT_LE(p, 2 * cyl.p_supply);
    }
    if (c.mujoco_warns) {
      EXPECT_GT(d->warning[mjWARN_BADCTRL].number, 0);
    } else {
      EXPECT_EQ(d->warning[mjWARN_BADCTRL].number, 0);
    }
  }
}

TEST(BadCommands, ValvesReadBadCommandsAsMuJoCoDoes) {
  // MuJoCo 2.2's mj_fwdActuation clamps ctrl to ctrlrange first (so +-inf becomes a range end, no
  // warning), then, if any control is still bad (NaN, or |u| > mjMAXVAL), warns and uses 0 for
  // every control of the step. The valves should see the same commands as MuJoCo's own actuators:
  // act_dot equals the one computed with the sanitized commands written in by hand.
  CountWarnings quiet;
  std::string unlimited = ReplaceAll(ReadText(ShippedModel("rig_onoff.xml")), " ctrllimited=\"true\" ctrlrange=\"0 1\"", "");
  struct Case {
    std::string name, xml;
    std::vector<std::pair<std::string, double>> given, sanitized;
  };
  const double kNaN = std::nan(""), kInf = HUGE_VAL;
  for (const Case& c : {
           Case{"rig_onoff u1 = +inf is u1 = 1", ReadText(ShippedModel("rig_onoff.xml")),
                {{"u1", kInf}, {"u2", 0}, {"u3", 0}, {"u4", 1}}, {{"u1", 1}, {"u2", 0}, {"u3", 0}, {"u4", 1}}},
           Case{"rig_per_chamber uP = +inf is uP = 10 V", ReadText(ShippedModel("rig_per_chamber.xml")),
                {{"uP", kInf}, {"uN", 5}}, {{"uP", 10}, {"uN", 5}}},
           Case{"rig_onoff u1 = NaN zeroes u2..u4 too", ReadText(ShippedModel("rig_onoff.xml")),
                {{"u1", kNaN}, {"u2", 1}, {"u3", 1}, {"u4", 0}}, {{"u1", 0}, {"u2", 0}, {"u3", 0}, {"u4", 0}}},
           Case{"rig_per_chamber uP = NaN zeroes uN too", ReadText(ShippedModel("rig_per_chamber.xml")),
                {{"uP", kNaN}, {"uN", 7}}, {{"uP", 0}, {"uN", 0}}},
           Case{"unlimited rig_onoff u1 = 1e11 (> mjMAXVAL) zeroes all", unlimited,
                {{"u1", 1e11}, {"u2", 0}, {"u3", 0}, {"u4", 1}}, {{"u1", 0}, {"u2", 0}, {"u3", 0}, {"u4", 0}}}}) {
    SCOPED_TRACE(c.name);
    AttachedModel rig;
    ASSERT_TRUE(rig.Load(c.xml)) << rig.error();
    const mjModel* m = rig.m();
    CylinderInfo cyl = rig.cylinder();
    mjData* given = rig.d();
    SetChamberPressure(m, given, cyl, Chamber::kP, 2e5);
    SetChamberPressure(m, given, cyl, Chamber::kN, 2e5);
    mjData* sanitized = mj_copyData(nullptr, m, given);
    for (const auto& [signal, u] : c.given) given->ctrl[cyl.CommandActuator(signal)] = u;
    for (const auto& [signal, u] : c.sanitized) sanitized->ctrl[cyl.CommandActuator(signal)] = u;
    mj_forward(m, given);
    mj_forward(m, sanitized);
    EXPECT_TRUE(SameBits(Array(given->act_dot, m->na), Array(sanitized->act_dot, m->na)));
    mj_deleteData(sanitized);
  }
}

class Threads : public MujocoTest {};

// 2000 steps of each mjData under its constant command k (= index), serially
std::vector<std::vector<double>> RunSerially(const mjModel* m, const CylinderInfo& cyl, int count, int steps) {
  std::vector<std::vector<double>> out;
  for (int k = 0; k < count; ++k) {
    mjData* d = mj_makeData(m);
    ConstantCommand(cyl, d, k);
    for (int i = 0; i < steps; ++i) mj_step(m, d);
    out.push_back(State(m, d));
    mj_deleteData(d);
  }
  return out;
}

TEST_F(Threads, ParallelSteppingMatchesSerial) {
  constexpr int kData = 8, kThreads = 4, kSteps = 2000;
  for (const char* file : {"rig_per_chamber.xml", "rig_onoff.xml"}) {
    SCOPED_TRACE(file);
    AttachedModel rig;
    ASSERT_TRUE(rig.Load(ShippedModel(file), true)) << rig.error();
    const mjModel* m = rig.m();
    CylinderInfo cyl = rig.cylinder();
    std::vector<std::vector<double>> serial = RunSerially(m, cyl, kData, kSteps);

    std::vector<mjData*> data;
    for (int k = 0; k < kData; ++k) {
      data.push_back(mj_makeData(m));
      ConstantCommand(cyl, data.back(), k);
    }
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t) {
      threads.emplace_back([&, t] {
        // each thread owns data t, t + 4; they take turns step by step to overlap as much as possible
        for (int i = 0; i < kSteps; ++i) {
          for (int k = t; k < kData; k += kThreads) mj_step(m, data[static_cast<size_t>(k)]);
        }
      });
    }
    for (std::thread& thread : threads) thread.join();
    for (int k = 0; k < kData; ++k) {
      EXPECT_TRUE(SameBits(State(m, data[static_cast<size_t>(k)]), serial[static_cast<size_t>(k)])) << "mjData " << k;
      mj_deleteData(data[static_cast<size_t>(k)]);
    }
    // the constant commands did make the runs differ
    EXPECT_FALSE(SameBits(serial[1], serial[6]));
  }
}

TEST_F(Threads, TwoModelsSteppedConcurrently) {
  constexpr int kSteps = 2000;
  AttachedModel a, b;
  ASSERT_TRUE(a.Load(ShippedModel("rig_onoff.xml"), true)) << a.error();
  ASSERT_TRUE(b.Load(ShippedModel("rig_proportional.xml"), true)) << b.error();
  CylinderInfo cyl_a = a.cylinder(), cyl_b = b.cylinder();
  mjData* da = mj_makeData(a.m());
  mjData* db = mj_makeData(b.m());
  RunPattern(a.m(), da, cyl_a, 0, kSteps);
  RunPattern(b.m(), db, cyl_b, 0, kSteps);
  std::vector<double> serial_a = State(a.m(), da), serial_b = State(b.m(), db);
  mj_deleteData(da);
  mj_deleteData(db);

  std::thread ta([&] { RunPattern(a.m(), a.d(), cyl_a, 0, kSteps); });
  std::thread tb([&] { RunPattern(b.m(), b.d(), cyl_b, 0, kSteps); });
  ta.join();
  tb.join();
  EXPECT_TRUE(SameBits(State(a.m(), a.d()), serial_a));
  EXPECT_TRUE(SameBits(State(b.m(), b.d()), serial_b));
}

}  // namespace
}  // namespace pneumatic
