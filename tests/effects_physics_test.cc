// The unmodelled effects of docs/effects.md as the extension models them (plugin/README.md,
// "Effects"), each checked against numbers with a closed form: a steady state, a conservation law,
// or the solution of a linear equation. Every effect is off by default; a model that switches it
// off explicitly steps bit for bit as one that does not mention it.
#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util.h"
#include "valves.h"

namespace pneumatic {
namespace {

using ::testing::HasSubstr;
using testing::LoadModelFromString;
using testing::MujocoTest;
using testing::Rk4Step;
using testing::SameBits;
using testing::State;

// A piston of `mass` kg on a slide joint "x" (no damping, no gravity, `joint_extra` attributes),
// driven by an on/off cylinder named "cyl" with `keys` added to its configuration; `actuators` are
// the extra actuators (before the chambers: MuJoCo 2.2 wants stateless actuators first, so state
// actuators go to `states`, after the chambers).
struct Spec {
  std::string keys;
  std::string base = "valve=onoff stroke=0.1 area=1.814e-4 dead_volume=2e-6 p_supply=6e5 p_exhaust=1e5 "
                     "temperature=296 sonic_conductance=3.4e-9 critical_ratio=0.433";
  std::string actuators;
  std::string states;
  std::string joint_extra;
  std::string timestep = "0.0005";
  double mass = 1;
  std::string range = "-0.05 0.05";
};

std::string Xml(const Spec& s) {
  std::string valves;
  for (const char* u : {"u1", "u2", "u3", "u4"}) {
    valves += "<general name=\"cyl." + std::string(u) + "\" joint=\"x\" gaintype=\"user\"/>\n";
  }
  char mass[32];
  std::snprintf(mass, sizeof(mass), "%.17g", s.mass);
  return "<mujoco><size nuser_actuator=\"128\"/><option timestep=\"" + s.timestep +
         "\" integrator=\"Euler\" gravity=\"0 0 0\"/>\n<worldbody><body><inertial pos=\"0 0 0\" mass=\"" + mass +
         "\" diaginertia=\"1e-4 1e-4 1e-4\"/><joint name=\"x\" type=\"slide\" axis=\"1 0 0\" limited=\"true\" range=\"" +
         s.range + "\" " + s.joint_extra + "/></body></worldbody>\n<actuator>\n" + valves + s.actuators +
         "<general name=\"cyl.P\" joint=\"x\" dyntype=\"user\" gaintype=\"user\"/>\n"
         "<general name=\"cyl.N\" joint=\"x\" dyntype=\"user\" gaintype=\"user\"/>\n" +
         s.states + "</actuator>\n<custom><text name=\"pneumatic:cyl\" data=\"" + s.base + " " + s.keys +
         "\"/></custom></mujoco>";
}

// a state actuator "cyl.<suffix>" (no force)
std::string StateActuator(const std::string& suffix) {
  return "<general name=\"cyl." + suffix + "\" joint=\"x\" dyntype=\"user\" gaintype=\"user\"/>\n";
}

using Model = testing::LoadedModel;

std::string AttachError(const std::string& xml) {
  std::string error;
  mjModel* m = LoadModelFromString(xml, &error);
  if (!m) return "load failed: " + error;
  bool attached = Attach(m, &error);
  mj_deleteModel(m);
  return attached ? "attached" : error;
}

// steps the model to time `until` (mj_forward after each step, so that its pressures are current) and
// returns the largest relative departure of gas() from `gas0`: a conserved amount's drift
double LargestDrift(const Model& model, const std::function<double()>& gas, double gas0, double until) {
  double worst = 0;
  while (model.d()->time < until) {
    mj_step(model.m(), model.d());
    mj_forward(model.m(), model.d());
    worst = std::max(worst, std::fabs(gas() / gas0 - 1));
  }
  return worst;
}

// ---------------------------------------------------------------------------------------------
// LuGre friction (Canudas de Wit, Olsson, Astrom and Lischinsky 1995, IEEE TAC 40(3):419)

// the cylinder's chambers are left at atmosphere through open exhaust valves, its area tiny: the
// piston feels the friction and the applied force only
constexpr double kFs = 40, kFc = 20, kSigma0 = 1e5;
Spec LuGreSpec(const std::string& extra) {
  Spec s;
  s.base = "valve=onoff stroke=4 area=1e-7 dead_volume=1e-3 p_supply=6e5 p_exhaust=1e5 temperature=296 "
           "sonic_conductance=3.4e-9 critical_ratio=0.433";
  s.keys = "coulomb_friction=20 friction_model=lugre static_friction=40 bristle_stiffness=1e5 " + extra;
  s.actuators = "<general name=\"cyl.friction\" joint=\"x\" gaintype=\"user\" biastype=\"user\"/>\n";
  s.states = StateActuator("z");
  s.range = "-1.9 1.9";
  return s;
}

// steps with a force on the joint given by force(t), valves venting both chambers
void RunWithForce(const Model& model, double until, const std::function<double(double)>& force) {
  model.Ctrl("cyl.u2") = 1, model.Ctrl("cyl.u4") = 1;
  while (model.d()->time < until - 1e-9) {
    model.d()->qfrc_applied[0] = force(model.d()->time);
    mj_step(model.m(), model.d());
  }
}

// Presliding: a force F < F_s, ramped slowly (quasi-static), is held by the bristles alone. With
// v << v_s (g = F_s) and dz/dx = 1 - sigma0 z / F_s along a monotone creep, z = F/sigma0 at rest
// gives the creep x = -(F_s/sigma0) ln(1 - F/F_s) (F/sigma0 to first order); then the piston stays.
// The creep speed grows as 1/(1 - F/F_s) near F_s, and a LuGre breakaway force falls with the rate
// of loading (Canudas de Wit et al. 1995, Section III): v_s = 0.1 m/s and a 2 s ramp keep the creep
// quasi-static (v < 4 mm/s, g within 0.2 % of F_s) up to 0.95 F_s.
Spec PreslidingSpec() { return LuGreSpec("bristle_damping=2000 stribeck_velocity=0.1"); }  // overdamped: 2 sqrt(sigma0 m) = 632
double Ramp(double f, double t) { return f * std::min(t / 2, 1.0); }

TEST(LuGre, ForceBelowBreakawayCreepsByTheBristleDeflectionAndStops) {
  for (double f : {10.0, 20.0, 36.0}) {
    SCOPED_TRACE("F = " + std::to_string(f));
    Model model(Xml(PreslidingSpec()));
    ASSERT_TRUE(model.ok()) << model.error();
    RunWithForce(model, 2.5, [&](double t) { return Ramp(f, t); });
    double x_held = model.d()->qpos[0];
    RunWithForce(model, 3.5, [&](double t) { return Ramp(f, t); });
    double creep = -(kFs / kSigma0) * std::log(1 - f / kFs);
    EXPECT_NEAR(model.d()->qpos[0] / creep, 1, 0.01);
    EXPECT_NEAR(model.Act("cyl.z"), f / kSigma0, 1e-3 * f / kSigma0) << "z = F/sigma0 at rest";
    EXPECT_LT(std::fabs(model.d()->qpos[0] - x_held), 1e-3 * creep) << "no sliding";
    EXPECT_LT(std::fabs(model.d()->qvel[0]), 1e-6);
  }
}

// ramped to just below F_s the piston holds; just above it breaks away and slides, the friction
// falling toward F_c
TEST(LuGre, BreaksAwayOnlyAboveTheStaticLevel) {
  for (double f : {0.95 * kFs, 1.05 * kFs}) {
    SCOPED_TRACE("F = " + std::to_string(f));
    Model model(Xml(PreslidingSpec()));
    ASSERT_TRUE(model.ok()) << model.error();
    // (above: until the piston has slid about 1 m of its 1.9 m)
    RunWithForce(model, f < kFs ? 3 : 2.3, [&](double t) { return Ramp(f, t); });
    double x = model.d()->qpos[0];
    if (f < kFs) {
      double creep = -(kFs / kSigma0) * std::log(1 - f / kFs);  // 1.2 mm
      EXPECT_NEAR(x / creep, 1, 0.02);
      EXPECT_LT(std::fabs(model.d()->qvel[0]), 1e-5);
    } else {
      EXPECT_GT(x, 0.1) << "slides";
      EXPECT_GT(model.d()->qvel[0], 1);
      mj_forward(model.m(), model.d());
      EXPECT_NEAR(model.d()->actuator_force[model.Id("cyl.friction")], -kFc, 0.5) << "sliding at the Coulomb level";
    }
  }
}

// Steady sliding under a constant force F: the velocity settles where the friction g(v) + sigma2 v
// equals F (z at its steady state g(v)/sigma0, dz/dt = 0), the root of
// F_c + (F_s - F_c) exp(-(v/v_s)^2) + sigma2 v = F
TEST(LuGre, SteadySlidingFrictionIsTheStribeckCurvePlusViscous) {
  const double sigma2 = 100, v_s = 0.3, f = 60;
  auto friction = [&](double v) { return kFc + (kFs - kFc) * std::exp(-(v / v_s) * (v / v_s)) + sigma2 * v; };
  double lo = 0.05, hi = 1;  // friction(lo) < f < friction(hi): the curve is increasing beyond its minimum
  ASSERT_LT(friction(lo), f);
  ASSERT_GT(friction(hi), f);
  for (int i = 0; i < 200; ++i) (friction((lo + hi) / 2) < f ? lo : hi) = (lo + hi) / 2;
  const double v_steady = (lo + hi) / 2;
  Model model(Xml(LuGreSpec("stribeck_velocity=0.3 viscous_friction=100 bristle_damping=300 x_mid=0")));
  ASSERT_TRUE(model.ok()) << model.error();
  model.d()->qpos[0] = -1.8;
  RunWithForce(model, 0.5, [&](double) { return f; });
  EXPECT_NEAR(model.d()->qvel[0] / v_steady, 1, 1e-6);
  mj_forward(model.m(), model.d());
  EXPECT_NEAR(model.d()->actuator_force[model.Id("cyl.friction")], -f, 1e-5 * f);
  double g = kFc + (kFs - kFc) * std::exp(-(v_steady / v_s) * (v_steady / v_s));
  EXPECT_NEAR(model.Act("cyl.z") / (g / kSigma0), 1, 1e-6) << "z = g(v)/sigma0";
}

TEST(LuGre, ConfigurationErrorsNameTheKeyAndTheJoint) {
  Spec s = LuGreSpec("");
  s.joint_extra = "frictionloss=\"40\"";
  std::string error = AttachError(Xml(s));
  EXPECT_THAT(error, HasSubstr("key 'friction_model'"));
  EXPECT_THAT(error, HasSubstr("joint 'x'"));
  EXPECT_THAT(error, HasSubstr("frictionloss"));
  s = LuGreSpec("");
  s.states = "";
  error = AttachError(Xml(s));
  EXPECT_THAT(error, HasSubstr("actuator 'cyl.z'"));
  EXPECT_THAT(error, HasSubstr("friction_model=lugre"));
  s = LuGreSpec("");
  s.keys = "coulomb_friction=20 friction_model=lugre";
  EXPECT_THAT(AttachError(Xml(s)), HasSubstr("key 'static_friction': required"));
  s.keys = "coulomb_friction=20 friction_model=lugre static_friction=10";
  EXPECT_THAT(AttachError(Xml(s)), HasSubstr("key 'static_friction': must be at least coulomb_friction"));
  s.keys = "coulomb_friction=20 bristle_stiffness=1e5";
  s.states = "";
  EXPECT_THAT(AttachError(Xml(s)), HasSubstr("key 'bristle_stiffness': applies only to friction_model=lugre"));
}

// ---------------------------------------------------------------------------------------------
// heat_transfer: the energy equation of an open chamber (Richer and Hurmuzlu 2000)

constexpr double kGamma = 1.4, kR = 287, kT = 296, kSupply = 6e5, kAtm = 1e5;
constexpr double kVolumeP = 2e-6 + 1.814e-4 * 0.05;  // chamber P at mid-stroke, m^3
constexpr double kCv = kR / (kGamma - 1);

// rig A with its piston held (1e12 kg: the volumes stay put to 1e-10), gas temperatures as states
Spec EnergySpec(const std::string& wall, const std::string& timestep) {
  Spec s;
  s.keys = "thermal_model=energy heat_capacity_ratio=1.4 step_tolerance=1e-6 wall_heat_conductance=" + wall;
  s.states = StateActuator("TP") + StateActuator("TN");
  s.mass = 1e12;
  s.timestep = timestep;
  return s;
}

// Filling a rigid tank from p0, T0 out of a supply at T_s, adiabatically: the internal energy gained
// is the enthalpy that came in, c_v (m T - m0 T0) = c_p T_s (m - m0), so with m = p V / (r T)
// T = gamma T_s p / (p0 gamma T_s / T0 + (p - p0)) at every pressure p of the fill, whatever its
// history. The gas then stays as it is once the valve closes.
TEST(HeatTransfer, AdiabaticFillHeatsTheGasToTheClosedForm) {
  for (const char* timestep : {"0.0001", "0.001"}) {
    SCOPED_TRACE(timestep);
    Model model(Xml(EnergySpec("0", timestep)));
    ASSERT_TRUE(model.ok()) << model.error();
    mj_forward(model.m(), model.d());
    EXPECT_EQ(model.P(Chamber::kP), kAtm);
    model.Ctrl("cyl.u1") = 1;  // supply into P
    while (model.d()->time < 0.01 - 1e-9) mj_step(model.m(), model.d());
    const double p = model.P(Chamber::kP), t = model.Act("cyl.TP") + kT;
    EXPECT_GT(p, 2e5);
    EXPECT_LT(p, 5e5);
    const double expected = kGamma * kT * p / (kAtm * kGamma * kT / kT + (p - kAtm));
    EXPECT_NEAR(t / expected, 1, 1e-7) << "T = " << t;
    EXPECT_GT(t, kT + 50) << "the gas heats";
    // closed: nothing changes (adiabatic, rigid)
    model.Ctrl("cyl.u1") = 0;
    while (model.d()->time < 0.05 - 1e-9) mj_step(model.m(), model.d());
    EXPECT_NEAR(model.P(Chamber::kP) / p, 1, 1e-9);
    EXPECT_NEAR((model.Act("cyl.TP") + kT) / t, 1, 1e-9);
    // chamber N, sealed, is untouched
    EXPECT_NEAR(model.P(Chamber::kN), kAtm, 1e-6);
    EXPECT_NEAR(model.Act("cyl.TN"), 0, 1e-9);
  }
}

// With the valve closed the gas of mass m exchanges heat with the wall alone: m c_v dT/dt = hA (T_w - T),
// so T - T_w decays as exp(-t hA / (m c_v)), and p = m r T / V with it (p / T constant: mass conserved)
TEST(HeatTransfer, ClosedChamberRelaxesToTheWallWithTimeConstantMcvOverHA) {
  const double wall = 0.05;
  Model model(Xml(EnergySpec("0.05", "0.0005")));
  ASSERT_TRUE(model.ok()) << model.error();
  model.Ctrl("cyl.u1") = 1;
  while (model.d()->time < 0.01 - 1e-9) mj_step(model.m(), model.d());
  model.Ctrl("cyl.u1") = 0;
  const double t_closed = model.d()->time;
  const double p_c = model.P(Chamber::kP), temp_c = model.Act("cyl.TP") + kT;
  ASSERT_GT(temp_c, kT + 30);
  const double mass = p_c * kVolumeP / (kR * temp_c);
  const double tau = mass * kCv / wall;
  ASSERT_GT(tau, 0.2);
  ASSERT_LT(tau, 0.6);
  double worst_t = 0, worst_mass = 0;
  for (double until : {0.1, 0.3, 0.6, 1.0, 1.5}) {
    while (model.d()->time < t_closed + until - 1e-9) mj_step(model.m(), model.d());
    double t = model.Act("cyl.TP") + kT, p = model.P(Chamber::kP);
    double expected = kT + (temp_c - kT) * std::exp(-(model.d()->time - t_closed) / tau);
    worst_t = std::max(worst_t, std::fabs(t - expected) / (temp_c - kT));
    worst_mass = std::max(worst_mass, std::fabs((p / t) / (p_c / temp_c) - 1));
  }
  // step_tolerance=1e-6: 0.5 Pa (or its temperature equivalent) per substep
  EXPECT_LT(worst_t, 1e-5) << "exp(-t hA / (m c_v))";
  EXPECT_LT(worst_mass, 1e-8) << "p / T: the mass";
  EXPECT_NEAR(model.P(Chamber::kP) / (p_c * (model.Act("cyl.TP") + kT) / temp_c), 1, 1e-9);
}

// Sealed, adiabatic and rigid, the chambers exchange gas only across the piston: the mass
// sum p V / (r T) and the internal energy sum p V / (gamma - 1) stay what they were, to round-off, while
// the leak equalizes the pressures (laminar and orifice leaks; the piston held: volumes fixed). Before,
// each chamber stepped with the other held at its start, and the two sides of the leak disagreed.
TEST(HeatTransfer, LeakAcrossThePistonKeepsTheGasMassAndEnergy) {
  for (const char* leak : {"piston_leak_conductance=1e-9", "piston_leak_area=2e-7"}) {
    for (const char* timestep : {"0.0001", "0.001"}) {
      SCOPED_TRACE(std::string(leak) + ", timestep " + timestep);
      Spec s = EnergySpec("0", timestep);
      s.keys += std::string(" ") + leak;
      s.mass = 1e20;  // held: under 3 bar the piston moves 1e-20 m in 0.2 s
      Model model(Xml(s));
      ASSERT_TRUE(model.ok()) << model.error();
      model.Act("cyl.P") = 3e5, model.Act("cyl.N") = 0;  // 4 bar against 1 bar, both at 296 K
      model.Act("cyl.TP") = 40;                            // and P 40 K warmer
      mj_forward(model.m(), model.d());
      auto sums = [&](double* mass, double* energy) {
        *mass = *energy = 0;
        for (Chamber k : {Chamber::kP, Chamber::kN}) {
          const double p = model.P(k), t = model.Act(k == Chamber::kP ? "cyl.TP" : "cyl.TN") + kT;
          *mass += p * kVolumeP / (kR * t);  // both chambers at mid-stroke: kVolumeP each
          *energy += p * kVolumeP / (kGamma - 1);
        }
      };
      double mass0, energy0;
      sums(&mass0, &energy0);
      const double gap0 = model.P(Chamber::kP) - model.P(Chamber::kN);
      double worst_mass = 0, worst_energy = 0;
      while (model.d()->time < 0.2 - 1e-9) {
        mj_step(model.m(), model.d());
        double mass, energy;
        sums(&mass, &energy);
        worst_mass = std::max(worst_mass, std::fabs(mass / mass0 - 1));
        worst_energy = std::max(worst_energy, std::fabs(energy / energy0 - 1));
      }
      const double gap = model.P(Chamber::kP) - model.P(Chamber::kN);
      EXPECT_LT(gap, 0.5 * gap0) << "the leak equalizes the pressures";
      EXPECT_GT(gap, -1e-9 * gap0) << "never past equalization";
      // to round-off: up to 2000 steps, each rounding every pressure and temperature once in act += h act_dot
      // (before: 7.5e-6 to 3.9e-4 of the mass, 1e-5 to 7.3e-4 of the energy)
      EXPECT_LT(worst_mass, 1e-12) << "the gas's mass";
      EXPECT_LT(worst_energy, 1e-11) << "the gas's internal energy (adiabatic, no work)";
    }
  }
}

// Sealed and adiabatic (hA = 0), the chambers follow the piston's work: p V^gamma and T V^(gamma - 1)
// stay constant while the piston (0.9 kg, free) swings between the two gas springs
TEST(HeatTransfer, SealedAdiabaticChambersFollowTheAdiabat) {
  for (const char* timestep : {"0.0001", "0.001"}) {
    SCOPED_TRACE(timestep);
    Spec s = EnergySpec("0", timestep);
    s.mass = 0.9;
    Model model(Xml(s));
    ASSERT_TRUE(model.ok()) << model.error();
    model.Act("cyl.P") = 2.5e5, model.Act("cyl.N") = 1.5e5;  // 3.5 bar and 2.5 bar: swings about x = 7 mm
    mj_forward(model.m(), model.d());
    auto volume = [&](Chamber k) {
      double x = model.d()->qpos[0];
      return 2e-6 + 1.814e-4 * (0.05 + (k == Chamber::kP ? x : -x));
    };
    double worst_p = 0, worst_t = 0, x_max = 0;
    double adiabat[2], isentrope[2];
    for (Chamber k : {Chamber::kP, Chamber::kN}) {
      adiabat[static_cast<int>(k)] = model.P(k) * std::pow(volume(k), kGamma);
      isentrope[static_cast<int>(k)] = kT * std::pow(volume(k), kGamma - 1);
    }
    while (model.d()->time < 0.1 - 1e-9) {
      mj_step(model.m(), model.d());
      mj_forward(model.m(), model.d());
      x_max = std::max(x_max, model.d()->qpos[0]);
      for (Chamber k : {Chamber::kP, Chamber::kN}) {
        int i = static_cast<int>(k);
        double t = model.Act(i == 0 ? "cyl.TP" : "cyl.TN") + kT;
        worst_p = std::max(worst_p, std::fabs(model.P(k) * std::pow(volume(k), kGamma) / adiabat[i] - 1));
        worst_t = std::max(worst_t, std::fabs(t * std::pow(volume(k), kGamma - 1) / isentrope[i] - 1));
      }
    }
    EXPECT_GT(x_max, 0.012) << "the piston swings";
    EXPECT_LT(x_max, 0.05) << "within the stroke";
    EXPECT_LT(worst_p, 1e-6) << "p V^gamma";
    EXPECT_LT(worst_t, 1e-6) << "T V^(gamma - 1)";
  }
}

// A hot chamber (592 K, 5 bar) venting through its open exhaust port (choked: 1 bar / 5 bar < b):
// the ISO 6358 law passes C p sqrt(T_ref / T) (the upstream is the chamber's gas), and with only an
// outflow dp/dt = -gamma r T mdot / V and dT/dt = -(gamma - 1) T mdot / m
TEST(HeatTransfer, OutflowFollowsTheUpstreamTemperature) {
  Model model(Xml(EnergySpec("0", "0.000001")));
  ASSERT_TRUE(model.ok()) << model.error();
  const double p0 = 5e5, t0 = 2 * kT;
  model.Act("cyl.P") = p0 - kAtm;
  model.Act("cyl.TP") = t0 - kT;
  model.Ctrl("cyl.u2") = 1;  // P to exhaust
  mj_step(model.m(), model.d());
  const double h = 1e-6;
  const double mdot = 3.4e-9 * p0 * std::sqrt(kT / t0);
  const double mass = p0 * kVolumeP / (kR * t0);
  EXPECT_NEAR(((model.P(Chamber::kP) - p0) / h) / (-kGamma * kR * t0 * mdot / kVolumeP), 1, 1e-3);
  EXPECT_NEAR((model.Act("cyl.TP") + kT - t0) / h / (-(kGamma - 1) * t0 * mdot / mass), 1, 1e-3);
}

TEST(HeatTransfer, ConfigurationErrorsNameTheKeyOrTheActuator) {
  Spec s = EnergySpec("0.05", "0.0005");
  s.states = StateActuator("TP");
  std::string error = AttachError(Xml(s));
  EXPECT_THAT(error, HasSubstr("actuator 'cyl.TN'"));
  EXPECT_THAT(error, HasSubstr("thermal_model=energy"));
  s = EnergySpec("0.05", "0.0005");
  s.keys = "thermal_model=energy";
  EXPECT_THAT(AttachError(Xml(s)), HasSubstr("key 'P.wall_heat_conductance': required"));
  s.keys = "thermal_model=energy wall_heat_conductance=1 step=explicit";
  EXPECT_THAT(AttachError(Xml(s)), HasSubstr("key 'thermal_model'"));
  s.keys = "wall_heat_conductance=1";
  s.states = "";
  EXPECT_THAT(AttachError(Xml(s)), HasSubstr("key 'P.wall_heat_conductance': applies only to thermal_model=energy"));
  // one value per chamber
  s = EnergySpec("0.05", "0.0005");
  s.keys = "thermal_model=energy P.wall_heat_conductance=0.1 N.wall_heat_conductance=0.2";
  Model model(Xml(s));
  ASSERT_TRUE(model.ok()) << model.error();
  std::string ignored;
  EXPECT_EQ(GetParameter(model.m(), "cyl", "N.wall_heat_conductance", &ignored).value_or(0), 0.2);
}

// ---------------------------------------------------------------------------------------------
// line_dynamics: a line volume between the valve and the chamber, behind an ISO 6358 restriction

// A line of V_L = 1e-6 m^3 at 1 bar behind chamber P's supply valve (C_v = 3.4e-9 kg/(s Pa)), into a
// chamber of 1.009e-3 m^3 at 0.2 bar (p_exhaust = p_atm = 0.2 bar) through C_r = 8.5e-9 kg/(s Pa).
// Both restrictions stay choked (p_L < b p_supply, p < b p_L), so the flows are linear and
//   dp_L/dt = (r T / V_L)(C_v p_s - C_r p_L):  p_L = p_inf + (p_L0 - p_inf) exp(-t / tau),
//   tau = V_L / (r T C_r) = 1.385 ms, p_inf = C_v p_s / C_r = 2.4 bar;
//   dp/dt = n r T C_r p_L / V:  p = p0 + (n r T C_r / V)(p_inf t + (p_L0 - p_inf) tau (1 - exp(-t / tau)))
TEST(LineDynamics, ASupplyStepReachesTheChamberWithTheLinesTimeConstant) {
  const double v_line = 1e-6, c_r = 8.5e-9, c_v = 3.4e-9, p_atm = 2e4, line0 = 1e5, n = 1.4;
  const double tau = v_line / (kR * kT * c_r), p_inf = c_v * kSupply / c_r;
  const double v = 1e-3 + 1.814e-4 * 0.05;
  for (const char* timestep : {"0.0001", "0.001"}) {
    SCOPED_TRACE(timestep);
    Spec s;
    s.base = "valve=onoff stroke=0.1 area=1.814e-4 dead_volume=2e-6 P.dead_volume=1e-3 p_supply=6e5 p_exhaust=2e4 "
             "temperature=296 sonic_conductance=3.4e-9 critical_ratio=0.433 step_tolerance=1e-8";
    s.keys = "P.line_volume=1e-6 P.line_conductance=8.5e-9";
    s.states = StateActuator("LP");
    s.mass = 1e12;
    s.timestep = timestep;
    Model model(Xml(s));
    ASSERT_TRUE(model.ok()) << model.error();
    // the line's state through the public API (pneumatic.h): chamber P's line, none at chamber N
    const CylinderInfo info = Cylinders(model.m()).at(0);
    ASSERT_TRUE(SetLinePressure(model.m(), model.d(), info, Chamber::kP, line0));
    EXPECT_EQ(model.Act("cyl.LP"), line0 - p_atm);
    EXPECT_FALSE(SetLinePressure(model.m(), model.d(), info, Chamber::kN, line0)) << "chamber N has no line";
    EXPECT_FALSE(LinePressure(model.m(), model.d(), info, Chamber::kN).has_value());
    model.Ctrl("cyl.u1") = 1;
    double worst_line = 0, worst_chamber = 0;
    for (double until : {0.001, 0.002, 0.005, 0.008}) {
      while (model.d()->time < until - 1e-9) mj_step(model.m(), model.d());
      double t = model.d()->time, decay = std::exp(-t / tau);
      double line = LinePressure(model.m(), model.d(), info, Chamber::kP).value();
      double chamber = model.P(Chamber::kP);
      double expected_line = p_inf + (line0 - p_inf) * decay;
      double expected = p_atm + n * kR * kT * c_r / v * (p_inf * t + (line0 - p_inf) * tau * (1 - decay));
      ASSERT_LT(line, 0.433 * kSupply) << "the valve stays choked";
      ASSERT_LT(chamber, 0.433 * line) << "the restriction stays choked";
      worst_line = std::max(worst_line, std::fabs(line - expected_line) / (p_inf - line0));
      worst_chamber = std::max(worst_chamber, std::fabs(chamber - expected) / (expected - p_atm));
    }
    EXPECT_LT(worst_line, 1e-6);
    EXPECT_LT(worst_chamber, 1e-6);
  }
}

// valves closed, an isothermal chamber (n = 1) at fixed volume: the line at 3 bar empties into the
// chamber at 1 bar, and the gas p_L V_L + p V stays; both end at the mixed pressure
TEST(LineDynamics, LineAndChamberConserveTheGasWithTheValveClosed) {
  const double v_line = 5e-6, line0 = 3e5;
  Spec s;
  s.keys = "polytropic_index=1 line_volume=5e-6 line_conductance=1e-9";
  s.states = StateActuator("LP") + StateActuator("LN");
  s.mass = 1e12;
  s.timestep = "0.0005";
  Model model(Xml(s));
  ASSERT_TRUE(model.ok()) << model.error();
  model.Act("cyl.LP") = line0 - kAtm;
  mj_forward(model.m(), model.d());
  auto gas = [&] { return (model.Act("cyl.LP") + kAtm) * v_line + model.P(Chamber::kP) * kVolumeP; };
  const double gas0 = gas();
  const double worst = LargestDrift(model, gas, gas0, 0.3);
  const double mixed = gas0 / (v_line + kVolumeP);
  EXPECT_LT(worst, 1e-10);
  EXPECT_NEAR(model.P(Chamber::kP) / mixed, 1, 1e-6);
  EXPECT_NEAR((model.Act("cyl.LP") + kAtm) / mixed, 1, 1e-6);
  EXPECT_NEAR(model.P(Chamber::kN), kAtm, 1e-4) << "chamber N and its line stay at p_atm (1e-9)";
  EXPECT_NEAR(model.Act("cyl.LN"), 0, 1e-4);
}

// valves closed, isothermal (n = 1), fixed volumes: both lines, both chambers and the two leaks across
// the piston (laminar and orifice, taken in halves around the lines' steps) exchange gas with
// p_LP V_L + p_P V_P + p_N V_N + p_LN V_L conserved; all four end at the mixed pressure
TEST(LineDynamics, LinesAndLeaksAcrossThePistonConserveTheGas) {
  for (const char* step : {"linearized", "exact"}) {
    SCOPED_TRACE(step);
    const double v_line = 5e-6;
    Spec s;
    s.keys = std::string("polytropic_index=1 line_volume=5e-6 line_conductance=1e-9 piston_leak_conductance=1e-10 "
                         "piston_leak_area=1e-8 step=") + step;
    s.states = StateActuator("LP") + StateActuator("LN");
    s.mass = 1e12;
    s.timestep = "0.001";
    Model model(Xml(s));
    ASSERT_TRUE(model.ok()) << model.error();
    model.Act("cyl.LP") = 4e5 - kAtm;
    model.Act("cyl.N") = 2e5 - kAtm;
    mj_forward(model.m(), model.d());
    auto gas = [&] {
      return (model.Act("cyl.LP") + model.Act("cyl.LN") + 2 * kAtm) * v_line +
             (model.P(Chamber::kP) + model.P(Chamber::kN)) * kVolumeP;
    };
    const double gas0 = gas();
    const double worst = LargestDrift(model, gas, gas0, 10);
    EXPECT_LT(worst, 1e-10);
    const double mixed = gas0 / (2 * v_line + 2 * kVolumeP);
    EXPECT_NEAR(model.P(Chamber::kP) / mixed, 1, 1e-6);
    EXPECT_NEAR(model.P(Chamber::kN) / mixed, 1, 1e-6);
    EXPECT_NEAR((model.Act("cyl.LP") + kAtm) / mixed, 1, 1e-6);
    EXPECT_NEAR((model.Act("cyl.LN") + kAtm) / mixed, 1, 1e-6);
  }
}

TEST(LineDynamics, ConfigurationErrorsNameTheKeyOrTheActuator) {
  Spec s;
  s.keys = "P.line_volume=1e-6 P.line_conductance=1e-9";
  std::string error = AttachError(Xml(s));
  EXPECT_THAT(error, HasSubstr("actuator 'cyl.LP'"));
  EXPECT_THAT(error, HasSubstr("P.line_volume > 0"));
  s.states = StateActuator("LP") + StateActuator("LN");
  EXPECT_THAT(AttachError(Xml(s)), HasSubstr("actuator 'cyl.LN': has no role"));
  s.keys = "line_volume=1e-6";
  EXPECT_THAT(AttachError(Xml(s)), HasSubstr("key 'P.line_conductance': required"));
  s.keys = "line_conductance=1e-9";
  EXPECT_THAT(AttachError(Xml(s)), HasSubstr("key 'P.line_conductance': applies only to line_volume > 0"));
}

// ---------------------------------------------------------------------------------------------
// leakage through orifices: paper 001 eq. 2 (Sanville 1971) with C_d = 1 and critical ratio 0.528

// the law written here independently: mass flow (kg/s) from p_u to p_d through an orifice of area a
double Orifice(double a, double p_u, double p_d) {
  const double c1 = std::sqrt(kGamma / kR * std::pow(2 / (kGamma + 1), (kGamma + 1) / (kGamma - 1)));
  const double b = 0.528, r = p_d / p_u;
  double shape = r <= b ? 1 : std::sqrt(1 - std::pow((r - b) / (1 - b), 2));
  return c1 * a * p_u / std::sqrt(kT) * shape;
}

// Two sealed chambers at fixed volume (isothermal, n = 1), 5 bar and 1 bar, joined by an orifice of
// 1e-8 m^2 across the piston: the first step's rates are -r T Q / V_P and +r T Q / V_N with Q the
// choked flow (1/5 < 0.528); the gas p_P V_P + p_N V_N stays; both end at the mixed pressure.
TEST(Leakage, PistonOrificeEqualisesTheChambersAtTheOrificeRate) {
  for (const char* step : {"linearized", "exact", "explicit"}) {
    SCOPED_TRACE(step);
    Spec s;
    s.keys = std::string("polytropic_index=1 piston_leak_area=1e-8 step=") + step;
    s.mass = 1e12;
    s.timestep = "0.00001";
    Model model(Xml(s));
    ASSERT_TRUE(model.ok()) << model.error();
    const double p_p = 5e5;
    model.Act("cyl.P") = p_p - kAtm;
    mj_forward(model.m(), model.d());
    const double v_n = kVolumeP;  // both chambers at mid-stroke (the held piston moves by nanometres)
    auto volume = [&](Chamber k) { return 2e-6 + 1.814e-4 * (0.05 + (k == Chamber::kP ? 1 : -1) * model.d()->qpos[0]); };
    auto gas = [&] { return model.P(Chamber::kP) * volume(Chamber::kP) + model.P(Chamber::kN) * volume(Chamber::kN); };
    const double gas0 = gas();
    mj_step(model.m(), model.d());
    const double q = Orifice(1e-8, p_p, kAtm), h = 1e-5;
    EXPECT_NEAR((model.P(Chamber::kP) - p_p) / h / (-kR * kT * q / kVolumeP), 1, 1e-4);
    EXPECT_NEAR((model.P(Chamber::kN) - kAtm) / h / (kR * kT * q / v_n), 1, 1e-4);
    if (std::string(step) == "explicit") continue;  // plain explicit Euler: the rate only
    model.m()->opt.timestep = 0.001;
    const double worst = LargestDrift(model, gas, gas0, 10);
    EXPECT_LT(worst, 1e-10);
    const double mixed = gas0 / (kVolumeP + v_n);
    EXPECT_NEAR(model.P(Chamber::kP) / mixed, 1, 1e-6);
    EXPECT_NEAR(model.P(Chamber::kN) / mixed, 1, 1e-6);
  }
}

// chamber P at 3 bar, sealed, with an orifice of 2e-8 m^2 to the atmosphere: the first step's rate is
// -n r T Q / V (choked, 1/3 < 0.528); it vents to p_atm and stays there; chamber N is untouched
TEST(Leakage, AtmosphereOrificeVentsAtTheOrificeRate) {
  for (const char* step : {"linearized", "exact"}) {
    SCOPED_TRACE(step);
    Spec s;
    s.keys = std::string("P.atmosphere_leak_area=2e-8 step=") + step;
    s.mass = 1e12;
    s.timestep = "0.00001";
    Model model(Xml(s));
    ASSERT_TRUE(model.ok()) << model.error();
    const double p0 = 3e5, n = 1.4;
    model.Act("cyl.P") = p0 - kAtm;
    mj_step(model.m(), model.d());
    EXPECT_NEAR((model.P(Chamber::kP) - p0) / 1e-5 / (-n * kR * kT * Orifice(2e-8, p0, kAtm) / kVolumeP), 1, 1e-4);
    model.m()->opt.timestep = 0.001;
    while (model.d()->time < 5) mj_step(model.m(), model.d());
    EXPECT_NEAR(model.P(Chamber::kP), kAtm, 1);
    EXPECT_GE(model.P(Chamber::kP), kAtm - 1e-6) << "never below the atmosphere";
    // sealed chamber N follows the held piston's nanometres: p V^n
    double v_n = 2e-6 + 1.814e-4 * (0.05 - model.d()->qpos[0]);
    EXPECT_NEAR(model.P(Chamber::kN) * std::pow(v_n / kVolumeP, n) / kAtm, 1, 1e-12);
  }
}

// the ISO 6358 law (paper 002 eq. 4) written here independently: mass flow (kg/s) from p_u to p_d
// through a conductance c (kg/(s Pa)) with critical ratio b; above a pressure ratio of `laminar` (the
// line's restriction: 0.999) linear in the pressure difference down to zero flow (plugin/README.md)
double Iso6358(double c, double b, double p_u, double p_d, double laminar = 1) {
  if (p_u < p_d) return -Iso6358(c, b, p_d, p_u, laminar);
  auto shape = [&](double r) { return r <= b ? 1 : std::sqrt(1 - std::pow((r - b) / (1 - b), 2)); };
  const double r = p_d / p_u;
  if (r <= laminar) return c * p_u * shape(r);
  return c * p_u * shape(laminar) * (1 - r) / (1 - laminar);
}

// Chamber P filling through a line (V_L = 2e-6 m^3, C_r = 5e-9 kg/(s Pa)) from the supply valve, chamber
// N venting through its exhaust valve, and every leak at once: laminar (2e-11 kg/(s Pa)) and orifice
// (5e-9 m^2) across the piston, an orifice (5e-9 m^2) from chamber P to the atmosphere. The piston held
// (fixed volumes), the equations are integrated here independently by classical RK4 at 1 us:
//   dp_L/dt = r T (Q_v(p_s, p_L) - Q_r(p_L, p_P)) / V_L
//   dp_P/dt = n r T (Q_r(p_L, p_P) + G (p_N - p_P) + Q_o(p_N, p_P) + Q_o(p_atm, p_P)) / V_P
//   dp_N/dt = n r T (-Q_v(p_N, p_ex) + G (p_P - p_N) + Q_o(p_P, p_N)) / V_N
// The extension takes the leaks across the piston in halves around the line's step (Strang splitting,
// second order), each part to step_tolerance = 1e-7: from 1 ms to 0.25 ms its error falls by more than
// the fourfold of a first-order method (second order: sixteen, less the tolerance's floor of about 2e-6
// of supply - exhaust, which the same run without leaks shows), and at 0.25 ms it is below 1e-4 of
// supply - exhaust. (Measured: 9.8e-5 and 1.7e-5.) It reaches the supply pressure in the steady state.
TEST(Leakage, WithALineFollowsAnIndependentFineStepReference) {
  const double n = 1.4, g = 2e-11, area = 5e-9, v_line = 2e-6, c_r = 5e-9, c_v = 3.4e-9, until = 0.2;
  // Orifice() is written for p_u >= p_d: the signed flow
  auto orifice = [&](double p_from, double p_to) {
    return p_from >= p_to ? Orifice(area, p_from, p_to) : -Orifice(area, p_to, p_from);
  };
  auto rates = [&](const double p[3], double out[3]) {  // p_L, p_P, p_N
    const double q_r = Iso6358(c_r, 0.433, p[0], p[1], 0.999);
    out[0] = kR * kT * (Iso6358(c_v, 0.433, kSupply, p[0]) - q_r) / v_line;
    out[1] = n * kR * kT * (q_r + g * (p[2] - p[1]) + orifice(p[2], p[1]) + orifice(kAtm, p[1])) / kVolumeP;
    out[2] = n * kR * kT * (-Iso6358(c_v, 0.433, p[2], kAtm) + g * (p[1] - p[2]) + orifice(p[1], p[2])) / kVolumeP;
  };
  std::vector<std::array<double, 3>> reference;  // every 1 ms
  {
    double p[3] = {kAtm, kAtm, 4e5};
    const double h = 1e-6;
    const int per_ms = 1000;
    reference.push_back({p[0], p[1], p[2]});
    for (int i = 1; i <= static_cast<int>(std::lround(until / h)); ++i) {
      Rk4Step<3>(rates, h, p);
      if (i % per_ms == 0) reference.push_back({p[0], p[1], p[2]});
    }
  }
  for (const char* step : {"linearized", "exact"}) {
    SCOPED_TRACE(step);
    double error[2] = {0, 0};
    const char* timesteps[2] = {"0.001", "0.00025"};
    for (int t = 0; t < 2; ++t) {
      Spec s;
      s.keys = std::string("P.line_volume=2e-6 P.line_conductance=5e-9 piston_leak_conductance=2e-11 piston_leak_area=5e-9 "
                           "P.atmosphere_leak_area=5e-9 step_tolerance=1e-7 step=") + step;
      s.states = StateActuator("LP");
      s.mass = 1e12;
      s.timestep = timesteps[t];
      Model model(Xml(s));
      ASSERT_TRUE(model.ok()) << model.error();
      model.Act("cyl.N") = 4e5 - kAtm;
      model.Ctrl("cyl.u1") = 1, model.Ctrl("cyl.u4") = 1;
      const CylinderInfo info = Cylinders(model.m()).at(0);
      for (size_t ms = 1; ms < reference.size(); ++ms) {
        while (model.d()->time < 1e-3 * ms - 1e-9) mj_step(model.m(), model.d());
        const double got[3] = {LinePressure(model.m(), model.d(), info, Chamber::kP).value(), model.P(Chamber::kP),
                               model.P(Chamber::kN)};
        for (int j = 0; j < 3; ++j) error[t] = std::max(error[t], std::fabs(got[j] - reference[ms][j]) / (kSupply - kAtm));
      }
    }
    // the steady state at the default step_tolerance (1e-4): line and chamber at the supply pressure (a
    // slope taken at the line's pressure, not the chord, once left them short of it, oscillating)
    {
      Spec s;
      s.keys = std::string("P.line_volume=2e-6 P.line_conductance=5e-9 step=") + step;
      s.states = StateActuator("LP");
      s.mass = 1e12;
      s.timestep = "0.001";
      Model model(Xml(s));
      ASSERT_TRUE(model.ok()) << model.error();
      model.Ctrl("cyl.u1") = 1;
      while (model.d()->time < 0.2 - 1e-9) mj_step(model.m(), model.d());
      EXPECT_NEAR(LinePressure(model.m(), model.d(), Cylinders(model.m()).at(0), Chamber::kP).value(), kSupply, 1);
      EXPECT_NEAR(model.P(Chamber::kP), kSupply, 1);
    }
    std::printf("%s: largest error %.3g at 1 ms, %.3g at 0.25 ms (of supply - exhaust)\n", step, error[0], error[1]);
    EXPECT_GT(error[0] / error[1], 4);
    EXPECT_LT(error[1], 1e-4);
  }
}

// ---------------------------------------------------------------------------------------------
// valve_deadband for valve=proportional_per_chamber (deadband_voltage)

// paper 000 eq. 3 with the seals moved out by the deadband: a(u; d) = a(u -/+ d; 0), so inside the
// widened band [U_r - d, U_c + d] no port opens beyond its area at the (moved) seal, the leak
TEST(ValveDeadband, PerChamberSealsMoveOutByTheDeadband) {
  ChamberConfig k;
  k.area_gain = 2e-6, k.u_supply_seal = 5.3, k.u_exhaust_seal = 4.7;
  k.leak_area_supply = 5e-8, k.leak_area_exhaust = 5e-8, k.area_smoothing = 1e-6;
  const double d = 1;
  const double supply_leak = ProportionalValveAreas(k, k.u_supply_seal).supply;
  const double exhaust_leak = ProportionalValveAreas(k, k.u_exhaust_seal).exhaust;
  for (double u = 3.7; u <= 6.3; u += 0.05) {
    SCOPED_TRACE(u);
    PortOpenings a = ProportionalValveAreas(k, u, d);
    EXPECT_LE(a.supply, supply_leak * (1 + 1e-12));
    EXPECT_LE(a.exhaust, exhaust_leak * (1 + 1e-12));
    EXPECT_NEAR(a.supply / ProportionalValveAreas(k, u - d).supply, 1, 1e-12);
    EXPECT_NEAR(a.exhaust / ProportionalValveAreas(k, u + d).exhaust, 1, 1e-12);
  }
  // beyond the band the ports open at the gain B, as without the deadband
  EXPECT_NEAR(ProportionalValveAreas(k, 8.3, d).supply / ProportionalValveAreas(k, 7.3).supply, 1, 1e-12);
  EXPECT_GT(ProportionalValveAreas(k, 8.3, d).supply, 3e-6);
}

// rig C with deadband_voltage=1 V commanded inside the widened band (uP = U_c + 0.9 V, uN = U_r - 0.9 V)
// steps as rig C with its seals moved to U_c + 1 and U_r - 1 (inside their sealed band: the leaks only,
// bounded as above); without the deadband the same commands fill P and vent N
TEST(ValveDeadband, CommandsInsideTheWidenedBandGiveOnlyTheLeaks) {
  std::string rig = testing::ReadText(testing::ShippedModel("rig_per_chamber.xml"));
  std::string with = testing::ReplaceAll(rig, "valve=proportional_per_chamber", "valve=proportional_per_chamber deadband_voltage=1");
  std::string moved = testing::ReplaceAll(rig, "u_supply_seal=5.3 u_exhaust_seal=4.7", "u_supply_seal=6.3 u_exhaust_seal=3.7");
  Model deadband(with), seals(moved), open(rig);
  ASSERT_TRUE(deadband.ok()) << deadband.error();
  ASSERT_TRUE(seals.ok()) << seals.error();
  const double u_c = 5.3, u_r = 4.7;  // rig C's seals
  for (const Model* model : {&deadband, &seals, &open}) {
    model->Ctrl("cyl.uP") = u_c + 0.9, model->Ctrl("cyl.uN") = u_r - 0.9;
    while (model->d()->time < 0.05 - 1e-9) mj_step(model->m(), model->d());
  }
  for (Chamber k : {Chamber::kP, Chamber::kN}) EXPECT_NEAR(deadband.P(k) / seals.P(k), 1, 1e-12);
  EXPECT_GT(open.P(Chamber::kP) - deadband.P(Chamber::kP), 1e5) << "without the deadband P fills";
  EXPECT_GT(deadband.P(Chamber::kN) - open.P(Chamber::kN), 5e4) << "without the deadband N stays vented";
  // deadband_voltage=0 is rig C, bit for bit
  Model zero(testing::ReplaceAll(rig, "valve=proportional_per_chamber", "valve=proportional_per_chamber deadband_voltage=0"));
  Model plain(rig);
  ASSERT_TRUE(zero.ok()) << zero.error();
  testing::RunPattern(zero.m(), zero.d(), zero.cylinder(), 0, 400);
  testing::RunPattern(plain.m(), plain.d(), plain.cylinder(), 0, 400);
  EXPECT_TRUE(SameBits(State(zero.m(), zero.d()), State(plain.m(), plain.d())));
}

// ---------------------------------------------------------------------------------------------
// every effect off: the same bits as a model that does not name it

TEST(EffectsOff, DefaultsGiveTheSameBitsAsAModelWithoutTheKeys) {
  const std::string pattern_keys[] = {
      "friction_model=coulomb_stribeck",
      "thermal_model=polytropic",
      "line_volume=0",
      "piston_leak_area=0 atmosphere_leak_area=0",
  };
  for (const std::string& keys : pattern_keys) {
    SCOPED_TRACE(keys);
    Spec plain, named;
    named.keys = keys;
    Model a(Xml(plain)), b(Xml(named));
    ASSERT_TRUE(a.ok()) << a.error();
    ASSERT_TRUE(b.ok()) << b.error();
    for (int i = 0; i < 400; ++i) {
      bool push = (i / 100) % 2 == 0;
      for (const Model* model : {&a, &b}) {
        model->Ctrl("cyl.u1") = push, model->Ctrl("cyl.u4") = push;
        model->Ctrl("cyl.u2") = !push, model->Ctrl("cyl.u3") = !push;
        mj_step(model->m(), model->d());
      }
    }
    EXPECT_TRUE(SameBits(State(a.m(), a.d()), State(b.m(), b.d())));
  }
}

}  // namespace
}  // namespace pneumatic
