#include "identification/uncertainty.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace pneumatic::identification {
namespace {

std::string Format(const char* format, double a) {
  char text[64];
  std::snprintf(text, sizeof(text), format, a);
  return text;
}

// [begin, end) of each series of residuals
std::vector<std::pair<int, int>> SeriesRanges(const std::vector<int>& starts, int n) {
  std::vector<std::pair<int, int>> ranges;
  if (starts.empty()) return {{0, n}};
  for (size_t i = 0; i < starts.size(); ++i) {
    ranges.emplace_back(starts[i], i + 1 < starts.size() ? starts[i + 1] : n);
  }
  return ranges;
}

// The lag window: twice the first lag at which the residuals' autocorrelation (pooled over the
// series) falls below 0.05, and at least Newey and West 1994's 4 (N/100)^(2/9); at most N/20.
// Twice, because Bartlett's weights 1 - l/(L+1) shrink the lags they keep: for residuals of
// AR(1) form with rho = 0.9 the first lag below 0.05 is 29, and L = 58 recovers 84 % of the
// long-run variance (1 + rho)/(1 - rho) where L = 29 recovers 70 % (the project's own rule).
int ChooseLagWindow(const Eigen::VectorXd& r, const std::vector<std::pair<int, int>>& ranges) {
  const int n = static_cast<int>(r.size());
  const int rule = static_cast<int>(std::floor(4 * std::pow(n / 100.0, 2.0 / 9.0)));
  const int most = std::max(n / 20, 0);
  const double variance = r.squaredNorm();
  int decorrelated = most;
  for (int lag = 1; lag <= most && variance > 0; ++lag) {
    double sum = 0;
    for (auto [begin, end] : ranges) {
      for (int t = begin + lag; t < end; ++t) sum += r[t] * r[t - lag];
    }
    if (sum / variance < 0.05) {
      decorrelated = lag;
      break;
    }
  }
  return std::min(most, std::max(rule, 2 * decorrelated));
}

// S of the sandwich: sum over t of g_t g_t^T plus Bartlett-weighted lagged cross products,
// g_t = J_t^T r_t (Newey and West 1987, eq. 2), within each series
Eigen::MatrixXd NeweyWestMeat(const Eigen::MatrixXd& J, const Eigen::VectorXd& r,
                              const std::vector<std::pair<int, int>>& ranges, int lag_window) {
  const Eigen::MatrixXd g = J.array().colwise() * r.array();  // row t: g_t^T
  Eigen::MatrixXd meat = g.transpose() * g;
  for (int lag = 1; lag <= lag_window; ++lag) {
    const double weight = 1.0 - lag / (lag_window + 1.0);
    Eigen::MatrixXd cross = Eigen::MatrixXd::Zero(J.cols(), J.cols());
    for (auto [begin, end] : ranges) {
      const int length = end - begin - lag;
      if (length <= 0) continue;
      cross += g.middleRows(begin + lag, length).transpose() * g.middleRows(begin, length);
    }
    meat += weight * (cross + cross.transpose());
  }
  return meat;
}

}  // namespace

