// Standard errors and correlations of least-squares estimates, and which of them are poorly
// determined: the part of the fitting layer every fit (paper 000's parametric model, the
// physical parameters, the diagnosis's effects) reports with its values.
//
// Linearised at the optimum, the estimate theta of min sum r_i(theta)^2 has the covariance
//   C = (J^T J)^-1 S (J^T J)^-1,
// J the Jacobian dr/dtheta. With independent residuals of one variance, S = sigma^2 J^T J and
// C = sigma^2 (J^T J)^-1, sigma^2 = r^T r / (N - p): the textbook covariance (e.g. Seber and
// Wild, Nonlinear Regression, 2003, eq. 2.21). Residuals of a simulation fitted along a noisy
// measured motion are correlated in time; for those, S is the heteroskedasticity and
// autocorrelation consistent estimate of Newey and West (Econometrica 55, 1987, eq. 2) with
// Bartlett weights 1 - l/(L+1), summed over lags l <= L within each series of residuals.
#ifndef PNEUMATIC_IDENTIFICATION_UNCERTAINTY_H_
#define PNEUMATIC_IDENTIFICATION_UNCERTAINTY_H_

#include <string>
#include <vector>

#include <Eigen/Dense>

namespace pneumatic::identification {

struct UncertaintyOptions {
  // Residuals 0..N-1 form time series that start at these indices (ascending, first 0); lags
  // never cross a series boundary. Empty: one series.
  std::vector<int> series_starts;
  // Lag window L of the Newey-West estimate, in residuals: 0 treats the residuals as
  // independent (textbook covariance); < 0 chooses L from the residuals (the first lag at
  // which their autocorrelation falls below 0.05, at least 4 (N/100)^(2/9), Newey and West
  // 1994's rule, at most N/20).
  int lag_window = -1;
  // A parameter is poorly determined if its standard error exceeds this fraction of
  // max(|value|, scale) ...
  double max_relative_error = 0.25;
  // ... or if its correlation with another parameter exceeds this in magnitude.
  double max_correlation = 0.95;
};

struct Uncertainty {
  std::vector<double> standard_error;     // per parameter, in its unit; +inf if undetermined
  Eigen::MatrixXd covariance;             // p x p
  Eigen::MatrixXd correlation;            // p x p, 1 on the diagonal
  int lag_window = 0;                     // L used
  // per parameter: "" if well determined, else why not, naming the partner of a strong
  // correlation, e.g. "standard error 62 % of its value" or "correlated with N.area_gain (-0.99)"
  std::vector<std::string> poorly_determined;
  std::string error;                      // non-empty if J^T J is singular or the input is inconsistent
};

// J: N x p Jacobian at the optimum in the parameters' own units; r: the N residuals there;
// names, values, scales: p each (scale: the magnitude below which |value| is not used as the
// reference of the relative error, e.g. the width of its plausible range / 100).
Uncertainty EstimateUncertainty(const Eigen::MatrixXd& J, const Eigen::VectorXd& r,
                                const std::vector<std::string>& names, const std::vector<double>& values,
                                const std::vector<double>& scales, const UncertaintyOptions& options);

}  // namespace pneumatic::identification

#endif  // PNEUMATIC_IDENTIFICATION_UNCERTAINTY_H_
