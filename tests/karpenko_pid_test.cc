// Paper 001's nonlinear PI (controllers/karpenko_pid.h) by hand on small cases and closed loop on
// rig B (models_mjcf/rig_proportional_full.xml: the paper's deadband and friction; rig_proportional.xml:
// nominal), and its reproduction (pneumo/reproduce_karpenko2006.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "karpenko_pid.h"
#include "reproductions/reproduce_karpenko2006.h"
#include "simulation/closed_loop.h"
#include "test_util.h"

namespace pneumatic {
namespace {

using ::testing::HasSubstr;
using testing::AttachedModel;
using testing::ShippedModel;

constexpr double kT = 0.001;  // s: rig B's 1 kHz

ValveDrive FiveThree() {
  ValveDrive drive;
  drive.kind = ValveDrive::Kind::kFiveThree;
  drive.half_stroke = 0.25;
  drive.u_max = 5;
  return drive;
}

std::unique_ptr<KarpenkoPid> Make(const KarpenkoPidParams& p) {
  std::string error;
  std::unique_ptr<KarpenkoPid> c = KarpenkoPid::Create({FiveThree()}, p, kT, &error);
  EXPECT_TRUE(c) << error;
  return c;
}

// one tick: the command u for reference r and position x
double Tick(KarpenkoPid* c, double r, double x) {
  std::vector<CylinderCommands> commands;
  c->Update(0, {{3e5, 3e5, x, r}}, &commands);
  EXPECT_EQ(commands.size(), 1u);
  EXPECT_EQ(commands[0].size(), 1u);
  EXPECT_EQ(commands[0][0].first, "u");
  return commands[0][0].second;
}

const std::vector<double>& Signal(const log::Log& log, const char* signal) {
  const int c = log.FindColumn("cyl", signal);
  EXPECT_GE(c, 0) << signal;
  return log.values.at(static_cast<size_t>(c));
}

log::Log RunRigB(const std::string& model_file, const std::string& reference, double size, const std::string& controller) {
  AttachedModel model;
  EXPECT_TRUE(model.Load(ShippedModel(model_file), true)) << model.error();
  double duration = 0;
  std::string error;
  std::optional<log::Log> ref = Karpenko2006Reference(reference, size, &duration, &error);
  EXPECT_TRUE(ref) << error;
  ClosedLoopResult result = RunKarpenko2006(model.m(), *ref, duration, *Karpenko2006Controller(controller));
  EXPECT_TRUE(result.log) << result.error;
  for (const std::string& w : result.summary.warnings) EXPECT_THAT(w, ::testing::Not(HasSubstr("MuJoCo"))) << w;
  return result.log ? *result.log : log::Log();
}

// (14) and (17) by hand
TEST(KarpenkoPid, VelocityErrorEq14AndBrakingEq17) {
  EXPECT_DOUBLE_EQ(KarpenkoVelocityErrorEq14(0, 0.1, 50), -0.1);   // stuck piston: e_db' = -x_d'
  EXPECT_DOUBLE_EQ(KarpenkoVelocityErrorEq14(0, -0.1, 50), 0.1);
  EXPECT_DOUBLE_EQ(KarpenkoVelocityErrorEq14(0.1, 0.1, 50), 0);    // tracking: none
  EXPECT_DOUBLE_EQ(KarpenkoVelocityErrorEq14(0, 0, 50), 0);        // both still: 0, not 0/0
  EXPECT_DOUBLE_EQ(KarpenkoVelocityErrorEq14(0.2, 0, 50), 0);      // reference still: x_d'^2 = 0
  // (0.05 - 0.1) 0.01 / (0.01 + 50 0.0025) = -0.0005 / 0.135
  EXPECT_NEAR(KarpenkoVelocityErrorEq14(0.05, 0.1, 50), -0.0005 / 0.135, 1e-15);
  EXPECT_EQ(KarpenkoBrakingEq17(0.1, -2), -2);  // decelerating: braking
  EXPECT_EQ(KarpenkoBrakingEq17(-0.1, 2), 2);
  EXPECT_EQ(KarpenkoBrakingEq17(0.1, 2), 0);    // accelerating: none
  EXPECT_EQ(KarpenkoBrakingEq17(0, -2), 0);
}

// (12)-(13): u = K_p e + K_i I, I integrates e dt while |e| > eps and is zeroed when |e| <= eps
TEST(KarpenkoPid, ResetIntegratorZeroesTheIntegralInsideEpsilon) {
  KarpenkoPidParams p;  // paper: K_p = 10, K_i = 26, eps = 1 mm, reset on
  for (bool reset : {true, false}) {
    p.reset = reset;
    auto c = Make(p);
    double I = 0;
    for (int k = 0; k < 3; ++k) {  // e = 5 mm
      I += 0.005 * kT;
      EXPECT_NEAR(Tick(c.get(), 0, -0.005), 10 * 0.005 + 26 * I, 1e-15);
      EXPECT_EQ(c->LastBranch(0), KarpenkoPid::kIntegrate);
    }
    EXPECT_NEAR(c->Integral(0), 1.5e-5, 1e-18);
    // the error crosses into |e| <= eps = 1 mm
    const double u = Tick(c.get(), 0, -0.0009);
    if (reset) {
      EXPECT_EQ(c->Integral(0), 0);
      EXPECT_EQ(c->LastBranch(0), KarpenkoPid::kReset);
      EXPECT_NEAR(u, 10 * 0.0009, 1e-15);
    } else {
      EXPECT_NEAR(c->Integral(0), 1.5e-5 + 0.0009 * kT, 1e-18);
      EXPECT_NEAR(u, 10 * 0.0009 + 26 * (1.5e-5 + 0.0009 * kT), 1e-15);
    }
  }
  // outside eps again: integrates from zero; exactly at eps: reset (|e| <= eps)
  auto c = Make(KarpenkoPidParams());
  Tick(c.get(), 0, -0.0005);
  Tick(c.get(), 0, 0.002);
  EXPECT_NEAR(c->Integral(0), -0.002 * kT, 1e-18);
  Tick(c.get(), 0, -0.001);
  EXPECT_EQ(c->Integral(0), 0);
  // saturation at the valve's u_max = 5 V
  EXPECT_EQ(Tick(c.get(), 0, -1), 5);
}

// reset_when_still: inside eps the integral is zeroed only while the reference is still (x_d' = 0)
TEST(KarpenkoPid, ResetOnlyWhileTheReferenceIsStill) {
  KarpenkoPidParams p;
  auto c = Make(p);
  Tick(c.get(), 0, -0.005);                 // I = 5e-6
  Tick(c.get(), 0.0001, 0.0001 - 0.0005);   // moving reference, |e| = 0.5 mm: integrates
  EXPECT_EQ(c->LastBranch(0), KarpenkoPid::kIntegrate);
  EXPECT_NEAR(c->Integral(0), 0.005 * kT + 0.0005 * kT, 1e-18);
  Tick(c.get(), 0.0001, 0.0001 - 0.0005);   // still again: reset
  EXPECT_EQ(c->LastBranch(0), KarpenkoPid::kReset);
  p.reset_when_still = false;               // (13) as printed: resets while moving too
  c = Make(p);
  Tick(c.get(), 0, -0.005);
  Tick(c.get(), 0.0001, 0.0001 - 0.0005);
  EXPECT_EQ(c->LastBranch(0), KarpenkoPid::kReset);
}

// (14)-(15): a reference moving at 0.1 m/s away from a stuck piston brings u to +-u_upper/lower at once
TEST(KarpenkoPid, AugmentationTriggersOnTheVelocityError) {
  KarpenkoPidParams p;
  p.augmentation = true;
  for (double sign : {1.0, -1.0}) {
    auto c = Make(p);
    EXPECT_EQ(Tick(c.get(), 0, 0), 0);
    const double u = Tick(c.get(), sign * 1e-4, 0);  // x_d' = 0.1 m/s, x_p' = 0: e_db' = -0.1 sign
    EXPECT_NEAR(c->VelocityError(0), -0.1 * sign, 1e-12);
    EXPECT_EQ(c->LastBranch(0), sign > 0 ? KarpenkoPid::kAugmentUpper : KarpenkoPid::kAugmentLower);
    EXPECT_NEAR(u, 0.65 * sign, 1e-12);
    EXPECT_NEAR(c->Integral(0), (0.65 * sign - 10 * sign * 1e-4) / 26, 1e-15);
  }
  // already beyond the threshold (u* = 10 V/m x 0.1 m = 1 V > 0.65 V): integrates (row 2)
  auto c = Make(p);
  Tick(c.get(), 0.1, 0);
  const double u = Tick(c.get(), 0.1001, 0);
  EXPECT_EQ(c->LastBranch(0), KarpenkoPid::kIntegrate);
  EXPECT_NEAR(u, 10 * 0.1001 + 26 * (0.1 + 0.1001) * kT, 1e-12);
  // below the threshold e_min' = 5 mm/s: plain integration
  c = Make(p);
  Tick(c.get(), 0, 0);
  Tick(c.get(), 4e-6, 0);  // 4 mm/s
  EXPECT_EQ(c->LastBranch(0), KarpenkoPid::kIntegrate);
  // augmentation off: no trigger
  c = Make(KarpenkoPidParams());
  Tick(c.get(), 0, 0);
  Tick(c.get(), 1e-4, 0);
  EXPECT_EQ(c->LastBranch(0), KarpenkoPid::kIntegrate);
}

// (16)-(17): a decelerating reference takes K_a x_d'' dt off the integral
TEST(KarpenkoPid, BrakingAccelerationEntersTheIntegral) {
  KarpenkoPidParams p;
  p.braking = true;
  auto c = Make(p);
  // the piston on the reference (e = 0, e_db' = 0); x_d: 0, 1e-4, 1.5e-4 -> x_d' = 0.05 m/s, x_d'' = -50 m/s^2
  Tick(c.get(), 0, 0);
  Tick(c.get(), 1e-4, 1e-4);
  EXPECT_EQ(c->Integral(0), 0);  // x_d'' needs two past samples
  const double u = Tick(c.get(), 1.5e-4, 1.5e-4);
  EXPECT_NEAR(c->Integral(0), 0.15 * -50 * kT, 1e-15);
  EXPECT_NEAR(u, 26 * 0.15 * -50 * kT, 1e-12);
  // accelerating (x_d' x_d'' > 0): nothing
  c = Make(p);
  Tick(c.get(), 0, 0);
  Tick(c.get(), 1e-4, 1e-4);
  Tick(c.get(), 2.5e-4, 2.5e-4);
  EXPECT_EQ(c->Integral(0), 0);
  // braking off: nothing
  c = Make(KarpenkoPidParams());
  Tick(c.get(), 0, 0);
  Tick(c.get(), 1e-4, 1e-4);
  Tick(c.get(), 1.5e-4, 1.5e-4);
  EXPECT_EQ(c->Integral(0), 0);
}

TEST(KarpenkoPid, BadConfigIsRefusedNamingTheKey) {
  KarpenkoPidParams p;
  std::string error;
  ASSERT_TRUE(ParseKarpenkoPidConfig("kp=12, epsilon=0.004\naugmentation=1 braking=1", &p, &error)) << error;
  EXPECT_EQ(p.kp, 12);
  EXPECT_EQ(p.epsilon, 0.004);
  EXPECT_TRUE(p.augmentation && p.braking);
  const std::pair<const char*, const char*> bad[] = {
      {"kq=1", "'kq'"},          {"epsilon=-0.001", "'epsilon'"}, {"reset=2", "'reset'"},
      {"ki=abc", "'ki'"},        {"beta=inf", "'beta'"},          {"u_lower", "'u_lower'"},
      {"augmentation=1 ki=0", "'ki'"}, {"ka=-1", "'ka'"},
  };
  for (const auto& [text, key] : bad) {
    KarpenkoPidParams q = p;
    error.clear();
    EXPECT_FALSE(ParseKarpenkoPidConfig(text, &q, &error)) << text;
    EXPECT_THAT(error, HasSubstr(key)) << text;
    EXPECT_THAT(error, HasSubstr("karpenko PID controller")) << text;
    EXPECT_EQ(q.kp, 12) << "unchanged on failure";
  }
  p = KarpenkoPidParams();
  p.e_dot_min = -1;
  EXPECT_FALSE(KarpenkoPid::Create({FiveThree()}, p, kT, &error));
  EXPECT_THAT(error, HasSubstr("'e_dot_min'"));
  ValveDrive per_chamber;
  EXPECT_FALSE(KarpenkoPid::Create({per_chamber}, KarpenkoPidParams(), kT, &error));
  EXPECT_THAT(error, HasSubstr("5/3"));
  // every key of the table parses at its paper value
  for (const KarpenkoPidKey& k : KarpenkoPidKeys()) {
    KarpenkoPidParams q;
    const double v = k.number ? KarpenkoPidParams().*(k.number) : (KarpenkoPidParams().*(k.flag) ? 1 : 0);
    EXPECT_TRUE(SetKarpenkoPidParameter(&q, k.key, v, &error)) << k.key << ": " << error;
  }
}

// the controller's state restored mid-way gives the same commands bit for bit
TEST(KarpenkoPid, StateRestoredMidwayGivesTheSameCommands) {
  const log::Log log = RunRigB("rig_proportional_full.xml", "s_curve", 0, "augmented_braking");
  ASSERT_GT(log.rows(), 1000u);
  const std::vector<double>& x = Signal(log, "x");
  const std::vector<double>& ref = Signal(log, "ref");
  const std::vector<double>& pP = Signal(log, "p_P");
  const std::vector<double>& pN = Signal(log, "p_N");
  const KarpenkoPidParams params = *Karpenko2006Controller("augmented_braking");
  auto whole = Make(params), first = Make(params), second = Make(params);
  const size_t half = log.rows() / 2;
  std::vector<CylinderCommands> a, b;
  for (size_t k = 0; k < log.rows(); ++k) {
    const std::vector<CylinderMeasurement> y = {{pP[k], pN[k], x[k], ref[k]}};
    whole->Update(log.time[k], y, &a);
    if (k == half) ASSERT_TRUE(second->SetState(first->State()));
    KarpenkoPid* c = k < half ? first.get() : second.get();
    c->Update(log.time[k], y, &b);
    ASSERT_EQ(std::memcmp(&a[0][0].second, &b[0][0].second, sizeof(double)), 0) << "tick " << k;
    // and the commands are the run's own (the log holds what the controller wrote)
    ASSERT_EQ(a[0][0].second, Signal(log, "u")[k]) << "tick " << k;
  }
  EXPECT_TRUE(testing::SameBits(whole->State(), second->State()));
  EXPECT_FALSE(second->SetState({1, 2, 3}));
  std::vector<double> bad = whole->State();
  bad[6] = 7;  // no such branch
  EXPECT_FALSE(second->SetState(bad));
}

// a step converges: on the nominal rig B (no deadband or friction) to the target; on rig B with the paper's
// deadband and friction, the paper's gains hunt (stick-slip) within a band of the target
TEST(KarpenkoPid, StepConvergesOnRigB) {
  for (const char* name : {"linear_pi", "reset_pi"}) {
    const log::Log nominal = RunRigB("rig_proportional.xml", "step", kKarpenko2006Step, name);
    const Karpenko2006StepMetrics n = Karpenko2006MeasureStep(nominal, kKarpenko2006StepTime, kKarpenko2006Step);
    EXPECT_LT(n.steady_error_mm, 0.1) << name;  // stated: 0.1 mm over the last 0.5 s of 5 s
    EXPECT_GT(n.rise_time_s, 0) << name;
    EXPECT_LT(n.rise_time_s, 0.5) << name;
    const log::Log full = RunRigB("rig_proportional_full.xml", "step", kKarpenko2006Step, name);
    const Karpenko2006StepMetrics f = Karpenko2006MeasureStep(full, kKarpenko2006StepTime, kKarpenko2006Step);
    EXPECT_GT(f.rise_time_s, 0) << name;
    EXPECT_LT(f.rise_time_s, 1.0) << name;
    // stated: within 10 mm of the target from 1.5 s after the step (the friction band of the hunting)
    const std::vector<double>& x = Signal(full, "x");
    for (size_t k = 0; k < full.rows(); ++k) {
      if (full.time[k] < kKarpenko2006StepTime + 1.5) continue;
      ASSERT_LT(std::fabs(x[k] - kKarpenko2006Step), 0.010) << name << " at " << full.time[k];
    }
  }
}

// max |x_d - x| (mm) after the first `from` s of a sine run on rig B with the paper's deadband and friction
double SineMaxError(const std::string& name, double a, double f, double duration, double from) {
  AttachedModel model;
  EXPECT_TRUE(model.Load(ShippedModel("rig_proportional_full.xml"), true)) << model.error();
  const log::Log ref = Karpenko2006SineReference(a, f, duration);
  ClosedLoopResult result = RunKarpenko2006(model.m(), ref, duration, *Karpenko2006Controller(name));
  EXPECT_TRUE(result.log) << result.error;
  if (!result.log) return 1e9;
  const std::vector<double>& x = Signal(*result.log, "x");
  double worst = 0;
  for (size_t k = 0; k < result.log->rows(); ++k) {
    if (result.log->time[k] >= from) worst = std::max(worst, std::fabs(ref.values[0][k] - x[k]));
  }
  std::printf("sine %.0f mm %.2f Hz, %s: max error %.2f mm\n", 1e3 * a, f, name.c_str(), 1e3 * worst);
  return 1e3 * worst;
}

// a slow sine on rig B with the paper's deadband and friction, judged after the first 2 s
TEST(KarpenkoPid, TracksASlowSineOnRigB) {
  // stated bounds (max error after 2 s, over 1.5 periods): the resetting PI on 50 mm at 0.05 Hz (16 mm/s peak):
  // 40 mm; the full controller (augmentation + braking, eps = 4 mm) on 100 mm at 0.1 Hz (63 mm/s peak): 45 mm,
  // and on 100 mm at 0.2 Hz: 20 mm. Not claimed: the full controller on the 16 mm/s sine (its fixed 0.65 V
  // augmentation runs the piston ahead of so slow a reference; see the reproduction's disagreement list).
  EXPECT_LT(SineMaxError("reset_pi", 0.050, 0.05, 32, 2), 40);
  EXPECT_LT(SineMaxError("augmented_braking", 0.100, 0.1, 17, 2), 45);
  EXPECT_LT(SineMaxError("augmented_braking", 0.100, 0.2, 9.5, 2), 20);
}

// issue 16's done-when: the resetting PI overshoots less than the linear PI; and the report's shape
TEST(KarpenkoPid, ReproductionResettingPiOvershootsLessThanLinearPi) {
  std::string error;
  const nlohmann::json j = ReproduceKarpenko2006(PNEUMATIC_MODELS_DIR, "", &error);
  ASSERT_FALSE(j.is_null()) << error;
  const double linear = j["step"]["linear_pi"]["overshoot_pct"], reset = j["step"]["reset_pi"]["overshoot_pct"];
  EXPECT_LT(reset, linear);
  EXPECT_TRUE(j["done_when"]["pass"].get<bool>());
  EXPECT_LT(j["step_nominal"]["reset_pi"]["overshoot_pct"].get<double>(),
            j["step_nominal"]["linear_pi"]["overshoot_pct"].get<double>());
  for (const char* run : {"linear_pi", "reset_pi"}) {
    for (const char* key : {"overshoot_pct", "rise_time_s", "steady_error_mm"}) {
      EXPECT_TRUE(j["step"][run][key].is_number()) << run << "." << key;
    }
  }
  for (const char* run : {"plain", "augmented_braking"}) {
    for (const char* key : {"peak_error_mm", "final_error_mm"}) {
      EXPECT_TRUE(j["s_curve"][run][key].is_number()) << run << "." << key;
    }
  }
  EXPECT_EQ(j["paper"]["simulation"]["step"]["linear_pi"]["overshoot_pct"], 29);
  EXPECT_EQ(j["paper"]["simulation"]["step"]["reset_pi"]["overshoot_pct_below"], 8);
  EXPECT_EQ(j["paper"]["experiment"]["step"]["reset_pi"]["rise_time_s"], 0.68);
  EXPECT_EQ(j["paper"]["experiment"]["step"]["reset_pi"]["steady_error_mm_below"], 1);
  EXPECT_TRUE(j["disagreement"].is_array());
  EXPECT_FALSE(j["disagreement"].empty());
  for (const nlohmann::json& c : j["comparison"]) EXPECT_TRUE(c.contains("difference")) << c.dump();
}

}  // namespace
}  // namespace pneumatic
