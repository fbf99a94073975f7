// Standard errors of least-squares estimates (pneumo/identification/uncertainty.h) against
// closed forms and against the spread of estimates over many noise realisations.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "identification/uncertainty.h"

namespace pneumatic::identification {
namespace {

using ::testing::HasSubstr;

// straight line y = a + b t fitted by least squares: J = [1, t]
Eigen::MatrixXd LineJacobian(int n) {
  Eigen::MatrixXd J(n, 2);
  for (int i = 0; i < n; ++i) J.row(i) << 1.0, i * 0.01;
  return J;
}

Eigen::VectorXd LineResiduals(const Eigen::MatrixXd& J, const Eigen::VectorXd& y) {
  Eigen::VectorXd theta = J.colPivHouseholderQr().solve(y);
  return y - J * theta;
}

TEST(Uncertainty, StraightLineMatchesClosedForm) {
  // SE(b) = sigma_hat / sqrt(sum (t - t_mean)^2), SE(a) = sigma_hat sqrt(1/n + t_mean^2 / Stt)
  const int n = 200;
  Eigen::MatrixXd J = LineJacobian(n);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0, 0.5);
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) y[i] = 2 + 3 * J(i, 1) + noise(rng);
  Eigen::VectorXd r = LineResiduals(J, y);
  UncertaintyOptions options;
  options.lag_window = 0;
  Uncertainty u = EstimateUncertainty(J, r, {"a", "b"}, {2, 3}, {1, 1}, options);
  ASSERT_EQ(u.error, "");
  double sigma = std::sqrt(r.squaredNorm() / (n - 2));
  double t_mean = J.col(1).mean();
  double stt = (J.col(1).array() - t_mean).square().sum();
  EXPECT_NEAR(u.standard_error[1], sigma / std::sqrt(stt), 1e-12 * sigma / std::sqrt(stt));
  EXPECT_NEAR(u.standard_error[0], sigma * std::sqrt(1.0 / n + t_mean * t_mean / stt), 1e-12);
  // corr(a, b) = -t_mean / sqrt(t_mean^2 + Stt / n)
  EXPECT_NEAR(u.correlation(0, 1), -t_mean / std::sqrt(t_mean * t_mean + stt / n), 1e-12);
}

TEST(Uncertainty, IdenticalColumnsAreNamedAsUndetermined) {
  Eigen::MatrixXd J(50, 3);
  for (int i = 0; i < 50; ++i) J.row(i) << 1.0, std::sin(i), std::sin(i);
  Eigen::VectorXd r = Eigen::VectorXd::LinSpaced(50, -1, 1);
  Uncertainty u = EstimateUncertainty(J, r, {"a", "C", "B"}, {1, 1, 1}, {1, 1, 1}, {});
  EXPECT_THAT(u.error, HasSubstr("C, B"));
  EXPECT_THAT(u.poorly_determined[1], HasSubstr("only a combination of C, B"));
  EXPECT_EQ(u.poorly_determined[0], "");
}

TEST(Uncertainty, EveryUndeterminedDirectionIsNamed) {
  // two pairs of columns, one identical, one within 1e-8 of identical: two null directions (eigenvalues
  // about 1e-32 and 1e-16 of the largest), both named whichever comes out smallest
  Eigen::MatrixXd J(50, 5);
  for (int i = 0; i < 50; ++i) {
    J.row(i) << 1.0, std::sin(i), std::sin(i), std::cos(0.3 * i), std::cos(0.3 * i) + 1e-8 * std::sin(2.1 * i);
  }
  Eigen::VectorXd r = Eigen::VectorXd::LinSpaced(50, -1, 1);
  Uncertainty u = EstimateUncertainty(J, r, {"a", "C", "B", "D", "E"}, {1, 1, 1, 1, 1}, {1, 1, 1, 1, 1}, {});
  EXPECT_THAT(u.error, HasSubstr("C, B"));
  EXPECT_THAT(u.error, HasSubstr("D, E"));
  EXPECT_THAT(u.poorly_determined[1], HasSubstr("only a combination of C, B"));
  EXPECT_THAT(u.poorly_determined[4], HasSubstr("only a combination of D, E"));
  EXPECT_EQ(u.poorly_determined[0], "");
}

