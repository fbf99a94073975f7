// Identification of paper 000's parametric pressure model (eqs. 7-10) from logs: the model's
// prediction and its derivatives, recovery of known parameters from data the model itself made,
// the fit and its multi-step drift on closed-loop logs of rig C (paper 000 V.C-V.D), bad input.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "formats/log_csv.h"
#include "identification/chamber_series.h"
#include "identification/drift.h"
#include "identification/output_error_fit.h"
#include "identification/parametric_fit.h"
#include "pneumatic/pneumatic.h"
#include "simulation/generate.h"
#include "test_util.h"

namespace pneumatic::identification {
namespace {

using ::testing::HasSubstr;
using testing::AttachedModel;
using testing::ShippedModel;

constexpr double kPc = 6.2e5, kPr = 1.0e5;  // Pa abs: rig C's supply and exhaust
constexpr double kH = 0.01;                 // s: paper 000's 100 Hz

ParametricModel Model(const std::array<double, 9>& c) {
  ParametricModel m;
  m.c = c;
  m.c_b = (kPc + kPr) / 2;
  m.c_s = (kPc - kPr) / 2;
  return m;
}

// ---------------------------------------------------------------------------------------------
// (1) the prediction

TEST(PredictNext, MatchesHandComputedValues) {
  // c1 = 5 V, c2 = 2 /V, c7 = 50 /(V s), c9 = 0.05 V, the rest 0; u = 6 V, x = 0, x' = 0, p = 2e5 Pa:
  //   u^ = 1 V, a = 2, g = 2/sqrt(5) = 0.8944272, s = 3.6e5 + 2.6e5 g = 592551.070 Pa        (10c)
  //   k = sqrt(1 + 0.01) - 0.1 + 0.05 = 0.9549876 V, r = 50 k = 47.749378 /s, r h = 0.4774938  (9, 10e)
  //   p(t+h) = s + (p - s) e^(-r h) = 592551.070 - 392551.070 x 0.6203361 = 349037.453 Pa    (7)
  ParametricModel m = Model({5, 2, 0, 0, 0, 0, 50, 0, 0.05});
  EXPECT_NEAR(EvaluateModel(m, 6, 0, 0).s, 592551.070, 1e-3);
  EXPECT_NEAR(EvaluateModel(m, 6, 0, 0).r, 47.749378, 1e-6);
  EXPECT_NEAR(PredictNext(m, 2e5, 6, 0, 0, kH), 349037.453, 1e-3);

  // every term: c3 = 0.5 /V^3, c4 = 1e4 Pa s/m, c5 = 100 /m, c6 = 10 /m, c8 = 0.2; u = 4 V, x = 0.02 m,
  // x' = 0.3 m/s, p = 3e5 Pa: u^ = -1 V, a = -2 - 0.5 = -2.5, g = -2.5/sqrt(7.25) = -0.9284767,
  //   s = 3.6e5 - 2.6e5 x 0.9284767 + 1e4 x 0.3 = 121596.060 Pa
  //   k = 1.0049876 - 0.1 + 0.05 - 0.2 = 0.7549876 V, r = (50 k + 100 x 0.3) / (1 + 10 x 0.02) = 56.457815 /s
  //   p(t+h) = s + (3e5 - s) e^(-0.56457815) = 223036.533 Pa
  m = Model({5, 2, 0.5, 1e4, 100, 10, 50, 0.2, 0.05});
  EXPECT_NEAR(EvaluateModel(m, 4, 0.02, 0.3).s, 121596.060, 1e-3);
  EXPECT_NEAR(EvaluateModel(m, 4, 0.02, 0.3).r, 56.457815, 1e-6);
  EXPECT_NEAR(PredictNext(m, 3e5, 4, 0.02, 0.3, kH), 223036.533, 1e-3);
}

TEST(PredictNext, HoldsThePressureWhereTheRateIsNegative) {
  // c5 x' = 100 x (-1) = -100 /s outweighs c7 k = 50 x 0.05: r < 0. The extension clamps r at 0
  // (plugin/src/chamber.cc IdentifiedPressureStep), so the pressure is held exactly; the unclamped
  // prediction the fit uses moves away from s instead.
  ParametricModel m = Model({5, 2, 0, 0, 100, 0, 50, 0, 0.05});
  ASSERT_LT(EvaluateModel(m, 5, 0, -1).r, 0);
  EXPECT_EQ(PredictNext(m, 2.5e5, 5, 0, -1, kH), 2.5e5);
  std::array<double, 9> J{};
  EXPECT_NE(PredictNextWithJacobian(m, 2.5e5, 5, 0, -1, kH, &J), 2.5e5);
  // where r >= 0 both agree to the bit
  EXPECT_EQ(PredictNextWithJacobian(m, 2.5e5, 6, 0.01, 0.2, kH, &J), PredictNext(m, 2.5e5, 6, 0.01, 0.2, kH));
}

TEST(PredictNext, AnalyticJacobianMatchesCentralDifferences) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1, 1);
  const std::array<double, 9> base = {5.1, 1.5, 0.3, 2e4, 300, 12, 60, 0.1, 0.05};
  for (int trial = 0; trial < 200; ++trial) {
    std::array<double, 9> c = base;
    for (size_t k = 0; k < 9; ++k) c[k] *= 1 + 0.3 * unit(rng);
    const double u = 5 + 2 * unit(rng), x = 0.04 * unit(rng), x_rate = 0.3 * unit(rng), p = 3.6e5 + 2.5e5 * unit(rng);
    std::array<double, 9> J{};
    PredictNextWithJacobian(Model(c), p, u, x, x_rate, kH, &J);
    for (size_t k = 0; k < 9; ++k) {
      // step: 1e-6 of the parameter's size (c1: volts; c8, c9 small: absolute 1e-7)
      const double step = std::max(std::fabs(c[k]), 0.1) * 1e-6;
      std::array<double, 9> up = c, down = c;
      up[k] += step, down[k] -= step;
      std::array<double, 9> unused{};
      const double numeric = (PredictNextWithJacobian(Model(up), p, u, x, x_rate, kH, &unused) -
                              PredictNextWithJacobian(Model(down), p, u, x, x_rate, kH, &unused)) /
                             (2 * step);
      // central differences of a smooth function: truncation O(step^2), far below 1e-5 of the
      // derivative, plus the rounding of two predictions of ~6e5 Pa divided by the step
      const double rounding = 6e5 * 2.2e-16 / step;
      EXPECT_NEAR(J[k], numeric, 1e-5 * std::fabs(numeric) + 100 * rounding)
          << "c" << k + 1 << " trial " << trial;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// (2) recovery of known parameters from data made by the model itself (no noise)

// n samples of a chamber driven by random command steps in 3..7 V (held 30-200 ms) while the piston
// moves sinusoidally, its pressure integrated with eq. 7 from the true parameters
ChamberSeries SyntheticSeries(const std::array<double, 9>& c_true, size_t n, std::uint64_t seed) {
  ChamberSeries s;
  s.name = "synthetic.P";
  s.period = kH;
  s.p_supply = kPc, s.p_exhaust = kPr;
  s.u_min = 0, s.u_max = 10;
  s.stroke = 0.1;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> command(3, 7);
  std::uniform_int_distribution<int> hold(3, 20);
  const ParametricModel model = Model(c_true);
  double p = 2e5, u = 5;
  int held = 0;
  auto position = [](double t) { return 0.04 * std::sin(2 * M_PI * 0.37 * t) * std::cos(2 * M_PI * 0.11 * t); };
  for (size_t t = 0; t < n; ++t) {
    if (held-- <= 0) u = command(rng), held = hold(rng);
    const double time = static_cast<double>(t) * kH;
    s.u.push_back(u);
    s.p.push_back(p);
    s.x.push_back(position(time));
    s.x_rate.push_back((position(time + kH) - position(time)) / kH);
    p = PredictNext(model, p, u, s.x.back(), s.x_rate.back(), kH);
  }
  return s;
}

TEST(FitChamber, RecoversTheTrueParametersFromEveryStart) {
  // r > 0 everywhere (c7 c9 = 6 /s > |c5 x'| <= 20 x 0.12 /s), so that the unclamped prediction the
  // fit uses reproduces the data exactly at c_true
  const std::array<double, 9> c_true = {5.1, 1.5, 0.3, 2e4, 20, 12, 60, 0.1, 0.1};
  const ChamberSeries s = SyntheticSeries(c_true, 10000, 3);
  // paper 000 V.C: "always converged to the same minimum, from different initial conditions"
  const std::vector<std::array<double, 9>> starts = {
      DefaultInitialGuess(s),
      {4, 0.5, 0, 0, 0, 0, 20, 0, 0.1},
      {7, 4, 1, -1e4, -200, -5, 200, -0.5, 0.001},
      {4.5, 1, 2, 5e4, 1000, 15, 100, 0.5, 0.5},
  };
  for (size_t i = 0; i < starts.size(); ++i) {
    ParametricFitOptions options;
    options.use_default_guess = false;
    options.initial_guesses = {starts[i]};
    ParametricFit fit = FitChamber(s, options);
    ASSERT_EQ(fit.error, "") << "start " << i;
    EXPECT_TRUE(fit.converged) << "start " << i;
    for (size_t k = 0; k < 9; ++k) {
      EXPECT_NEAR(fit.model.c[k], c_true[k], 1e-6 * std::max(std::fabs(c_true[k]), 1.0))
          << "c" << k + 1 << " from start " << i;
    }
    EXPECT_LT(fit.rms_residual, 1e-3) << "start " << i;  // Pa: the data is the model's own
    EXPECT_GT(fit.one_step_fit_pct, 99.9999) << "start " << i;
  }
}

TEST(FitChambers, GivesTheSameBitsWhateverTheThreads) {
  const std::array<double, 9> c_true = {5.1, 1.5, 0.3, 2e4, 20, 12, 60, 0.1, 0.1};
  std::vector<ChamberSeries> series;
  for (std::uint64_t seed = 10; seed < 15; ++seed) series.push_back(SyntheticSeries(c_true, 3000, seed));
  for (ChamberSeries& s : series) {
    for (double& p : s.p) p += 800 * std::sin(p);  // a deterministic disturbance, so that no fit is exact
  }
  const std::vector<ParametricFit> one = FitChambers(series, {}, 1);
  for (int threads : {2, 3, 8}) {
    const std::vector<ParametricFit> many = FitChambers(series, {}, threads);
    ASSERT_EQ(many.size(), series.size());
    for (size_t i = 0; i < series.size(); ++i) {
      ASSERT_EQ(many[i].error, "");
      EXPECT_EQ(many[i].name, one[i].name);
      std::vector<double> a(one[i].model.c.begin(), one[i].model.c.end()), b(many[i].model.c.begin(), many[i].model.c.end());
      a.insert(a.end(), one[i].standard_error.begin(), one[i].standard_error.end());
      b.insert(b.end(), many[i].standard_error.begin(), many[i].standard_error.end());
      a.push_back(one[i].rms_residual), b.push_back(many[i].rms_residual);
      EXPECT_TRUE(testing::SameBits(a, b)) << "series " << i << ", " << threads << " threads";
      EXPECT_EQ(many[i].iterations, one[i].iterations);
      EXPECT_EQ(many[i].warnings, one[i].warnings);
    }
  }
}

// Coarse-to-fine (ParametricFitOptions::coarse_samples): a long series is first fitted on every
// k-th pair, then on all pairs from there with QR-compressed blocks; the result must be the
// full-data optimum, i.e. what the fit gives with every iteration on the full data.
TEST(FitChamber, CoarseToFineReachesTheFullDataOptimum) {
  const std::array<double, 9> c_true = {5.1, 1.5, 0.3, 2e4, 20, 12, 60, 0.1, 0.1};
  ChamberSeries s = SyntheticSeries(c_true, 40000, 21);
  {
    // noise-free: the true parameters, as from every start of the recovery test
    ParametricFitOptions options;
    options.coarse_samples = 5000;  // every 8th pair
    const ParametricFit fit = FitChamber(s, options);
    ASSERT_EQ(fit.error, "");
    EXPECT_TRUE(fit.converged);
    EXPECT_GT(fit.coarse_iterations, 0);
    for (size_t k = 0; k < 9; ++k) {
      EXPECT_NEAR(fit.model.c[k], c_true[k], 1e-6 * std::max(std::fabs(c_true[k]), 1.0)) << "c" << k + 1;
    }
  }
  for (double& p : s.p) p += 800 * std::sin(p);  // a deterministic disturbance, so that no fit is exact
  ParametricFitOptions coarse_to_fine, full_only;
  coarse_to_fine.coarse_samples = 5000;
  full_only.coarse_samples = 0;
  const ParametricFit a = FitChamber(s, coarse_to_fine), b = FitChamber(s, full_only);
  ASSERT_EQ(a.error, "");
  ASSERT_EQ(b.error, "");
  EXPECT_TRUE(a.converged);
  EXPECT_TRUE(b.converged);
  EXPECT_GT(a.coarse_iterations, 0);
  EXPECT_EQ(b.coarse_iterations, 0);
  for (size_t k = 0; k < 9; ++k) {
    // the same optimum to within the solver's tolerances: a small fraction of the standard error
    EXPECT_NEAR(a.model.c[k], b.model.c[k], 0.01 * b.standard_error[k]) << "c" << k + 1;
    EXPECT_NEAR(a.standard_error[k], b.standard_error[k], 1e-3 * b.standard_error[k]) << "c" << k + 1;
  }
  EXPECT_NEAR(a.rms_residual, b.rms_residual, 1e-6 * b.rms_residual);
  // and the same bits on any thread
  const std::vector<ParametricFit> threaded = FitChambers({s, s}, coarse_to_fine, 2);
  ASSERT_EQ(threaded.size(), 2u);
  for (const ParametricFit& fit : threaded) {
    std::vector<double> x(fit.model.c.begin(), fit.model.c.end()), y(a.model.c.begin(), a.model.c.end());
    x.insert(x.end(), fit.standard_error.begin(), fit.standard_error.end());
    y.insert(y.end(), a.standard_error.begin(), a.standard_error.end());
    EXPECT_TRUE(testing::SameBits(x, y));
  }
}

// ---------------------------------------------------------------------------------------------
// (2b) the output-error refinement (identification/output_error_fit.h)

// r > 0 everywhere (as in RecoversTheTrueParametersFromEveryStart): the clamped prediction the
// refinement runs is eq. 7 itself along the data
const std::array<double, 9> kRefineTruth = {5.1, 1.5, 0.3, 2e4, 20, 12, 60, 0.1, 0.1};

TEST(RefineOutputError, RecoversTheTrueParametersFromAPerturbedStart) {
  const ChamberSeries s = SyntheticSeries(kRefineTruth, 3000, 5);
  // every parameter off: the sigmoid's origin by 0.2 V, its scale and kink, the compression and
  // rate terms by tens of percent
  const std::array<double, 9> start = {5.3, 1.2, 0.5, 1.4e4, 30, 10, 80, 0.2, 0.07};
  OutputErrorOptions options;
  options.horizon_s = 0.3;
  const OutputErrorFit fit = RefineOutputError(s, Model(start), options);
  ASSERT_EQ(fit.error, "");
  EXPECT_TRUE(fit.converged);
  // 3000 rows, sequences of 30 steps every 15 rows, each needing 31 entries: starts 0, 15, ..., 2955
  EXPECT_EQ(fit.sequences, 198);
  // the data is the model's own: the cost is 0 at the truth, reached to the accuracy of Ceres' stopping
  // criteria on central differences (measured: c4 within 5e-7 relative, the rest within 1e-8)
  for (size_t k = 0; k < 9; ++k) {
    EXPECT_NEAR(fit.model.c[k], kRefineTruth[k], 1e-5 * std::max(std::fabs(kRefineTruth[k]), 1.0)) << "c" << k + 1;
  }
  EXPECT_GT(fit.rms_before_pa, 1e4);  // Pa: the start is far off
  EXPECT_LT(fit.rms_after_pa, 0.01);
}

// Noise on the measured pressure is also an input of the one-step fit (p_t in eq. 7): its fit is
// biased (errors in variables), and the bias shows in the model's own prediction. The refinement
// fits that prediction, which starts from one noisy sample and then runs on the model alone.
TEST(RefineOutputError, RemovesTheDriftOfAOneStepFitToNoisyPressures) {
  ChamberSeries train = SyntheticSeries(kRefineTruth, 10000, 3);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0, 10000);  // Pa: 2 % of P_c - P_r
  for (double& p : train.p) p += noise(rng);
  const ChamberSeries held_out = SyntheticSeries(kRefineTruth, 10000, 4);  // noise-free
  ParametricFitOptions one_step_options;
  one_step_options.use_default_guess = false;
  one_step_options.initial_guesses = {kRefineTruth};
  const ParametricFit one_step = FitChamber(train, one_step_options);
  ASSERT_EQ(one_step.error, "");
  const OutputErrorFit refined = RefineOutputError(train, one_step.model, OutputErrorOptions{});
  ASSERT_EQ(refined.error, "");
  const double drift_truth = Drift(held_out, Model(kRefineTruth)).std_pct.back();
  const double drift_one_step = Drift(held_out, one_step.model).std_pct.back();
  const double drift_refined = Drift(held_out, refined.model).std_pct.back();
  std::printf("held-out drift at 2 s: truth %.4f %%, one-step fit %.4f %%, refined %.4f %%\n", drift_truth,
              drift_one_step, drift_refined);
  // measured: 0.35 % and 0.07 % (the truth: 0). The one-step fit's bias does not shrink with more
  // data; the refinement's regressors are the model's own predictions, not the noisy samples
  EXPECT_LT(drift_refined, 0.5 * drift_one_step);
  EXPECT_LE(refined.rms_after_pa, refined.rms_before_pa);
}

TEST(RefineOutputErrors, GivesTheSameBitsWhateverTheThreads) {
  const std::vector<ChamberSeries> series = {SyntheticSeries(kRefineTruth, 2000, 1), SyntheticSeries(kRefineTruth, 2000, 2),
                                             SyntheticSeries(kRefineTruth, 2000, 3)};
  const std::vector<ParametricModel> starts(3, Model({5.3, 1.2, 0.5, 1.4e4, 30, 10, 80, 0.2, 0.07}));
  const std::vector<OutputErrorFit> one = RefineOutputErrors(series, starts, {}, 1);
  const std::vector<OutputErrorFit> two = RefineOutputErrors(series, starts, {}, 2);
  for (size_t i = 0; i < series.size(); ++i) {
    ASSERT_EQ(one[i].error, "");
    EXPECT_EQ(one[i].model.c, two[i].model.c) << i;
    EXPECT_EQ(one[i].rms_after_pa, two[i].rms_after_pa) << i;
  }
}

TEST(RefineOutputError, RefusesAHorizonLongerThanTheSeries) {
  const ChamberSeries s = SyntheticSeries(kRefineTruth, 100, 1);  // 1 s at 100 Hz
  OutputErrorOptions options;
  options.horizon_s = 2;
  const OutputErrorFit fit = RefineOutputError(s, Model(kRefineTruth), options);
  EXPECT_THAT(fit.error, HasSubstr("horizon of 2"));
  EXPECT_EQ(fit.model.c, kRefineTruth);  // the start, untouched
}

// ---------------------------------------------------------------------------------------------
// (3) closed-loop logs of rig C (paper 000 V.C): fit on one, drift on another

std::vector<ChamberSeries> RigCChambers(double duration, std::uint64_t seed) {
  AttachedModel rig;
  EXPECT_TRUE(rig.Load(ShippedModel("rig_per_chamber.xml"), true)) << rig.error();
  GenerateOptions options;
  options.duration = duration;
  options.seed = seed;
  GenerateResult generated = Generate(rig.m(), options);
  EXPECT_EQ(generated.error, "");
  std::vector<ChamberSeries> chambers;
  if (generated.log) EXPECT_EQ(ExtractChambers(rig.m(), *generated.log, &chambers), "");
  return chambers;
}

// the MJCF text of rig C with both chambers on the identified model with these fits
std::string IdentifiedRigC(const std::vector<ParametricFit>& fits) {
  std::string keys = " pressure_model=identified";
  for (const ParametricFit& fit : fits) {
    const std::string side = fit.name.substr(fit.name.size() - 1);  // "P" or "N"
    for (size_t k = 0; k < 9; ++k) {
      char value[64];
      std::snprintf(value, sizeof(value), "%.17g", fit.model.c[k]);
      keys += " " + side + ".c" + std::to_string(k + 1) + "=" + value;
    }
  }
  return testing::ReplaceAll(testing::ReadText(ShippedModel("rig_per_chamber.xml")), "area_smoothing=1e-6",
                             "area_smoothing=1e-6" + keys);
}

// rms of p_{t+1} - p_t: the error of predicting that the pressure holds
double HoldRms(const ChamberSeries& s) {
  double sum = 0;
  for (size_t t = 0; t + 1 < s.p.size(); ++t) sum += (s.p[t + 1] - s.p[t]) * (s.p[t + 1] - s.p[t]);
  return std::sqrt(sum / static_cast<double>(s.p.size() - 1));
}

// One process generates both logs (~1.3 s each) and fits both chambers once, so all checks on them
// live in this test.
TEST(RigC, FitOnOneLogPredictsAnotherWithinFourPercentOverTwoSeconds) {
  const std::vector<ChamberSeries> train = RigCChambers(100, 1);
  const std::vector<ChamberSeries> held_out = RigCChambers(100, 2);
  ASSERT_EQ(train.size(), 2u);
  ASSERT_EQ(held_out.size(), 2u);
  ASSERT_EQ(train[0].name, "cyl.P");
  ASSERT_EQ(train[1].name, "cyl.N");
  const std::vector<ParametricFit> fits = FitChambers(train, {}, 2);
  std::vector<ParametricModel> models;
  for (const ParametricFit& fit : fits) {
    ASSERT_EQ(fit.error, "") << fit.name;
    EXPECT_TRUE(fit.converged) << fit.name;
    models.push_back(fit.model);
  }
  // the volume enters eq. 10e's denominator (paper 000 III.C): 1 + c6 x is the chamber volume in
  // units of its volume at x = 0, so c6 = +-1/(stroke/2 + V0/A) on rig C: 15.94 /m for P
  // (A_P = 7.854e-5 m^2), -15.35 /m for N (A_N = 6.597e-5 m^2), V0 = 1e-6 m^3; the fit is an
  // approximation of another model, so within 10 %
  EXPECT_NEAR(fits[0].model.c[5], 1 / (0.05 + 1e-6 / 7.854e-5), 1.6);
  EXPECT_NEAR(fits[1].model.c[5], -1 / (0.05 + 1e-6 / 6.597e-5), 1.5);

  // the fitted values are accepted by the extension's MJCF (plugin/src/config.cc)
  AttachedModel identified;
  EXPECT_TRUE(identified.Load(IdentifiedRigC(fits))) << identified.error();

  // one step on held-out data: better than holding the pressure (p_{t+1} = p_t)
  for (size_t i = 0; i < 2; ++i) {
    const OneStepScore score = ScoreOneStep(held_out[i], models[i]);
    EXPECT_LT(score.rms_residual, HoldRms(held_out[i])) << held_out[i].name;
    std::printf("%s: training one-step fit %.2f %% (rms %.0f Pa), held-out %.2f %% (rms %.0f Pa, holding: %.0f Pa)\n",
                fits[i].name.c_str(), fits[i].one_step_fit_pct, fits[i].rms_residual, score.fit_pct,
                score.rms_residual, HoldRms(held_out[i]));
  }

  // paper 000 V.D: 48 starts per chamber, 2 s each, p^_0 = p_0; the acceptance: the pooled
  // standard deviation of p^ - p stays under 4 % of P_c - P_r at every horizon up to 2 s
  const DriftCurve pooled = PoolDrift(held_out, models);
  ASSERT_EQ(pooled.error, "");
  EXPECT_EQ(pooled.sequences, 96);
  ASSERT_EQ(pooled.horizon_s.size(), 201u);
  EXPECT_DOUBLE_EQ(pooled.horizon_s.back(), 2.0);
  const double pooled_worst = *std::max_element(pooled.std_pct.begin(), pooled.std_pct.end());
  EXPECT_LT(pooled_worst, 4.0);
  std::printf("held-out drift, pooled over %d sequences: std %.2f %% at 2 s, worst %.2f %% (rms at 2 s %.2f %%)\n",
              pooled.sequences, pooled.std_pct.back(), pooled_worst, pooled.rms_pct.back());
  for (size_t i = 0; i < 2; ++i) {
    const DriftCurve d = Drift(held_out[i], models[i]);
    ASSERT_EQ(d.error, "");
    EXPECT_EQ(d.sequences, 48);
    // paper 000 Fig. 13: every chamber's drift "less than 10 %"
    const double worst = *std::max_element(d.std_pct.begin(), d.std_pct.end());
    EXPECT_LT(worst, 10.0) << held_out[i].name;
    std::printf("  %s: std %.2f %% at 2 s, worst %.2f %%\n", held_out[i].name.c_str(), d.std_pct.back(), worst);
  }
}

// Paper 000 V.C: "the optimization always converged to the same minimum, from different initial
// conditions". Measured here on a closed-loop rig C log, from 8 starts on a grid around the default
// guess (c1 +-0.5 V around the valve centre, c2 x1/3 and x3, the rate gain c7 x1/3 and x3): most
// reach the default start's optimum, the same cost to 1e-9 relative and every c within 0.01 of its
// standard error. Not all: on this log, chamber P from (c1 + 0.5 V, c2 / 3, 3 c7) runs to r h >> 1,
// where e^(-r h) ~ 0 flattens the cost in c7, and stops on c3's bound at 5 times the rms. Such an
// end is never silent: it carries the warning of a parameter on its bound.
TEST(RigC, FitsFromDifferentStartsReachTheSameOptimumOrWarn) {
  const std::vector<ChamberSeries> train = RigCChambers(30, 3);
  ASSERT_EQ(train.size(), 2u);
  int same = 0, starts = 0;
  for (const ChamberSeries& s : train) {
    const ParametricFit reference = FitChamber(s, {});
    ASSERT_EQ(reference.error, "") << s.name;
    const std::array<double, 9> guess = DefaultInitialGuess(s);
    for (double dc1 : {-0.5, 0.5}) {
      for (double c2_factor : {1.0 / 3, 3.0}) {
        for (double c7_factor : {1.0 / 3, 3.0}) {
          std::array<double, 9> c = guess;
          c[0] += dc1, c[1] *= c2_factor, c[6] *= c7_factor;
          ParametricFitOptions options;
          options.use_default_guess = false;
          options.initial_guesses = {c};
          const ParametricFit fit = FitChamber(s, options);
          ASSERT_EQ(fit.error, "") << s.name << " start " << starts;
          ++starts;
          bool reached = std::fabs(fit.rms_residual - reference.rms_residual) <= 1e-9 * reference.rms_residual;
          for (size_t k = 0; k < 9; ++k) {
            reached &= std::fabs(fit.model.c[k] - reference.model.c[k]) <= 0.01 * reference.standard_error[k];
          }
          if (reached) {
            ++same;
          } else {
            // a worse local minimum, and flagged
            EXPECT_GT(fit.rms_residual, 2 * reference.rms_residual) << s.name << " start " << starts - 1;
            std::string warnings;
            for (const std::string& w : fit.warnings) warnings += w + "\n";
            EXPECT_THAT(warnings, ::testing::HasSubstr("bound")) << s.name << " start " << starts - 1;
          }
        }
      }
    }
  }
  std::printf("%d of %d starts reached the default start's optimum\n", same, starts);
  EXPECT_GE(same, starts - 2);
}

// The shipped identified humanoid (models_mjcf/humanoid_pneumatic_identified.xml, written by
// scripts/identify_humanoid from 100 s logs of the physical humanoid, seeds 1 and 2) against a log it
// has not seen: 30 s of the physical humanoid under `pneumo generate`, seed 3. Paper 000 V.D, Fig. 13:
// the pooled drift after 2 s is "less than 10 %" and "usually less than 4 %". Measured: 4.18 % (on
// the fit's own held-out log 3.71 %); the chambers over 10 % are printed (here waist_pitch.N, 14.5 %;
// on the held-out log l_shoulder_shrug.N, 11.7 %: chambers whose data has little in it).
TEST(Humanoid, IdentifiedModelPredictsAnUnseenLogWithinPaper000sDrift) {
  AttachedModel physical, identified;
  ASSERT_TRUE(physical.Load(ShippedModel("humanoid_pneumatic.xml"), true)) << physical.error();
  ASSERT_TRUE(identified.Load(ShippedModel("humanoid_pneumatic_identified.xml"), true)) << identified.error();
  GenerateOptions options;
  options.duration = 30;
  options.seed = 3;
  const GenerateResult generated = Generate(physical.m(), options);
  ASSERT_TRUE(generated.log) << generated.error;
  std::vector<ChamberSeries> series;
  ASSERT_EQ(ExtractChambers(physical.m(), *generated.log, &series), "");
  ASSERT_EQ(series.size(), 72u);
  std::vector<ParametricModel> models;
  for (const ChamberSeries& s : series) {
    const std::string cylinder = s.name.substr(0, s.name.size() - 2), chamber = s.name.substr(s.name.size() - 1);
    std::array<double, 9> c{};
    for (size_t i = 0; i < 9; ++i) {
      std::string error;
      const std::optional<double> value = GetParameter(identified.m(), cylinder, chamber + ".c" + std::to_string(i + 1), &error);
      ASSERT_TRUE(value) << s.name << ": " << error;
      c[i] = *value;
    }
    models.push_back(ModelFor(s, c));
    const DriftCurve drift = Drift(s, models.back());
    ASSERT_EQ(drift.error, "") << s.name;
    if (drift.std_pct.back() > 10) std::printf("%s: %.2f %% at 2 s\n", s.name.c_str(), drift.std_pct.back());
  }
  const DriftCurve pooled = PoolDrift(series, models);
  ASSERT_EQ(pooled.error, "");
  std::printf("the identified humanoid on an unseen 30 s log: pooled drift %.2f %% at 2 s\n", pooled.std_pct.back());
  EXPECT_LT(pooled.std_pct.back(), 10.0);
}

// ---------------------------------------------------------------------------------------------
// (4) bad input

// a short closed-loop log of rig C and its model
struct ShortLog {
  AttachedModel rig;
  log::Log log;
  explicit ShortLog(double duration) {
    EXPECT_TRUE(rig.Load(ShippedModel("rig_per_chamber.xml"), true)) << rig.error();
    GenerateOptions options;
    options.duration = duration;
    GenerateResult generated = Generate(rig.m(), options);
    EXPECT_EQ(generated.error, "");
    if (generated.log) log = *generated.log;
  }
  std::vector<double>& Column(const std::string& name) {
    int i = log.FindColumn("cyl", name);
    EXPECT_GE(i, 0) << name;
    return log.values.at(static_cast<size_t>(i));
  }
};

TEST(ExtractChambers, NamesAMissingColumn) {
  ShortLog data(2);
  const int column = data.log.FindColumn("cyl", "p_N");
  ASSERT_GE(column, 0);
  data.log.columns.erase(data.log.columns.begin() + column);
  data.log.values.erase(data.log.values.begin() + column);
  std::vector<ChamberSeries> out;
  EXPECT_THAT(ExtractChambers(data.rig.m(), data.log, &out), HasSubstr("no column 'cyl.p_N'"));
  EXPECT_TRUE(out.empty());
}

TEST(ExtractChambers, SaysHowManyRowsAreNeededAndWhy) {
  ShortLog data(2);
  std::vector<ChamberSeries> out;
  ASSERT_EQ(ExtractChambers(data.rig.m(), data.log, &out), "");
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].p.size(), data.log.rows() - 1);  // the last row has no forward difference
  EXPECT_EQ(out[0].x_rate[5], (data.Column("x")[6] - data.Column("x")[5]) / data.log.Period());
  data.log.time.resize(50);
  for (auto& column : data.log.values) column.resize(50);
  out.clear();
  const std::string error = ExtractChambers(data.rig.m(), data.log, &out);
  EXPECT_THAT(error, HasSubstr("50 rows"));
  EXPECT_THAT(error, HasSubstr("at least 92"));
  EXPECT_THAT(error, HasSubstr("per parameter"));
}

