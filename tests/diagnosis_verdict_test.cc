// The diagnosis' verdict on real logs (issue 55): the noise floor, the structure of what a model
// leaves, the rejection of implausible or undetermined fits, and the calibration of the model's
// nominal parameters, each against a number worked out by hand or a known truth.
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "diagnosis/calibration.h"
#include "diagnosis/candidates.h"
#include "diagnosis/diagnose.h"
#include "diagnosis/noise_floor.h"
#include "diagnosis/plausibility.h"
#include "diagnosis/refinement.h"
#include "diagnosis/residual_tests.h"
#include "diagnosis/unexplained.h"
#include "simulation/closed_loop.h"

namespace pneumatic::diagnosis {
namespace {

const std::string kRigC = std::string(PNEUMATIC_MODELS_DIR) + "/rig_per_chamber.xml";

// --- the noise floor ---------------------------------------------------------------------------

// Under a slow sine (20 kPa at 0.5 Hz, logged at 500 Hz: its second differences are 0.3 Pa, far
// below the noise) the second-difference estimate recovers white noise of 500 Pa; 5000 rows give its
// lower quartile to about 3 %.
TEST(NoiseFloor, SecondDifferencesRecoverWhiteNoiseUnderASlowSignal) {
  std::mt19937_64 random(7);
  std::normal_distribution<double> noise(0, 500);
  std::vector<double> y;
  for (int i = 0; i < 5000; ++i) y.push_back(3e5 + 2e4 * std::sin(2 * M_PI * 0.5 * i * 0.002) + noise(random));
  EXPECT_NEAR(SensorNoise(y), 500, 25);
  // a noise-free ramp has no second differences at all
  std::vector<double> ramp;
  for (int i = 0; i < 100; ++i) ramp.push_back(1e5 + 10.0 * i);
  EXPECT_NEAR(SensorNoise(ramp), 0, 1e-9);
}

// Each signal's gap is weighed against its own floor: two pressures at their floors of 0.01 and a
// position at four times its floor of 0.002 are sqrt((1 + 1 + 16) / 3) = sqrt(6) = 2.449 floors,
// where the plain ratio of the means, sqrt(2.64e-4 / 2.04e-4) = 1.138, lets the pressures' larger
// floors hide the position. The discretisation gap adds to every signal's floor; a signal without
// a floor leaves the ratio unknown.
TEST(NoiseFloor, EachSignalIsWeighedAgainstItsOwnFloor) {
  NoiseFloor f;
  f.signal_floor = {0.01, 0.01, 0.002};
  const std::vector<double> gap = {0.01, 0.01, 0.008};
  EXPECT_NEAR(GapOverFloor(gap, f), std::sqrt(6.0), 1e-12);
  f.discretisation_gap = 0.002;  // floors^2 1.04e-4, 1.04e-4, 8e-6: ratios^2 0.9615, 0.9615, 8
  EXPECT_NEAR(GapOverFloor(gap, f), std::sqrt((2 * 1e-4 / 1.04e-4 + 6.4e-5 / 8e-6) / 3), 1e-12);
  f.signal_floor[1] = 0;
  f.discretisation_gap = 0;
  EXPECT_TRUE(std::isnan(GapOverFloor(gap, f)));
  EXPECT_TRUE(std::isnan(GapOverFloor({0.01, 0.01}, f)));  // a gap per signal, or none
}

// A prediction that starts each window from the measured (noisy) state and is otherwise exact:
// its first row's error is n_start - n_next, of standard deviation sqrt(2) sigma, and the first-row
// estimate gives sigma (400 windows: the median's error about 6 %).
TEST(NoiseFloor, FirstRowErrorsOfAnExactPredictionGiveTheSensorNoise) {
  std::mt19937_64 random(11);
  std::normal_distribution<double> noise(0, 300);
  Measurements meas;
  meas.period = 0.002;
  CylinderSeries c;
  const int rows = 400 * 10 + 1;
  std::vector<double> truth(rows), measured(rows);
  for (int i = 0; i < rows; ++i) {
    meas.time.push_back(i * meas.period);
    truth[i] = 2e5 + 5e4 * std::sin(i * 0.01);
    measured[i] = truth[i] + noise(random);
  }
  c.signal[kPressureP] = c.signal[kPressureN] = measured;
  c.signal[kPosition].assign(rows, 0);
  meas.cylinders.push_back(c);
  Windows w;
  w.horizon_rows = 10;
  Prediction p;
  p.simulated.assign(3, std::vector<double>(rows, std::nan("")));
  for (int start = 0; start + 1 < rows; start += 10) {
    w.starts.push_back(start);
    // the exact step from the measured start: truth's change added to the start's measurement
    const double next = measured[start] + truth[start + 1] - truth[start];
    p.simulated[kPressureP][start + 1] = p.simulated[kPressureN][start + 1] = next;
    p.simulated[kPosition][start + 1] = 0;
  }
  const std::vector<double> sigma = FirstRowNoise(meas, w, p);
  ASSERT_EQ(sigma.size(), 3u);
  EXPECT_NEAR(sigma[kPressureP], 300, 0.12 * 300);
  EXPECT_EQ(sigma[kPressureP], sigma[kPressureN]);
  EXPECT_EQ(sigma[kPosition], 0);
}

// The noise added to estimate what the windows carry is the same for the same seed, and has the
// standard deviation asked for.
TEST(NoiseFloor, AddedNoiseIsReproducibleAndOfTheGivenSize) {
  Measurements meas;
  meas.period = 0.002;
  CylinderSeries c;
  const int rows = 20000;
  for (int k = 0; k < kSignalsPerCylinder; ++k) c.signal[k].assign(rows, 1.0);
  c.velocity.assign(rows, 0);
  meas.time.assign(rows, 0);
  meas.cylinders.push_back(c);
  const Measurements a = WithAddedNoise(meas, {100, 200, 1e-4}, 42), b = WithAddedNoise(meas, {100, 200, 1e-4}, 42);
  for (int k = 0; k < kSignalsPerCylinder; ++k) EXPECT_EQ(a.cylinders[0].signal[k], b.cylinders[0].signal[k]);
  double sum = 0, sq = 0;
  for (double y : a.cylinders[0].signal[kPressureN]) sum += y - 1, sq += (y - 1) * (y - 1);
  EXPECT_NEAR(sum / rows, 0, 4 * 200 / std::sqrt(rows));
  EXPECT_NEAR(std::sqrt(sq / rows), 200, 0.02 * 200);
  EXPECT_NE(a.cylinders[0].velocity, c.velocity);  // the position's noise moves the velocity estimate
}

// --- the structure of a residual ---------------------------------------------------------------

// The correlation ratio of r = step(q) + noise over q's bins is the step's share of r's variance:
// a step of +-1 over unit noise gives 1 / (1 + 1) = 0.5; r independent of q gives about
// (bins - 1) / n; a state with two values (an on/off command) makes two bins, never bins of r.
TEST(ResidualStructure, CorrelationRatioIsTheShareOfVarianceTheStatesBinsExplain) {
  std::mt19937_64 random(3);
  std::normal_distribution<double> unit(0, 1);
  std::uniform_real_distribution<double> uniform(-1, 1);
  std::vector<double> q, r, independent, onoff, r_onoff;
  for (int i = 0; i < 20000; ++i) {
    q.push_back(uniform(random));
    r.push_back((q.back() > 0 ? 1 : -1) + unit(random));
    independent.push_back(unit(random));
    onoff.push_back(i % 3 == 0 ? 1 : 0);
    r_onoff.push_back(unit(random));
  }
  const BinnedDependence step = CorrelationRatio(r, q, 10);
  EXPECT_NEAR(step.eta2, 0.5, 0.02);
  ASSERT_EQ(step.centre.size(), 10u);
  EXPECT_NEAR(step.mean.front(), -1, 0.05);
  EXPECT_NEAR(step.mean.back(), 1, 0.05);
  EXPECT_LT(CorrelationRatio(independent, q, 10).eta2, 10 * 9.0 / 20000);
  const BinnedDependence binary = CorrelationRatio(r_onoff, onoff, 10);
  EXPECT_EQ(binary.centre.size(), 2u);
  EXPECT_LT(binary.eta2, 10 * 1.0 / 20000);
}

// A one-cylinder log whose residual of x is `residual(row)`, predicted on every row but the first of
// each 20-row window; the floor of every signal `floor`
struct SyntheticResidual {
  Measurements meas;
  GapOptions g;
  Evaluated full;
  NoiseFloor floor;
};
SyntheticResidual MakeResidual(const std::function<double(double x, int row)>& residual, double floor) {
  SyntheticResidual s;
  const int rows = 6000;
  s.meas.period = 0.002;
  CylinderSeries c;
  c.info.name = "cyl";
  // two sines of incommensurate frequencies: x is not periodic over the log, and neither its
  // velocity nor its acceleration is a function of it
  for (int i = 0; i < rows; ++i) {
    const double t = i * s.meas.period, w1 = 2 * M_PI * 0.7, w2 = 2 * M_PI * 0.23;
    s.meas.time.push_back(t);
    c.signal[kPosition].push_back(0.03 * std::sin(w1 * t) + 0.015 * std::sin(w2 * t + 1));
    c.signal[kPressureP].push_back(3e5);
    c.signal[kPressureN].push_back(3e5);
    c.velocity.push_back(0.03 * w1 * std::cos(w1 * t) + 0.015 * w2 * std::cos(w2 * t + 1));
  }
  s.meas.cylinders.push_back(c);
  s.g.signal_scale = {1e4, 1e4, 0.02};
  s.g.windows.horizon_rows = 19;
  for (int start = 0; start + 20 <= rows; start += 20) s.g.windows.starts.push_back(start);
  s.full.prediction.simulated.assign(3, std::vector<double>(rows, std::nan("")));
  double sq[3] = {0, 0, 0};
  int n = 0;
  for (int start : s.g.windows.starts) {
    for (int row = start + 1; row < start + 20; ++row, ++n) {
      const double e = residual(c.signal[kPosition][row], row);
      s.full.prediction.simulated[kPressureP][row] = 3e5;
      s.full.prediction.simulated[kPressureN][row] = 3e5;
      s.full.prediction.simulated[kPosition][row] = c.signal[kPosition][row] + e;
      sq[kPosition] += e * e;
    }
  }
  s.full.signal_rms = {0, 0, std::sqrt(sq[kPosition] / n)};
  s.full.signal_gap = {0, 0, s.full.signal_rms[kPosition] / 0.02};
  s.full.gap = s.full.signal_gap[kPosition] / std::sqrt(3.0);
  s.floor.signal_floor = {floor, floor, floor};
  s.floor.floor = floor;
  return s;
}

// A residual of x that is a dead band of 0.5 mm against the direction of x (a backlash's
// signature, not noise): structured, its strongest dependence on x, and "present" at a floor far
// below it; white noise of the same size is not structured, but as far above the floor it is
// unexplained all the same (a disturbance the states do not show: VerdictWithoutEffect).
TEST(ResidualStructure, AStateDependentResidualIsStructuredAndNoiseIsNot) {
  const SyntheticResidual backlash = MakeResidual([](double x, int) { return x > 0 ? 5e-4 : -5e-4; }, 1e-3);
  const Unexplained u = DescribeResidual(backlash.meas, backlash.g, backlash.full, {}, {}, {}, {}, backlash.floor, 2);
  ASSERT_EQ(u.signals.size(), 3u);
  const ResidualStructure& x = u.signals[kPosition];
  EXPECT_TRUE(x.structured);
  ASSERT_FALSE(x.dependences.empty());
  EXPECT_EQ(x.dependences[0].state, "cyl.x");
  // ten bins of equal count: one may straddle the step, so at least 0.9 of the variance is explained
  EXPECT_GT(x.dependences[0].eta2, 0.9);
  // the systematic part is nearly the whole residual, 0.5 mm over the scale of 20 mm, less the share
  // of the bin that may straddle the step and the chance level
  EXPECT_GT(x.systematic, std::sqrt(0.8) * 5e-4 / 0.02);
  EXPECT_LE(x.systematic, 5e-4 / 0.02 + 1e-12);
  EXPECT_TRUE(u.present);
  EXPECT_EQ(VerdictWithoutEffect(u), "unexplained");
  EXPECT_NE(u.summary.find("cyl.x"), std::string::npos) << u.summary;

  std::mt19937_64 random(5);
  std::normal_distribution<double> noise(0, 5e-4);
  const SyntheticResidual white = MakeResidual([&](double, int) { return noise(random); }, 1e-3);
  const Unexplained w = DescribeResidual(white.meas, white.g, white.full, {}, {}, {}, {}, white.floor, 2);
  EXPECT_FALSE(w.signals[kPosition].structured) << w.summary;
  EXPECT_FALSE(w.structured);
  EXPECT_FALSE(w.present);
  // its gap, 0.5 mm RMS over the scale of 20 mm on one of three signals each of floor 0.001, is
  // about 0.025 / 0.001 / sqrt(3) = 14.4 floors
  EXPECT_NEAR(w.ratio, 14.4, 1.0);
  EXPECT_NEAR(w.gap / w.floor, 14.4, 1.0);  // every floor equal: the log's ratio is the same
  EXPECT_TRUE(w.above_floor) << w.summary;
  EXPECT_EQ(VerdictWithoutEffect(w), "unexplained");
  EXPECT_NE(w.summary.find("drift"), std::string::npos) << w.summary;
}

// The same structured residual within the floor's margin is not unexplained: a gap of 1.5 floors
// (x's gap 1.5 sqrt(3) times its floor, the pressures' none).
TEST(ResidualStructure, AGapWithinTheFloorMarginIsNotUnexplained) {
  const SyntheticResidual s = MakeResidual([](double x, int) { return x > 0 ? 5e-4 : -5e-4; }, 1e-3);
  NoiseFloor floor = s.floor;
  const double f = s.full.signal_gap[kPosition] / (1.5 * std::sqrt(3.0));
  floor.signal_floor = {f, f, f};
  floor.floor = f;
  const Unexplained u = DescribeResidual(s.meas, s.g, s.full, {}, {}, {}, {}, floor, 2);
  EXPECT_NEAR(u.ratio, 1.5, 1e-12);
  EXPECT_TRUE(u.signals[kPosition].structured);
  EXPECT_FALSE(u.above_floor);
  EXPECT_FALSE(u.present);
  EXPECT_EQ(VerdictWithoutEffect(u), "none");
}

// A gap on one signal is not diluted by the others' larger floors: x's residual at 4 floors beside
// pressures of ten times its floor is above the margin (sqrt(16 / 3) = 2.31 floors), though the
// log's gap is 0.23 times the log's floor.
TEST(ResidualStructure, AGapOnOneSignalIsWeighedAgainstItsOwnFloor) {
  const SyntheticResidual s = MakeResidual([](double x, int) { return x > 0 ? 5e-4 : -5e-4; }, 1e-3);
  NoiseFloor floor = s.floor;
  const double f = s.full.signal_gap[kPosition] / 4;
  floor.signal_floor = {10 * f, 10 * f, f};
  floor.floor = std::sqrt((100 + 100 + 1) / 3.0) * f;
  const Unexplained u = DescribeResidual(s.meas, s.g, s.full, {}, {}, {}, {}, floor, 2);
  EXPECT_NEAR(u.ratio, 4 / std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(u.gap / u.floor, 4 / std::sqrt(201.0), 1e-12);
  EXPECT_TRUE(u.above_floor);
  EXPECT_TRUE(u.present);
  EXPECT_EQ(VerdictWithoutEffect(u), "unexplained");
}

// --- implausible and undetermined fits ----------------------------------------------------------

Candidate TwoParameters() {
  Candidate c;
  c.effect = "leakage";
  EffectParameter area;  // logarithmic, absent at its lower bound
  area.name = "cyl:piston_leak_area", area.unit = "m^2", area.lower = 1e-12, area.upper = 1e-5, area.logarithmic = true;
  EffectParameter gain;  // linear, absent at its nominal 1
  gain.name = "cyl.p_P:gain", gain.unit = "1", gain.nominal = 1, gain.lower = 0.5, gain.upper = 1.5;
  c.parameters = {area, gain};
  return c;
}

TEST(Plausibility, RejectsAValueAtItsFarBoundOrOneTheDataDoNotDetermine) {
  const Candidate c = TwoParameters();
  // well determined: passes
  EXPECT_EQ(Implausible(c, {1e-8, 1.03}, {1e-9, 0.005}), "");
  // the area at its upper bound: implausible
  EXPECT_NE(Implausible(c, {1e-5, 1.03}, {1e-9, 0.005}).find("piston_leak_area at its upper bound"), std::string::npos);
  // the gain's standard error larger than its deviation from 1 beside a determined area: the area
  // is the effect, the gain is not shown
  EXPECT_EQ(Implausible(c, {1e-8, 1.03}, {1e-9, 0.04}), "");
  // neither determined: nothing the data show
  EXPECT_NE(Implausible(c, {1e-8, 1.03}, {2e-8, 0.04}).find("not determined"), std::string::npos);
  // the area at its far bound beside an undetermined gain: still implausible
  EXPECT_NE(Implausible(c, {1e-5, 1.03}, {1e-9, 0.04}).find("at its upper bound"), std::string::npos);
  // the area at its lower bound is a leak absent, not a fault; the gain alone is the effect
  EXPECT_EQ(Implausible(c, {1e-12, 1.03}, {1e-6, 0.005}), "");
  // both at the model without the effect: nothing to show
  EXPECT_EQ(Implausible(c, {1e-12, 1.0}, {1e-6, 0.0}).find("every parameter"), 0u);
  EXPECT_NE(Implausible(c, {1e-12, 1.0}, {1e-6, 0.005}), "");
  // the case: a dead time of 0.1 ms +- 12 ms
  Candidate delay;
  EffectParameter dead;
  dead.name = "cyl:spool_dead_time", dead.unit = "s", dead.lower = 1e-5, dead.upper = 0.05, dead.logarithmic = true;
  delay.parameters = {dead};
  EXPECT_NE(Implausible(delay, {1e-4}, {0.012}), "");
  // an unrestricted line is absent at its upper bound (EffectParameter::absent)
  Candidate line;
  EffectParameter conductance;
  conductance.name = "cyl:P.line_conductance", conductance.lower = 1e-10, conductance.upper = 1e-7, conductance.logarithmic = true;
  conductance.absent = conductance.upper;
  EffectParameter volume = conductance;
  volume.name = "cyl:P.line_volume", volume.absent = std::nan("");
  line.parameters = {volume, conductance};
  EXPECT_EQ(Implausible(line, {1e-8, 1e-7}, {1e-9, 1.0}), "");
  // the gas energy equation's wall conductance: adiabatic walls (its lower end) are no effect,
  // isothermal walls (its upper end) a polytropic index of 1, no effect a calibration cannot give;
  // the far bound is also what ValueAtAFarBound names
  Candidate energy;
  EffectParameter wall;
  wall.name = "cyl:wall_heat_conductance", wall.lower = 1e-3, wall.upper = 1e3, wall.logarithmic = true;
  energy.parameters = {wall};
  EXPECT_EQ(Implausible(energy, {1e-3}, {0.5}).find("every parameter"), 0u);
  EXPECT_EQ(Implausible(energy, {1e3}, {1e4}).find("cyl:wall_heat_conductance at its upper bound"), 0u);
  EXPECT_EQ(ValueAtAFarBound(energy, {1e3}).find("cyl:wall_heat_conductance at its upper bound"), 0u);
  EXPECT_EQ(ValueAtAFarBound(energy, {1e-3}), "");
  EXPECT_EQ(ValueAtAFarBound(energy, {1.0}), "");
}

// A nuisance parameter (EffectParameter::nuisance) is not the effect's size: the logged supply's p_S
// sensor offset, where the effect is the logged supply itself. At 0, or undetermined (bench_diagnose's
// rig A supply tank: 7 +- 14 Pa), it leaves the form the effect; at a bound of its range it refuses
// it as any parameter would. Beside a parameter that is the effect's size, that one decides.
TEST(Plausibility, ANuisanceParameterNeitherShowsNorRefusesItsEffect) {
  Candidate logged;
  logged.effect = "supply_drop";
  EffectParameter offset;
  offset.name = "p_S:offset", offset.unit = "Pa", offset.lower = -26000, offset.upper = 26000, offset.scale = 5200;
  offset.nuisance = true;
  logged.parameters = {offset};
  EXPECT_EQ(Implausible(logged, {0.0}, {14.0}), "");
  EXPECT_EQ(Implausible(logged, {6.93}, {14.0}), "");
  EXPECT_EQ(Implausible(logged, {-26000.0}, {14.0}).find("p_S:offset at its lower bound"), 0u);
  // without the flag, the same offset is refused: at 0 it is the model without the effect, at 6.93
  // +- 14 Pa undetermined
  offset.nuisance = false;
  logged.parameters = {offset};
  EXPECT_EQ(Implausible(logged, {0.0}, {14.0}).find("every parameter"), 0u);
  EXPECT_NE(Implausible(logged, {6.93}, {14.0}).find("not determined"), std::string::npos);
  // a nuisance beside a magnitude: the magnitude at the model without the effect refuses the form
  offset.nuisance = true;
  Candidate both = TwoParameters();
  both.parameters.push_back(offset);
  EXPECT_EQ(Implausible(both, {1e-12, 1.0, 6.93}, {1e-6, 0.0, 14.0}).find("every parameter"), 0u);
  EXPECT_EQ(Implausible(both, {1e-8, 1.03, 6.93}, {1e-9, 0.005, 14.0}), "");
}

// --- parameters before effects -------------------------------------------------------------------

// The calibration of rig C: the flow coefficient, both dead volumes, the polytropic index and the
// joint's damping, each starting at the model's value within its plausible range (calibration.h)
TEST(Calibration, FitsTheModelsNominalParametersWithinPlausibleRanges) {
  std::string error;
  ModelPtr m = LoadEditedModel(kRigC, {}, &error);
  ASSERT_TRUE(m) << error;
  Measurements meas;
  CylinderSeries c;
  c.info = Cylinders(m.get())[0];
  c.joint = 0;
  meas.cylinders.push_back(c);
  const Candidate cal = CalibrationCandidate(m.get(), meas);
  std::vector<std::string> names;
  for (const EffectParameter& p : cal.parameters) names.push_back(p.name);
  EXPECT_EQ(names, (std::vector<std::string>{"cyl:discharge_coefficient", "cyl:P.dead_volume", "cyl:N.dead_volume",
                                             "cyl:polytropic_index", "cyl:joint x damping"}));
  // rig C's MJCF: C 0.72, V0 1e-6 m^3, kappa 1.4, damping 20 N s/m
  EXPECT_DOUBLE_EQ(cal.parameters[0].nominal, 0.72);
  EXPECT_DOUBLE_EQ(cal.parameters[0].lower, 0.7 * 0.72);
  EXPECT_DOUBLE_EQ(cal.parameters[1].upper, 1.45e-6);
  // the index over its physical range: isothermal 1 to adiabatic gamma = 1.4, a value at either kept
  EXPECT_DOUBLE_EQ(cal.parameters[3].lower, 1.0);
  EXPECT_DOUBLE_EQ(cal.parameters[3].upper, 1.4);
  EXPECT_TRUE(cal.parameters[3].ends_are_physical_limits);
  EXPECT_FALSE(cal.parameters[0].ends_are_physical_limits);
  EXPECT_DOUBLE_EQ(cal.parameters[4].lower, 0.55 * 20);
  // each applies to the model: both chambers' coefficient, one chamber's dead volume
  ModelPtr edited = LoadEditedModel(kRigC, {}, &error);
  SignalModel signals;
  ASSERT_EQ(cal.parameters[0].apply(edited.get(), &signals, 0.6), "");
  ASSERT_EQ(cal.parameters[2].apply(edited.get(), &signals, 1.2e-6), "");
  ASSERT_EQ(cal.parameters[4].apply(edited.get(), &signals, 25), "");
  EXPECT_EQ(GetParameter(edited.get(), "cyl", "P.discharge_coefficient", &error).value_or(0), 0.6);
  EXPECT_EQ(GetParameter(edited.get(), "cyl", "N.discharge_coefficient", &error).value_or(0), 0.6);
  EXPECT_EQ(GetParameter(edited.get(), "cyl", "N.dead_volume", &error).value_or(0), 1.2e-6);
  EXPECT_EQ(GetParameter(edited.get(), "cyl", "P.dead_volume", &error).value_or(0), 1e-6);
  EXPECT_EQ(edited->dof_damping[0], 25);
}


// --- which richer forms a round fits --------------------------------------------------------------

// a simpler or richer form's result as a round ranks it
CandidateResult Ranked(const std::string& effect, double delta_ic, bool explains, bool refinement = false,
                       bool leaves_nothing_to_explain = false) {
  CandidateResult r;
  r.effect = effect, r.form = effect + (refinement ? " (richer)" : " (simpler)");
  r.delta_ic = delta_ic, r.explains = explains, r.refinement = refinement;
  r.leaves_nothing_to_explain = leaves_nothing_to_explain;
  return r;
}

// The leader is the best simpler form by dIC whatever its effect; the first refined effect the best
// among those with a richer form to fit (heat transfer, one form, leads and is passed over, as on the
// independent suite's C09); the runner-up the next of those whose simpler form explains the gap
// (leakage, better by dIC but not explaining, is passed over). An effect counts with its best
// simpler form; a failed fit (NaN dIC) counts for nothing.
TEST(RefinedEffects, FirstIsTheBestWithRicherFormsAndTheRunnerUpMustExplain) {
  const double failed = std::numeric_limits<double>::quiet_NaN();
  const std::vector<CandidateResult> ranking = {
      Ranked("heat_transfer", -50, true), Ranked("line_dynamics", -20, true), Ranked("line_dynamics", -49, true),
      Ranked("leakage", -45, false),      Ranked("valve_delay", -30, true),   Ranked("friction", failed, false)};
  const std::set<std::string> refinable = {"line_dynamics", "leakage", "valve_delay", "friction"};
  const RefinedEffects e = ChooseRefinedEffects(ranking, refinable);
  EXPECT_EQ(e.leader, "heat_transfer");
  EXPECT_EQ(e.first, "line_dynamics");
  EXPECT_EQ(e.runner_up, "valve_delay");
  // with nothing refinable, no effect is refined, and the leader stays
  const RefinedEffects none = ChooseRefinedEffects(ranking, {});
  EXPECT_EQ(none.leader, "heat_transfer");
  EXPECT_EQ(none.first, "");
  EXPECT_EQ(none.runner_up, "");
  // equal dICs go to the effect first by name
  const RefinedEffects tie = ChooseRefinedEffects({Ranked("valve_delay", -10, true), Ranked("leakage", -10, true)}, {"leakage", "valve_delay"});
  EXPECT_EQ(tie.leader, "leakage");
  EXPECT_EQ(tie.first, "leakage");
  EXPECT_EQ(tie.runner_up, "valve_delay");
}

// A form that leaves nothing to explain settles the richer forms of every other refined effect, but
// not the round leader's: its richer forms are still fitted after another effect's form, and after
// its own simpler forms, until one of its own richer forms leaves nothing to explain.
TEST(RefinedEffects, TheLeadersRicherFormsAreSettledOnlyByItsOwn) {
  std::vector<CandidateResult> ranking = {Ranked("leakage", -40, true), Ranked("supply_drop", -35, true, false, true)};
  // supply_drop's lower supply leaves nothing: the leader's (leakage's) richer forms go on, and so do
  // supply_drop's own (its simpler form does not settle them); any other effect's are settled by it
  EXPECT_EQ(SettledBefore("leakage", ranking, "leakage"), nullptr);
  EXPECT_EQ(SettledBefore("supply_drop", ranking, "leakage"), nullptr);
  const CandidateResult* settled = SettledBefore("valve_delay", ranking, "leakage");
  ASSERT_NE(settled, nullptr);
  EXPECT_EQ(settled->effect, "supply_drop");
  // the leader's own simpler form leaving nothing does not settle its richer forms either
  ranking[0].leaves_nothing_to_explain = true;
  EXPECT_EQ(SettledBefore("leakage", ranking, "leakage"), nullptr);
  // one of its richer forms does
  ranking.push_back(Ranked("leakage", -60, true, true, true));
  settled = SettledBefore("leakage", ranking, "leakage");
  ASSERT_NE(settled, nullptr);
  EXPECT_TRUE(settled->refinement);
  // with supply_drop the leader, leakage's form leaving nothing settles none of supply_drop's
  EXPECT_EQ(SettledBefore("supply_drop", {Ranked("leakage", -40, true, false, true)}, "supply_drop"), nullptr);
}

// --- end to end on rig C ---------------------------------------------------------------------------

// A closed-loop rig C log (PID at 500 Hz on a two-sine reference, 500 Pa / 0.05 mm sensor noise) of
// a rig that is not the model: `real` edits the loaded model before the run.
log::Log RealRigCLog(std::uint64_t seed, double duration, const std::function<void(mjModel*)>& real) {
  std::string error;
  ModelPtr m = LoadEditedModel(kRigC, {}, &error);
  EXPECT_TRUE(m) << error;
  real(m.get());
  log::Log ref;
  ref.columns = {{"cyl", "ref"}};
  ref.values.assign(1, {});
  const double phase = 0.7 * static_cast<double>(seed);
  for (double t = 0; t <= duration + 1e-9; t += 0.01) {
    ref.time.push_back(t);
    ref.values[0].push_back(0.02 * std::sin(2 * M_PI * 0.6 * t + phase) * std::min(t, 1.0) + 0.008 * std::sin(2 * M_PI * 1.3 * t));
  }
  ClosedLoopOptions o;
  o.duration = duration;
  o.control_rate = 500;
  o.reference = &ref;
  o.seed = seed;
  o.noise_pressure = 500;
  o.noise_position = 5e-5;
  ClosedLoopResult r = RunClosedLoop(m.get(), o);
  EXPECT_TRUE(r.log) << r.error;
  r.log->source = "rig C seed " + std::to_string(seed);
  return *r.log;
}

// Parameters before effects: a rig whose discharge coefficient is 17 % low, dead volumes 30 % large
// and damping 25 % high, and nothing else. The verdict is none, with a calibration that finds the
// coefficient and the damping (the dead volumes, 1e-6 m^3 beside chambers of up to 8e-6, are
// weakly seen), and the calibrated model predicts the held-out log better than the model as given.
TEST(DiagnosisVerdict, ParametersOffAloneAreACalibrationNotAnEffect) {
  auto real = [](mjModel* m) {
    std::string error;
    for (const char* key : {"P.discharge_coefficient", "N.discharge_coefficient"}) ASSERT_TRUE(SetParameter(m, "cyl", key, 0.6, &error)) << error;
    for (const char* key : {"P.dead_volume", "N.dead_volume"}) ASSERT_TRUE(SetParameter(m, "cyl", key, 1.3e-6, &error)) << error;
    m->dof_damping[0] = 25;
  };
  const log::Log train = RealRigCLog(1, 4.0, real), held = RealRigCLog(2, 4.0, real);
  DiagnoseOptions o;
  o.effects = {"friction", "leakage", "payload"};
  const Diagnosis d = Diagnose(kRigC, train, &held, o);
  ASSERT_EQ(d.error, "");
  EXPECT_EQ(d.verdict, "none");
  EXPECT_TRUE(d.effects.empty());
  ASSERT_EQ(d.calibration_status.rfind("fitted", 0), 0u) << d.calibration_status;
  ASSERT_EQ(d.calibration.size(), 5u);
  EXPECT_EQ(d.calibration[0].name, "cyl:discharge_coefficient");
  EXPECT_NEAR(d.calibration[0].value, 0.6, 0.03);  // 5 %
  EXPECT_EQ(d.calibration[4].name, "cyl:joint x damping");
  EXPECT_NEAR(d.calibration[4].value, 25, 2.5);  // 10 %
  EXPECT_LT(d.heldout_gap_calibrated, 0.7 * d.heldout_gap_before);
  EXPECT_FALSE(d.unexplained.present) << d.unexplained.summary;
}

// A polytropic index at a physical limit is a value, not a sign of missing physics: a rig whose
// chambers are isothermal (n = 1, the lower end of the index's range) against the model's adiabatic
// 1.4. The calibration keeps the index at 1 where it would set a parameter at the bound of a
// plausible range back to the model's value (and leave the difference to an effect).
TEST(DiagnosisVerdict, AnIndexAtAPhysicalLimitIsKept) {
  auto real = [](mjModel* m) {
    std::string error;
    for (const char* key : {"P.polytropic_index", "N.polytropic_index"}) ASSERT_TRUE(SetParameter(m, "cyl", key, 1.0, &error)) << error;
  };
  const log::Log train = RealRigCLog(1, 4.0, real), held = RealRigCLog(2, 4.0, real);
  DiagnoseOptions o;
  o.effects = {"payload"};
  const Diagnosis d = Diagnose(kRigC, train, &held, o);
  ASSERT_EQ(d.error, "");
  ASSERT_EQ(d.calibration_status.rfind("fitted", 0), 0u) << d.calibration_status;
  EXPECT_EQ(d.calibration_status.find("polytropic_index"), std::string::npos) << d.calibration_status;
  const auto index = std::find_if(d.calibration.begin(), d.calibration.end(),
                                  [](const CalibratedParameter& p) { return p.name == "cyl:polytropic_index"; });
  ASSERT_NE(index, d.calibration.end());
  EXPECT_NEAR(index->value, 1.0, 0.02) << d.calibration_status;
  EXPECT_EQ(d.verdict, "none");
}

// A wrong nominal parameter that hides an effect on the model as given: the rig's damping is 40 %
// below the model's 20 N s/m and its seals have Coulomb friction of 0.3 N (MuJoCo's frictionloss,
// the candidate's own form). On the model as given, friction adds to a dissipation already too high
// and is no evidence at all (its fit stays at zero); the calibration alone takes the damping to
// about 16 N s/m and leaves a structured residual. Fitted together with the calibration (the wider
// joint screening of diagnose.cc), friction is found, and with it both values.
TEST(DiagnosisVerdict, AnEffectAWrongParameterHidesIsFittedWithTheCalibration) {
  auto real = [](mjModel* m) {
    m->dof_damping[0] = 12;
    m->dof_frictionloss[0] = 0.3;
  };
  const log::Log train = RealRigCLog(1, 4.0, real), held = RealRigCLog(2, 4.0, real);
  DiagnoseOptions o;
  o.effects = {"friction"};
  const Diagnosis d = Diagnose(kRigC, train, &held, o);
  ASSERT_EQ(d.error, "");
  ASSERT_FALSE(d.rounds.empty());
  double as_given_ic = std::nan("");  // the Coulomb form's on the model as given
  for (const CandidateResult& c : d.rounds[0].ranking) {
    if (c.on_model_as_given && c.form == "Coulomb friction (the joint's frictionloss)") as_given_ic = c.delta_ic;
  }
  EXPECT_GT(as_given_ic, o.max_delta_ic);  // the case this test is about: no strong evidence as given
  EXPECT_EQ(d.verdict, "friction") << d.unexplained.summary;
  ASSERT_EQ(d.parameters.size(), 1u);  // the Coulomb form: its as-given dIC above, so the wider screening's
  EXPECT_EQ(d.parameters[0].name, "cyl:joint x frictionloss");
  EXPECT_NEAR(d.parameters[0].value, 0.3, 0.045);  // 15 %
  double damping = std::nan("");
  for (const CalibratedParameter& p : d.calibration) {
    if (p.name == "cyl:joint x damping") damping = p.value;
  }
  EXPECT_NEAR(damping, 12, 1.8);  // 15 %
}

// Physics no candidate has: a spring of 2000 N/m pulling the piston to mid-stroke (a load the
// library cannot form: no mass, friction, leak or sensor error acts as a force in x). The verdict
// is unexplained, the residual is above the floor and depends on x, and it looks mechanical: the
// motion from the measured pressures fails, the pressures along the measured motion do not.
TEST(DiagnosisVerdict, PhysicsOutsideTheLibraryIsUnexplained) {
  auto real = [](mjModel* m) { m->jnt_stiffness[0] = 2000; };
  const log::Log train = RealRigCLog(1, 4.0, real), held = RealRigCLog(2, 4.0, real);
  DiagnoseOptions o;
  o.effects = {"friction", "payload", "sensor_bias"};
  const Diagnosis d = Diagnose(kRigC, train, &held, o);
  ASSERT_EQ(d.error, "");
  EXPECT_EQ(d.verdict, "unexplained") << d.unexplained.summary;
  EXPECT_TRUE(d.effects.empty());
  EXPECT_TRUE(d.unexplained.present);
  EXPECT_GT(d.unexplained.ratio, o.floor_multiple);
  EXPECT_GT(d.unexplained.gap, o.floor_multiple * d.unexplained.floor);  // and by the log's means too
  EXPECT_EQ(d.unexplained.side, "mechanical") << d.unexplained.summary;
  const ResidualStructure& x = d.unexplained.signals[kPosition];
  EXPECT_TRUE(x.structured);
}

}  // namespace
}  // namespace pneumatic::diagnosis
