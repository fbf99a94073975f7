// valve_delay of docs/effects.md for the proportional valves (plugin/README.md, "valve_delay"):
// the per-chamber valves' spool lag (spool_time_constant, paper 001 eq. 1's lag applied to each chamber's
// valve of paper 000) and the dead time of both proportional valve kinds (spool_dead_time, the (1,2) Pade
// approximant of exp(-s T)), each checked against numbers derived by hand or integrated independently.
// Both are off by default; a model that names their defaults steps bit for bit as one that does not.
#include <cmath>
#include <functional>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util.h"

namespace pneumatic {
namespace {

using ::testing::HasSubstr;
using testing::LoadModelFromString;
using testing::Rk4Step;
using testing::SameBits;
using testing::State;

using Model = testing::LoadedModel;

std::string AttachError(const std::string& xml) {
  std::string error;
  mjModel* m = LoadModelFromString(xml, &error);
  if (!m) return "load failed: " + error;
  bool attached = Attach(m, &error);
  mj_deleteModel(m);
  return attached ? "attached" : error;
}

std::string StateActuators(std::initializer_list<const char*> suffixes) {
  std::string text;
  for (const char* s : suffixes) {
    text += "<general name=\"cyl." + std::string(s) + "\" joint=\"x\" dyntype=\"user\" gaintype=\"user\"/>\n";
  }
  return text;
}

constexpr char kChamberN[] = "<general name=\"cyl.N\" joint=\"x\" dyntype=\"user\" gaintype=\"user\"/>";

// rig C (models_mjcf/rig_per_chamber.xml) with `keys`; `lag`: uP and uN with user dynamics (their act the
// lagged voltage); `states`: state actuators after the chambers
std::string RigC(const std::string& keys, bool lag, const std::string& states) {
  using testing::ReplaceAll;
  std::string rig = testing::ReadText(testing::ShippedModel("rig_per_chamber.xml"));
  rig = ReplaceAll(rig, "valve=proportional_per_chamber", "valve=proportional_per_chamber " + keys);
  if (lag) {
    for (const char* u : {"uP", "uN"}) {
      rig = ReplaceAll(rig, "name=\"cyl." + std::string(u) + "\" joint=\"x\" gaintype=\"user\"",
                       "name=\"cyl." + std::string(u) + "\" joint=\"x\" dyntype=\"user\" gaintype=\"user\"");
    }
  }
  return ReplaceAll(rig, kChamberN, std::string(kChamberN) + "\n" + states);
}

// rig B (models_mjcf/rig_proportional.xml: 5/3 valve, spool lag 4.2 ms) with `keys` and `states`;
// `no_lag`: spool_time_constant=0 (cyl.u then without dynamics)
std::string RigB(const std::string& keys, const std::string& states, bool no_lag = false) {
  using testing::ReplaceAll;
  std::string rig = testing::ReadText(testing::ShippedModel("rig_proportional.xml"));
  rig = ReplaceAll(rig, "valve=proportional_5_3", "valve=proportional_5_3 " + keys);
  if (no_lag) {
    rig = ReplaceAll(rig, "spool_time_constant=4.2e-3", "spool_time_constant=0");
    rig = ReplaceAll(rig, "name=\"cyl.u\" joint=\"x\" dyntype=\"user\"", "name=\"cyl.u\" joint=\"x\"");
  }
  return ReplaceAll(rig, kChamberN, std::string(kChamberN) + "\n" + states);
}

// rig C with sharp seals (area_smoothing 0.01 mm^2 in place of 1 mm^2: each port opens within 5 mV of
// its seal voltage, instead of over about a volt)
std::string SharpSeals(const std::string& xml) { return testing::ReplaceAll(xml, "area_smoothing=1e-6", "area_smoothing=1e-8"); }

// rig C with a valve 100 times larger (B = 200 mm^2/V: the chamber follows its opening within a step or
// so), sharp seals without leaks (a sealed port passes nothing, between 4.7 and 5.3 V the chamber is closed)
std::string FastValve(const std::string& xml) {
  std::string text = testing::ReplaceAll(SharpSeals(xml), "area_gain=2e-6", "area_gain=2e-4");
  return testing::ReplaceAll(text, "leak_area_supply=5e-8 leak_area_exhaust=5e-8", "leak_area_supply=0 leak_area_exhaust=0");
}

// The step response of the (1,2) Pade approximant of exp(-s T), G = (1 - sT/3)/(1 + 2sT/3 + (sT)^2/6),
// by hand: the poles are (-2 +- i sqrt2)/T, y(0) = 0 and y'(0) = -2/T (the ratio of the leading
// coefficients, -T/3 over T^2/6), so with theta = t/T
//   y = 1 - exp(-2 theta) (cos(sqrt2 theta) + 2 sqrt2 sin(sqrt2 theta))
double PadeStep(double theta) {
  const double w = std::sqrt(2.0) * theta;
  return 1 - std::exp(-2 * theta) * (std::cos(w) + 2 * std::sqrt(2.0) * std::sin(w));
}

// An independent integration of G(s) in another realisation (controllable canonical form:
// (T^2/6) z'' + (2T/3) z' + z = u, y = z - (T/3) z'), followed by the lag tau s' = gain y - s (tau = 0:
// s = gain y), by classic RK4 with 20000 substeps per T; returns s(t) for u = 0 before 0 and `u` after,
// everything at rest at 0 before
double IntegratedDelayAndLag(double u, double dead_time, double lag, double gain, double t) {
  const double T = dead_time;
  auto rate = [&](const double x[3], double out[3]) {
    double z = x[0], dz = x[1];
    double y = z - T / 3 * dz;
    out[0] = dz;
    out[1] = (u - z - 2 * T / 3 * dz) * 6 / (T * T);
    out[2] = lag > 0 ? (gain * y - x[2]) / lag : 0;
  };
  double x[3] = {0, 0, 0};
  const int n = static_cast<int>(std::ceil(t / T * 20000));
  const double h = t / n;
  for (int i = 0; i < n; ++i) Rk4Step<3>(rate, h, x);
  return lag > 0 ? x[2] : gain * (x[0] - T / 3 * x[1]);
}

// ---------------------------------------------------------------------------------------------
// the per-chamber valves' spool lag (spool_time_constant)

// a voltage step from rest (act 0 = lagged voltage 0 V) to u: the act of uP is u (1 - exp(-t/tau)),
// solved exactly over each step (only MuJoCo's act += h act_dot rounds)
TEST(PerChamberSpoolLag, StepResponseIsOneMinusExpOfTimeOverTau) {
  const double tau = 0.005, u = 7, u_n = 3;
  for (const char* timestep : {"0.0001", "0.001"}) {
    SCOPED_TRACE(timestep);
    std::string xml = testing::ReplaceAll(RigC("spool_time_constant=0.005", true, ""), "timestep=\"0.0001\"",
                                          std::string("timestep=\"") + timestep + "\"");
    Model model(xml);
    ASSERT_TRUE(model.ok()) << model.error();
    model.Ctrl("cyl.uP") = u, model.Ctrl("cyl.uN") = u_n;
    for (double t : {0.001, 0.002, 0.005, 0.01, 0.02, 0.05}) {
      model.StepUntil(t);
      const double time = model.d()->time;
      EXPECT_NEAR(model.Act("cyl.uP"), u * (1 - std::exp(-time / tau)), 1e-12 * u) << "t = " << time;
      EXPECT_NEAR(model.Act("cyl.uN"), u_n * (1 - std::exp(-time / tau)), 1e-12 * u_n) << "t = " << time;
    }
  }
}

// the ports follow the lagged voltage: starting at rest on 4.3 V (chamber P vented, both models
// identical), a step of uP to 7 V fills P later with the lag; the lag's act starts at rest on 4.3 V
// (a keyframe's act), so before the step both models are the same bits. Sharp seals: the supply port
// opens at 5.3 V (between 4.7 and 5.3 V both ports pass their 0.05 mm^2 leaks only)
TEST(PerChamberSpoolLag, PortsFollowTheLaggedVoltage) {
  Model lagged(SharpSeals(RigC("spool_time_constant=0.005", true, ""))), plain(SharpSeals(RigC("", false, "")));
  ASSERT_TRUE(lagged.ok()) << lagged.error();
  ASSERT_TRUE(plain.ok()) << plain.error();
  lagged.Act("cyl.uP") = 4.3, lagged.Act("cyl.uN") = 4.3;
  for (const Model* m : {&lagged, &plain}) m->Ctrl("cyl.uP") = 4.3, m->Ctrl("cyl.uN") = 4.3;
  lagged.StepUntil(0.05);
  plain.StepUntil(0.05);
  ASSERT_EQ(lagged.P(Chamber::kP), plain.P(Chamber::kP)) << "at rest on 4.3 V the lag changes nothing";
  const double p0 = plain.P(Chamber::kP);
  for (const Model* m : {&lagged, &plain}) m->Ctrl("cyl.uP") = 7;
  // without the lag P fills at once; with tau = 5 ms the supply seal (5.3 V) is passed when
  // 4.3 + 2.7 (1 - exp(-t/tau)) = 5.3, t = tau ln(2.7/1.7) = 2.31 ms after the step
  const double opens = 0.005 * std::log(2.7 / 1.7);
  lagged.StepUntil(0.05 + 0.9 * opens);
  plain.StepUntil(0.05 + 0.9 * opens);
  EXPECT_GT(plain.P(Chamber::kP) - p0, 1e5) << "P fills at once without the lag";
  EXPECT_LT(lagged.P(Chamber::kP) - p0, 1e4) << "the lagged voltage has not reached the supply seal";
  lagged.StepUntil(0.05 + 3 * opens);
  EXPECT_GT(lagged.P(Chamber::kP) - p0, 1e5) << "then it fills";
}

// ---------------------------------------------------------------------------------------------
// the dead time (spool_dead_time): the (1,2) Pade approximant of exp(-s T)

// a step of uP from rest (0 V) to 7 V: the delay line's x1 (act of cyl.dP1) is 7 y(t/T) with the
// closed form above; its DC gain is 1 (x1 -> 7, x2 -> 0); at t = 0 nothing passes (strictly proper);
// the mean delay, the integral of 1 - y, is exactly T (-G'(0) = T/3 + 2T/3); by hand
// y(T/2) = 1 - e^-1 (cos(0.7071) + 2 sqrt2 sin(0.7071)) = 0.0444 and y(T) = 0.6008
TEST(DeadTime, PadeStepResponseHasTheClosedFormUnitDcGainAndMeanDelayT) {
  const double dead = 0.01, u = 7, h = 1e-4;
  Model model(RigC("spool_dead_time=0.01", false, StateActuators({"dP1", "dP2", "dN1", "dN2"})));
  ASSERT_TRUE(model.ok()) << model.error();
  model.Ctrl("cyl.uP") = u;
  double worst = 0, lacking = 0, previous = 0;  // lacking: the trapezoid rule on 1 - y
  while (model.d()->time < 0.3 - 1e-9) {
    mj_step(model.m(), model.d());
    const double y = model.Act("cyl.dP1") / u;
    worst = std::max(worst, std::fabs(y - PadeStep(model.d()->time / dead)));
    lacking += h / 2 * ((1 - previous) + (1 - y));
    previous = y;
    if (std::fabs(model.d()->time - dead / 2) < h / 2) EXPECT_NEAR(y, 0.0444, 1e-4) << "y(T/2)";
    if (std::fabs(model.d()->time - dead) < h / 2) EXPECT_NEAR(y, 0.6008, 1e-4) << "y(T)";
  }
  EXPECT_LT(worst, 1e-12) << "closed form";
  EXPECT_NEAR(model.Act("cyl.dP1"), u, 1e-12 * u) << "DC gain 1";
  EXPECT_NEAR(model.Act("cyl.dP2"), 0, 1e-12 * u) << "x2 at rest";
  // the trapezoid rule's error on f = 1 - y: (h^2/12)(f'(inf) - f'(0)) = -h^2 / (6 T) (f'(0) = -y'(0) = -2/T),
  // -(h/T)^2 / 6 = -1.7e-5 of T
  EXPECT_NEAR(lacking / dead, 1 - (h / dead) * (h / dead) / 6, 1e-7) << "mean delay T";
  EXPECT_EQ(model.Act("cyl.dN1"), 0) << "uN stays at 0 V: its line stays at rest";
  EXPECT_EQ(model.Act("cyl.dN2"), 0);
  // mj_resetData: act = 0 and ctrl = 0, the line at rest on 0 V, and it stays there
  mj_resetData(model.m(), model.d());
  for (int i = 0; i < 100; ++i) mj_step(model.m(), model.d());
  EXPECT_EQ(model.Act("cyl.dP1"), 0);
  EXPECT_EQ(model.Act("cyl.dP2"), 0);
}

// the realisation is G(s): an independent RK4 integration of another realisation of the same transfer
// function agrees with the extension's exact step, for the per-chamber delay line and for the 5/3 valve's
// spool (dead time then the 4.2 ms lag, both solved exactly; and without the lag)
TEST(DeadTime, AgreesWithAnIndependentIntegrationOfTheTransferFunction) {
  const double dead = 0.008, u = 6;
  Model per_chamber(RigC("spool_dead_time=0.008", false, StateActuators({"dP1", "dP2", "dN1", "dN2"})));
  ASSERT_TRUE(per_chamber.ok()) << per_chamber.error();
  per_chamber.Ctrl("cyl.uP") = u;
  // rig B: u saturates at u_max = 5 V before the delay (ctrlrange clips 6 to 5 first, too)
  Model five_three(RigB("spool_dead_time=0.008", StateActuators({"d1", "d2"})));
  ASSERT_TRUE(five_three.ok()) << five_three.error();
  five_three.Ctrl("cyl.u") = 4;
  Model no_lag(RigB("spool_dead_time=0.008", StateActuators({"d1", "d2"}), true));
  ASSERT_TRUE(no_lag.ok()) << no_lag.error();
  const double k_v = 2.5e-4, tau = 4.2e-3;
  for (double t : {0.002, 0.006, 0.01, 0.02, 0.04}) {
    SCOPED_TRACE(t);
    per_chamber.StepUntil(t);
    five_three.StepUntil(t);
    const double time = per_chamber.d()->time;
    EXPECT_NEAR(per_chamber.Act("cyl.dP1"), IntegratedDelayAndLag(u, dead, 0, 1, time), 1e-9 * u);
    const double spool = IntegratedDelayAndLag(4, dead, tau, k_v, five_three.d()->time);
    EXPECT_NEAR(five_three.Act("cyl.u"), spool, 1e-9 * k_v * 4) << "spool x_v (m)";
    EXPECT_NEAR(five_three.Act("cyl.d1"), IntegratedDelayAndLag(4, dead, 0, 1, five_three.d()->time), 1e-9 * 4);
  }
  // without a lag the 5/3 valve has no spool state: the delay line alone
  no_lag.Ctrl("cyl.u") = 4;
  no_lag.StepUntil(0.01);
  EXPECT_NEAR(no_lag.Act("cyl.d1"), 4 * PadeStep(no_lag.d()->time / dead), 1e-12 * 4);
}

// The effect on the chamber: rig C with a fast valve (FastValve) at rest on 4.3 V (P vented through its
// open exhaust port; the delay lines at rest on 4.3 V, dP1 = dN1 = 4.3, as a keyframe sets them), uP
// stepped to 6.3 V. Chamber P's supply port opens at U_c = 5.3 V, halfway: without the dead time P rises
// 10 kPa within a step or two; with it, once the Pade output y has passed 1/2, which the closed form places
// at t_half = 0.896 T. So the arrival shifts by t_half, about T (the approximant's mean delay is exactly T,
// its median 10 % less). What moves it off t_half: the opening ramp after y passes U_c (the area B (y - U_c)
// grows at B 2 V / T; with dp/dt = (n r T / V)(mdot / a) B (2 V / T) t, 10 kPa takes about 0.15 ms at
// T = 10 ms, 0.2 ms at 20 ms) later, the undelayed arrival (0.1 to 0.2 ms) earlier, and the 0.1 ms steps:
// under 2 % of T, hence 3 %.
TEST(DeadTime, TheCommandReachesTheChamberPressureLaterByAboutT) {
  const double u0 = 4.3, u1 = 6.3, t_step = 0.05;
  // t_half from the closed form, by bisection
  double lo = 0.5, hi = 1.2;
  for (int i = 0; i < 100; ++i) (PadeStep((lo + hi) / 2) < 0.5 ? lo : hi) = (lo + hi) / 2;
  const double theta_half = (lo + hi) / 2;
  ASSERT_NEAR(theta_half, 0.896, 0.001);
  // line_delay (line_dynamics' transport delay) is a dead time of the command too: the same shift
  for (const std::string key : {"spool_dead_time", "line_delay"})
  for (double dead : {0.01, 0.02}) {
    SCOPED_TRACE(key + " " + std::to_string(dead));
    Model delayed(FastValve(
        RigC(key + "=" + std::to_string(dead), false, StateActuators({"dP1", "dP2", "dN1", "dN2"}))));
    Model plain(FastValve(RigC("", false, "")));
    ASSERT_TRUE(delayed.ok()) << delayed.error();
    delayed.Act("cyl.dP1") = u0, delayed.Act("cyl.dN1") = u0;
    double arrival[2] = {0, 0};
    int i = 0;
    for (const Model* model : {&plain, &delayed}) {
      model->Ctrl("cyl.uP") = u0, model->Ctrl("cyl.uN") = u0;
      model->StepUntil(t_step);
      const double p0 = model->P(Chamber::kP);
      model->Ctrl("cyl.uP") = u1;
      while (model->P(Chamber::kP) < p0 + 1e4 && model->d()->time < t_step + 3 * dead) mj_step(model->m(), model->d());
      arrival[i++] = model->d()->time - t_step;
    }
    EXPECT_EQ(delayed.Act("cyl.dN1"), u0) << "uN held: its line stays at rest";
    EXPECT_LT(arrival[0], 0.5e-3) << "without the dead time P rises at once";
    const double shift = arrival[1] - arrival[0];
    EXPECT_NEAR(shift / dead, theta_half, 0.03) << "shift " << shift;
    EXPECT_NEAR(shift / dead, 1, 0.15) << "about T";
  }
}

// line_delay is the project's own form of a line's transport delay: a dead time of the command added to
// spool_dead_time, through the same delay line. So a line delay T_l with a spool dead time T_s steps as a
// spool dead time T_s + T_l alone, bit for bit (2^-7 s + 2^-8 s: the values and their sum are exact).
TEST(LineDelay, StepsAsASpoolDeadTimeOfTheSumBitForBit) {
  struct Case {
    std::string name, split, summed;
  };
  const std::string line_states = "spool_dead_time=0.0078125 line_delay=0.00390625", summed = "spool_dead_time=0.01171875";
  const Case cases[] = {
      {"per chamber", RigC(line_states, false, StateActuators({"dP1", "dP2", "dN1", "dN2"})),
       RigC(summed, false, StateActuators({"dP1", "dP2", "dN1", "dN2"}))},
      {"5/3", RigB(line_states, StateActuators({"d1", "d2"})), RigB(summed, StateActuators({"d1", "d2"}))},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    Model split(c.split), sum(c.summed);
    ASSERT_TRUE(split.ok()) << split.error();
    ASSERT_TRUE(sum.ok()) << sum.error();
    testing::RunPattern(split.m(), split.d(), split.cylinder(), 0, 800);
    testing::RunPattern(sum.m(), sum.d(), sum.cylinder(), 0, 800);
    EXPECT_TRUE(SameBits(State(split.m(), split.d()), State(sum.m(), sum.d())));
    EXPECT_NE(split.P(Chamber::kP), split.P(Chamber::kN)) << "the pattern moved the chambers";
  }
}

// ---------------------------------------------------------------------------------------------
// configuration: keys, actuators, defaults off

TEST(ValveDelay, KeysAreDocumentedWithUnitsDefaultsAndRanges) {
  const ParameterDoc* dead = nullptr;
  const ParameterDoc* lag = nullptr;
  for (const ParameterDoc& p : Parameters()) {
    if (p.key == "spool_dead_time") dead = &p;
    if (p.key == "spool_time_constant") lag = &p;
  }
  ASSERT_NE(dead, nullptr) << "pneumo params lists Parameters()";
  EXPECT_EQ(dead->unit, "s");
  EXPECT_EQ(dead->default_value, "0");
  EXPECT_EQ(dead->min, 0);
  EXPECT_EQ(dead->max, 0.1);
  EXPECT_THAT(dead->scope, HasSubstr("valve=proportional_5_3 or valve=proportional_per_chamber"));
  EXPECT_THAT(dead->meaning, HasSubstr("Pade"));
  const ParameterDoc* line = nullptr;
  for (const ParameterDoc& p : Parameters()) {
    if (p.key == "line_delay") line = &p;
  }
  ASSERT_NE(line, nullptr);
  EXPECT_EQ(line->unit, "s");
  EXPECT_EQ(line->default_value, "0");
  EXPECT_EQ(line->max, 0.1);
  EXPECT_THAT(line->meaning, HasSubstr("added to spool_dead_time"));
  ASSERT_NE(lag, nullptr);
  EXPECT_EQ(lag->unit, "s");
  EXPECT_THAT(lag->scope, HasSubstr("valve=proportional_per_chamber"));
  EXPECT_THAT(lag->meaning, HasSubstr("0 for proportional_per_chamber"));
  // the derived defaults: 4.2 ms for the 5/3 valve (paper 001), 0 per chamber
  Model b(RigB("", "")), c(RigC("", false, ""));
  ASSERT_TRUE(b.ok()) << b.error();
  ASSERT_TRUE(c.ok()) << c.error();
  std::string error;
  EXPECT_EQ(GetParameter(c.m(), "cyl", "spool_time_constant", &error).value_or(-1), 0) << error;
  EXPECT_EQ(GetParameter(c.m(), "cyl", "spool_dead_time", &error).value_or(-1), 0) << error;
  EXPECT_EQ(GetParameter(b.m(), "cyl", "spool_dead_time", &error).value_or(-1), 0) << error;
}

TEST(ValveDelay, AttachRefusesActuatorsThatDoNotMatchNamingThem) {
  // a dead time without its delay-line states
  std::string error = AttachError(RigB("spool_dead_time=0.005", ""));
  EXPECT_THAT(error, HasSubstr("actuator 'cyl.d1'"));
  EXPECT_THAT(error, HasSubstr("spool_dead_time + line_delay > 0"));
  error = AttachError(RigB("line_delay=0.005", ""));
  EXPECT_THAT(error, HasSubstr("actuator 'cyl.d1'"));
  EXPECT_THAT(error, HasSubstr("spool_dead_time + line_delay > 0"));
  error = AttachError(RigC("spool_dead_time=0.005", false, StateActuators({"dP1", "dP2", "dN1"})));
  EXPECT_THAT(error, HasSubstr("actuator 'cyl.dN2'"));
  // delay-line states without a dead time
  error = AttachError(RigC("", false, StateActuators({"dP1", "dP2", "dN1", "dN2"})));
  EXPECT_THAT(error, HasSubstr("actuator 'cyl.dP1': has no role"));
  EXPECT_THAT(error, HasSubstr("spool_dead_time + line_delay > 0"));
  // the 5/3 valve's states on a per-chamber cylinder
  error = AttachError(RigC("spool_dead_time=0.005", false, StateActuators({"dP1", "dP2", "dN1", "dN2", "d1"})));
  EXPECT_THAT(error, HasSubstr("actuator 'cyl.d1': has no role"));
  // a lag needs uP and uN with user dynamics; without a lag they have none
  error = AttachError(RigC("spool_time_constant=0.005", false, ""));
  EXPECT_THAT(error, HasSubstr("actuator 'cyl.uP'"));
  EXPECT_THAT(error, HasSubstr("dyntype=\"user\""));
  EXPECT_THAT(error, HasSubstr("lagged voltage"));
  error = AttachError(RigC("", true, ""));
  EXPECT_THAT(error, HasSubstr("actuator 'cyl.uP'"));
  EXPECT_THAT(error, HasSubstr("dyntype=\"none\""));
  // a delay-line state must apply no force and not be clipped
  error = AttachError(RigB("spool_dead_time=0.005",
                           StateActuators({"d1"}) +
                               "<general name=\"cyl.d2\" joint=\"x\" dyntype=\"user\" gaintype=\"fixed\" gainprm=\"1\"/>"));
  EXPECT_THAT(error, HasSubstr("actuator 'cyl.d2': applies no force"));
  // keys
  EXPECT_THAT(AttachError(RigB("spool_dead_time=0.2", StateActuators({"d1", "d2"}))),
              HasSubstr("key 'spool_dead_time': value 0.2 is out of range [0, 0.1] s"));
  std::string onoff = testing::ReadText(testing::ShippedModel("rig_onoff.xml"));
  EXPECT_THAT(AttachError(testing::ReplaceAll(onoff, "valve=onoff", "valve=onoff spool_dead_time=0.001")),
              HasSubstr("key 'spool_dead_time': applies only to valve=proportional_5_3 or valve=proportional_per_chamber"));
  EXPECT_THAT(AttachError(testing::ReplaceAll(onoff, "valve=onoff", "valve=onoff line_delay=0.001")),
              HasSubstr("key 'line_delay': applies only to valve=proportional_5_3 or valve=proportional_per_chamber"));
  EXPECT_THAT(AttachError(testing::ReplaceAll(onoff, "valve=onoff", "valve=onoff spool_time_constant=0.001")),
              HasSubstr("key 'spool_time_constant': applies only to valve=proportional_5_3 or valve=proportional_per_chamber"));
}

// rig B and rig C with the keys named at their defaults step as the shipped rigs, bit for bit
TEST(ValveDelay, DefaultsOffGiveTheSameBitsAsTheShippedRigs) {
  struct Case {
    std::string file, named;
  };
  const Case cases[] = {
      {"rig_per_chamber.xml", RigC("spool_time_constant=0 spool_dead_time=0", false, "")},
      {"rig_proportional.xml", RigB("spool_dead_time=0", "")},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.file);
    Model shipped(testing::ReadText(testing::ShippedModel(c.file))), named(c.named);
    ASSERT_TRUE(shipped.ok()) << shipped.error();
    ASSERT_TRUE(named.ok()) << named.error();
    testing::RunPattern(shipped.m(), shipped.d(), shipped.cylinder(), 0, 800);
    testing::RunPattern(named.m(), named.d(), named.cylinder(), 0, 800);
    EXPECT_TRUE(SameBits(State(shipped.m(), shipped.d()), State(named.m(), named.d())));
  }
}

// SetParameter switches the dead time on a copy; it must then find the delay-line actuators (here it cannot)
TEST(ValveDelay, SetParameterChecksTheActuatorsAsAttachDoes) {
  Model c(RigC("", false, ""));
  ASSERT_TRUE(c.ok()) << c.error();
  std::string error;
  EXPECT_FALSE(SetParameter(c.m(), "cyl", "spool_dead_time", 0.005, &error));
  EXPECT_THAT(error, HasSubstr("actuator 'cyl.dP1'"));
  Model d(RigC("spool_dead_time=0.005", false, StateActuators({"dP1", "dP2", "dN1", "dN2"})));
  ASSERT_TRUE(d.ok()) << d.error();
  EXPECT_TRUE(SetParameter(d.m(), "cyl", "spool_dead_time", 0.01, &error)) << error;
  EXPECT_EQ(GetParameter(d.m(), "cyl", "spool_dead_time", &error).value_or(0), 0.01);
}

}  // namespace
}  // namespace pneumatic
