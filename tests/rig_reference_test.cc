// Tests of the independent rig reference (tests/reference/rig_reference.h) against numbers
// worked out by hand from docs/rigs.md.
#include "rig_reference.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace pneumatic::reference {
namespace {

constexpr double kFineDt = 1e-6;  // the users' default fine step, s

std::string RigName(Rig rig) {
  switch (rig) {
    case Rig::kOnOff: return "A_OnOff";
    case Rig::kProportional: return "B_Proportional";
    case Rig::kPerChamber: return "C_PerChamber";
  }
  return "?";
}

// rig C thin-plate flow a * phi(pu, pd) with docs/rigs.md's constants
double RigCFlow(const RigParams& p, double area, double pu, double pd) {
  return FlowThinPlate(area, p.polytropic_index, p.discharge_coefficient, p.molar_mass,
                       p.universal_gas_constant, p.compressibility, p.temperature, pu, pd);
}

// parameters ---------------------------------------------------------------------------------

TEST(RigParams, DefaultsAreRigsMdNumbers) {
  const RigParams a = DefaultParams(Rig::kOnOff);
  EXPECT_EQ(a.stroke, 0.1);
  EXPECT_EQ(a.area_P, 1.814e-4);
  EXPECT_EQ(a.polytropic_index, 1.2);
  EXPECT_EQ(a.valve_conductance, 3.4e-9);
  EXPECT_EQ(a.valve_critical_ratio, 0.433);
  const RigParams b = DefaultParams(Rig::kProportional);
  EXPECT_EQ(b.area_P, 10.6e-4);
  EXPECT_EQ(b.work_factor, 0.89);
  EXPECT_EQ(b.spool_time_constant, 4.2e-3);
  EXPECT_EQ(b.spool_deadband, 0.0);  // nominal
  const RigParams c = DefaultParams(Rig::kPerChamber);
  EXPECT_EQ(c.area_P, 7.854e-5);
  EXPECT_EQ(c.area_N, 6.597e-5);
  EXPECT_EQ(c.supply_pressure, 6.2e5);
  EXPECT_EQ(c.area_per_volt, 2e-6);
  EXPECT_EQ(ControlPeriod(Rig::kOnOff), 2e-3);
  EXPECT_EQ(ControlPeriod(Rig::kProportional), 1e-3);
  EXPECT_EQ(ControlPeriod(Rig::kPerChamber), 10e-3);
}

TEST(RigParams, ChamberVolumes) {
  const RigParams c = DefaultParams(Rig::kPerChamber);
  // V_P = A_P (L/2 + x) + V0 = 7.854e-5 * 0.07 + 1e-6; V_N = 6.597e-5 * 0.03 + 1e-6
  EXPECT_NEAR(ChamberVolumeP(c, 0.02), 6.4978e-6, 1e-18);
  EXPECT_NEAR(ChamberVolumeN(c, 0.02), 2.9791e-6, 1e-18);
}

// flow laws ----------------------------------------------------------------------------------

TEST(Flow, Iso6358ChokedSubsonicReversed) {
  const double c = 3.4e-9, b = 0.433;
  // choked: 1e5/3e5 = 0.333 <= 0.433, Q = C pu = 3.4e-9 * 3e5
  EXPECT_NEAR(FlowIso6358(c, b, 3e5, 1e5), 1.02e-3, 1e-15);
  // subsonic: r = 2/3, s = (2/3 - 0.433)/0.567 = 0.41211, phi = sqrt(1 - s^2) = 0.911134
  EXPECT_NEAR(FlowIso6358(c, b, 3e5, 2e5), 9.293565404529363e-4, 1e-15);
  // reversed: Q(Pu, Pd) = -Q(Pd, Pu)
  EXPECT_NEAR(FlowIso6358(c, b, 1e5, 3e5), -1.02e-3, 1e-15);
  EXPECT_NEAR(FlowIso6358(c, b, 1.5e5, 2.5e5), -8.122952103366812e-4, 1e-15);
  EXPECT_EQ(FlowIso6358(c, b, 2e5, 2e5), 0.0);
  EXPECT_EQ(FlowIso6358(c, b, 0.0, 0.0), 0.0);  // no division by zero
  EXPECT_NEAR(FlowIso6358(c, b, 2e5, 0.0), 6.8e-4, 1e-15);
}

TEST(Flow, SanvilleChokedSubsonicReversed) {
  // C1 = sqrt(1.4/287 (2/2.4)^6) = 0.0404184 sqrt(kg K / J); full opening
  // a = C_d w k_v 5 V = 0.7 * 0.0226 * 1.25e-3 = 1.9775e-5 m^2
  const double a = 1.9775e-5;
  auto m = [&](double pu, double pd) { return FlowSanville(a, 300.0, 1.4, 287.0, 0.2, pu, pd); };
  // choked: 0.9e5/5e5 = 0.18 <= 0.2: C1 a pu / sqrt(300)
  EXPECT_NEAR(m(5e5, 0.9e5), 0.04041841989407281 * a * 5e5 / std::sqrt(300.0), 1e-15);
  EXPECT_NEAR(m(5e5, 0.9e5), 0.023073060267994057, 1e-12);
  // subsonic: r = 0.6, s = 0.5, psi = sqrt(0.75)
  EXPECT_NEAR(m(5e5, 3e5), 0.023073060267994057 * std::sqrt(0.75), 1e-12);
  EXPECT_NEAR(m(3e5, 5e5), -0.01998185633513224, 1e-12);
  EXPECT_EQ(FlowSanville(0.0, 300.0, 1.4, 287.0, 0.2, 5e5, 1e5), 0.0);
  EXPECT_EQ(m(0.0, 0.0), 0.0);
}

TEST(Flow, ThinPlateChokedSubsonicReversed) {
  const RigParams c = DefaultParams(Rig::kPerChamber);
  // alpha = C sqrt(2 Mm/(Z Rg T) k/(k-1)) = 6.6073695e-3, beta = 1.7100147e-3 s/m,
  // theta = 1.2^3.5 = 1.8929292
  const double area = 1e-6;
  // choked: 6.2e5/1e5 > theta: beta pu a
  EXPECT_NEAR(RigCFlow(c, area, 6.2e5, 1e5), 1.0602091431098479e-3, 1e-15);
  // subsonic: r = 0.75, alpha pu sqrt(r^(1/0.7) - r^(2.4/1.4)) a
  EXPECT_NEAR(RigCFlow(c, area, 2e5, 1.5e5), 3.0225670396146214e-4, 1e-15);
  EXPECT_NEAR(RigCFlow(c, area, 1.5e5, 2e5), -3.0225670396146214e-4, 1e-15);
  // continuous across the critical ratio pu/pd = theta
  const double theta = std::pow(1.2, 3.5);
  EXPECT_NEAR(RigCFlow(c, area, 2e5 * theta * (1 - 1e-12), 2e5),
              RigCFlow(c, area, 2e5 * theta * (1 + 1e-12), 2e5), 1e-12);
  EXPECT_NEAR(RigCFlow(c, area, 3e5, 0.0), 1.7100147469513677e-3 * 3e5 * area, 1e-15);
  EXPECT_EQ(RigCFlow(c, area, 0.0, 0.0), 0.0);
}

TEST(Flow, ValveAreasPaper000) {
  const RigParams c = DefaultParams(Rig::kPerChamber);
  // a_c(5) = 0.05 + smax(-0.6 - 0.05) mm^2 = 0.05 + (sqrt(1.4225) - 0.65)/2 = 0.3213 mm^2
  EXPECT_NEAR(SupplyPortArea(c, 5.0) * 1e6, 0.32, 0.005);  // docs/rigs.md: "about 0.3 mm^2"
  EXPECT_NEAR(SupplyPortArea(c, 5.0) * 1e6, 0.3213430220938282, 1e-12);
  EXPECT_NEAR(ExhaustPortArea(c, 5.0) * 1e6, 0.3213430220938282, 1e-12);
  // a_c(7) = 0.05 + smax(3.4 - 0.05) = 0.05 + (sqrt(12.2225) + 3.35)/2 = 3.4730 mm^2
  EXPECT_NEAR(SupplyPortArea(c, 7.0) * 1e6, 3.47, 0.005);  // docs/rigs.md: "3.5 mm^2"
  EXPECT_NEAR(SupplyPortArea(c, 7.0) * 1e6, 3.473034610641334, 1e-12);
  EXPECT_NEAR(ExhaustPortArea(c, 3.0) * 1e6, 3.473034610641334, 1e-12);
  // far closed side tends to the leakage 0.05 mm^2 from above
  EXPECT_NEAR(SupplyPortArea(c, 3.0) * 1e6, 0.10315579809229476, 1e-12);
  // u = -100 V: y = -210.65 mm^2, smax(y) ~ 1/(4 |y|) = 1.1868e-3 mm^2
  EXPECT_NEAR(SupplyPortArea(c, -100.0) * 1e6, 0.05 + 1.0 / (4 * 210.65), 1e-8);
}

// chamber and piston equations ---------------------------------------------------------------

// rig A, valves closed: dp/dt = -k p A v / V, so p V^k is constant (paper 002 eq. 1)
TEST(Dynamics, SealedChamberRigAIsPolytropic) {
  const RigParams p = DefaultParams(Rig::kOnOff);
  RigState s;
  s.p_P = 2e5;
  s.p_N = 1.5e5;
  s.v = 0.5;
  const RigCommand closed;  // u1..u4 = 0
  const double cP = s.p_P * std::pow(ChamberVolumeP(p, s.x), 1.2);
  const double cN = s.p_N * std::pow(ChamberVolumeN(p, s.x), 1.2);
  const auto log = Simulate(p, s, std::vector<RigCommand>(25, closed), 2e-3, kFineDt);
  const RigState end = Integrate(p, log.back().state, closed, 2e-3, kFineDt);
  EXPECT_GT(std::fabs(end.x), 5e-3);  // it did move, and compressed or expanded both sides
  for (const Sample& r : log) {
    EXPECT_NEAR(r.state.p_P * std::pow(ChamberVolumeP(p, r.state.x), 1.2) / cP, 1.0, 1e-10);
    EXPECT_NEAR(r.state.p_N * std::pow(ChamberVolumeN(p, r.state.x), 1.2) / cN, 1.0, 1e-10);
  }
}

// rig B with the spool centred: dp/dt = -alpha gamma p A v / V, so p V^(alpha gamma) is
// constant: alpha acts on the piston-work term only
TEST(Dynamics, SealedChamberRigBUsesAlphaOnWorkTerm) {
  const RigParams p = DefaultParams(Rig::kProportional);
  RigState s;
  s.p_P = 3e5;
  s.p_N = 2e5;
  s.v = -1.0;
  const double n = 0.89 * 1.4;
  const double cP = s.p_P * std::pow(ChamberVolumeP(p, s.x), n);
  const RigState end = Integrate(p, s, RigCommand{}, 0.05, kFineDt);
  EXPECT_GT(std::fabs(end.x), 1e-2);
  EXPECT_NEAR(end.p_P * std::pow(ChamberVolumeP(p, end.x), n) / cP, 1.0, 1e-10);
}

// rig A, U1 and U4 open, piston held by a huge mass: p_P -> P_S, p_N -> P_E, also from above
TEST(Dynamics, RigASteadyStateReachesSupplyAndExhaust) {
  RigParams p = DefaultParams(Rig::kOnOff);
  p.mass = 1e15;
  RigCommand mode6;  // paper 002 Table I M6
  mode6.u1 = 1;
  mode6.u4 = 1;
  for (double p0 : {1e5, 3.5e5}) {
    RigState s;
    s.p_P = p0;
    s.p_N = 2.5e5;
    const RigState end = Integrate(p, s, mode6, 0.5, kFineDt);
    EXPECT_NEAR(end.p_P, 3e5, 1e-3) << "from p_P = " << p0;
    EXPECT_NEAR(end.p_N, 1e5, 1e-3);
    EXPECT_LT(std::fabs(end.x), 1e-12);
  }
}

// rig C, one fixed command, piston held: the pressure settles where a_c phi(Pc, p) = a_r phi(p, Pr).
// Near 5 V the ports are ~0.3 mm^2 and the approach is exponential with a ~50 ms time constant,
// hence 2 s, at a 1e-5 s step (the convergence test shows 1e-5 is within ~0.02 Pa of 2.5e-7)
TEST(Dynamics, RigCSteadyStateIsFlowBalance) {
  RigParams p = DefaultParams(Rig::kPerChamber);
  p.mass = 1e15;
  for (double u : {3.5, 4.8, 5.0, 5.5, 6.5}) {
    const double ac = SupplyPortArea(p, u), ar = ExhaustPortArea(p, u);
    double lo = p.exhaust_pressure, hi = p.supply_pressure;
    for (int i = 0; i < 200; ++i) {
      const double mid = 0.5 * (lo + hi);
      const double q = RigCFlow(p, ac, p.supply_pressure, mid) - RigCFlow(p, ar, mid, p.exhaust_pressure);
      (q > 0 ? lo : hi) = mid;
    }
    RigCommand cmd;
    cmd.uP = u;
    cmd.uN = u;
    RigState s;
    s.p_N = 6e5;  // one chamber from below, one from above
    const RigState end = Integrate(p, s, cmd, 2.0, 1e-5);
    EXPECT_NEAR(end.p_P, lo, 1e-2) << "u = " << u;
    EXPECT_NEAR(end.p_N, lo, 1e-2) << "u = " << u;
  }
}

// rig C piston: M dv/dt = A_P (p_P - P_r) - A_N (p_N - P_r) - b v
TEST(Dynamics, RigCForceUsesGaugePressuresOnUnequalAreas) {
  const RigParams p = DefaultParams(Rig::kPerChamber);
  RigState s;
  s.p_P = 4e5;
  s.p_N = 5e5;
  s.v = 0.1;
  const RigState d = Derivative(p, s, RigCommand{});
  // (7.854e-5 * 3e5 - 6.597e-5 * 4e5 - 20 * 0.1) / 0.5 = (23.562 - 26.388 - 2) / 0.5
  EXPECT_NEAR(d.v, -9.652, 1e-9);
  EXPECT_EQ(d.x, 0.1);
  EXPECT_EQ(d.spool, 0.0);
}

// rig B spool: first-order lag to k_v sat(u)
TEST(Dynamics, RigBSpoolLagAndSaturation) {
  const RigParams p = DefaultParams(Rig::kProportional);
  RigCommand cmd;
  cmd.u = 3.0;
  RigState s;
  s.x = -0.2;  // keep the piston from reaching its end during the 20 ms: check stroke below
  const RigState one_tau = Integrate(p, s, cmd, 4.2e-3, kFineDt);
  EXPECT_NEAR(one_tau.spool, 2.5e-4 * 3.0 * (1.0 - std::exp(-1.0)), 1e-15);
  cmd.u = 9.0;  // saturates at 5 V
  const RigState sat = Integrate(p, s, cmd, 4.2e-3, kFineDt);
  EXPECT_NEAR(sat.spool, 2.5e-4 * 5.0 * (1.0 - std::exp(-1.0)), 1e-15);
}

// rig B flow direction and the optional deadband
TEST(Dynamics, RigBValveDirectionAndDeadband) {
  RigParams p = DefaultParams(Rig::kProportional);
  RigState s;
  s.p_P = 3e5;
  s.p_N = 3e5;
  s.spool = 1e-4;  // x_v > 0: supply -> P, N -> exhaust
  RigState d = Derivative(p, s, RigCommand{});
  EXPECT_GT(d.p_P, 0.0);
  EXPECT_LT(d.p_N, 0.0);
  s.spool = -1e-4;
  d = Derivative(p, s, RigCommand{});
  EXPECT_LT(d.p_P, 0.0);
  EXPECT_GT(d.p_N, 0.0);
  // deadband 0.12 of 2 k_v 5 V: half band 1.5e-4 m; x_v = 2e-4 acts like 0.5e-4 nominal
  const RigParams nominal = p;
  p.spool_deadband = 0.12;
  s.spool = 2e-4;
  RigState s_nominal = s;
  s_nominal.spool = 0.5e-4;
  EXPECT_NEAR(Derivative(p, s, RigCommand{}).p_P, Derivative(nominal, s_nominal, RigCommand{}).p_P,
              1e-6);
  s.spool = -1.4e-4;  // inside the band: no flow
  EXPECT_EQ(Derivative(p, s, RigCommand{}).p_P, 0.0);
  EXPECT_EQ(Derivative(p, s, RigCommand{}).p_N, 0.0);
}

// integration and sampling -------------------------------------------------------------------

TEST(Integrate, LastStepIsShortenedAndZeroDurationIsIdentity) {
  const RigParams p = DefaultParams(Rig::kOnOff);
  RigCommand cmd;
  cmd.u1 = 1;
  cmd.u4 = 1;
  const RigState s0;
  const RigState a = Integrate(p, s0, cmd, 1.05e-3, 1e-4);
  const RigState b = Integrate(p, Integrate(p, s0, cmd, 1e-3, 1e-4), cmd, 0.05e-3, 1e-4);
  EXPECT_NEAR(a.p_P, b.p_P, 1e-9);
  EXPECT_NEAR(a.x, b.x, 1e-18);
  // and it is not the 11-full-steps result
  const RigState c = Integrate(p, s0, cmd, 1.1e-3, 1e-4);
  EXPECT_GT(std::fabs(c.p_P - a.p_P), 100.0);
  const RigState z = Integrate(p, s0, cmd, 0.0, 1e-4);
  EXPECT_EQ(z.p_P, s0.p_P);
  EXPECT_EQ(z.x, s0.x);
}

TEST(Simulate, SamplesAtTheStartOfEachInterval) {
  const RigParams p = DefaultParams(Rig::kProportional);
  const std::vector<RigCommand> cmds = Excitation(Rig::kProportional, 0.02, 7);
  ASSERT_EQ(cmds.size(), 20u);
  RigState init;
  init.p_P = 2e5;
  const auto log = Simulate(p, init, cmds, 1e-3, 1e-5);
  ASSERT_EQ(log.size(), cmds.size());
  EXPECT_EQ(log[0].state.p_P, 2e5);  // before the first command acts
  RigState s = init;
  for (std::size_t k = 0; k < log.size(); ++k) {
    EXPECT_DOUBLE_EQ(log[k].time, 1e-3 * static_cast<double>(k));
    EXPECT_EQ(log[k].command.u, cmds[k].u);
    EXPECT_EQ(log[k].state.p_P, s.p_P);
    EXPECT_EQ(log[k].state.x, s.x);
    s = Integrate(p, s, cmds[k], 1e-3, 1e-5);
  }
}

// per rig: fine-step convergence and the excitation --------------------------------------------

class PerRig : public ::testing::TestWithParam<Rig> {};

// the state over 0.5 s of excitation at fine_dt = 1e-6 against 5e-7. Measured (x86-64, gcc):
// max |dp| 3.8e-4 Pa (A), 1.6e-5 Pa (B), 4.5e-4 Pa (C); max |dx| 4.4e-11, 3.2e-12, 7.4e-12 m.
TEST_P(PerRig, FineStepConverges) {
  const Rig rig = GetParam();
  const RigParams p = DefaultParams(rig);
  const auto cmds = Excitation(rig, 0.5, 1);
  const auto a = Simulate(p, RigState{}, cmds, p.control_period, 1e-6);
  const auto b = Simulate(p, RigState{}, cmds, p.control_period, 5e-7);
  double dp = 0, dx = 0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    dp = std::max({dp, std::fabs(a[k].state.p_P - b[k].state.p_P),
                   std::fabs(a[k].state.p_N - b[k].state.p_N)});
    dx = std::max(dx, std::fabs(a[k].state.x - b[k].state.x));
  }
  std::printf("[ measured ] rig %s: fine_dt 1e-6 vs 5e-7 over 0.5 s: max|dp| = %.2e Pa, "
              "max|dx| = %.2e m\n", RigName(rig).c_str(), dp, dx);
  EXPECT_LT(dp, 1e-2);  // required: < 1 Pa
  EXPECT_LT(dx, 1e-9);  // required: < 1e-7 m
}

