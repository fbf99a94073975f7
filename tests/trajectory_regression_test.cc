// Trajectory regression tests: closed-loop rollouts of the shipped models compared with golden logs
// (tests/golden/trajectories/) under per-signal tolerances, so that a change of the physics, the
// models or the controller that moves a trajectory is seen.
//
// To regenerate the goldens ON PURPOSE (after a change that is meant to move the trajectories),
// run from the repository root:
//
//   PNEUMATIC_UPDATE_GOLDENS=1 build/bin/trajectory_regression_test
//
// and commit the changed files under tests/golden/trajectories/ with a note saying why.
//
// Tolerances, per signal: pressures 0.05 % of supply - exhaust (260 Pa on rig C), positions 0.02 mm
// (or 0.02 mrad), velocities 2 mm/s, proportional commands 0.01 V, on/off commands exact. They
// allow the last-digit differences of another compiler or library build to grow over the run,
// and are far below what a change of the physics gives (the dead volume +5 % moves rig C's
// pressures by kPa: a test below shows the comparison failing on it).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "formats/log_csv.h"
#include "simulation/closed_loop.h"
#include "simulation/controller_config.h"
#include "test_util.h"

namespace pneumatic {
namespace {

using testing::AttachedModel;
using testing::ShippedModel;

const char* const kRegenerate = "PNEUMATIC_UPDATE_GOLDENS=1 build/bin/trajectory_regression_test";

std::string GoldenPath(const std::string& name) {
  return std::string(PNEUMATIC_GOLDEN_DIR) + "/trajectories/" + name + ".csv";
}

// the controller configuration shipped with a model ("" for the default PID): the humanoid's gains
// (models_mjcf/humanoid_pid.json), which the default ones leave its waist undamped
std::string ControllerConfig(const std::string& name) {
  return name == "humanoid_pneumatic" ? ShippedModel("humanoid_pid.json") : "";
}

// the rollout a golden records: 3 s under the PID (the model's shipped gains, or the defaults), a step
// of a fifth of the half stroke at 0.5 s and back to the middle at 2 s, at 100 Hz
log::Log Rollout(const mjModel* m, const std::string& config, std::string* error) {
  const std::vector<CylinderInfo> cylinders = Cylinders(m);
  log::Log reference;
  reference.time = {0, 0.5, 0.5001, 2, 2.0001, 10};
  for (const CylinderInfo& c : cylinders) {
    std::string why;
    const double half_stroke = GetParameter(m, c.name, "stroke", &why).value_or(0) / 2;
    const double step = 0.2 * half_stroke;
    reference.columns.push_back({c.name, "ref"});
    reference.values.push_back({0, 0, step, step, 0, 0});
  }
  ClosedLoopOptions options;
  if (!config.empty()) {
    if ((*error = ReadControllerConfig(config, &options)) != "") return log::Log{};
  }
  options.duration = 3;
  options.reference = &reference;
  ClosedLoopResult result = RunClosedLoop(m, options);
  *error = result.error;
  return result.log ? *result.log : log::Log{};
}

double Tolerance(const mjModel* m, const log::Column& column) {
  const std::string& s = column.signal;
  if (s == "p_P" || s == "p_N" || s == "p_S") {
    for (const CylinderInfo& c : Cylinders(m)) {
      if (c.name == column.cylinder) return 5e-4 * (c.p_supply - c.p_exhaust);
    }
  }
  if (s == "x" || s == "ref") return 2e-5;
  if (s == "v") return 2e-3;
  if (s == "u1" || s == "u2" || s == "u3" || s == "u4") return 0;
  return 0.01;  // V, or duty
}

// "" if `actual` matches `golden` within the tolerances, else the first difference found
std::string Compare(const mjModel* m, const log::Log& golden, const log::Log& actual) {
  if (golden.rows() != actual.rows() || golden.columns.size() != actual.columns.size()) {
    return "the rollout has " + std::to_string(actual.rows()) + " rows and " + std::to_string(actual.columns.size()) +
           " columns, the golden " + std::to_string(golden.rows()) + " and " + std::to_string(golden.columns.size());
  }
  for (size_t c = 0; c < golden.columns.size(); ++c) {
    if (golden.columns[c].name() != actual.columns[c].name()) {
      return "column " + std::to_string(c) + " is " + actual.columns[c].name() + ", the golden's " + golden.columns[c].name();
    }
    const double tolerance = Tolerance(m, golden.columns[c]);
    for (size_t r = 0; r < golden.rows(); ++r) {
      const double difference = std::fabs(actual.values[c][r] - golden.values[c][r]);
      if (!(difference <= tolerance)) {
        char text[300];
        std::snprintf(text, sizeof(text), "%s at t = %.3f s: %.9g, golden %.9g (difference %.3g, tolerance %.3g)",
                      golden.columns[c].name().c_str(), golden.time[r], actual.values[c][r], golden.values[c][r],
                      difference, tolerance);
        return text;
      }
    }
  }
  return "";
}

class Trajectory : public ::testing::TestWithParam<const char*> {};

TEST_P(Trajectory, MatchesItsGolden) {
  const std::string name = GetParam();
  AttachedModel model;
  ASSERT_TRUE(model.Load(ShippedModel(name + ".xml"), true)) << model.error();
  std::string error;
  const log::Log actual = Rollout(model.m(), ControllerConfig(name), &error);
  ASSERT_EQ(error, "");
  if (std::getenv("PNEUMATIC_UPDATE_GOLDENS")) {
    log::Log golden = actual;
    const std::string gains = ControllerConfig(name).empty() ? "the default PID" : "the PID of " + ControllerConfig(name);
    golden.comments = {"golden trajectory of models_mjcf/" + name + ".xml: 3 s under " + gains + ", steps of the "
                       "reference at 0.5 s and 2 s; regenerate with " + std::string(kRegenerate)};
    ASSERT_EQ(log::WriteLog(GoldenPath(name), golden), "");
    GTEST_SKIP() << "wrote " << GoldenPath(name);
  }
  log::ReadResult golden = log::ReadLog(GoldenPath(name), {});
  ASSERT_TRUE(golden.log) << golden.error << "\nto create it: " << kRegenerate;
  EXPECT_EQ(Compare(model.m(), *golden.log, actual), "")
      << "\nif this change is meant to move the trajectory, regenerate the goldens: " << kRegenerate;
}

INSTANTIATE_TEST_SUITE_P(ShippedModels, Trajectory,
                         ::testing::Values("rig_onoff", "rig_proportional", "rig_per_chamber", "humanoid_pneumatic"),
                         [](const ::testing::TestParamInfo<const char*>& info) { return std::string(info.param); });

// the comparison fails when it should: rig C with 5 % more dead volume in chamber P
TEST(TrajectoryComparison, FailsOnAChangedDeadVolume) {
  AttachedModel model;
  ASSERT_TRUE(model.Load(ShippedModel("rig_per_chamber.xml"), true)) << model.error();
  std::string error;
  const log::Log nominal = Rollout(model.m(), "", &error);
  ASSERT_EQ(error, "");
  ASSERT_TRUE(SetParameter(model.m(), "cyl", "P.dead_volume", 1.05e-6, &error)) << error;
  const log::Log changed = Rollout(model.m(), "", &error);
  ASSERT_EQ(error, "");
  EXPECT_THAT(Compare(model.m(), nominal, changed), ::testing::HasSubstr("cyl.p_P"));
  EXPECT_EQ(Compare(model.m(), nominal, nominal), "");
}

}  // namespace
}  // namespace pneumatic
