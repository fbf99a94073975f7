// Flow laws and valve openings against values computed by hand from the papers.
#include <cmath>

#include <gtest/gtest.h>

#include "config.h"
#include "flow.h"
#include "valves.h"

namespace pneumatic {
namespace {

// rig A (docs/rigs.md): C_val = 3.4e-9 kg/(s Pa), b = 0.433
TEST(FlowIso6358, ChokedFlowIsCvalTimesUpstreamPressure) {
  // paper 002 eq. (4): pd/pu = 1/3 <= b, so Q = C_val pu = 3.4e-9 * 3e5
  FlowLawConstants law = Iso6358Constants(0.433);
  EXPECT_DOUBLE_EQ(MassFlow(law, 3.4e-9, 3e5, 1e5), 1.02e-3);
}

TEST(FlowIso6358, SubsonicFlowFollowsTheEllipse) {
  // pd/pu = 2/3: s = (2/3 - 0.433)/(1 - 0.433) = 0.4121105, sqrt(1 - s^2) = 0.9111339
  FlowLawConstants law = Iso6358Constants(0.433);
  EXPECT_NEAR(MassFlow(law, 3.4e-9, 3e5, 2e5), 1.02e-3 * 0.9111338631891533, 1e-15);
}

TEST(FlowIso6358, FlowReversesWhenDownstreamIsHigher) {
  // docs/rigs.md: Q(pu, pd) = -Q(pd, pu)
  FlowLawConstants law = Iso6358Constants(0.433);
  EXPECT_DOUBLE_EQ(MassFlow(law, 3.4e-9, 2e5, 3e5), -MassFlow(law, 3.4e-9, 3e5, 2e5));
  EXPECT_EQ(MassFlow(law, 3.4e-9, 2e5, 2e5), 0.0);
}

// rig B (docs/rigs.md, paper 001 Table I): gamma = 1.4, R = 287, T = 300, C_d = 0.7, P_cr = 0.2
TEST(FlowSanville, ChokedFlowMatchesPaper001Eq2) {
  // C1 = sqrt(1.4/287 (2/2.4)^6) = 0.0404184; area w x_v = 0.0226 * 1e-3 m^2
  // m = C1 C_d a pu / sqrt(T) = 0.0404184 * 0.7 * 2.26e-5 * 5e5 / sqrt(300) = 0.0184584 kg/s
  FlowLawConstants law = SanvilleConstants(0.7, 0.2, 1.4, 287, 300);
  EXPECT_NEAR(MassFlow(law, 2.26e-5, 5e5, 1e5), 0.018458448214395247, 1e-12);
}

TEST(FlowSanville, SubsonicFlowMatchesPaper001Eq2) {
  // pd/pu = 0.6: ((0.6 - 0.2)/0.8)^2 = 0.25, sqrt(0.75) = 0.8660254
  FlowLawConstants law = SanvilleConstants(0.7, 0.2, 1.4, 287, 300);
  EXPECT_NEAR(MassFlow(law, 2.26e-5, 5e5, 3e5), 0.018458448214395247 * std::sqrt(0.75), 1e-12);
}

// rig C (docs/rigs.md, paper 000 Table II): C = 0.72, kappa = 1.4, Z = 0.99, r = 8.31/0.029, T = 293
FlowLawConstants RigCThinPlate() { return ThinPlateConstants(0.72, 1.4, 0.99, 8.31 / 0.029, 293); }

TEST(FlowThinPlate, ConstantsMatchPaper000Appendix) {
  // eqs. (11)-(13): alpha = C sqrt(2/(Z r T) k/(k-1)), beta = C sqrt(k/(Z r T) (2/(k+1))^((k+1)/(k-1))),
  // theta = ((k+1)/2)^(k/(k-1)) = 1.2^3.5
  FlowLawConstants law = RigCThinPlate();
  EXPECT_NEAR(law.alpha, 0.006607369526475502, 1e-15);
  EXPECT_NEAR(law.beta, 0.0017100147469513677, 1e-15);
  EXPECT_NEAR(law.theta, 1.892929158737854, 1e-12);
}

TEST(FlowThinPlate, ChokedAndSubsonicFlowMatchEq1c) {
  FlowLawConstants law = RigCThinPlate();
  // 6.2e5 / 1e5 > theta: z = beta pu; area 3.5 mm^2
  EXPECT_NEAR(MassFlow(law, 3.5e-6, 6.2e5, 1e5), 3.5e-6 * 0.0017100147469513677 * 6.2e5, 1e-15);
  // 6.2e5 / 4e5 < theta: z = alpha pu sqrt(r^(2/k) - r^((k+1)/k)), r = 4/6.2
  EXPECT_NEAR(MassFlow(law, 3.5e-6, 6.2e5, 4e5), 0.0035967745838849322, 1e-14);
}

TEST(FlowThinPlate, TabulatedShapeMatchesTheFormulaOverTheSubsonicRange) {
  // the law's factor sqrt(r^(2/k) - r^((k+1)/k)) is evaluated from a cubic Hermite table of its smooth
  // part; against the formula (two powers) on 100001 ratios from 1/theta to 1, for air and helium.
  // Measured: within 5e-14 where the formula is exact (r <= 0.99), slope within 2e-7
  for (double kappa : {1.4, 1.67}) {
    FlowLawConstants law = ThinPlateConstants(0.72, kappa, 0.99, 287, 293);
    double worst = 0, worst_slope = 0;
    for (int i = 0; i <= 100000; ++i) {
      double r = 1 / law.theta + (1 - 1 / law.theta) * i / 100000.0;
      double slope = 0;
      double table = law.table->Shape(r, &slope);
      double exact = std::sqrt(std::max(std::pow(r, 2 / kappa) - std::pow(r, (kappa + 1) / kappa), 0.0));
      // the formula itself cancels near r = 1 (rounding about 1e-16 / (1 - r)): compare where it is exact
      if (r <= 0.99) worst = std::max(worst, std::fabs(table / exact - 1));
      // the slope against a central difference of the formula, away from r = 1 where it is unbounded
      if (r < 0.999) {
        double dr = 1e-7;
        auto formula = [&](double x) { return std::sqrt(std::pow(x, 2 / kappa) - std::pow(x, (kappa + 1) / kappa)); };
        double difference = (formula(r + dr) - formula(r - dr)) / (2 * dr);
        worst_slope = std::max(worst_slope, std::fabs(slope - difference) / std::max(std::fabs(difference), 1e-2));
      }
    }
    EXPECT_LT(worst, 1e-12) << "kappa " << kappa;
    EXPECT_LT(worst_slope, 1e-6) << "kappa " << kappa;
  }
}

TEST(FlowThinPlate, IsContinuousAtTheCriticalRatio) {
  // paper 000: the flow function is continuously differentiable; both branches meet at pu/pd = theta
  FlowLawConstants law = RigCThinPlate();
  double pd = 1e5, pu = law.theta * pd;
  double below = MassFlow(law, 1e-6, pu * (1 - 1e-9), pd), above = MassFlow(law, 1e-6, pu * (1 + 1e-9), pd);
  EXPECT_NEAR(below, above, 1e-9 * above * 10);
}

TEST(FlowLaws, NonPositivePressuresGiveFiniteFlows) {
  for (const FlowLawConstants& law : {Iso6358Constants(0.433), SanvilleConstants(0.7, 0.2, 1.4, 287, 300), RigCThinPlate()}) {
    EXPECT_TRUE(std::isfinite(MassFlow(law, 1e-6, 3e5, 0)));
    EXPECT_TRUE(std::isfinite(MassFlow(law, 1e-6, -1, 3e5)));
    EXPECT_EQ(MassFlow(law, 1e-6, 0, 0), 0.0);
  }
}

// paper 000 eq. (3) on rig C's valve: B = 2 mm^2/V, U_c = 5.3 V, U_r = 4.7 V, L_c = L_r = 0.05 mm^2
ChamberConfig RigCValve() {
  ChamberConfig k;
  k.area_gain = 2e-6, k.u_supply_seal = 5.3, k.u_exhaust_seal = 4.7;
  k.leak_area_supply = 5e-8, k.leak_area_exhaust = 5e-8, k.area_smoothing = 1e-6;
  return k;
}

TEST(ProportionalValve, AreasMatchPaper000Eq3) {
  // in mm^2: a_c(u) = 0.05 + smax((u - 5.3) 2 - 0.05), smax(y) = (sqrt(y^2 + 1) + y)/2
  // u = 5: smax(-0.65) = 0.2713430 -> 0.3213430 (docs/rigs.md: about 0.3 mm^2 open near 5 V)
  // u = 7: smax(3.35) = 3.4230346 -> 3.4730346 (docs/rigs.md: 3.5 mm^2)
  ChamberConfig k = RigCValve();
  EXPECT_NEAR(ProportionalValveAreas(k, 5).supply, 0.3213430220938282e-6, 1e-16);
  EXPECT_NEAR(ProportionalValveAreas(k, 5).exhaust, 0.3213430220938282e-6, 1e-16);
  EXPECT_NEAR(ProportionalValveAreas(k, 7).supply, 3.473034610641334e-6, 1e-16);
  EXPECT_NEAR(ProportionalValveAreas(k, 7).exhaust, 0.10315579809229476e-6, 1e-16);
  EXPECT_NEAR(ProportionalValveAreas(k, 3).exhaust, 3.473034610641334e-6, 1e-16);
}

CylinderConfig Spool(double deadband, double time_constant) {
  CylinderConfig c;
  c.valve = ValveKind::kProportional53;
  c.spool_gain = 2.5e-4, c.u_max = 5, c.orifice_gradient = 0.0226;
  c.deadband = deadband, c.spool_time_constant = time_constant;
  return c;
}

TEST(Spool, LagIsExactFirstOrder) {
  // paper 001 eq. (1): x_v(h) = k_v u + (x_v(0) - k_v u) exp(-h / tau_v)
  CylinderConfig c = Spool(0, 4.2e-3);
  ValveInputs in;
  in.step = 1e-3, in.command[0] = 4, in.state[0] = 0;
  EXPECT_NEAR(ValveStateAtEnd(c, 0, in), 1e-3 * (1 - std::exp(-1e-3 / 4.2e-3)), 1e-18);
  // the command saturates at u_max = 5 V
  in.command[0] = 9, in.state[0] = 1.25e-3;
  EXPECT_DOUBLE_EQ(ValveStateAtEnd(c, 0, in), 1.25e-3);
}

TEST(Spool, DeadbandCoversTwelvePercentOfTheSpoolRange) {
  // paper 001: deadband 12 % of the spool range 2 k_v u_max = 2.5 mm, i.e. |x_v| < 0.15 mm gives no flow
  CylinderConfig c = Spool(0.12, 0);
  EXPECT_EQ(SpoolOpening(c, 0.149e-3), 0.0);
  EXPECT_EQ(SpoolOpening(c, -0.149e-3), 0.0);
  EXPECT_NEAR(SpoolOpening(c, 0.25e-3), 0.1e-3, 1e-15);
  EXPECT_NEAR(SpoolOpening(c, -0.25e-3), -0.1e-3, 1e-15);
}

TEST(Spool, PositiveSpoolFillsPAndVentsN) {
  // docs/rigs.md rig B: x_v >= 0 connects supply -> P and N -> exhaust
  CylinderConfig c = Spool(0, 0);
  ValveInputs in;
  in.step = 1e-3, in.command[0] = 2;  // x_v = 0.5 mm, area = 0.0226 * 0.5e-3
  PortOpenings p = PortSchedule(c, 0, in).At(0), n = PortSchedule(c, 1, in).At(0);
  EXPECT_NEAR(p.supply, 1.13e-5, 1e-18);
  EXPECT_EQ(p.exhaust, 0.0);
  EXPECT_EQ(n.supply, 0.0);
  EXPECT_NEAR(n.exhaust, 1.13e-5, 1e-18);
}

CylinderConfig OnOff(double delay_open, double delay_close) {
  CylinderConfig c;
  c.valve = ValveKind::kOnOff;
  c.delay_open = delay_open, c.delay_close = delay_close;
  c.chamber[0].flow = c.chamber[1].flow = FlowLaw::kIso6358;
  c.chamber[0].sonic_conductance = c.chamber[1].sonic_conductance = 3.4e-9;
  return c;
}

TEST(OnOffValve, OpensAfterTheOpeningDelayAndClosesAfterTheClosingDelay) {
  // paper 002: 1.3 ms to open, 0.2 ms to close; a 2 ms step starting closed with U1 commanded open
  CylinderConfig c = OnOff(1.3e-3, 0.2e-3);
  ValveInputs in;
  in.step = 2e-3, in.command[0] = 1, in.state[0] = 0;
  PortSchedule opening(c, 0, in);
  ASSERT_EQ(opening.breakpoints().size(), 1u);
  EXPECT_NEAR(opening.breakpoints()[0], 1.3e-3, 1e-15);
  EXPECT_EQ(opening.At(1.2e-3).supply, 0.0);
  EXPECT_EQ(opening.At(1.4e-3).supply, 3.4e-9);
  // the armature rises at 0.5 / 1.3 ms: after 2 ms it is at 2 / 2.6 of its travel
  EXPECT_NEAR(ValveStateAtEnd(c, 0, in), 2.0 / 2.6, 1e-15);
  // now commanded closed from fully open: flow stops 0.2 ms later
  in.command[0] = 0, in.state[0] = 1;
  PortSchedule closing(c, 0, in);
  ASSERT_EQ(closing.breakpoints().size(), 1u);
  EXPECT_NEAR(closing.breakpoints()[0], 0.2e-3, 1e-15);
}

TEST(OnOffValve, PulseShorterThanTheOpeningDelayNeverOpens) {
  CylinderConfig c = OnOff(1.3e-3, 0.2e-3);
  ValveInputs in;
  in.step = 1e-3, in.command[0] = 1, in.state[0] = 0;
  EXPECT_EQ(PortSchedule(c, 0, in).At(0.99e-3).supply, 0.0);
  in.state[0] = ValveStateAtEnd(c, 0, in);  // 0.5/1.3 = 0.3846
  EXPECT_NEAR(in.state[0], 0.5 / 1.3, 1e-15);
  in.command[0] = 0;
  EXPECT_EQ(PortSchedule(c, 0, in).At(0).supply, 0.0);
}

TEST(OnOffValve, SwitchedPwmOpensMode6ForTheDutyFraction) {
  // paper 003 eqs. (12)-(13): duty 0.3 at 100 Hz, edge-aligned: U1 and U4 open for the first 3 ms of
  // each 10 ms
  CylinderConfig c = OnOff(0, 0);
  c.input = CommandInput::kPwm, c.pwm_frequency = 100, c.pwm_alignment = PwmAlignment::kLeading;
  ValveInputs in;
  in.time = 0.02, in.step = 0.01, in.command[0] = 0.3;
  PortSchedule p(c, 0, in), n(c, 1, in);
  ASSERT_EQ(p.breakpoints().size(), 1u);
  EXPECT_NEAR(p.breakpoints()[0], 3e-3, 1e-12);
  EXPECT_EQ(p.At(1e-3).supply, 3.4e-9);
  EXPECT_EQ(p.At(1e-3).exhaust, 0.0);
  EXPECT_EQ(n.At(1e-3).exhaust, 3.4e-9);
  EXPECT_EQ(p.At(5e-3).supply, 0.0);
  // negative duty: mode 7, P vents and N fills
  in.command[0] = -0.5;
  EXPECT_EQ(PortSchedule(c, 0, in).At(1e-3).exhaust, 3.4e-9);
  EXPECT_EQ(PortSchedule(c, 1, in).At(1e-3).supply, 3.4e-9);
}

TEST(OnOffValve, CentredPwmOpensInTheMiddleOfEachPeriod) {
  // duty 0.3 at 100 Hz, centred (the default): open from 3.5 ms to 6.5 ms of each 10 ms period
  CylinderConfig c = OnOff(0, 0);
  c.input = CommandInput::kPwm, c.pwm_frequency = 100;
  ASSERT_EQ(c.pwm_alignment, PwmAlignment::kCenter);
  ValveInputs in;
  in.time = 0.02, in.step = 0.01, in.command[0] = 0.3;
  PortSchedule p(c, 0, in);
  ASSERT_EQ(p.breakpoints().size(), 2u);
  EXPECT_NEAR(p.breakpoints()[0], 3.5e-3, 1e-12);
  EXPECT_NEAR(p.breakpoints()[1], 6.5e-3, 1e-12);
  EXPECT_EQ(p.At(1e-3).supply, 0.0);
  EXPECT_EQ(p.At(5e-3).supply, 3.4e-9);
  EXPECT_EQ(p.At(8e-3).supply, 0.0);
  // a step that ends before the pulse starts, one that starts inside it, one that straddles two periods
  in.time = 0.021, in.step = 1e-3;
  EXPECT_TRUE(PortSchedule(c, 0, in).breakpoints().empty());
  EXPECT_EQ(PortSchedule(c, 0, in).At(0.5e-3).supply, 0.0);
  in.time = 0.025, in.step = 1e-3;  // 25 to 26 ms, inside the pulse (23.5 to 26.5 ms) throughout
  EXPECT_TRUE(PortSchedule(c, 0, in).breakpoints().empty());
  EXPECT_EQ(PortSchedule(c, 0, in).At(0).supply, 3.4e-9);
  in.time = 0.0255, in.step = 2e-3;  // 25.5 to 27.5 ms: closes 1 ms into the step
  ASSERT_EQ(PortSchedule(c, 0, in).breakpoints().size(), 1u);
  EXPECT_NEAR(PortSchedule(c, 0, in).breakpoints()[0], 1e-3, 1e-12);
  in.time = 0.0265, in.step = 0.01;  // 26.5 to 36.5 ms: the next pulse is 33.5 to 36.5 ms
  PortSchedule next(c, 0, in);
  ASSERT_EQ(next.breakpoints().size(), 1u);
  EXPECT_NEAR(next.breakpoints()[0], 7e-3, 1e-12);
  EXPECT_EQ(next.At(1e-3).supply, 0.0);
  EXPECT_EQ(next.At(8e-3).supply, 3.4e-9);
  // per carrier period the valve is open for the duty fraction, wherever the pulse sits
  c.pwm_alignment = PwmAlignment::kLeading;
  in.time = 0.02, in.step = 0.01;
  PortSchedule leading(c, 0, in);
  EXPECT_NEAR(leading.breakpoints()[0], 3e-3, 1e-12);
}

TEST(OnOffValve, AveragedPwmScalesTheOpeningByTheDuty) {
  // paper 003 eq. (14): duty u >= 0 weights mode 6 by u
  CylinderConfig c = OnOff(0, 0);
  c.input = CommandInput::kPwm, c.pwm_frequency = 0;
  ValveInputs in;
  in.step = 1e-3, in.command[0] = 0.25;
  EXPECT_DOUBLE_EQ(PortSchedule(c, 0, in).At(0).supply, 0.25 * 3.4e-9);
  EXPECT_DOUBLE_EQ(PortSchedule(c, 1, in).At(0).exhaust, 0.25 * 3.4e-9);
  EXPECT_EQ(PortSchedule(c, 1, in).At(0).supply, 0.0);
}

}  // namespace
}  // namespace pneumatic