TEST(ExtractChambers, RefusesACommandOutsideTheCtrlrange) {
  ShortLog data(2);
  data.Column("uP")[17] = 10.5;  // rig C's valves take 0..10 V
  std::vector<ChamberSeries> out;
  const std::string error = ExtractChambers(data.rig.m(), data.log, &out);
  EXPECT_THAT(error, HasSubstr("'cyl.uP', row 17"));
  EXPECT_THAT(error, HasSubstr("10.5 V"));
  EXPECT_THAT(error, HasSubstr("[0, 10]"));
}

TEST(ExtractChambers, RefusesAFiveThreeValve) {
  AttachedModel rig;
  ASSERT_TRUE(rig.Load(ShippedModel("rig_proportional.xml"), true)) << rig.error();
  log::Log log;
  for (const char* signal : {"u", "p_P", "p_N", "x"}) log.columns.push_back({"cyl", signal});
  for (int t = 0; t < 200; ++t) log.time.push_back(0.01 * t);
  log.values = {std::vector<double>(200, 1.0), std::vector<double>(200, 2e5), std::vector<double>(200, 2e5),
                std::vector<double>(200, 0.0)};
  std::vector<ChamberSeries> out;
  const std::string error = ExtractChambers(rig.m(), log, &out);
  EXPECT_THAT(error, HasSubstr("cylinder 'cyl' has valve=proportional_5_3"));
  EXPECT_THAT(error, HasSubstr("only valve=proportional_per_chamber"));
}