// 4 s of excitation at fine_dt = 1e-6 stays inside 80 % of the half stroke, uses valid
// commands, moves both ways and swings the pressures over most of supply - exhaust
TEST_P(PerRig, ExcitationStaysInStrokeAndExcites) {
  const Rig rig = GetParam();
  const RigParams p = DefaultParams(rig);
  const double half = 0.5 * p.stroke;
  for (uint32_t seed : {1u, 2u}) {
    const auto cmds = Excitation(rig, 4.0, seed);
    ASSERT_EQ(cmds.size(), static_cast<std::size_t>(std::lround(4.0 / p.control_period)));
    for (const RigCommand& c : cmds) {
      if (rig == Rig::kOnOff) {
        for (double ui : {c.u1, c.u2, c.u3, c.u4}) ASSERT_TRUE(ui == 0.0 || ui == 1.0);
        ASSERT_LE(c.u1 + c.u2, 1.0);  // paper 002: no bypass of a chamber
        ASSERT_LE(c.u3 + c.u4, 1.0);
      } else if (rig == Rig::kProportional) {
        ASSERT_LE(std::fabs(c.u), 5.0);
      } else {
        ASSERT_TRUE(c.uP >= 3.0 && c.uP <= 7.0 && c.uN >= 3.0 && c.uN <= 7.0);
      }
    }
    const auto log = Simulate(p, RigState{}, cmds, p.control_period, kFineDt);
    double x_min = 0, x_max = 0, p_min = 1e9, p_max = 0;
    for (const Sample& r : log) {
      x_min = std::min(x_min, r.state.x);
      x_max = std::max(x_max, r.state.x);
      p_min = std::min({p_min, r.state.p_P, r.state.p_N});
      p_max = std::max({p_max, r.state.p_P, r.state.p_N});
    }
    std::printf("[ measured ] rig %s seed %u: x in [%.1f, %.1f] %% of L/2, p in [%.0f, %.0f] Pa\n",
                RigName(rig).c_str(), seed, 100 * x_min / half, 100 * x_max / half, p_min, p_max);
    EXPECT_LT(std::max(-x_min, x_max), 0.8 * half) << "seed " << seed;
    EXPECT_LT(x_min, -0.1 * half) << "seed " << seed;
    EXPECT_GT(x_max, 0.1 * half) << "seed " << seed;
    EXPECT_LT(p_min, p.exhaust_pressure + 0.1 * (p.supply_pressure - p.exhaust_pressure));
    EXPECT_GT(p_max, p.exhaust_pressure + 0.7 * (p.supply_pressure - p.exhaust_pressure));
    EXPECT_GT(p_min, 0.5 * p.exhaust_pressure);
  }
}

TEST_P(PerRig, ExcitationIsDeterministicPerSeed) {
  const Rig rig = GetParam();
  const auto a = Excitation(rig, 0.3, 1), b = Excitation(rig, 0.3, 1), c = Excitation(rig, 0.3, 2);
  ASSERT_EQ(a.size(), b.size());
  int differ = 0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].u1, b[k].u1);
    EXPECT_EQ(a[k].u4, b[k].u4);
    EXPECT_EQ(a[k].u, b[k].u);
    EXPECT_EQ(a[k].uP, b[k].uP);
    EXPECT_EQ(a[k].uN, b[k].uN);
    differ += a[k].u1 != c[k].u1 || a[k].u2 != c[k].u2 || a[k].u != c[k].u || a[k].uP != c[k].uP;
  }
  EXPECT_GT(differ, static_cast<int>(a.size()) / 4);
}

INSTANTIATE_TEST_SUITE_P(Rigs, PerRig,
                         ::testing::Values(Rig::kOnOff, Rig::kProportional, Rig::kPerChamber),
                         [](const ::testing::TestParamInfo<Rig>& param_info) {
                           return RigName(param_info.param);
                         });

}  // namespace
}  // namespace pneumatic::reference
