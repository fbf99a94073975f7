// The model-stored design of the extension: Attach writes each cylinder's
// configuration into the model (actuator_user), so copies made with
// mj_copyModel step like their original without Attach, models may be freed
// without Detach, and parameters are read and written by MJCF key
// (GetParameter / SetParameter) with the MJCF's checks. Also the laminar
// leaks (piston_leak_conductance, atmosphere_leak_conductance) against the
// closed-form solution of their linear ODEs.
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util.h"

namespace pneumatic {
namespace {

using ::testing::HasSubstr;
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
using testing::ShippedModel;


// a shipped rig's MJCF with `extra` appended to its "pneumatic:cyl" configuration text
std::string WithConfig(const std::string& file, const std::string& extra) {
  std::string xml = ReadText(ShippedModel(file));
  size_t text = xml.find("name=\"pneumatic:cyl\" data=\"");
  EXPECT_NE(text, std::string::npos);
  size_t end = xml.find('"', xml.find("data=\"", text) + 6);
  xml.insert(end, " " + extra);
  return xml;
}

// loads MJCF text and attaches; null (with a failure) if either fails
mjModel* LoadAttached(const std::string& xml) {
  std::string error;
  mjModel* m = LoadModelFromString(xml, &error);
  EXPECT_NE(m, nullptr) << error;
  if (!m) return nullptr;
  if (!Attach(m, &error)) {
    ADD_FAILURE() << "Attach: " << error;
    mj_deleteModel(m);
    return nullptr;
  }
  return m;
}



// the state after `steps` steps of the pattern from reset
std::vector<double> PatternRun(const mjModel* m, int steps) {
  mjData* d = mj_makeData(m);
  RunPattern(m, d, Cylinders(m).at(0), 0, steps);
  std::vector<double> s = State(m, d);
  mj_deleteData(d);
  return s;
}

bool SameInfo(const CylinderInfo& a, const CylinderInfo& b) {
  return a.name == b.name && a.chamber_actuator[0] == b.chamber_actuator[0] &&
         a.chamber_actuator[1] == b.chamber_actuator[1] && a.command_actuators == b.command_actuators &&
         a.p_atm == b.p_atm && a.p_supply == b.p_supply && a.p_exhaust == b.p_exhaust && a.x_mid == b.x_mid;
}

// ---------------------------------------------------------------------------------------------
// 1. copies

class ModelCopy : public MujocoTest {};

TEST_F(ModelCopy, CopyStepsLikeItsOriginalAndOutlivesIt) {
  constexpr int kSteps = 2000;
  for (const char* file : kShippedRigs) {
    SCOPED_TRACE(file);
    std::string error;
    char buffer[1000] = "";
    mjModel* original = mj_loadXML(ShippedModel(file).c_str(), nullptr, buffer, sizeof(buffer));
    ASSERT_NE(original, nullptr) << buffer;
    ASSERT_TRUE(Attach(original, &error)) << error;
    mjModel* copy = mj_copyModel(nullptr, original);  // no Attach on the copy
    ASSERT_NE(copy, nullptr);
    EXPECT_TRUE(IsAttached(copy));
    ASSERT_EQ(Cylinders(copy).size(), 1u);
    EXPECT_EQ(Cylinders(copy)[0].name, "cyl");
    EXPECT_TRUE(SameInfo(Cylinders(copy)[0], Cylinders(original)[0]));
    CylinderInfo cyl = Cylinders(original)[0];

    // the original's run over 2 * kSteps, as the reference; the copy's first half interleaved with it
    mjData* d_original = mj_makeData(original);
    mjData* d_copy = mj_makeData(copy);
    for (int i = 0; i < kSteps; ++i) {
      RunPattern(original, d_original, cyl, i, 1);
      RunPattern(copy, d_copy, cyl, i, 1);
    }
    EXPECT_TRUE(SameBits(State(original, d_original), State(copy, d_copy)));
    // the pattern did drive the chambers (a copy that ignored the extension would not match anyway)
    EXPECT_GT(std::fabs(ChamberPressure(copy, d_copy, cyl, Chamber::kP) - cyl.p_atm), 1e3);
    RunPattern(original, d_original, cyl, kSteps, kSteps);
    std::vector<double> reference = State(original, d_original);
    mj_deleteData(d_original);

    // the original freed without Detach: the copy goes on alone, on this thread, then on a fresh
    // thread (no decoded model cached there: it reads everything from the copy)
    mj_deleteModel(original);
    EXPECT_TRUE(IsAttached(copy));
    ASSERT_EQ(Cylinders(copy).size(), 1u);
    EXPECT_EQ(Cylinders(copy)[0].name, "cyl");
    RunPattern(copy, d_copy, cyl, kSteps, kSteps / 2);
    std::thread other([&] { RunPattern(copy, d_copy, cyl, kSteps + kSteps / 2, kSteps / 2); });
    other.join();
    EXPECT_TRUE(SameBits(reference, State(copy, d_copy)));
    mj_deleteData(d_copy);
    mj_deleteModel(copy);  // also without Detach
  }
}

// ---------------------------------------------------------------------------------------------
// 2. freeing without Detach leaves nothing behind

class FreeWithoutDetach : public MujocoTest {};

TEST_F(FreeWithoutDetach, NextModelStepsAsInAFreshRun) {
  constexpr int kSteps = 2000;
  // each rig's run, loaded, attached and run first, on a fresh thread (nothing decoded there before)
  std::vector<std::vector<double>> fresh;
  for (const char* file : kShippedRigs) {
    std::vector<double> run;
    std::thread t([&] {
      mjModel* m = LoadAttached(ReadText(ShippedModel(file)));
      if (!m) return;
      run = PatternRun(m, kSteps);
      mj_deleteModel(m);
    });
    t.join();
    fresh.push_back(run);
  }
  constexpr int kRigs = sizeof(kShippedRigs) / sizeof(kShippedRigs[0]);
  for (int first = 0; first < kRigs; ++first) {
    for (int second = 0; second < kRigs; ++second) {
      if (first == second) continue;
      SCOPED_TRACE(std::string(kShippedRigs[first]) + " freed, then " + kShippedRigs[second]);
      mjModel* gone = LoadAttached(ReadText(ShippedModel(kShippedRigs[first])));
      ASSERT_NE(gone, nullptr);
      mjData* d = mj_makeData(gone);
      RunPattern(gone, d, Cylinders(gone).at(0), 0, 300);
      mj_deleteData(d);
      mj_deleteModel(gone);  // no Detach
      mjModel* next = LoadAttached(ReadText(ShippedModel(kShippedRigs[second])));
      ASSERT_NE(next, nullptr);
      EXPECT_TRUE(SameBits(PatternRun(next, kSteps), fresh[static_cast<size_t>(second)]));
      mj_deleteModel(next);
    }
  }
}

// Two models whose cylinders have the same configuration text and actuator ids but different
// mechanics (the static friction is the joint's frictionloss; the joint's dof index differs):
// each must step as it does alone, whichever was attached last. A decoding shared between them
// (a fingerprint blind to the transmission) would give one the other's friction level or dof.
TEST_F(FreeWithoutDetach, EqualCylindersOnDifferentMechanicsStepAsAlone) {
  constexpr int kSteps = 2000;
  std::string friction = ReadText(ShippedModel("rig_onoff.xml"));
  friction = ReplaceAll(friction, "damping=\"50\"", "damping=\"50\" frictionloss=\"$FL\"");
  friction = ReplaceAll(friction, "critical_ratio=0.433\"", "critical_ratio=0.433 coulomb_friction=10\"");
  friction = ReplaceAll(friction, "<general name=\"cyl.u1\"",
                        "<general name=\"cyl.friction\" joint=\"x\" gaintype=\"user\" biastype=\"user\"/>\n"
                        "    <general name=\"cyl.u1\"");
  struct Pair {
    std::string name, a, b;
  };
  std::string plain = ReadText(ShippedModel("rig_onoff.xml"));
  // a second slide joint in front of the piston's: the piston's dof is 1, not 0; same actuator ids
  std::string shifted = ReplaceAll(plain, "    <body name=\"piston\">",
                                   "    <body name=\"sled\" pos=\"0 1 0\"><inertial pos=\"0 0 0\" mass=\"2\" "
                                   "diaginertia=\"1e-4 1e-4 1e-4\"/><joint name=\"y\" type=\"slide\" axis=\"0 1 0\" "
                                   "damping=\"1\"/></body>\n    <body name=\"piston\">");
  for (const Pair& pair : {Pair{"frictionloss 20 vs 40", ReplaceAll(friction, "$FL", "20"), ReplaceAll(friction, "$FL", "40")},
                           Pair{"piston dof 0 vs 1", plain, shifted}}) {
    SCOPED_TRACE(pair.name);
    std::vector<double> alone_a, alone_b;
    // alone: each on its own fresh thread (nothing decoded there before)
    std::thread ta([&] {
      mjModel* a = LoadAttached(pair.a);
      if (a) alone_a = PatternRun(a, kSteps), mj_deleteModel(a);
    });
    ta.join();
    std::thread tb([&] {
      mjModel* b = LoadAttached(pair.b);
      if (b) alone_b = PatternRun(b, kSteps), mj_deleteModel(b);
    });
    tb.join();
    ASSERT_FALSE(alone_a.empty());
    ASSERT_FALSE(alone_b.empty());
    ASSERT_FALSE(SameBits(alone_a, alone_b)) << "the mechanics should make the runs differ";
    // both attached on this thread, b last; then a attached last
    mjModel* a = LoadAttached(pair.a);
    mjModel* b = LoadAttached(pair.b);
    ASSERT_TRUE(a && b);
    EXPECT_TRUE(SameBits(PatternRun(a, kSteps), alone_a)) << "a, stepped after b was attached";
    EXPECT_TRUE(SameBits(PatternRun(b, kSteps), alone_b)) << "b, stepped after a was stepped";
    mj_deleteModel(a);
    mj_deleteModel(b);
  }
}

// ---------------------------------------------------------------------------------------------
// 3. GetParameter / SetParameter

class Parameters : public MujocoTest {
 protected:
  void SetUp() override {
    MujocoTest::SetUp();
    m_ = LoadAttached(ReadText(ShippedModel("rig_onoff.xml")));
    ASSERT_NE(m_, nullptr);
    cyl_ = Cylinders(m_).at(0);
  }
  void TearDown() override {
    if (m_) mj_deleteModel(m_);
    MujocoTest::TearDown();
  }
  double Get(const mjModel* m, const std::string& key) {
    std::string error;
    std::optional<double> v = GetParameter(m, "cyl", key, &error);
    EXPECT_TRUE(v.has_value()) << key << ": " << error;
    return v.value_or(std::nan(""));
  }