Uncertainty EstimateUncertainty(const Eigen::MatrixXd& J, const Eigen::VectorXd& r,
                                const std::vector<std::string>& names, const std::vector<double>& values,
                                const std::vector<double>& scales, const UncertaintyOptions& options) {
  Uncertainty out;
  const int n = static_cast<int>(J.rows());
  const int p = static_cast<int>(J.cols());
  if (r.size() != n || static_cast<int>(names.size()) != p || static_cast<int>(values.size()) != p ||
      static_cast<int>(scales.size()) != p) {
    out.error = "uncertainty: the Jacobian, residuals, names, values and scales do not match in size";
    return out;
  }
  if (n <= p) {
    out.error = "uncertainty: " + std::to_string(n) + " residuals cannot determine " + std::to_string(p) +
                " parameters";
    return out;
  }
  if (!J.allFinite() || !r.allFinite()) {
    out.error = "uncertainty: the Jacobian or the residuals are not finite";
    return out;
  }
  const auto ranges = SeriesRanges(options.series_starts, n);

  // (J^T J)^-1 through the eigen-decomposition of the column-scaled normal matrix, so that
  // parameters of very different units do not hide a rank deficiency or fake one
  Eigen::VectorXd column_norm = J.colwise().norm().transpose();
  out.standard_error.assign(p, std::numeric_limits<double>::infinity());
  out.poorly_determined.assign(p, "");
  for (int j = 0; j < p; ++j) {
    if (column_norm[j] == 0) out.poorly_determined[j] = "the data do not depend on it";
  }
  Eigen::VectorXd unit = column_norm.unaryExpr([](double c) { return c > 0 ? 1 / c : 1.0; });
  const Eigen::MatrixXd Js = J * unit.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(Js.transpose() * Js);
  const Eigen::VectorXd lambda = eigen.eigenvalues();  // ascending
  if (lambda[0] <= 1e-12 * lambda[p - 1]) {
    // name the parameters that make up each undetermined direction (every eigenvalue that small: which
    // of several comes out smallest can turn on round-off)
    std::string groups;
    for (int k = 0; k < p && lambda[k] <= 1e-12 * lambda[p - 1]; ++k) {
      const Eigen::VectorXd direction = eigen.eigenvectors().col(k);
      std::string partners;
      for (int j = 0; j < p; ++j) {
        if (std::fabs(direction[j]) > 0.1) partners += (partners.empty() ? "" : ", ") + names[j];
      }
      for (int j = 0; j < p; ++j) {
        if (std::fabs(direction[j]) > 0.1 && out.poorly_determined[j].empty()) {
          out.poorly_determined[j] = "not determined by the data: only a combination of " + partners + " is";
        }
      }
      groups += groups.empty() ? partners + " separately" : ", nor " + partners;
    }
    out.error = "the data do not determine " + groups;
    return out;
  }
  const Eigen::MatrixXd bread =
      unit.asDiagonal() * eigen.eigenvectors() * lambda.cwiseInverse().asDiagonal() *
      eigen.eigenvectors().transpose() * unit.asDiagonal();  // (J^T J)^-1

  if (options.lag_window == 0) {
    out.lag_window = 0;
    const double sigma2 = r.squaredNorm() / (n - p);  // Seber and Wild 2003, eq. 2.21
    out.covariance = sigma2 * bread;
  } else {
    out.lag_window = options.lag_window > 0 ? options.lag_window : ChooseLagWindow(r, ranges);
    const double small_sample = static_cast<double>(n) / (n - p);
    out.covariance = small_sample * bread * NeweyWestMeat(J, r, ranges, out.lag_window) * bread;
  }

  out.correlation = out.covariance;
  for (int j = 0; j < p; ++j) out.standard_error[j] = std::sqrt(std::max(out.covariance(j, j), 0.0));
  for (int i = 0; i < p; ++i) {
    for (int j = 0; j < p; ++j) {
      double denominator = out.standard_error[i] * out.standard_error[j];
      out.correlation(i, j) = i == j ? 1.0 : (denominator > 0 ? out.covariance(i, j) / denominator : 0.0);
    }
  }

  for (int j = 0; j < p; ++j) {
    if (!out.poorly_determined[j].empty()) continue;
    const double reference = std::max(std::fabs(values[j]), scales[j]);
    const double relative = out.standard_error[j] / reference;
    int partner = -1;
    for (int i = 0; i < p; ++i) {
      if (i != j && (partner < 0 || std::fabs(out.correlation(i, j)) > std::fabs(out.correlation(partner, j)))) {
        partner = i;
      }
    }
    if (relative > options.max_relative_error) {
      out.poorly_determined[j] = "standard error " + Format("%.0f", 100 * relative) + " % of its value";
    } else if (partner >= 0 && std::fabs(out.correlation(partner, j)) > options.max_correlation) {
      out.poorly_determined[j] =
          "correlated with " + names[partner] + " (" + Format("%+.3f", out.correlation(partner, j)) + ")";
    }
  }
  return out;
}

}  // namespace pneumatic::identification
