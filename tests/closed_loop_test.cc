// Closed-loop rollouts (pneumo/simulation/closed_loop.h, `pneumo rollout --controller`): a PID on position
// drives each rig's valves, the log and summary say what happened, and runs are reproducible.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "formats/log_csv.h"
#include "position_pid.h"
#include "position_stiffness.h"
#include "simulation/closed_loop.h"
#include "simulation/controller_config.h"
#include "sliding_mode.h"
#include "test_util.h"

namespace pneumatic {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;
using testing::AttachedModel;
using testing::ReadText;
using testing::ReplaceAll;
using testing::ShippedModel;

// a reference log: x = 0 until 0.5 s, then `target`
log::Log StepReference(double target) {
  log::Log ref;
  ref.columns = {{"cyl", "ref"}};
  ref.time = {0, 0.5, 0.5001, 10};
  ref.values = {{0, 0, target, target}};
  return ref;
}

// docs/log_format.md: "A measured column holds the value sampled at this row's time". Every row's
// x and v must be the piston's at the row's time, as a full forward pass of the state at that time gives
// them (mj_step leaves actuator lengths and site positions as they were at the start of its step, one
// model step old): on a rig (a slide joint) and on the humanoid (hinges, and cylinders pinned between
// sites with mount=hinge_sites)
TEST(ClosedLoop, EveryRowHoldsThePistonsPositionAndVelocityAtItsTime) {
  for (const char* file : {"rig_proportional.xml", "humanoid_pneumatic.xml"}) {
    SCOPED_TRACE(file);
    AttachedModel model;
    ASSERT_TRUE(model.Load(ShippedModel(file), true)) << model.error();
    const mjModel* m = model.m();
    const std::vector<CylinderInfo> cylinders = Cylinders(m);
    ClosedLoopOptions options;
    options.duration = 0.2;
    log::Log reference = StepReference(0.01);  // the rig's cylinder "cyl" steps at 0.05 s; the humanoid holds its pose
    reference.time = {0, 0.05, 0.0501, 10};
    if (cylinders.size() == 1) options.reference = &reference;
    // at every tick's time (after each tick's last step), x and v from a forward pass of a copy
    const long steps_per_tick = std::lround(1 / (options.control_rate * m->opt.timestep));
    std::unique_ptr<mjData, void (*)(mjData*)> copy(mj_makeData(m), mj_deleteData);
    std::vector<std::vector<double>> x_at_tick, v_at_tick;  // by tick, by cylinder
    long steps = -1;                                         // the observer first sees the state before any step
    options.observer = [&](const mjData* d) {
      if (++steps % steps_per_tick != 0) return std::string();
      mj_copyData(copy.get(), m, d);
      mj_forward(m, copy.get());
      x_at_tick.emplace_back(), v_at_tick.emplace_back();
      for (const CylinderInfo& c : cylinders) {
        x_at_tick.back().push_back(PistonPosition(m, copy.get(), c));
        v_at_tick.back().push_back(PistonVelocity(m, copy.get(), c));
      }
      return std::string();
    };
    ClosedLoopResult result = RunClosedLoop(m, options);
    ASSERT_TRUE(result.log) << result.error;
    const log::Log& log = *result.log;
    ASSERT_EQ(log.rows(), 20u);
    ASSERT_GE(x_at_tick.size(), log.rows());
    double moved = 0;
    for (size_t r = 0; r < log.rows(); ++r) {
      for (size_t i = 0; i < cylinders.size(); ++i) {
        SCOPED_TRACE(cylinders[i].name + " at t = " + std::to_string(log.time[r]));
        const double x = log.values[log.FindColumn(cylinders[i].name, "x")][r];
        const double v = log.values[log.FindColumn(cylinders[i].name, "v")][r];
        ASSERT_NEAR(x, x_at_tick[r][i], 1e-12);
        ASSERT_NEAR(v, v_at_tick[r][i], 1e-12);
        moved = std::max(moved, std::fabs(x - x_at_tick[0][i]));
      }
    }
    EXPECT_GT(moved, 1e-4) << "m: the pistons move, so that a row one step late would show";
  }
}

// The proportional rigs follow a step of 10 mm (a fifth of the half stroke) under the default PID:
// within 1 mm after 2.5 s, with every chamber pressure between exhaust and supply. (Rig A's on/off
// valves under a plain PID limit-cycle around the target, as paper 002 explains: its sliding-mode
// controllers are the issue of the papers' controllers.)
TEST(ClosedLoop, ProportionalRigsFollowAStepWithinOneMillimetre) {
  for (const char* rig : {"rig_proportional.xml", "rig_per_chamber.xml"}) {
    AttachedModel model;
    ASSERT_TRUE(model.Load(ShippedModel(rig), true)) << model.error();
    const log::Log reference = StepReference(0.01);
    ClosedLoopOptions options;
    options.duration = 3;
    options.reference = &reference;
    ClosedLoopResult result = RunClosedLoop(model.m(), options);
    ASSERT_TRUE(result.log) << rig << ": " << result.error;
    const log::Log& log = *result.log;
    EXPECT_EQ(log.rows(), 300u) << rig;  // 3 s at 100 Hz
    const std::vector<double>& x = log.values[static_cast<size_t>(log.FindColumn("cyl", "x"))];
    EXPECT_NEAR(x.back(), 0.01, 1e-3) << rig;
    EXPECT_EQ(log.values[static_cast<size_t>(log.FindColumn("cyl", "ref"))].back(), 0.01) << rig;
    ASSERT_EQ(result.summary.cylinders.size(), 1u);
    EXPECT_TRUE(result.summary.cylinders[0].within_supply_range) << rig;
    EXPECT_TRUE(result.summary.warnings.empty()) << rig << ": " << result.summary.warnings.front();
    EXPECT_EQ(result.summary.steps, std::lround(3 / model.m()->opt.timestep)) << rig;
  }
}

// docs/log_format.md's p_S is the supply pressure the valves see: with a reservoir feeding the cylinder
// (supply=NAME: here a tank of 5e-5 m^3, about 10 mid-stroke chambers of rig C, behind a line of half
// its valve's conductance) it is the reservoir's pressure, charged to the compressor's 6.2e5 Pa at reset,
// drawn down while a step fills a chamber, never above the compressor, and recovering once the piston
// holds; without one, the constant p_supply.
TEST(ClosedLoop, LogsTheSupplyPressureTheValvesSee) {
  const std::string rig = ReadText(ShippedModel("rig_per_chamber.xml"));
  std::string fed = ReplaceAll(rig, "</actuator>", "  <general name=\"tank.pressure\" joint=\"x\" dyntype=\"user\" gaintype=\"user\"/>\n</actuator>");
  fed = ReplaceAll(fed, "</custom>", "  <text name=\"pneumatic_reservoir:tank\" data=\"volume=5e-5 line_conductance=2.9e-9\"/>\n</custom>");
  fed = ReplaceAll(fed, "area_smoothing=1e-6\"", "area_smoothing=1e-6 supply=tank\"");
  ASSERT_NE(fed.find("supply=tank"), std::string::npos);
  const log::Log reference = StepReference(0.03);
  ClosedLoopOptions options;
  options.duration = 3;
  options.reference = &reference;
  for (const bool with_tank : {false, true}) {
    AttachedModel model;
    ASSERT_TRUE(with_tank ? model.Load(fed) : model.Load(ShippedModel("rig_per_chamber.xml"), true)) << model.error();
    ClosedLoopResult result = RunClosedLoop(model.m(), options);
    ASSERT_TRUE(result.log) << result.error;
    const std::vector<double>& p_s = result.log->values[static_cast<size_t>(result.log->FindColumn("cyl", "p_S"))];
    const double lowest = *std::min_element(p_s.begin(), p_s.end());
    EXPECT_EQ(p_s.front(), 6.2e5) << "charged at reset";
    EXPECT_LE(*std::max_element(p_s.begin(), p_s.end()), 6.2e5);
    if (!with_tank) {
      EXPECT_EQ(lowest, 6.2e5);
      continue;
    }
    EXPECT_LT(lowest, 0.99 * 6.2e5) << "drawn down by the step";
    EXPECT_GT(p_s.back(), lowest + 0.5 * (6.2e5 - lowest)) << "refilled while the piston holds";
  }
}

// A reference the piston cannot reach is followed as far as the stroke goes and named in the
// summary's warnings: rig C's stroke is 0.1 m, so x reaches at most 0.05 m either side of mid-stroke
TEST(ClosedLoop, WarnsOfAReferenceBeyondTheStroke) {
  AttachedModel model;
  ASSERT_TRUE(model.Load(ShippedModel("rig_per_chamber.xml"), true)) << model.error();
  ClosedLoopOptions options;
  options.duration = 0.1;
  const std::string beyond = "cylinder 'cyl': its reference reaches -0.06, beyond the stroke (x within +-0.05 of mid-stroke)";
  for (const double target : {0.05, -0.06}) {
    const log::Log reference = StepReference(target);
    options.reference = &reference;
    ClosedLoopResult result = RunClosedLoop(model.m(), options);
    ASSERT_TRUE(result.log) << result.error;
    const bool warned = std::any_of(result.summary.warnings.begin(), result.summary.warnings.end(),
                                    [&](const std::string& w) { return w.rfind(beyond, 0) == 0; });
    EXPECT_EQ(warned, target < -0.05) << target;
    EXPECT_EQ(result.summary.warnings.size(), target < -0.05 ? 1u : 0u) << target;
  }
}

TEST(ClosedLoop, SameOptionsGiveTheSameLogAndNoiseChangesIt) {
  AttachedModel model;
  ASSERT_TRUE(model.Load(ShippedModel("rig_per_chamber.xml"), true)) << model.error();
  const log::Log reference = StepReference(-0.02);
  ClosedLoopOptions options;
  options.duration = 1;
  options.reference = &reference;
  options.noise_position = 1e-4;
  options.seed = 7;
  ClosedLoopResult a = RunClosedLoop(model.m(), options), b = RunClosedLoop(model.m(), options);
  ASSERT_TRUE(a.log && b.log);
  for (size_t c = 0; c < a.log->values.size(); ++c) EXPECT_TRUE(testing::SameBits(a.log->values[c], b.log->values[c]));
  options.seed = 8;
  ClosedLoopResult other = RunClosedLoop(model.m(), options);
  ASSERT_TRUE(other.log);
  const int x = a.log->FindColumn("cyl", "x");
  EXPECT_NE(a.log->values[static_cast<size_t>(x)], other.log->values[static_cast<size_t>(x)]);
}

// the controller's state is all of it: a copy given the same state gives the same commands
TEST(PositionPid, StateRoundTripsAndRefusesAWrongSize) {
  ValveDrive drive;
  drive.half_stroke = 0.05;
  PositionPid a({drive}, {PositionPidGains{}}, 0.01), b({drive}, {PositionPidGains{}}, 0.01);
  std::vector<CylinderCommands> ca, cb;
  for (int k = 0; k < 10; ++k) a.Update(0.01 * k, {{3e5, 2e5, 0.001 * k, 0.02}}, &ca);
  ASSERT_TRUE(b.SetState(a.State()));
  a.Update(0.1, {{3e5, 2e5, 0.011, 0.02}}, &ca);
  b.Update(0.1, {{3e5, 2e5, 0.011, 0.02}}, &cb);
  EXPECT_EQ(ca, cb);
  EXPECT_FALSE(b.SetState({1, 2}));
  // paper 000's set-up: uP and uN move apart around the valve centre plus the co-contraction
  ASSERT_EQ(ca[0].size(), 2u);
  EXPECT_EQ(ca[0][0].first, "uP");
  EXPECT_NEAR((ca[0][0].second + ca[0][1].second) / 2, 5 + 0.5, 1e-12);
  EXPECT_GT(ca[0][0].second, ca[0][1].second);  // x below its target: push P
}

// With a bandwidth, the gains of the triple pole at -w on the cylinder's authority
// a = F_span mobility / (l/2) replace the fixed ones where larger, tick by tick; the integral of the
// error carries over. By hand: F_span = 100 N, l/2 = 0.05 m, w = 20 rad/s, T = 0.01 s.
TEST(PositionPid, BandwidthRaisesTheGainsToTheLoad) {
  ValveDrive drive;
  drive.half_stroke = 0.05, drive.force_span = 100;
  PositionPidGains gains;
  gains.kp = gains.ki = gains.kd = 0, gains.bandwidth = 20, gains.co_contraction = 0.5, gains.swing = 2;
  PositionPid pid({drive}, {gains}, 0.01);
  EXPECT_TRUE(pid.UsesMobility());
  EXPECT_FALSE(PositionPid({drive}, {PositionPidGains{}}, 0.01).UsesMobility());
  std::vector<CylinderCommands> out;
  CylinderMeasurement y;
  // mobility 2 1/kg: a = 4000 1/s^2, kp = 3 w^2/a = 0.3, ki = w^3/a = 2, kd = 3 w/a = 0.015; x = 0,
  // ref = 1 mm: e = 0.02 (of l/2), no rate yet: d = 0.3 * 0.02 + 2 * 0.02 * 0.01 = 0.0064
  y.x = 0, y.reference = 0.001, y.mobility = 2;
  pid.Update(0, {y}, &out);
  EXPECT_NEAR(out[0][0].second, 5 + 0.5 + 2 * 0.0064, 1e-12);
  // mobility 4: a = 8000, the gains halve; x = 0.5 mm: e = 0.01, the integral 2e-4 + 1e-4, the rate
  // 0.01 / 0.01 s: d = 0.15 * 0.01 + 1 * 3e-4 - 0.0075 * 1 = -0.0057
  y.x = 0.0005, y.mobility = 4;
  pid.Update(0.01, {y}, &out);
  EXPECT_NEAR(out[0][0].second, 5 + 0.5 - 2 * 0.0057, 1e-12);
  EXPECT_NEAR(out[0][1].second, 5 + 0.5 + 2 * 0.0057, 1e-12);
  // fixed gains above the placed ones stay: kp = 1 against 0.15
  PositionPidGains floor = gains;
  floor.kp = 1;
  PositionPid fixed({drive}, {floor}, 0.01);
  y.x = 0, y.mobility = 4;
  fixed.Update(0, {y}, &out);
  EXPECT_NEAR(out[0][0].second, 5 + 0.5 + 2 * (1 * 0.02 + 1 * 0.02 * 0.01), 1e-12);
  // no mobility measured: the fixed gains alone (kp = 1, ki = kd = 0)
  PositionPid blind({drive}, {floor}, 0.01);
  y.mobility = 0;
  blind.Update(0, {y}, &out);
  EXPECT_NEAR(out[0][0].second, 5 + 0.5 + 2 * 0.02, 1e-12);
}

// a controller that records each tick's mobility and leaves the valves at rest; `reads` says
// whether it declares that it reads the mobility
class MobilityRecorder : public Controller {
 public:
  MobilityRecorder(std::vector<double>* seen, bool reads) : seen_(seen), reads_(reads) {}
  double Period() const override { return 0.01; }
  void Update(double, const std::vector<CylinderMeasurement>& measured, std::vector<CylinderCommands>* commands) override {
    seen_->push_back(measured[0].mobility);
    commands->assign(measured.size(), {{"uP", 5.0}, {"uN", 5.0}});
  }
  std::vector<double> State() const override { return {}; }
  bool SetState(const std::vector<double>& state) override { return state.empty(); }
  bool UsesMobility() const override { return reads_; }

