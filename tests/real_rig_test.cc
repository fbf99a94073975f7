// Tests of the diagnosis suite's real rig (tests/reference/real_rig.h) and its case list
// (tests/reference/suite_cases.h): the base rig against tests/reference's docs/rigs.md simulator, a
// conservation law, LuGre's static friction, a tube's limit, the step's convergence, determinism.
#include "real_rig.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "suite_cases.h"

namespace pneumatic::reference {
namespace {

constexpr Rig kRigs[] = {Rig::kOnOff, Rig::kProportional, Rig::kPerChamber};

Sensors Exact() {
  Sensors s;
  s.pressure_lag = 0;
  s.position_quantum = 0;
  return s;
}

// rig A's mode M6 (U1, U4: P from the supply, N to the exhaust)
RigCommand FillP() {
  RigCommand c;
  c.u1 = 1, c.u4 = 1;
  return c;
}

// --- the base rig --------------------------------------------------------------------------------

// Every effect off and docs/rigs.md's numbers: the real rig is docs/rigs.md's rig, as tests/reference
// integrates it (same RK4 step), over 0.5 s of that simulator's own excitation.
TEST(RealRig, EffectFreeNominalRigMatchesTheReference) {
  for (Rig rig : kRigs) {
    const double period = ControlPeriod(rig), step = 1e-5;
    const std::vector<RigCommand> commands = Excitation(rig, 0.5, 3);
    const std::vector<Sample> reference = Simulate(DefaultParams(rig), RigState{}, commands, period, step);
    RealRig real(NominalRealRig(rig), Exact(), step);
    double worst_p = 0, worst_x = 0;
    for (size_t k = 0; k < commands.size(); ++k) {
      const RealRig::State& s = real.state();
      worst_p = std::max({worst_p, std::fabs(s[RealRig::kPP] - reference[k].state.p_P), std::fabs(s[RealRig::kPN] - reference[k].state.p_N)});
      worst_x = std::max(worst_x, std::fabs(s[RealRig::kX] - reference[k].state.x));
      real.Advance(commands[k], period);
    }
    SCOPED_TRACE(RigLetter(rig));
    // rounding only: a millipascal and a nanometre over 0.5 s
    EXPECT_LT(worst_p, 1e-3);
    EXPECT_LT(worst_x, 1e-9);
  }
}

// --- leakage -------------------------------------------------------------------------------------

// The piston leak moves gas from one chamber to the other: with the valves closed the total mass
// p_P V_P / (r T) + p_N V_N / (r T) stays (isothermal chambers, k = 1, so that p V / (r T) is the
// mass while the piston moves), while the pressures equalise.
TEST(RealRig, SealedPistonLeakConservesTheGasMass) {
  RealRigParams p = NominalRealRig(Rig::kOnOff);
  p.rig.polytropic_index = 1;
  p.leakage.piston.laminar = 1e-9;  // m^3/(s Pa)
  p.leakage.piston.orifice = 2e-7;  // m^2
  RealRig rig(p, Exact(), 1e-5);
  RealRig::State s = rig.state();
  s[RealRig::kPP] = 2.8e5, s[RealRig::kPN] = 1.2e5;
  rig.SetState(s);
  const double rt = p.rig.gas_constant * p.rig.temperature;
  auto mass = [&](const RealRig::State& q) {
    const double x = q[RealRig::kX];
    return (q[RealRig::kPP] * (p.rig.area_P * (0.05 + x) + p.dead_volume_P) +
            q[RealRig::kPN] * (p.rig.area_N * (0.05 - x) + p.dead_volume_N)) / rt;
  };
  const double before = mass(rig.state());
  for (int k = 0; k < 500; ++k) rig.Advance(RigCommand{}, 2e-3);  // 1 s, all valves closed
  const RealRig::State& after = rig.state();
  EXPECT_NEAR(mass(after) / before, 1.0, 1e-9);
  // and the leak acted: the pressures are within a tenth of their first difference
  EXPECT_LT(std::fabs(after[RealRig::kPP] - after[RealRig::kPN]), 0.1 * 1.6e5);
}

// The series restriction: laminar at small drops (Q = rho g dp; at 0.01 Pa the orifice part takes
// 2e-6 of the drop), odd in the drop, and below both parts alone at large drops.
TEST(RealRig, SeriesRestrictionIsLaminarAtSmallDropsAndOdd) {
  const SeriesRestriction r{1e-9, 1e-7};
  const double rt = 287 * 293, p = 3e5;
  const double rho = (p + p - 0.01) / (2 * rt);
  EXPECT_NEAR(SeriesRestrictionFlow(r, 287, 293, p, p - 0.01), rho * 1e-9 * 0.01, 1e-5 * rho * 1e-9 * 0.01);
  EXPECT_EQ(SeriesRestrictionFlow(r, 287, 293, 2e5, 3e5), -SeriesRestrictionFlow(r, 287, 293, 3e5, 2e5));
  const double big = SeriesRestrictionFlow(r, 287, 293, 3e5, 1e5), rho_big = 2e5 / rt;
  EXPECT_LT(big, rho_big * 1e-9 * 2e5);
  EXPECT_LT(big, rho_big * 1e-7 * std::sqrt(2 * 2e5 / rho_big));
}

// --- friction ------------------------------------------------------------------------------------

// LuGre holds the piston against a force below the break-away force F_s: after the step's
// transient (the bristles' deflection F / sigma0 = 32 um, and a slip while the bristles swing
// through the Stribeck curve) it stays put; above F_s it slides away.
TEST(RealRig, LuGreHoldsThePistonBelowTheBreakAwayForce) {
  for (double share : {0.8, 1.2}) {
    RealRigParams p = NominalRealRig(Rig::kOnOff);
    p.friction.on = true;
    p.friction.coulomb = 2, p.friction.stiction = 4;  // N
    p.friction.stribeck_velocity = 0.01;
    p.friction.bristle_stiffness = 1e5;
    RealRig rig(p, Exact(), 1e-5);
    RealRig::State s = rig.state();
    const double force = share * p.friction.stiction;
    s[RealRig::kPN] = 1.5e5, s[RealRig::kPP] = 1.5e5 + force / p.rig.area_P;
    rig.SetState(s);
    for (int k = 0; k < 100; ++k) rig.Advance(RigCommand{}, 2e-3);  // 0.2 s, valves closed
    const double settled = rig.state()[RealRig::kX];
    for (int k = 0; k < 400; ++k) rig.Advance(RigCommand{}, 2e-3);  // 0.8 s more
    const double x = rig.state()[RealRig::kX];
    SCOPED_TRACE(share);
    if (share < 1) {
      EXPECT_LT(std::fabs(x), 0.2e-3);
      EXPECT_LT(std::fabs(x - settled), 1e-6);
      EXPECT_LT(std::fabs(rig.state()[RealRig::kV]), 1e-5);
    } else {
      EXPECT_GT(settled, 1e-3);  // slid a millimetre and more within 0.2 s
    }
  }
}

// --- line dynamics -------------------------------------------------------------------------------

// the largest pressure difference (Pa) between rig A's chamber P with a tube and without, over 20 ms
// of filling from the supply and 10 ms of venting
double TubeDeviation(double volume, double laminar, double step) {
  auto run = [&](const RealRigParams& p) {
    RealRig rig(p, Exact(), step);
    std::vector<double> p_P;
    for (int k = 0; k < 15; ++k) {
      p_P.push_back(rig.state()[RealRig::kPP]);
      RigCommand c = FillP();
      if (k >= 10) c.u1 = 0, c.u2 = 1;  // then P vents
      rig.Advance(c, 2e-3);
    }
    p_P.push_back(rig.state()[RealRig::kPP]);
    return p_P;
  };
  RealRigParams base = NominalRealRig(Rig::kOnOff), tube = base;
  tube.tube.volume = volume;
  tube.tube.segments = 4;
  tube.tube.restriction.laminar = laminar;
  const std::vector<double> a = run(base), b = run(tube);
  double worst = 0;
  for (size_t k = 0; k < a.size(); ++k) worst = std::max(worst, std::fabs(a[k] - b[k]));
  return worst;
}

// A tube of vanishing volume and resistance is no tube: with 2 % of the dead volume and a
// restriction dropping about 10 % of the gauge pressure at the valve's full flow (1e-3 kg/s),
// chamber P stays within 10 % of the gauge of the base rig's, and with a quarter of that volume
// and resistance nearer by more than half again (the segments' time constants, 0.5 us and 30 ns,
// set the steps); a tube of no volume is no tube at all
TEST(RealRig, TubeOfVanishingVolumeAndResistanceIsTheBaseRig) {
  const double volume = 0.02 * 2e-6;
  const double laminar = 1e-3 / 2.0 / 2e4;  // m^3/(s Pa): 1e-3 kg/s at about 2 kg/m^3 over 20 kPa
  const double coarse = TubeDeviation(volume, laminar, 2e-7);
  const double fine = TubeDeviation(volume / 4, 4 * laminar, 1.25e-8);
  EXPECT_LT(coarse, 0.1 * 2e5);
  EXPECT_GT(coarse, 0.0);
  EXPECT_LT(fine, 0.35 * coarse);
  EXPECT_EQ(TubeDeviation(0, laminar, 1e-5), 0.0);
}

// --- numerics ------------------------------------------------------------------------------------

// Halving the suite's RK4 step changes the logged signals by less than 1 % of the sensor noise
// (5 Pa, 0.5 um), on a test log of one case of each rig and each effect, replayed open loop
// with the commands of the log.
TEST(RealRig, HalvingTheSuiteStepChangesTheLogsByLessThanOnePercentOfTheNoise) {
  std::set<std::string> seen;
  for (const SuiteCase& c : SuiteCases()) {
    const std::string kind = std::string(RigLetter(c.rig)) + c.truth;
    if (!seen.insert(kind).second && c.truth != "unexplained") continue;
    const std::vector<RigCommand> commands = LogCommands(c.rig, SimulateCase(c, kTestLog, 1.5));
    const log::Log a = ReplayCase(c, commands, kSuiteFineStep), b = ReplayCase(c, commands, kSuiteFineStep / 2);
    double worst_p = 0, worst_x = 0;
    for (const char* signal : {"p_P", "p_N", "p_S", "x"}) {
      const int i = a.FindColumn("cyl", signal);
      for (size_t k = 0; k < a.rows(); ++k) {
        const double d = std::fabs(a.values[i][k] - b.values[i][k]);
        (std::string(signal) == "x" ? worst_x : worst_p) = std::max(std::string(signal) == "x" ? worst_x : worst_p, d);
      }
    }
    SCOPED_TRACE(c.id);
    EXPECT_LT(worst_p, 0.01 * 500);
    EXPECT_LT(worst_x, 0.01 * 5e-5);
  }
}

TEST(RealRig, SameSeedSameBits) {
  const std::vector<SuiteCase> cases = SuiteCases();
  for (const SuiteCase& c : {cases.front(), cases[cases.size() / 2], cases.back()}) {
    const log::Log a = SimulateCase(c, kSelectionLog, 1.0), b = SimulateCase(c, kSelectionLog, 1.0);
    EXPECT_EQ(a.time, b.time);
    EXPECT_EQ(a.values, b.values) << c.id;
    const log::Log other = SimulateCase(c, kTestLog, 1.0);
    EXPECT_NE(a.values, other.values) << c.id << ": the test log must have an excitation of its own";
  }
}

// --- the case list -------------------------------------------------------------------------------

// At least 66 cases with unique ids; per rig at least 3 parameters-only cases; at least 12
// out-of-library ones (6 kinds x 2); every rate used; noise factors in [0.5, 2]; perturbations
// within their bounds; the moving mass as nominal unless the truth is a payload.
TEST(SuiteCases, MixMeetsTheIssue) {
  const std::vector<SuiteCase> cases = SuiteCases();
  EXPECT_GE(cases.size(), 66u);
  std::set<std::string> ids;
  std::map<std::string, int> truths, none_per_rig;
  std::set<double> rates;
  for (const SuiteCase& c : cases) {
    SCOPED_TRACE(c.id);
    EXPECT_TRUE(ids.insert(c.id).second);
    truths[c.truth]++;
    if (c.truth == "none") none_per_rig[RigLetter(c.rig)]++;
    rates.insert(c.rate);
    EXPECT_GE(c.noise, 0.5);
    EXPECT_LE(c.noise, 2.0);
    const Perturbation& p = c.perturbation;
    for (double f : {p.flow, p.critical_ratio}) EXPECT_TRUE(f >= 0.8 && f <= 1.2);
    for (double f : {p.dead_volume_P, p.dead_volume_N, p.damping}) EXPECT_TRUE(f >= 0.7 && f <= 1.3);
    EXPECT_TRUE(p.polytropic_index >= 1.0 && p.polytropic_index <= 1.4);
    EXPECT_EQ(c.params.rig.mass, DefaultParams(c.rig).mass);
    if (c.truth != "payload") EXPECT_EQ(c.params.added_mass, 0.0);
    EXPECT_GE(c.sensors.pressure_lag, 0.03e-3);
    EXPECT_LE(c.sensors.pressure_lag, 0.1e-3);
  }
  for (const char* rig : {"A", "B", "C"}) EXPECT_GE(none_per_rig[rig], 3) << rig;
  EXPECT_GE(truths["unexplained"], 12);
  EXPECT_EQ(rates, (std::set<double>{100, 200, 500, 1000}));
}

// The excitation keeps the piston inside the stroke, off the end stops, most of the time (inside 98 %
// of the half stroke on 95 % of the rows; it tracks set points up to 85 % of it, and a loop with
// no integral action may stop short or beyond) and visits both halves of the stroke.
TEST(SuiteCases, PistonStaysInsideTheStroke) {
  std::set<Rig> seen;
  for (const SuiteCase& c : SuiteCases()) {
    if (!seen.insert(c.rig).second) continue;
    const log::Log log = SimulateCase(c, kTrainLog, kDefaultDurations[kTrainLog]);
    const std::vector<double>& x = log.values[static_cast<size_t>(log.FindColumn("cyl", "x"))];
    const double half = 0.5 * DefaultParams(c.rig).stroke;
    const auto inside = std::count_if(x.begin(), x.end(), [&](double v) { return std::fabs(v) < 0.98 * half; });
    SCOPED_TRACE(c.id);
    EXPECT_GT(static_cast<double>(inside) / x.size(), 0.95);
    EXPECT_LT(*std::min_element(x.begin(), x.end()), -0.3 * half);
    EXPECT_GT(*std::max_element(x.begin(), x.end()), 0.3 * half);
  }
}

}  // namespace
}  // namespace pneumatic::reference