TEST(FitChamber, RefusesAChamberNeverExcited) {
  ShortLog data(5);
  for (double& u : data.Column("uN")) u = 5.0;  // held at the valve's centre, (U_c + U_r)/2
  std::vector<ChamberSeries> out;
  ASSERT_EQ(ExtractChambers(data.rig.m(), data.log, &out), "");
  const ParametricFit fit = FitChamber(out[1], {});
  EXPECT_THAT(fit.error, HasSubstr("cyl.N"));
  EXPECT_THAT(fit.error, HasSubstr("never excited"));
  EXPECT_THAT(fit.error, HasSubstr("c1..c9"));
}

TEST(FitChamber, WarnsOfParametersAWeakExcitationLeavesUndetermined) {
  ShortLog data(20);
  // chamber N's valve only dithers by +-0.1 V inside its sealed band (U_r = 4.7 V .. U_c = 5.3 V)
  std::vector<double>& u = data.Column("uN");
  for (size_t t = 0; t < u.size(); ++t) u[t] = 5.0 + ((t / 7) % 2 ? 0.1 : -0.1);
  std::vector<ChamberSeries> out;
  ASSERT_EQ(ExtractChambers(data.rig.m(), data.log, &out), "");
  const ParametricFit fit = FitChamber(out[1], {});
  ASSERT_EQ(fit.error, "");
  // a +-0.1 V dither cannot locate the valve's origin c1 (nor the sigmoid's width): a warning names it
  EXPECT_THAT(fit.warnings, ::testing::Contains(::testing::AllOf(HasSubstr("determine"), HasSubstr("c1"))))
      << ::testing::PrintToString(fit.warnings);
}

TEST(Drift, RefusesDataShorterThanTheHorizon) {
  const ChamberSeries s = SyntheticSeries({5.1, 1.5, 0.3, 2e4, 20, 12, 60, 0.1, 0.1}, 150, 1);
  const DriftCurve d = Drift(s, Model({5.1, 1.5, 0.3, 2e4, 20, 12, 60, 0.1, 0.1}));
  EXPECT_THAT(d.error, HasSubstr("150 samples (1.5 s) are shorter than the drift horizon of 2 s"));
  EXPECT_TRUE(d.std_pct.empty());
  // one that fits exactly: the last sequence ends on the last sample; the model is the data's own
  const DriftCurve exact = Drift(s, Model({5.1, 1.5, 0.3, 2e4, 20, 12, 60, 0.1, 0.1}), 3, 1.49);
  ASSERT_EQ(exact.error, "");
  EXPECT_EQ(exact.sequences, 3);
  EXPECT_EQ(*std::max_element(exact.rms_pct.begin(), exact.rms_pct.end()), 0.0);
}

}  // namespace
}  // namespace pneumatic::identification
