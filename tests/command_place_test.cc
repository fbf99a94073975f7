// commands=chambers: a cylinder's valve commands read from the ctrl of its chamber actuators,
// two actuators per cylinder instead of up to four. The physics is the same, so a model in this
// form must step bit for bit like the same model with its own command actuators, for each valve
// arrangement that allows it; the arrangements that need a command actuator's act (valve states)
// or more than two commands are refused, naming the key.
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util.h"

namespace pneumatic {
namespace {

using ::testing::HasSubstr;
using testing::AttachedModel;
using testing::MujocoTest;
using testing::ReadText;
using testing::ReplaceAll;
using testing::RigAOnPwm;
using testing::RunPattern;
using testing::SameBits;
using testing::ShippedModel;
using testing::State;

constexpr int kSteps = 4000;  // covers 12 push/pull phases of PatternCommand and its staircase

// the state after kSteps of the command pattern, written through CylinderInfo::command_actuators
std::vector<double> StateAfterPattern(const std::string& xml) {
  AttachedModel model;
  EXPECT_TRUE(model.Load(xml)) << model.error();
  if (!model.m()) return {};
  RunPattern(model.m(), model.d(), model.cylinder(), 0, kSteps);
  return State(model.m(), model.d());
}

// `xml` without the command actuator element `command`, its ctrlrange moved to cyl.P
std::string CommandInChamberP(const std::string& xml, const std::string& command, const std::string& range) {
  std::string limits = R"( ctrllimited="true" ctrlrange=")" + range + R"(")";
  std::string out = ReplaceAll(xml, R"(<general name=")" + command + R"(" joint="x" gaintype="user")" + limits + "/>", "");
  return ReplaceAll(out, R"(<general name="cyl.P" joint="x" dyntype="user" gaintype="user"/>)",
                    R"(<general name="cyl.P" joint="x" dyntype="user" gaintype="user")" + limits + "/>");
}

// both models step alike under the command pattern
void ExpectSameSteps(const std::string& separate, const std::string& chambers) {
  std::vector<double> expected = StateAfterPattern(separate);
  ASSERT_FALSE(expected.empty());
  EXPECT_TRUE(SameBits(StateAfterPattern(chambers), expected));
}

class CommandPlace : public MujocoTest {};

TEST_F(CommandPlace, PerChamberValvesStepBitForBitAsWithTheirOwnActuators) {
  // rig C as shipped: cyl.uP and cyl.uN carry the voltages (0..10 V)
  std::string separate = ReadText(ShippedModel("rig_per_chamber.xml"));
  std::string chambers = ReplaceAll(separate, R"(<general name="cyl.uP" joint="x" gaintype="user" ctrllimited="true" ctrlrange="0 10"/>)", "");
  chambers = ReplaceAll(chambers, R"(<general name="cyl.uN" joint="x" gaintype="user" ctrllimited="true" ctrlrange="0 10"/>)", "");
  chambers = ReplaceAll(chambers, R"(dyntype="user" gaintype="user"/>)",
                        R"(dyntype="user" gaintype="user" ctrllimited="true" ctrlrange="0 10"/>)");
  chambers = ReplaceAll(chambers, "valve=proportional_per_chamber", "valve=proportional_per_chamber commands=chambers");

  AttachedModel compact;
  ASSERT_TRUE(compact.Load(chambers)) << compact.error();
  EXPECT_EQ(compact.m()->nu, 2);
  CylinderInfo info = compact.cylinder();
  ASSERT_EQ(info.command_actuators.size(), 2u);
  EXPECT_EQ(info.command_actuators[0].first, "uP");
  EXPECT_EQ(info.command_actuators[0].second, info.chamber_actuator[0]);
  EXPECT_EQ(info.command_actuators[1].first, "uN");
  EXPECT_EQ(info.command_actuators[1].second, info.chamber_actuator[1]);

  ExpectSameSteps(separate, chambers);
}

TEST_F(CommandPlace, FiveThreeValveWithoutLagStepsBitForBitAsWithItsOwnActuator) {
  // rig B with the spool lag off (a lag keeps its state in the command actuator's act)
  std::string separate = ReadText(ShippedModel("rig_proportional.xml"));
  separate = ReplaceAll(separate, "spool_time_constant=4.2e-3", "spool_time_constant=0");
  separate = ReplaceAll(separate, R"(<general name="cyl.u" joint="x" dyntype="user" gaintype="user")",
                        R"(<general name="cyl.u" joint="x" gaintype="user")");
  std::string chambers = CommandInChamberP(separate, "cyl.u", "-5 5");
  ExpectSameSteps(separate, ReplaceAll(chambers, "spool_time_constant=0", "spool_time_constant=0 commands=chambers"));
}

TEST_F(CommandPlace, PwmDutyStepsBitForBitAsWithItsOwnActuator) {
  // switched (100 Hz) and averaged PWM
  for (double frequency : {100.0, 0.0}) {
    SCOPED_TRACE("pwm_frequency " + std::to_string(frequency));
    std::string separate = RigAOnPwm(frequency);
    std::string chambers = CommandInChamberP(separate, "cyl.duty", "-1 1");
    ExpectSameSteps(separate, ReplaceAll(chambers, "input=pwm", "input=pwm commands=chambers"));
  }
}

// the error Attach gives for `xml`
std::string AttachError(const std::string& xml) {
  AttachedModel model;
  EXPECT_FALSE(model.Load(xml));
  return model.error();
}

TEST_F(CommandPlace, RefusesWhatAChamberActuatorCannotHold) {
  // four on/off commands
  std::string onoff = ReadText(ShippedModel("rig_onoff.xml"));
  EXPECT_THAT(AttachError(ReplaceAll(onoff, "valve=onoff", "valve=onoff commands=chambers")),
              HasSubstr("key 'commands': chambers holds two commands"));
  // a spool lag (rig B's, 4.2 ms) keeps its state in cyl.u's act
  std::string five_three = ReadText(ShippedModel("rig_proportional.xml"));
  EXPECT_THAT(AttachError(ReplaceAll(five_three, "valve=proportional_5_3", "valve=proportional_5_3 commands=chambers")),
              HasSubstr("key 'spool_time_constant': a spool lag keeps its state"));
  // a command actuator left in place is named, with what to do
  std::string per_chamber = ReadText(ShippedModel("rig_per_chamber.xml"));
  EXPECT_THAT(AttachError(ReplaceAll(per_chamber, "valve=proportional_per_chamber",
                                     "valve=proportional_per_chamber commands=chambers")),
              HasSubstr("actuator 'cyl.uP': commands=chambers reads this command from the ctrl of 'cyl.P'"));
}

}  // namespace
}  // namespace pneumatic