  mjModel* m_ = nullptr;
  CylinderInfo cyl_;
};

TEST_F(Parameters, GetReturnsTheMjcfValues) {
  // rig A's text: area=1.814e-4 dead_volume=2.0e-6 ... polytropic_index=1.2; step defaults to linearized (index 0)
  EXPECT_EQ(Get(m_, "P.area"), 1.814e-4);
  EXPECT_EQ(Get(m_, "N.area"), 1.814e-4);
  EXPECT_EQ(Get(m_, "N.dead_volume"), 2.0e-6);
  EXPECT_EQ(Get(m_, "P.polytropic_index"), 1.2);
  EXPECT_EQ(Get(m_, "stroke"), 0.1);
  EXPECT_EQ(Get(m_, "p_supply"), 3.0e5);
  EXPECT_EQ(Get(m_, "piston_leak_conductance"), 0.0);
  EXPECT_EQ(Get(m_, "step"), 0.0);
}

TEST_F(Parameters, SetAreaChangesTheForceOnTheNextForward) {
  mjModel* before = mj_copyModel(nullptr, m_);  // a copy made before the change
  mjData* d = mj_makeData(m_);
  // gauge pressures 1.5e5 (P) and 0.4e5 (N)
  SetChamberPressure(m_, d, cyl_, Chamber::kP, cyl_.p_atm + 1.5e5);
  SetChamberPressure(m_, d, cyl_, Chamber::kN, cyl_.p_atm + 0.4e5);
  mj_forward(m_, d);
  EXPECT_EQ(d->actuator_force[cyl_.chamber_actuator[0]], 1.814e-4 * 1.5e5);

  std::string error;
  ASSERT_TRUE(SetParameter(m_, "cyl", "P.area", 2.5e-4, &error)) << error;
  EXPECT_EQ(Get(m_, "P.area"), 2.5e-4);
  EXPECT_EQ(Get(m_, "N.area"), 1.814e-4);
  mj_forward(m_, d);
  // F_P = A_P (p_P - p_atm) with the new area; chamber N's force is -A_N times its gauge pressure
  EXPECT_EQ(d->actuator_force[cyl_.chamber_actuator[0]], 2.5e-4 * 1.5e5);
  EXPECT_EQ(d->actuator_force[cyl_.chamber_actuator[1]], -1.814e-4 * 0.4e5);
  // the generalized force on the slide joint (gear 1): 2.5e-4 * 1.5e5 - 1.814e-4 * 0.4e5 = 30.244 N
  EXPECT_NEAR(d->qfrc_actuator[0], 2.5e-4 * 1.5e5 - 1.814e-4 * 0.4e5, 1e-12);

  // the copy made before keeps the old area, and its force
  EXPECT_EQ(Get(before, "P.area"), 1.814e-4);
  mjData* d_before = mj_makeData(before);
  mju_copy(d_before->act, d->act, m_->na);
  mj_forward(before, d_before);
  EXPECT_EQ(d_before->actuator_force[cyl_.chamber_actuator[0]], 1.814e-4 * 1.5e5);
  mj_deleteData(d_before);
  mj_deleteData(d);

  // and the copy's dynamics are the original's: it steps as a freshly loaded rig A
  mjModel* fresh = LoadAttached(ReadText(ShippedModel("rig_onoff.xml")));
  ASSERT_NE(fresh, nullptr);
  std::vector<double> fresh_run = PatternRun(fresh, 1000);
  EXPECT_TRUE(SameBits(PatternRun(before, 1000), fresh_run));
  // while the changed model does not
  EXPECT_FALSE(SameBits(PatternRun(m_, 1000), fresh_run));
  // and the changed model steps as rig A loaded with P.area=2.5e-4 in its text
  mjModel* written = LoadAttached(ReplaceAll(ReadText(ShippedModel("rig_onoff.xml")), "area=1.814e-4",
                                             "P.area=2.5e-4 N.area=1.814e-4"));
  ASSERT_NE(written, nullptr);
  EXPECT_TRUE(SameBits(PatternRun(m_, 1000), PatternRun(written, 1000)));
  mj_deleteModel(written);
  mj_deleteModel(fresh);
  mj_deleteModel(before);
}

TEST_F(Parameters, PlainChamberKeySetsBothChambers) {
  std::string error;
  ASSERT_TRUE(SetParameter(m_, "cyl", "dead_volume", 3.5e-6, &error)) << error;
  EXPECT_EQ(Get(m_, "P.dead_volume"), 3.5e-6);
  EXPECT_EQ(Get(m_, "N.dead_volume"), 3.5e-6);
  ASSERT_TRUE(SetParameter(m_, "cyl", "N.dead_volume", 4e-6, &error)) << error;
  EXPECT_EQ(Get(m_, "P.dead_volume"), 3.5e-6);
  EXPECT_EQ(Get(m_, "N.dead_volume"), 4e-6);
  // a sealed chamber at the new dead volume: act_dot of a closed chamber with the piston at rest is 0,
  // so check instead the model against rig A written with dead_volume=3.5e-6 P, 4e-6 N
  mjModel* written = LoadAttached(ReplaceAll(ReadText(ShippedModel("rig_onoff.xml")), "dead_volume=2.0e-6",
                                             "P.dead_volume=3.5e-6 N.dead_volume=4e-6"));
  ASSERT_NE(written, nullptr);
  EXPECT_TRUE(SameBits(PatternRun(m_, 1000), PatternRun(written, 1000)));
  mj_deleteModel(written);
}

TEST_F(Parameters, SetChoiceByText) {
  std::string error;
  ASSERT_TRUE(SetParameter(m_, "cyl", "step", std::string("exact"), &error)) << error;
  EXPECT_EQ(Get(m_, "step"), 1.0);  // "linearized exact explicit"
  mjModel* written = LoadAttached(WithConfig("rig_onoff.xml", "step=exact"));
  ASSERT_NE(written, nullptr);
  mjModel* linearized = LoadAttached(ReadText(ShippedModel("rig_onoff.xml")));
  ASSERT_NE(linearized, nullptr);
  std::vector<double> run = PatternRun(m_, 1000);
  EXPECT_TRUE(SameBits(run, PatternRun(written, 1000)));
  EXPECT_FALSE(SameBits(run, PatternRun(linearized, 1000))) << "step=exact should not be the linearized step bit for bit";
  // a bad choice is refused, naming the choices
  EXPECT_FALSE(SetParameter(m_, "cyl", "step", std::string("rk4"), &error));
  EXPECT_THAT(error, HasSubstr("cylinder 'cyl'"));
  EXPECT_THAT(error, HasSubstr("key 'step'"));
  EXPECT_THAT(error, HasSubstr("linearized exact explicit"));
  EXPECT_EQ(Get(m_, "step"), 1.0);
  mj_deleteModel(linearized);
  mj_deleteModel(written);
}

TEST_F(Parameters, FailedSetNamesTheProblemAndChangesNothing) {
  mjModel* untouched = mj_copyModel(nullptr, m_);
  struct Case {
    std::string name, cylinder, key;
    double value;
    std::vector<std::string> says;
  };
  const double kNaN = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Case> cases = {
      {"unknown key", "cyl", "bogus", 1, {"cylinder 'cyl'", "key 'bogus'", "unknown key"}},
      {"unknown prefixed key", "cyl", "P.bogus", 1, {"cylinder 'cyl'", "key 'P.bogus'", "unknown key"}},
      {"unknown cylinder", "nope", "P.area", 1e-4, {"'nope'"}},
      {"out of range", "cyl", "P.area", -1e-4, {"cylinder 'cyl'", "key 'P.area'", "out of range [1e-07, 0.1]"}},
      {"out of range, plain chamber key", "cyl", "polytropic_index", 2.5,
       {"cylinder 'cyl'", "polytropic_index'", "out of range [1, 1.7]"}},
      {"out of range, cylinder key", "cyl", "gas_constant", 1e308, {"cylinder 'cyl'", "key 'gas_constant'", "out of range"}},
      {"NaN", "cyl", "stroke", kNaN, {"cylinder 'cyl'", "key 'stroke'", "not finite"}},
      {"infinity", "cyl", "P.dead_volume", HUGE_VAL, {"cylinder 'cyl'", "key 'P.dead_volume'", "not finite"}},
      {"does not apply", "cyl", "spool_gain", 2.5e-4,
       {"cylinder 'cyl'", "key 'spool_gain'", "applies only to valve=proportional_5_3"}},
      {"relation", "cyl", "p_supply", 0.9e5, {"cylinder 'cyl'", "key 'p_supply'", "must exceed p_exhaust"}},
      {"prefix on a cylinder key", "cyl", "P.stroke", 0.1, {"cylinder 'cyl'", "P.stroke", "cylinder parameter"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    std::string error;
    EXPECT_FALSE(SetParameter(m_, c.cylinder, c.key, c.value, &error));
    for (const std::string& s : c.says) EXPECT_THAT(error, HasSubstr(s));
  }
  // nothing changed: the parameters read back as in the MJCF, and the model steps as the untouched copy
  EXPECT_EQ(Get(m_, "P.area"), 1.814e-4);
  EXPECT_EQ(Get(m_, "stroke"), 0.1);
  EXPECT_EQ(Get(m_, "p_supply"), 3e5);
  EXPECT_EQ(Get(m_, "gas_constant"), 287.0);
  EXPECT_TRUE(SameBits(PatternRun(m_, 2000), PatternRun(untouched, 2000)));
  mj_deleteModel(untouched);
}

TEST_F(Parameters, GetRefusesWhatItCannotAnswer) {
  struct Case {
    std::string name, cylinder, key;
    std::vector<std::string> says;
  };
  for (const Case& c : {Case{"chamber key without prefix", "cyl", "dead_volume",
                             {"cylinder 'cyl'", "key 'dead_volume'", "P.dead_volume"}},
                        Case{"unknown key", "cyl", "bogus", {"cylinder 'cyl'", "key 'bogus'", "unknown key"}},
                        Case{"unknown cylinder", "nope", "P.area", {"'nope'"}},
                        Case{"does not apply", "cyl", "spool_gain", {"key 'spool_gain'", "applies only to"}},
                        Case{"cylinder key with a chamber's prefix", "cyl", "P.stroke",
                             {"key 'P.stroke'", "a cylinder key: give stroke"}}}) {
    SCOPED_TRACE(c.name);
    std::string error;
    EXPECT_FALSE(GetParameter(m_, c.cylinder, c.key, &error).has_value());
    for (const std::string& s : c.says) EXPECT_THAT(error, HasSubstr(s));
  }
  // a detached model has no parameters
  mjModel* detached = mj_copyModel(nullptr, m_);
  Detach(detached);
  std::string error;
  EXPECT_FALSE(GetParameter(detached, "cyl", "P.area", &error).has_value());
  EXPECT_THAT(error, HasSubstr("not attached"));
  EXPECT_FALSE(SetParameter(detached, "cyl", "P.area", 2e-4, &error));
  EXPECT_THAT(error, HasSubstr("not attached"));
  mj_deleteModel(detached);
}

// GetParameter reads the configuration directly; the configuration text formats every key that applies:
// both must give the same value, bit for bit, for every key of every shipped model's cylinders, and a
// key the text leaves out (it does not apply) must be refused
TEST_F(Parameters, GetAgreesWithTheConfigurationTextOnEveryKey) {
  std::vector<std::string> files(std::begin(kShippedRigs), std::end(kShippedRigs));
  files.push_back("humanoid_pneumatic.xml");  // mount=hinge_sites, vanes
  files.push_back("humanoid_pneumatic_identified.xml");
  for (const std::string& file : files) {
    SCOPED_TRACE(file);
    mjModel* m = LoadAttached(ReadText(ShippedModel(file)));
    ASSERT_NE(m, nullptr);
    for (const CylinderInfo& c : Cylinders(m)) {
      std::string error;
      std::optional<std::string> text = ConfigurationText(m, c.name, &error);
      ASSERT_TRUE(text) << error;
      std::map<std::string, std::string> pairs;
      std::istringstream words(*text);
      for (std::string word; words >> word;) pairs[word.substr(0, word.find('='))] = word.substr(word.find('=') + 1);
      int answered = 0;
      for (const ParameterDoc& doc : pneumatic::Parameters()) {  // (Parameters alone is this fixture)
        const bool chamber = doc.scope.rfind("chamber", 0) == 0;
        for (const std::string& key : chamber ? std::vector<std::string>{"P." + doc.key, "N." + doc.key}
                                              : std::vector<std::string>{doc.key}) {
          SCOPED_TRACE(c.name + " " + key);
          auto it = pairs.find(key);
          std::optional<double> value = GetParameter(m, c.name, key, &error);
          if (it == pairs.end()) {
            EXPECT_FALSE(value) << "not in the text: " << *text;
            continue;
          }
          if (doc.is_choice) {
            EXPECT_EQ(GetChoice(m, c.name, key, &error).value_or("?"), it->second);
          } else if (value) {  // (a name, such as supply=, is not a number)
            EXPECT_TRUE(SameBits({*value}, {std::strtod(it->second.c_str(), nullptr)})) << it->second;
          } else {
            EXPECT_THAT(error, HasSubstr("holds a name"));
          }
          ++answered;
        }
      }
      EXPECT_EQ(answered, static_cast<int>(pairs.size())) << "every key of the text is a documented parameter";
    }
    mj_deleteModel(m);
  }
}

// ---------------------------------------------------------------------------------------------
// 4. Attach, Detach, Attach

class Reattach : public MujocoTest {};

TEST_F(Reattach, ReattachedModelStepsAsAFreshlyAttachedOne) {
  for (const char* file : kShippedRigs) {
    SCOPED_TRACE(file);
    std::string xml = ReadText(ShippedModel(file));
    mjModel* m = LoadAttached(xml);
    ASSERT_NE(m, nullptr);
    std::vector<double> first = PatternRun(m, 1000);
    Detach(m);
    EXPECT_FALSE(IsAttached(m));
    EXPECT_TRUE(Cylinders(m).empty());
    std::string error;
    ASSERT_TRUE(Attach(m, &error)) << error;
    EXPECT_TRUE(IsAttached(m));
    mjModel* fresh = LoadAttached(xml);
    ASSERT_NE(fresh, nullptr);
    std::vector<double> again = PatternRun(m, 2000);
    EXPECT_TRUE(SameBits(again, PatternRun(fresh, 2000)));
    EXPECT_TRUE(SameBits(std::vector<double>(first), PatternRun(m, 1000)));
    mj_deleteModel(fresh);
    mj_deleteModel(m);
  }
}

TEST_F(Reattach, ReattachDiscardsSetParameterValues) {
  // pneumatic.h: "Attaching again re-reads the MJCF text, discarding values set with SetParameter"
  std::string xml = ReadText(ShippedModel("rig_onoff.xml"));
  mjModel* fresh = LoadAttached(xml);
  ASSERT_NE(fresh, nullptr);
  for (bool detach_first : {false, true}) {
    SCOPED_TRACE(detach_first ? "Set, Detach, Attach" : "Set, Attach");
    mjModel* m = LoadAttached(xml);
    ASSERT_NE(m, nullptr);
    std::string error;
    ASSERT_TRUE(SetParameter(m, "cyl", "P.area", 2.5e-4, &error)) << error;
    ASSERT_TRUE(SetParameter(m, "cyl", "dead_volume", 3e-6, &error)) << error;
    if (detach_first) Detach(m);
    EXPECT_TRUE(Attach(m, &error)) << error;
    std::optional<double> area = GetParameter(m, "cyl", "P.area", &error);
    EXPECT_EQ(area.value_or(0), 1.814e-4) << error;
    EXPECT_EQ(m->actuator_gainprm[mjNGAIN * Cylinders(fresh)[0].chamber_actuator[0]], 1.814e-4);
    if (IsAttached(m)) EXPECT_TRUE(SameBits(PatternRun(m, 1000), PatternRun(fresh, 1000)));
    mj_deleteModel(m);
  }
  mj_deleteModel(fresh);
}

// ---------------------------------------------------------------------------------------------
// 5. laminar leaks against the closed form

// rig A (A = 1.814e-4 m^2, l = 0.1 m, V0 = 2e-6 m^3, n = 1.2, r = 287, T = 296), valves closed
constexpr double kArea = 1.814e-4, kStroke = 0.1, kDeadVolume = 2e-6, kN = 1.2, kR = 287, kT = 296;
// the piston is held at x = 0.02 by a 1e12 kg mass: under the largest chamber force here,
// A (3e5 - 1e5) = 36.3 N, it moves by F t^2 / (2 M) = 36.3 * 0.2^2 / 2e12 < 1e-12 m in 0.2 s
constexpr double kX = 0.02;
double VolumeP(double x) { return kArea * (kStroke / 2 + x) + kDeadVolume; }
double VolumeN(double x) { return kArea * (kStroke / 2 - x) + kDeadVolume; }

std::string HeldRigA(const std::string& timestep, const std::string& extra) {
  std::string xml = WithConfig("rig_onoff.xml", extra);
  // the shipped timestep replaced by the case's
  size_t value = xml.find("timestep=\"") + std::strlen("timestep=\"");
  xml.replace(value, xml.find('"', value) - value, timestep);
  return ReplaceAll(xml, "mass=\"0.9\"", "mass=\"1e12\"");
}

struct LeakCase {
  const char* step;
  const char* timestep;
};
void PrintTo(const LeakCase& c, std::ostream* os) { *os << "step=" << c.step << " timestep=" << c.timestep; }
std::string Name(const ::testing::TestParamInfo<LeakCase>& info) {
  return std::string(info.param.step) + "_" + (std::string(info.param.timestep) == "0.00025" ? "250us" : "1ms");
}

class Leakage : public MujocoTest, public ::testing::WithParamInterface<LeakCase> {
 protected:
  // loads the held rig A with the leak, starts it at x = kX with the given pressures
  void Start(const std::string& leak, double p_p, double p_n) {
    m_ = LoadAttached(HeldRigA(GetParam().timestep, leak + " step=" + GetParam().step));
    ASSERT_NE(m_, nullptr);
    d_ = mj_makeData(m_);
    cyl_ = Cylinders(m_).at(0);
    ASSERT_EQ(cyl_.p_atm, 1e5);
    d_->qpos[0] = kX;
    SetChamberPressure(m_, d_, cyl_, Chamber::kP, p_p);
    SetChamberPressure(m_, d_, cyl_, Chamber::kN, p_n);
    mj_forward(m_, d_);
    ASSERT_NEAR(PistonPosition(m_, d_, cyl_), kX, 1e-15);
  }
  void TearDown() override {
    if (d_) mj_deleteData(d_);
    if (m_) mj_deleteModel(m_);
    MujocoTest::TearDown();
  }
  double P(Chamber k) const { return ChamberPressure(m_, d_, cyl_, k); }
  // steps until t (valves closed: ctrl stays 0) and refreshes the derived quantities
  void RunUntil(double t) {
    while (d_->time < t - 0.5 * m_->opt.timestep) mj_step(m_, d_);
    mj_forward(m_, d_);
    EXPECT_NEAR(PistonPosition(m_, d_, cyl_), kX, 1e-9) << "the piston was not held";
  }

  mjModel* m_ = nullptr;
  mjData* d_ = nullptr;
  CylinderInfo cyl_;
};

TEST_P(Leakage, PistonLeakDecaysAtTheClosedFormRate) {
  // dp_P/dt = -n r T G (p_P - p_N) / V_P, dp_N/dt = +n r T G (p_P - p_N) / V_N (valves closed, piston
  // held): p_P - p_N decays as exp(-lambda t), lambda = n r T G (1/V_P + 1/V_N), and
  // V_P p_P + V_N p_N is constant. G = 1e-9 kg/(s Pa) at x = 0.02: V_P = 1.46978e-5 m^3,
  // V_N = 7.442e-6 m^3, lambda = 20.63 /s, a time constant of 48.5 ms.
  const double kG = 1e-9;
  Start("piston_leak_conductance=1e-9", 3e5, 1e5);
  if (HasFatalFailure()) return;
  const double lambda = kN * kR * kT * kG * (1 / VolumeP(kX) + 1 / VolumeN(kX));
  ASSERT_NEAR(lambda, 20.63, 0.01);
  const double weighted0 = VolumeP(kX) * P(Chamber::kP) + VolumeN(kX) * P(Chamber::kN);
  const double difference0 = P(Chamber::kP) - P(Chamber::kN);
  ASSERT_EQ(difference0, 2e5);
  for (double time_constants : {1.0, 2.0}) {
    SCOPED_TRACE(std::to_string(time_constants) + " time constants");
    RunUntil(time_constants / lambda);
    double t = d_->time;
    double difference = P(Chamber::kP) - P(Chamber::kN);
    double rate = std::log(difference0 / difference) / t;
    EXPECT_NEAR(rate / lambda, 1, 1e-3) << "measured rate " << rate << " /s at t = " << t << " s, lambda " << lambda;
    double weighted = VolumeP(kX) * P(Chamber::kP) + VolumeN(kX) * P(Chamber::kN);
    EXPECT_NEAR(weighted / weighted0, 1, 1e-9) << "V_P p_P + V_N p_N moved by " << weighted - weighted0;
  }
}

TEST_P(Leakage, AtmosphereLeakDecaysAtTheClosedFormRate) {
  // dp_P/dt = -n r T G (p_P - p_atm) / V_P: p_P - p_atm decays at n r T G / V_P; chamber N (no leak,
  // sealed, piston held) keeps its pressure. G = 3e-9 kg/(s Pa): rate 20.81 /s, 48 ms.
  const double kG = 3e-9;
  Start("P.atmosphere_leak_conductance=3e-9", 3e5, 1.5e5);
  if (HasFatalFailure()) return;
  const double lambda = kN * kR * kT * kG / VolumeP(kX);
  ASSERT_NEAR(lambda, 20.81, 0.01);
  const double gauge0 = P(Chamber::kP) - cyl_.p_atm;
  for (double time_constants : {1.0, 2.0}) {
    SCOPED_TRACE(std::to_string(time_constants) + " time constants");
    RunUntil(time_constants / lambda);
    double t = d_->time;
    double rate = std::log(gauge0 / (P(Chamber::kP) - cyl_.p_atm)) / t;
    EXPECT_NEAR(rate / lambda, 1, 1e-3) << "measured rate " << rate << " /s at t = " << t << " s, lambda " << lambda;
    // the piston moves < 1e-9 m: chamber N's pressure changes by < n p A dx / V_N = 3e-6 Pa
    EXPECT_NEAR(P(Chamber::kN), 1.5e5, 1e-3);
  }
}

INSTANTIATE_TEST_SUITE_P(Steps, Leakage,
                         ::testing::Values(LeakCase{"linearized", "0.00025"}, LeakCase{"linearized", "0.001"},
                                           LeakCase{"exact", "0.00025"}, LeakCase{"exact", "0.001"}),
                         Name);

TEST_F(Parameters, LeakConductancesAreParameters) {
  std::string error;
  ASSERT_TRUE(SetParameter(m_, "cyl", "piston_leak_conductance", 1e-9, &error)) << error;
  ASSERT_TRUE(SetParameter(m_, "cyl", "N.atmosphere_leak_conductance", 2e-9, &error)) << error;
  EXPECT_EQ(Get(m_, "piston_leak_conductance"), 1e-9);
  EXPECT_EQ(Get(m_, "N.atmosphere_leak_conductance"), 2e-9);
  EXPECT_EQ(Get(m_, "P.atmosphere_leak_conductance"), 0.0);
  // documented range [0, 1e-6]
  EXPECT_FALSE(SetParameter(m_, "cyl", "piston_leak_conductance", -1e-12, &error));
  EXPECT_THAT(error, HasSubstr("key 'piston_leak_conductance'"));
  EXPECT_THAT(error, HasSubstr("out of range [0, 1e-06]"));
  EXPECT_FALSE(SetParameter(m_, "cyl", "P.atmosphere_leak_conductance", 2e-6, &error));
  EXPECT_THAT(error, HasSubstr("key 'P.atmosphere_leak_conductance'"));
  mjModel* written = LoadAttached(
      WithConfig("rig_onoff.xml", "piston_leak_conductance=1e-9 N.atmosphere_leak_conductance=2e-9"));
  ASSERT_NE(written, nullptr);
  EXPECT_TRUE(SameBits(PatternRun(m_, 1000), PatternRun(written, 1000)));
  mj_deleteModel(written);
}

}  // namespace
}  // namespace pneumatic

namespace pneumatic {
namespace {

std::string last_warning;
void RecordWarning(const char* message) { last_warning = message; }

TEST(StaleInputs, ActDotBeforeTheForcesIsReported) {
  // MuJoCo 2.2.2 computes every actuator force before act_dot, and the velocity prediction reads
  // them; a pass whose chamber forces do not match its act (here: act changed after mj_forward,
  // then act_dot asked for directly) says so instead of running silently on stale forces
  AttachedModel rig;
  ASSERT_TRUE(rig.Load(ShippedModel("rig_onoff.xml"), true)) << rig.error();
  mjModel* m = rig.m();
  mjData* d = rig.d();
  mj_forward(m, d);
  int p = rig.cylinder().chamber_actuator[0];
  d->act[p - (m->nu - m->na)] = 1e5;  // 1 bar gauge: the force MuJoCo computed was for 0
  void (*previous)(const char*) = mju_user_warning;
  mju_user_warning = RecordWarning;
  last_warning.clear();
  int leader = m->nu - m->na;  // the first actuator with user dynamics is pneumatic in rig A
  ASSERT_TRUE(mjcb_act_dyn != nullptr);
  mjcb_act_dyn(m, d, leader);
  mju_user_warning = previous;
  EXPECT_THAT(last_warning, HasSubstr("actuator forces are not current"));
}

// rig C's "pneumatic:cyl" element with its data replaced by `data`
std::string RigCWithData(const std::string& data) {
  std::string xml = ReadText(ShippedModel("rig_per_chamber.xml"));
  size_t begin = xml.find("data=\"", xml.find("name=\"pneumatic:cyl\"")) + 6;
  return xml.replace(begin, xml.find('"', begin) - begin, data);
}

// keys that are only valid together (the identified model needs c1..c9) are set at once, and the
// configuration text written back into the MJCF gives a model that steps bit for bit the same
TEST(SetParametersTogether, IdentifiedModelAndItsTextRoundTrip) {
  mjModel* m = LoadAttached(ReadText(ShippedModel("rig_per_chamber.xml")));
  ASSERT_NE(m, nullptr);
  std::string error;
  // one key alone: the identified model's c1..c9 are required
  EXPECT_FALSE(SetParameter(m, "cyl", "P.pressure_model", std::string("identified"), &error));
  EXPECT_THAT(error, HasSubstr("c1"));
  std::vector<std::pair<std::string, std::string>> identified = {
      {"P.pressure_model", "identified"}, {"P.c1", "5.1"}, {"P.c2", "2.5"}, {"P.c3", "0.3"},
      {"P.c4", "1e5"}, {"P.c5", "-10"}, {"P.c6", "3"}, {"P.c7", "20"}, {"P.c8", "0.1"}, {"P.c9", "0.05"}};
  ASSERT_TRUE(SetParameters(m, "cyl", identified, &error)) << error;
  EXPECT_EQ(GetParameter(m, "cyl", "P.c7", &error), 20.0);
  EXPECT_EQ(GetParameter(m, "cyl", "P.pressure_model", &error), 1.0);  // "physical identified"
  EXPECT_FALSE(GetParameter(m, "cyl", "N.c7", &error)) << "chamber N keeps the physical model";

  std::optional<std::string> text = ConfigurationText(m, "cyl", &error);
  ASSERT_TRUE(text) << error;
  EXPECT_THAT(*text, HasSubstr("P.c7=20"));
  mjModel* written = LoadAttached(RigCWithData(*text));
  ASSERT_NE(written, nullptr);
  EXPECT_TRUE(SameBits(PatternRun(m, 2000), PatternRun(written, 2000)));
  // and it is not the physical model's run
  mjModel* physical = LoadAttached(ReadText(ShippedModel("rig_per_chamber.xml")));
  ASSERT_NE(physical, nullptr);
  EXPECT_FALSE(SameBits(PatternRun(m, 2000), PatternRun(physical, 2000)));

  // all or nothing: one bad value among good ones changes nothing
  EXPECT_FALSE(SetParameters(m, "cyl", {{"P.c7", "30"}, {"P.c8", "2"}}, &error));
  EXPECT_THAT(error, HasSubstr("c8"));
  EXPECT_EQ(GetParameter(m, "cyl", "P.c7", &error), 20.0);
  EXPECT_FALSE(ConfigurationText(m, "nope", &error));
  EXPECT_THAT(error, HasSubstr("nope"));
  mj_deleteModel(physical);
  mj_deleteModel(written);
  mj_deleteModel(m);
}

}  // namespace
}  // namespace pneumatic