TEST(Uncertainty, StrongCorrelationAndLargeErrorAreFlagged) {
  // two nearly collinear regressors: corr of the estimates close to -1
  const int n = 100;
  Eigen::MatrixXd J(n, 2);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> unit(0, 1);
  for (int i = 0; i < n; ++i) {
    double s = std::sin(0.1 * i);
    J.row(i) << s, s + 0.01 * unit(rng);
  }
  Eigen::VectorXd r(n);
  for (int i = 0; i < n; ++i) r[i] = 0.01 * unit(rng);
  UncertaintyOptions options;
  options.lag_window = 0;
  options.max_relative_error = 1e9;  // only the correlation criterion
  Uncertainty u = EstimateUncertainty(J, r, {"C", "B"}, {1, 1}, {1, 1}, options);
  ASSERT_EQ(u.error, "");
  EXPECT_LT(u.correlation(0, 1), -0.95);
  EXPECT_THAT(u.poorly_determined[0], HasSubstr("correlated with B (-"));
  EXPECT_THAT(u.poorly_determined[1], HasSubstr("correlated with C (-"));
  options.max_relative_error = 1e-6;  // now every error is large
  u = EstimateUncertainty(J, r, {"C", "B"}, {1, 1}, {1, 1}, options);
  EXPECT_THAT(u.poorly_determined[0], HasSubstr("standard error"));
}

// The mean of AR(1) noise e_t = rho e_{t-1} + w_t over n samples: the textbook error assumes
// independent samples and is too small by sqrt((1 + rho) / (1 - rho)) = 4.4 at rho = 0.9; the
// Newey-West error must cover the truth about 68 % of the time. Over 400 realisations the
// binomial spread of that fraction is sqrt(0.68 * 0.32 / 400) = 2.3 %: 0.58..0.78 is over 4 sigma.
TEST(Uncertainty, NeweyWestIsHonestForCorrelatedResiduals) {
  const int n = 2000, trials = 400;
  const double rho = 0.9;
  Eigen::MatrixXd J = Eigen::MatrixXd::Ones(n, 1);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> w(0, 1);
  int covered_nw = 0, covered_textbook = 0;
  for (int trial = 0; trial < trials; ++trial) {
    Eigen::VectorXd e(n);
    double state = w(rng) / std::sqrt(1 - rho * rho);  // stationary start
    for (int t = 0; t < n; ++t) {
      state = rho * state + w(rng);
      e[t] = state;
    }
    double mean = e.mean();  // the estimate; the truth is 0
    Eigen::VectorXd r = e.array() - mean;
    UncertaintyOptions nw;
    Uncertainty u = EstimateUncertainty(J, r, {"mean"}, {mean}, {1}, nw);
    ASSERT_EQ(u.error, "");
    covered_nw += std::fabs(mean) <= u.standard_error[0];
    UncertaintyOptions textbook;
    textbook.lag_window = 0;
    covered_textbook += std::fabs(mean) <= EstimateUncertainty(J, r, {"mean"}, {mean}, {1}, textbook).standard_error[0];
  }
  double fraction = static_cast<double>(covered_nw) / trials;
  EXPECT_GT(fraction, 0.58);
  EXPECT_LT(fraction, 0.78);
  // the textbook error covers only |z| < 1/4.4: about 18 %
  EXPECT_LT(static_cast<double>(covered_textbook) / trials, 0.3);
}

TEST(Uncertainty, MismatchedSizesAndTooFewResidualsAreErrors) {
  Eigen::MatrixXd J = Eigen::MatrixXd::Ones(2, 2);
  EXPECT_THAT(EstimateUncertainty(J, Eigen::VectorXd::Zero(2), {"a", "b"}, {1, 1}, {1, 1}, {}).error,
              HasSubstr("2 residuals cannot determine 2 parameters"));
  EXPECT_THAT(EstimateUncertainty(J, Eigen::VectorXd::Zero(3), {"a", "b"}, {1, 1}, {1, 1}, {}).error,
              HasSubstr("do not match"));
}

}  // namespace
}  // namespace pneumatic::identification