 private:
  std::vector<double>* seen_;
  bool reads_;
};

// On rig C the piston is the slide joint's 0.5 kg body: the rollout measures a mobility of 1/0.5 kg
// at every tick for a controller that reads it (0 for one that does not), and computing it leaves
// the run as it was (the same log as without a controller: the valves at rest either way)
TEST(ClosedLoop, MeasuresTheMobilityThePistonSees) {
  AttachedModel model;
  ASSERT_TRUE(model.Load(ShippedModel("rig_per_chamber.xml"), true)) << model.error();
  std::vector<double> seen;
  ClosedLoopOptions options;
  options.duration = 0.2;
  options.controller = "custom";
  bool reads = true;
  options.make_controller = [&](const std::vector<ValveDrive>&, double, std::string*) {
    return std::unique_ptr<Controller>(new MobilityRecorder(&seen, reads));
  };
  ClosedLoopResult recorded = RunClosedLoop(model.m(), options);
  ASSERT_TRUE(recorded.log) << recorded.error;
  ASSERT_EQ(seen.size(), 20u);
  for (double mobility : seen) EXPECT_NEAR(mobility, 1 / 0.5, 1e-12);
  seen.clear(), reads = false;
  ASSERT_TRUE(RunClosedLoop(model.m(), options).log);
  ASSERT_EQ(seen.size(), 20u);
  for (double mobility : seen) EXPECT_EQ(mobility, 0);
  options.controller = "none";
  ClosedLoopResult rest = RunClosedLoop(model.m(), options);
  ASSERT_TRUE(rest.log) << rest.error;
  for (size_t c = 0; c < rest.log->values.size(); ++c) EXPECT_EQ(recorded.log->values[c], rest.log->values[c]);
}

// The humanoid under the gains it carries (<text name="pneumo:controller:pid">, which `pneumo rollout
// --controller pid` uses: those of models_mjcf/humanoid_pid.json, HumanoidCarriesTheGainsOf...): holding its initial pose
// while the chambers fill from atmosphere, every vane within 0.01 rad RMS and every linear cylinder
// within 2.5 mm RMS (a tenth of the 25 mm strokes of its smallest cylinders; under the default gains
// the waist yaw swings by 0.8 rad); performing the wave (models_mjcf/humanoid_wave.csv), the waving
// joint within 0.1 rad RMS (the wave swings it by +-0.44 rad at 1 Hz), the other vanes within
// 0.05 rad and the linear cylinders within 5 mm; in both, every chamber inside [p_exhaust, p_supply]
// at every step (the shipped gains set pressure targets 30 kPa inside it; under the valve mapping 10
// cylinders pass p_supply holding and 14 in the wave). The same with the identified pressure model.
TEST(Humanoid, HoldsItsPoseAndWavesUnderItsShippedGains) {
  log::ReadResult wave = log::ReadLog(ShippedModel("humanoid_wave.csv"), {});
  ASSERT_TRUE(wave.log) << wave.error;
  for (const char* file : {"humanoid_pneumatic.xml", "humanoid_pneumatic_identified.xml"}) {
    SCOPED_TRACE(file);
    AttachedModel model;
    ASSERT_TRUE(model.Load(ShippedModel(file), true)) << model.error();
    const mjModel* m = model.m();
    const std::vector<const log::Log*> references = {nullptr, &*wave.log};  // hold, then wave
    for (const log::Log* reference : references) {
      ClosedLoopOptions options;
      nlohmann::json gains;
      std::string where;
      bool carried = false;
      ASSERT_EQ(ModelControllerConfig(m, "pid", &gains, &where, &carried), "");
      ASSERT_TRUE(carried);
      ASSERT_EQ(ReadControllerConfig(gains, where, &options), "");
      options.duration = reference ? 7.5 : 5;
      options.reference = reference;
      ClosedLoopResult run = RunClosedLoop(m, options);
      ASSERT_TRUE(run.log) << run.error;
      const std::vector<CylinderInfo> cylinders = Cylinders(m);
      ASSERT_EQ(run.summary.cylinders.size(), cylinders.size());
      int vanes = 0;
      for (size_t i = 0; i < cylinders.size(); ++i) {
        const CylinderSummary& s = run.summary.cylinders[i];
        // a vane is on its hinge; a linear cylinder is pinned between two sites (mount=hinge_sites), whose
        // chamber actuators drive the hinge too
        const bool vane = DrivenJoint(m, cylinders[i]) >= 0;
        vanes += vane;
        const double bound = !reference ? (vane ? 0.01 : 2.5e-3) : s.name == "r_shoulder_yaw" ? 0.1 : vane ? 0.05 : 5e-3;
        EXPECT_LT(s.rms_tracking_error, bound) << s.name << (reference ? " in the wave" : " holding");
        EXPECT_TRUE(s.within_supply_range) << s.name << (reference ? " in the wave" : " holding") << ": "
                                           << s.p_max[0] << ", " << s.p_max[1] << " Pa";
      }
      EXPECT_EQ(vanes, 8) << "the humanoid's 8 rotary vanes, and 28 linear cylinders held to millimetres";
    }
  }
}

// Both pneumatic humanoids carry the gains of models_mjcf/humanoid_pid.json, the file the README,
// the demo and the benchmarks name (scripts/make_humanoid.py copies it into the model; rerun it after
// editing the file); the motor twin, which the PID does not drive, carries none.
TEST(Humanoid, CarriesTheGainsOfHumanoidPidJson) {
  nlohmann::json file;
  ASSERT_EQ(ReadJsonFile(ShippedModel("humanoid_pid.json"), &file), "");
  for (const char* name : {"humanoid_pneumatic.xml", "humanoid_pneumatic_identified.xml", "humanoid_motors.xml"}) {
    SCOPED_TRACE(name);
    char error[1000] = "";
    std::unique_ptr<mjModel, void (*)(mjModel*)> m(mj_loadXML(ShippedModel(name).c_str(), nullptr, error, sizeof(error)),
                                                   mj_deleteModel);
    ASSERT_TRUE(m) << error;
    nlohmann::json carried;
    std::string where;
    bool found = false;
    ASSERT_EQ(ModelControllerConfig(m.get(), "pid", &carried, &where, &found), "");
    if (std::string(name) == "humanoid_motors.xml") {
      EXPECT_FALSE(found);
    } else {
      ASSERT_TRUE(found);
      EXPECT_EQ(where, "the model's custom text 'pneumo:controller:pid'");
      EXPECT_EQ(carried, file);
    }
  }
}

// Pressure targets (PositionPidGains::pressure_margin, controllers/position_pid.h) on rig C. At the
// first tick the piston sits on its target (demand 0), so both chambers aim at the middle of the supply
// range, 360 kPa, from p_atm. Each valve gets the command whose flow at the tick, held, would close
// pressure_step = a quarter of the error in one 10 ms period: 4.82 V, below the centre, because eq. 3's
// smoothing leaves the supply port 0.26 mm^2 open there. The inflow stays choked all the tick, and the
// exhaust port, 0.43 mm^2 open at that command, takes back a share that grows with the pressure, to
// 38 % of the inflow at the tick's end (148 kPa, subsonic to p_exhaust; eq. 1c by hand). So P covers
// between 0.25 x 0.62 = 15.5 % and 25 % of the way. Then the rig follows the 10 mm step within 1 mm,
// as under the valve mapping, every chamber at every step inside [p_exhaust, p_supply - margin].
// found by tests/fuzz/fuzz_controller_config: a number beyond a double threw past the syntax-error handler
// and ended the program (std::terminate) instead of naming the file
TEST(ControllerConfig, ANumberBeyondADoubleIsAnErrorNamingTheFile) {
  nlohmann::json config;
  const std::string error = ParseJson("{\"kp\": -1e511}", "gains.json", &config);
  EXPECT_THAT(error, HasSubstr("gains.json: "));
  EXPECT_THAT(error, HasSubstr("number overflow"));
  EXPECT_THAT(ParseJson("{\"kp\": ", "gains.json", &config), HasSubstr("gains.json: "));
  EXPECT_EQ(ParseJson("{\"kp\": 1.5}", "gains.json", &config), "");
  EXPECT_EQ(config["kp"], 1.5);
}

TEST(ClosedLoop, PressureTargetsMoveEachChamberAQuarterOfTheWayPerTickAndStayBelowTheSupply) {
  AttachedModel model;
  ASSERT_TRUE(model.Load(ShippedModel("rig_per_chamber.xml"), true)) << model.error();
  const log::Log reference = StepReference(0.01);
  ClosedLoopOptions options;
  options.duration = 3;
  options.reference = &reference;
  options.gains.pressure_margin = 30e3;
  ClosedLoopResult result = RunClosedLoop(model.m(), options);
  ASSERT_TRUE(result.log) << result.error;
  const log::Log& log = *result.log;
  const std::vector<double>& p_P = log.values[static_cast<size_t>(log.FindColumn("cyl", "p_P"))];
  const std::vector<double>& x = log.values[static_cast<size_t>(log.FindColumn("cyl", "x"))];
  const double p_atm = 1e5, p_mid = (6.2e5 + 1e5) / 2;
  ASSERT_EQ(p_P[0], p_atm);
  const double covered = (p_P[1] - p_atm) / (p_mid - p_atm);
  EXPECT_GT(covered, 0.155);
  EXPECT_LE(covered, 0.25);
  EXPECT_NEAR(x.back(), 0.01, 1e-3);
  const CylinderSummary& s = result.summary.cylinders[0];
  EXPECT_TRUE(s.within_supply_range);
  for (int k = 0; k < 2; ++k) EXPECT_LE(s.p_max[k], 6.2e5 - 30e3) << "chamber " << k;
  // pressure targets need the physical model of a per-chamber valve, and room between the margins
  options.gains.pressure_margin = 260e3;
  EXPECT_THAT(RunClosedLoop(model.m(), options).error, HasSubstr("pressure_margin 260000"));
  options.gains.pressure_margin = 30e3, options.gains.pressure_step = 1.5;
  EXPECT_THAT(RunClosedLoop(model.m(), options).error, HasSubstr("pressure_step must be in (0, 1]"));
  options.gains.pressure_step = 0.25;
  AttachedModel five_three;
  ASSERT_TRUE(five_three.Load(ShippedModel("rig_proportional.xml"), true)) << five_three.error();
  options.gains.pressure_margin = 30e3;
  EXPECT_THAT(RunClosedLoop(five_three.m(), options).error,
              HasSubstr("cylinder 'cyl': pressure_margin needs one proportional valve per chamber"));
}

// Pressure targets on paper 000's identified model: each valve gets the command whose pressure,
// predicted one period on by eq. 7 (s and r of eqs. 8-10, the volume sensor held), is the aim
// p + pressure_step (p* - p). On a rig whose piston cannot move (a 1e6 kg load) and whose model has no
// volume terms (c4 = c5 = c6 = 0), s and r stay as the command set them, so the extension's step of
// eq. 7 lands on the aim: from p_atm, with the piston on its target (demand 0, p* = 360 kPa),
// 100 + 0.25 (360 - 100) = 165 kPa after one tick and 165 + 0.25 (360 - 165) = 213.75 kPa after two.
TEST(ClosedLoop, PressureTargetsOnTheIdentifiedModelLandOnTheirAim) {
  AttachedModel model;
  ASSERT_TRUE(model.Load(testing::IdentifiedRig())) << model.error();
  ClosedLoopOptions options;
  options.duration = 0.03;
  options.gains.pressure_margin = 30e3;
  ClosedLoopResult result = RunClosedLoop(model.m(), options);
  ASSERT_TRUE(result.log) << result.error;
  const log::Log& log = *result.log;
  for (const char* signal : {"p_P", "p_N"}) {
    const std::vector<double>& p = log.values[static_cast<size_t>(log.FindColumn("cyl", signal))];
    EXPECT_EQ(p[0], 1e5) << signal;
    EXPECT_NEAR(p[1], 165e3, 1) << signal;
    EXPECT_NEAR(p[2], 213.75e3, 1) << signal;
  }
}

TEST(ClosedLoop, BadOptionsAreNamed) {
  AttachedModel model;
  ASSERT_TRUE(model.Load(ShippedModel("rig_per_chamber.xml"), true)) << model.error();
  ClosedLoopOptions options;
  options.duration = 1;
  options.control_rate = 3000;  // 0.33 ms: not a whole number of 0.1 ms steps
  EXPECT_THAT(RunClosedLoop(model.m(), options).error, HasSubstr("not a whole number of model timesteps"));
  options.control_rate = 100;
  options.controller = "mpc";
  EXPECT_THAT(RunClosedLoop(model.m(), options).error, HasSubstr("unknown controller 'mpc'"));
  options.controller = "pid";
  options.cylinder_gains["knee"] = {};
  EXPECT_THAT(RunClosedLoop(model.m(), options).error, HasSubstr("'knee', which is not a cylinder"));
  options.cylinder_gains.clear();
  options.command_delay_ticks = -1;
  EXPECT_THAT(RunClosedLoop(model.m(), options).error, HasSubstr("command delay must be >= 0"));
  options.command_delay_ticks = 2;
  ClosedLoopState state;
  options.resume = &state;
  EXPECT_THAT(RunClosedLoop(model.m(), options).error, HasSubstr("command delay cannot be resumed"));
}

// command_delay_ticks: the valves get each tick's commands, as logged, that many ticks late, and
// stay at rest (rig C: 5 V, each valve at its centre) until the first arrives
TEST(ClosedLoop, ACommandDelayHandsTheValvesEachTicksCommandsThatManyTicksLate) {
  AttachedModel model;
  ASSERT_TRUE(model.Load(ShippedModel("rig_per_chamber.xml"), true)) << model.error();
  ClosedLoopOptions options;
  options.duration = 0.1;
  options.control_rate = 100;  // 100 steps of 0.1 ms per tick
  options.command_delay_ticks = 3;
  const log::Log ref = StepReference(0.02);
  options.reference = &ref;
  const int uP = mj_name2id(model.m(), mjOBJ_ACTUATOR, "cyl.uP");
  std::vector<double> applied;  // cyl.uP's ctrl over each step
  bool first = true;
  options.observer = [&](const mjData* d) {
    if (!first) applied.push_back(d->ctrl[uP]);
    first = false;
    return std::string();
  };
  ClosedLoopResult r = RunClosedLoop(model.m(), options);
  ASSERT_TRUE(r.log) << r.error;
  const std::vector<double>& logged = r.log->values[r.log->FindColumn("cyl", "uP")];
  ASSERT_EQ(logged.size(), 10u);
  ASSERT_EQ(applied.size(), 1000u);
  EXPECT_NEAR(applied[0], 5.0, 1e-12);
  for (size_t k = 0; k < 10; ++k) {
    const double expected = k < 3 ? applied[0] : logged[k - 3];
    for (size_t step = 0; step < 100; ++step) ASSERT_EQ(applied[100 * k + step], expected) << "tick " << k << ", step " << step;
  }
  EXPECT_GT(std::fabs(logged[0] - 5.0), 0.1) << "the PID's first command is not the rest command: the test shows nothing";
}

// Issue 16: "a rollout saved mid-way and resumed gives the same log, bit for bit": 1 s, then 1 s
// more from its final state, against 2 s in one go; with sensor noise (the streams are state too),
// under the PID on rig C and paper 002's 7-mode controller on rig A
TEST(ClosedLoop, ARunSavedMidWayAndResumedGivesTheSameLogBitForBit) {
  struct Case {
    const char* rig;
    double rate;
    bool sliding;
  };
  for (Case c : {Case{"rig_per_chamber.xml", 100, false}, Case{"rig_onoff.xml", 500, true}}) {
    AttachedModel model;
    ASSERT_TRUE(model.Load(ShippedModel(c.rig), true)) << model.error();
    const log::Log reference = StepReference(0.01);
    ClosedLoopOptions options;
    options.reference = &reference;
    options.control_rate = c.rate;
    options.noise_pressure = 500, options.noise_position = 1e-4, options.seed = 3;
    if (c.sliding) {
      options.controller = "custom";
      options.make_controller = [](const std::vector<ValveDrive>& drives, double period, std::string* error) {
        return std::unique_ptr<Controller>(SlidingModeController::Create(drives, SlidingModeParams{}, period, error));
      };
    }
    options.duration = 2;
    const ClosedLoopResult whole = RunClosedLoop(model.m(), options);
    options.duration = 1;
    const ClosedLoopResult first = RunClosedLoop(model.m(), options);
    options.resume = &first.final_state;
    const ClosedLoopResult second = RunClosedLoop(model.m(), options);
    ASSERT_TRUE(whole.log && first.log && second.log) << c.rig << whole.error << first.error << second.error;
    ASSERT_EQ(first.log->rows() + second.log->rows(), whole.log->rows()) << c.rig;
    for (size_t col = 0; col < whole.log->values.size(); ++col) {
      std::vector<double> joined = first.log->values[col];
      joined.insert(joined.end(), second.log->values[col].begin(), second.log->values[col].end());
      EXPECT_TRUE(testing::SameBits(joined, whole.log->values[col])) << c.rig << " " << whole.log->columns[col].name();
    }
    std::vector<double> times = first.log->time;
    times.insert(times.end(), second.log->time.begin(), second.log->time.end());
    EXPECT_TRUE(testing::SameBits(times, whole.log->time)) << c.rig;
    // a state of another model is refused
    AttachedModel other;
    ASSERT_TRUE(other.Load(ShippedModel("rig_proportional_full.xml"), true)) << other.error();
    options.controller = "pid";
    EXPECT_THAT(RunClosedLoop(other.m(), options).error, HasSubstr("not one of this model's runs")) << c.rig;
  }
}

// a controller of one's own plugs in through the factory; commands that are not the valve's are refused
class WrongSignals : public Controller {
 public:
  double Period() const override { return 0.01; }
  void Update(double, const std::vector<CylinderMeasurement>& measured, std::vector<CylinderCommands>* commands) override {
    commands->assign(measured.size(), {{"u", 1.0}});
  }
  std::vector<double> State() const override { return {}; }
  bool SetState(const std::vector<double>& state) override { return state.empty(); }
};

TEST(ClosedLoop, CustomControllersPlugInAndMustWriteTheValvesSignals) {
  AttachedModel model;
  ASSERT_TRUE(model.Load(ShippedModel("rig_per_chamber.xml"), true)) << model.error();
  ClosedLoopOptions options;
  options.duration = 0.5;
  options.controller = "custom";
  options.make_controller = [](const std::vector<ValveDrive>& drives, double period, std::string*) {
    return std::unique_ptr<Controller>(new PositionPid(drives, std::vector<PositionPidGains>(drives.size()), period));
  };
  ClosedLoopResult custom = RunClosedLoop(model.m(), options);
  options.controller = "pid";
  ClosedLoopResult pid = RunClosedLoop(model.m(), options);
  ASSERT_TRUE(custom.log && pid.log) << custom.error << pid.error;
  for (size_t c = 0; c < pid.log->values.size(); ++c) EXPECT_EQ(custom.log->values[c], pid.log->values[c]);
  options.controller = "custom";
  options.make_controller = [](const std::vector<ValveDrive>&, double, std::string*) {
    return std::unique_ptr<Controller>(new WrongSignals);
  };
  EXPECT_THAT(RunClosedLoop(model.m(), options).error, HasSubstr("are not its valve's signals"));
}

// paper 000's set-up: position and co-contraction driven separately. At 1 kHz on rig C, a step of
// the position to -20 mm under a mean chamber pressure of 30 % and 70 % of the way from exhaust to
// supply: both reached (0.5 mm; 1 % of supply - exhaust) over the last second of 4 s
TEST(PositionStiffness, HoldsPositionAndMeanPressureSeparately) {
  AttachedModel model;
  ASSERT_TRUE(model.Load(ShippedModel("rig_per_chamber.xml"), true)) << model.error();
  const log::Log reference = StepReference(-0.02);
  for (double mean : {0.3, 0.7}) {
    PositionStiffnessParams params;
    ASSERT_EQ(ParsePositionStiffnessConfig("mean_pressure=" + std::to_string(mean), &params), "");
    ClosedLoopOptions options;
    options.duration = 4;
    options.control_rate = 1000;
    options.reference = &reference;
    options.controller = "custom";
    options.make_controller = [params](const std::vector<ValveDrive>& drives, double period, std::string* error) {
      return std::unique_ptr<Controller>(PositionStiffness::Create(drives, params, period, error));
    };
    ClosedLoopResult result = RunClosedLoop(model.m(), options);
    ASSERT_TRUE(result.log) << result.error;
    const log::Log& log = *result.log;
    const auto& x = log.values[static_cast<size_t>(log.FindColumn("cyl", "x"))];
    const auto& p_P = log.values[static_cast<size_t>(log.FindColumn("cyl", "p_P"))];
    const auto& p_N = log.values[static_cast<size_t>(log.FindColumn("cyl", "p_N"))];
    for (size_t row = log.rows() - 1000; row < log.rows(); ++row) {
      ASSERT_NEAR(x[row], -0.02, 5e-4) << "mean " << mean << ", t = " << log.time[row];
      ASSERT_NEAR(((p_P[row] + p_N[row]) / 2 - 1e5) / 5.2e5, mean, 0.01) << "mean " << mean << ", t = " << log.time[row];
    }
  }
  PositionStiffnessParams params;
  EXPECT_THAT(ParsePositionStiffnessConfig("mean_pressure=1.5", &params), HasSubstr("key 'mean_pressure'"));
  EXPECT_THAT(ParsePositionStiffnessConfig("stifness_kp=1", &params), HasSubstr("unknown key 'stifness_kp'"));
  EXPECT_EQ(params.mean_pressure, 0.5);
  std::string error;
  ValveDrive onoff;
  onoff.kind = ValveDrive::Kind::kOnOff;
  EXPECT_EQ(PositionStiffness::Create({onoff}, params, 0.001, &error), nullptr);
  EXPECT_THAT(error, HasSubstr("one proportional valve per chamber"));
}

std::string Quote(const std::string& s) { return "'" + s + "'"; }

int Pneumo(const std::string& args, std::string* err) {
  const std::string err_path = ::testing::TempDir() + "closed_loop_err_" + std::to_string(getpid());
  int status = std::system((Quote(PNEUMO_BINARY) + " " + args + " >/dev/null 2>" + Quote(err_path)).c_str());
  *err = ReadText(err_path);
  fs::remove(err_path);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// the command line: two seeds on one or two threads give the same bytes; the summary has its keys
TEST(ClosedLoopCommand, JobsDoNotChangeTheLogs) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("closed_loop_" + std::to_string(getpid()));
  fs::create_directories(dir);
  std::string err;
  for (const char* jobs : {"1", "2"}) {
    const std::string out = (dir / (std::string("j") + jobs + "_{run}.csv")).string();
    const std::string summary = (dir / (std::string("j") + jobs + "_{run}.json")).string();
    ASSERT_EQ(Pneumo("rollout " + Quote(ShippedModel("rig_per_chamber.xml")) +
                         " --controller pid --duration 0.5 --seed 1 --seed 2 --noise-position 1e-4 --jobs " + jobs +
                         " --out " + Quote(out) + " --summary " + Quote(summary),
                     &err),
              0)
        << err;
  }
  for (const char* run : {"seed1", "seed2"}) {
    EXPECT_TRUE(ReadText((dir / (std::string("j1_") + run + ".csv")).string()) ==
                ReadText((dir / (std::string("j2_") + run + ".csv")).string()))
        << run;
  }
  nlohmann::json s = nlohmann::json::parse(ReadText((dir / "j2_seed1.json").string()));
  for (const char* key : {"steps", "real_time_factor", "cylinders", "warnings"}) EXPECT_TRUE(s.contains(key)) << key;
  EXPECT_EQ(s["controller"], (nlohmann::json{{"name", "pid"}, {"configuration", "the controller's defaults"}}));
  EXPECT_EQ(s["steps"].get<long>(), 5000);
  // several runs need {run} in the output names; a gains file with an unknown key is refused, naming it
  EXPECT_EQ(Pneumo("rollout " + Quote(ShippedModel("rig_per_chamber.xml")) +
                       " --controller pid --duration 0.5 --seed 1 --seed 2 --out " + Quote((dir / "x.csv").string()),
                   &err),
            1);
  EXPECT_THAT(err, HasSubstr("{run}"));
  std::ofstream((dir / "gains.json").string()) << R"({"kp": 2, "kpp": 3})";
  EXPECT_EQ(Pneumo("rollout " + Quote(ShippedModel("rig_per_chamber.xml")) + " --controller pid --controller-config " +
                       Quote((dir / "gains.json").string()) + " --duration 0.5 --out " + Quote((dir / "x.csv").string()),
                   &err),
            1);
  EXPECT_THAT(err, HasSubstr("unknown key 'kpp'"));
  EXPECT_EQ(Pneumo("rollout " + Quote(ShippedModel("rig_per_chamber.xml")) + " --reference x.csv --duration 1 --out " +
                       Quote((dir / "x.csv").string()),
                   &err),
            1);
  EXPECT_THAT(err, HasSubstr("--reference needs --controller"));
  // the papers' controllers from the command line: a config key they do not know is named
  std::ofstream((dir / "sliding.json").string()) << R"({"omega": 100, "omegaa": 3})";
  EXPECT_EQ(Pneumo("rollout " + Quote(ShippedModel("rig_onoff.xml")) + " --controller sliding7 --controller-config " +
                       Quote((dir / "sliding.json").string()) + " --control-rate 500 --duration 0.5 --out " +
                       Quote((dir / "x.csv").string()),
                   &err),
            1);
  EXPECT_THAT(err, HasSubstr("key 'omegaa'"));
  // and one runs on its rig
  EXPECT_EQ(Pneumo("rollout " + Quote(ShippedModel("rig_onoff.xml")) +
                       " --controller sliding7 --control-rate 500 --duration 0.5 --out " + Quote((dir / "x.csv").string()),
                   &err),
            0)
      << err;
  fs::remove_all(dir);
}

// Every run writes its own files: a seed given twice, two variations of one name, or a name that is not
// a plain file name part ('/' would write elsewhere) is refused before anything runs, and nothing is written
TEST(ClosedLoopCommand, RefusesRunsThatWouldWriteTheSameFiles) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("closed_loop_names_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string rig = Quote(ShippedModel("rig_per_chamber.xml"));
  const std::string out = " --duration 0.1 --out " + Quote((dir / "{run}.csv").string());
  std::string err;
  EXPECT_EQ(Pneumo("rollout " + rig + " --controller pid --seed 1 --seed 2 --seed 1 --jobs 2" + out, &err), 1);
  EXPECT_THAT(err, HasSubstr("--seed 1 is given twice"));
  const std::pair<const char*, const char*> cases[] = {
      {R"([{"name": "a", "set": {"cyl:dead_volume": 3e-6}}, {"name": "a", "set": {"cyl:dead_volume": 4e-6}}])",
       "two variations are named 'a'"},
      {R"([{"name": "../a", "set": {}}])", "variation name '../a' must be a non-empty file name part"},
      {R"([{"name": "", "set": {}}])", "variation name '' must be a non-empty file name part"}};
  for (const auto& [variations, message] : cases) {
    std::ofstream((dir / "variations.json").string()) << variations;
    EXPECT_EQ(Pneumo("rollout " + rig + " --controller pid --variations " + Quote((dir / "variations.json").string()) + out, &err), 1);
    EXPECT_THAT(err, HasSubstr(message));
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1) << "only variations.json";
  fs::remove_all(dir);
}

// Without --duration a run follows its --reference to the end: its log is the bytes of the same run
// with --duration set to the reference's last time (0.3 s here); holding a pose has no length of its
// own, and a reference that ends at t = 0 none either: each is refused, naming what to give, as is a
// --duration of 0
TEST(ClosedLoopCommand, RunsTheReferencesSpanWithoutADuration) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("closed_loop_span_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string rig = Quote(ShippedModel("rig_per_chamber.xml"));
  std::ofstream((dir / "ref.csv").string()) << "time,cyl.ref\n0,0\n0.1,0.01\n0.3,0.02\n";
  const std::string reference = " --reference " + Quote((dir / "ref.csv").string());
  std::string err;
  ASSERT_EQ(Pneumo("rollout " + rig + " --controller pid" + reference + " --out " + Quote((dir / "span.csv").string()), &err), 0)
      << err;
  EXPECT_THAT(err, HasSubstr("running the reference's 0.3 s"));
  ASSERT_EQ(Pneumo("rollout " + rig + " --controller pid" + reference + " --duration 0.3 --out " +
                       Quote((dir / "given.csv").string()),
                   &err),
            0)
      << err;
  const std::string span = ReadText((dir / "span.csv").string());
  EXPECT_FALSE(span.empty());
  EXPECT_TRUE(span == ReadText((dir / "given.csv").string()));
  EXPECT_EQ(Pneumo("rollout " + rig + " --controller pid --out " + Quote((dir / "x.csv").string()), &err), 1);
  EXPECT_THAT(err, HasSubstr("--controller needs --duration (or a --reference"));
  std::ofstream((dir / "ref0.csv").string()) << "time,cyl.ref\n0,0\n";
  EXPECT_EQ(Pneumo("rollout " + rig + " --controller pid --reference " + Quote((dir / "ref0.csv").string()) + " --out " +
                       Quote((dir / "x.csv").string()),
                   &err),
            1);
  EXPECT_THAT(err, HasSubstr("ref0.csv: its last row is at t = 0 s, not after the run's start at 0 s: give --duration"));
  // a --duration of 0 is a mistake, not a request for the reference's span
  EXPECT_EQ(Pneumo("rollout " + rig + " --controller pid" + reference + " --duration 0 --out " + Quote((dir / "x.csv").string()), &err), 1);
  EXPECT_THAT(err, HasSubstr("--duration must be positive"));
  EXPECT_FALSE(fs::exists(dir / "x.csv"));
  fs::remove_all(dir);
}

// A model carries its controller's configuration as <text name="pneumo:controller:pid" data='{...}'>:
// without --controller-config the rollout runs on it (the same bytes as the same JSON given as a file,
// other bytes than the defaults), --controller-config replaces it, and a bad key in it is refused,
// naming the model file, the text and the key.
TEST(ClosedLoopCommand, UsesTheConfigurationTheModelCarries) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("closed_loop_carried_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string rig = ReadText(ShippedModel("rig_per_chamber.xml"));
  ASSERT_NE(rig.find("<custom>"), std::string::npos);
  auto model_carrying = [&](const std::string& name, const std::string& json) {
    const std::string path = (dir / name).string();
    std::ofstream(path) << ReplaceAll(rig, "<custom>", "<custom>\n    <text name=\"pneumo:controller:pid\" data='" + json + "'/>");
    return path;
  };
  const std::string gains = R"({"kp": 0.5, "kd": 0})";
  const std::string carrying = model_carrying("carrying.xml", gains);
  std::ofstream((dir / "gains.json").string()) << gains;
  std::ofstream((dir / "empty.json").string()) << "{}";
  std::string err;
  auto run = [&](const std::string& model, const std::string& extra, const std::string& out) {
    EXPECT_EQ(Pneumo("rollout " + Quote(model) + " --controller pid --duration 0.3 " + extra + " --out " +
                         Quote((dir / out).string()),
                     &err),
              0)
        << err;
    return ReadText((dir / out).string());
  };
  const std::string carried = run(carrying, "--summary " + Quote((dir / "carried.json").string()), "carried.csv");
  EXPECT_THAT(err, HasSubstr("pid configuration from " + carrying + ": the model's custom text 'pneumo:controller:pid'"));
  // the summary says which gains the run had
  const nlohmann::json summary = nlohmann::json::parse(ReadText((dir / "carried.json").string()));
  EXPECT_EQ(summary["controller"]["name"], "pid");
  EXPECT_EQ(summary["controller"]["configuration"], carrying + ": the model's custom text 'pneumo:controller:pid'");
  const std::string from_file = run(ShippedModel("rig_per_chamber.xml"), "--controller-config " + Quote((dir / "gains.json").string()), "file.csv");
  const std::string defaults = run(ShippedModel("rig_per_chamber.xml"), "", "defaults.csv");
  const std::string replaced = run(carrying, "--controller-config " + Quote((dir / "empty.json").string()), "replaced.csv");
  EXPECT_THAT(err, Not(HasSubstr("custom text")));
  // the logs' first comment names the model: compare from the header on
  auto body = [](const std::string& log) { return log.substr(log.find("\ntime,")); };
  EXPECT_TRUE(body(carried) == body(from_file));
  EXPECT_FALSE(body(carried) == body(defaults));
  EXPECT_TRUE(body(replaced) == body(defaults));

  const std::string bad = model_carrying("bad.xml", R"({"kp": 2, "kpp": 3})");
  EXPECT_EQ(Pneumo("rollout " + Quote(bad) + " --controller pid --duration 0.3 --out " + Quote((dir / "x.csv").string()), &err), 1);
  EXPECT_THAT(err, HasSubstr(bad + ": the model's custom text 'pneumo:controller:pid': unknown key 'kpp'"));
  const std::string broken = model_carrying("broken.xml", R"({"kp": 2,)");
  EXPECT_EQ(Pneumo("rollout " + Quote(broken) + " --controller pid --duration 0.3 --out " + Quote((dir / "x.csv").string()), &err), 1);
  EXPECT_THAT(err, HasSubstr(broken + ": the model's custom text 'pneumo:controller:pid': [json.exception.parse_error"));
  EXPECT_FALSE(fs::exists(dir / "x.csv"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace pneumatic
