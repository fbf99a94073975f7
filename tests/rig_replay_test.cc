// Open-loop replay of the rigs against the independent fine-step reference of
// docs/rigs.md: the acceptance numbers.
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "reference_log.h"
#include "simulation/rollout.h"
#include "test_util.h"

namespace pneumatic {
namespace {

using reference::Rig;
using testing::AttachedModel;
using testing::ShippedModel;

struct ReplayError {
  double pressure = 0;  // max |p_sim - p_ref| over both chambers and all rows, Pa
  double position = 0;  // max |x_sim - x_ref|, m
};

using reference::ExcitationPattern;

constexpr double kSeconds = 4;  // length of every reference log, s

// the 4 s reference log of a rig under an excitation pattern and seed, computed once per process.
// RK4 at 1 us; the fast-switching logs at 10 us, within 1 Pa and 3e-8 m of 1 us on seeds 1-3
// (measured), 1e-4 of the bounds below, in a tenth of the time
const log::Log& ReferenceLog(Rig rig, ExcitationPattern pattern = ExcitationPattern::kDefault, uint32_t seed = 1) {
  static std::map<std::tuple<Rig, ExcitationPattern, uint32_t>, log::Log> cache;
  auto key = std::make_tuple(rig, pattern, seed);
  auto it = cache.find(key);
  if (it == cache.end()) {
    const double fine_step = pattern == ExcitationPattern::kFastSwitching ? 1e-5 : 1e-6;
    auto samples = reference::Simulate(reference::DefaultParams(rig), reference::RigState{},
                                       reference::Excitation(rig, kSeconds, seed, 0, pattern),
                                       reference::ControlPeriod(rig), fine_step);
    it = cache.emplace(key, reference::ToLog(rig, samples)).first;
  }
  return it->second;
}

// replays `ref` through the shipped model of `rig` at `timestep` (0: the model's own)
ReplayError Replay(Rig rig, const log::Log& ref, double timestep, bool follow_motion = false) {
  AttachedModel model;
  EXPECT_TRUE(model.Load(ShippedModel(reference::RigModelFile(rig)), true)) << model.error();
  if (timestep > 0) model.m()->opt.timestep = timestep;
  RolloutOptions options;
  options.follow_motion = follow_motion;
  RolloutResult result = Rollout(model.m(), &ref, options);
  EXPECT_TRUE(result.log) << result.error;
  ReplayError e;
  if (!result.log) return e;
  const log::Log& sim = *result.log;
  for (const char* signal : {"p_P", "p_N", "x"}) {
    const auto& a = sim.values[sim.FindColumn("cyl", signal)];
    const auto& b = ref.values[ref.FindColumn("cyl", signal)];
    double& worst = signal[0] == 'x' ? e.position : e.pressure;
    for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::fabs(a[i] - b[i]));
  }
  return e;
}

// replays the default reference log (seed 1) through the shipped model at `timestep` (0: the model's own)
ReplayError Replay(Rig rig, double timestep, bool follow_motion = false) {
  return Replay(rig, ReferenceLog(rig), timestep, follow_motion);
}

double SupplyMinusExhaust(Rig rig) {
  reference::RigParams p = reference::DefaultParams(rig);
  return p.supply_pressure - p.exhaust_pressure;
}

class RigReplay : public ::testing::TestWithParam<Rig> {};

TEST_P(RigReplay, ShippedModelReplaysFourSecondsWithinOnePercentAndHalfAMillimetre) {
  // done-when of the issue: pressure within 1 % of supply - exhaust, position within 0.5 mm over 4 s
  Rig rig = GetParam();
  ReplayError e = Replay(rig, 0);
  RecordProperty("pressure_error_fraction", std::to_string(e.pressure / SupplyMinusExhaust(rig)));
  RecordProperty("position_error_m", std::to_string(e.position));
  EXPECT_LT(e.pressure, 0.01 * SupplyMinusExhaust(rig));
  EXPECT_LT(e.position, 0.5e-3);
}

// the commands of a log as rows, to compare one row with the next
std::vector<std::vector<double>> CommandRows(const log::Log& log, size_t command_columns) {
  std::vector<std::vector<double>> rows(log.time.size(), std::vector<double>(command_columns));
  for (size_t c = 0; c < command_columns; ++c) {
    for (size_t i = 0; i < log.time.size(); ++i) rows[i][c] = log.values[c][i];
  }
  return rows;
}

TEST_P(RigReplay, ShippedModelReplaysFastSwitchingWithinOnePercentAndHalfAMillimetre) {
  // item 4 of the issue: the same bounds under fast mode switching, as a sliding controller switches:
  // every command held 10-80 ms (reference::FastSwitchingExcitation), open loop at the model's own
  // timestep, for three seeds. Measured (x86-64, gcc), worst of seeds 1-3: 0.30 % / 0.26 mm (A, 0.05 ms),
  // 0.07 % / 0.27 mm (B, 0.1 ms), 0.16 % / 0.13 mm (C, 0.1 ms); the models' comments give the coarser steps
  Rig rig = GetParam();
  const reference::RigParams p = reference::DefaultParams(rig);
  const size_t command_columns = rig == Rig::kOnOff ? 4 : rig == Rig::kProportional ? 1 : 2;
  for (uint32_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const log::Log& ref = ReferenceLog(rig, ExcitationPattern::kFastSwitching, seed);
    ASSERT_EQ(ref.time.size(), static_cast<size_t>(std::lround(kSeconds / p.control_period)));
    // the excitation: valid commands, each held 10-80 ms (the last one may be cut at 4 s), in the stroke
    const auto rows = CommandRows(ref, command_columns);
    size_t start = 0;
    for (size_t i = 1; i <= rows.size(); ++i) {
      if (i < rows.size() && rows[i] == rows[start]) continue;
      const double held = static_cast<double>(i - start) * p.control_period;
      if (i < rows.size()) EXPECT_GE(held, 10e-3 - 1e-9) << "at t = " << ref.time[start];
      EXPECT_LE(held, 80e-3 + 1e-9) << "at t = " << ref.time[start];
      start = i;
    }
    for (const auto& row : rows) {
      for (double u : row) {
        if (rig == Rig::kOnOff) ASSERT_TRUE(u == 0 || u == 1);
        if (rig == Rig::kProportional) ASSERT_LE(std::fabs(u), 5.0);
        if (rig == Rig::kPerChamber) ASSERT_TRUE(u >= 3 && u <= 7);
      }
    }
    double x_max = 0;
    for (double x : ref.values[ref.FindColumn("cyl", "x")]) x_max = std::max(x_max, std::fabs(x));
    EXPECT_LT(x_max, 0.8 * 0.5 * p.stroke);

    ReplayError e = Replay(rig, ref, 0);
    RecordProperty("seed_" + std::to_string(seed) + "_pressure_error_fraction",
                   std::to_string(e.pressure / SupplyMinusExhaust(rig)));
    RecordProperty("seed_" + std::to_string(seed) + "_position_error_m", std::to_string(e.position));
    EXPECT_LT(e.pressure, 0.01 * SupplyMinusExhaust(rig));
    EXPECT_LT(e.position, 0.5e-3);
  }
}

TEST_P(RigReplay, OpenLoopAtOneMillisecondStepsWithinMeasuredBounds) {
  // the 1 ms replay open loop, the whole rig simulated: MuJoCo's first-order mechanics moves the piston,
  // whose position error then moves the chamber volumes, so the errors are well above the pressure
  // model's own (the follow-motion test below). Measured (x86-64, gcc), in % of supply - exhaust / mm:
  //   default excitation, seed 1: A 1.01 / 0.77, B 0.27 / 0.45, C 0.39 / 0.33;
  //   fast switching, worst of seeds 1-3: A 5.9 / 5.5, B 0.64 / 2.7, C 2.1 / 1.7.
  // The bounds are those figures with 25-35 % to spare. Rig A's 7 mm under fast switching is docs/rigs.md's
  // figure for this pressure step with b v implicit; with the volume along Euler's own path, implicit
  // damping included, seeds 1-3 measure 4.5, 0.84 and 5.5 mm. docs/rigs.md's ~1.3 mm with b v explicit is
  // not reached: a diagnostic replay with b v explicit (damping moved to qfrc_passive) measures 4.4,
  // 0.92 and 5.1 mm on the same logs, so this excitation, not the damping, sets the figure
  struct Bounds {
    double pressure_fraction, position;  // 1, m
  };
  Rig rig = GetParam();
  Bounds normal, fast;
  switch (rig) {
    case Rig::kOnOff: normal = {0.0125, 1.0e-3}, fast = {0.075, 7.0e-3}; break;
    case Rig::kProportional: normal = {0.0035, 0.6e-3}, fast = {0.008, 3.5e-3}; break;
    case Rig::kPerChamber: normal = {0.005, 0.45e-3}, fast = {0.026, 2.1e-3}; break;
  }
  ReplayError e = Replay(rig, 1e-3);
  EXPECT_LT(e.pressure, normal.pressure_fraction * SupplyMinusExhaust(rig));
  EXPECT_LT(e.position, normal.position);
  for (uint32_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE("fast switching, seed " + std::to_string(seed));
    e = Replay(rig, ReferenceLog(rig, ExcitationPattern::kFastSwitching, seed), 1e-3);
    EXPECT_LT(e.pressure, fast.pressure_fraction * SupplyMinusExhaust(rig));
    EXPECT_LT(e.position, fast.position);
  }
}

TEST_P(RigReplay, PressureWithinHalfAPercentAtOneMillisecondSteps) {
  // item 10 of the issue: pressure error below 0.5 % of supply - exhaust at 1 ms steps. The pressures
  // are simulated along the reference's motion (paper 000 II.5, V.D): open loop, MuJoCo's first-order
  // mechanics adds its own position error (0.77 mm on rig A at 1 ms), which moves the chamber volumes
  Rig rig = GetParam();
  ReplayError e = Replay(rig, 1e-3, /*follow_motion=*/true);
  EXPECT_LT(e.pressure, 0.005 * SupplyMinusExhaust(rig));
}

TEST_P(RigReplay, OpenLoopErrorsHalveWithTheTimestep) {
  // with the motion simulated too, every error is first order in the step: the 1 ms figures
  // (README, "Accuracy") shrink by half at 0.5 ms, so they are discretisation, not model, error
  Rig rig = GetParam();
  ReplayError coarse = Replay(rig, 1e-3), fine = Replay(rig, 5e-4);
  EXPECT_GT(coarse.pressure / fine.pressure, 1.7);
  EXPECT_LT(coarse.pressure / fine.pressure, 2.3);
  EXPECT_GT(coarse.position / fine.position, 1.7);
  EXPECT_LT(coarse.position / fine.position, 2.3);
}

INSTANTIATE_TEST_SUITE_P(Rigs, RigReplay, ::testing::Values(Rig::kOnOff, Rig::kProportional, Rig::kPerChamber),
                         [](const auto& info) {
                           switch (info.param) {
                             case Rig::kOnOff: return std::string("OnOff");
                             case Rig::kProportional: return std::string("Proportional");
                             case Rig::kPerChamber: return std::string("PerChamber");
                           }
                           return std::string();
                         });

}  // namespace
}  // namespace pneumatic
