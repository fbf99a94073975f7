// Tests of the residuals for remaining structure (issue 14): whether what the model leaves
// unexplained is noise or an effect it lacks.
#ifndef PNEUMATIC_DIAGNOSIS_RESIDUAL_TESTS_H_
#define PNEUMATIC_DIAGNOSIS_RESIDUAL_TESTS_H_

#include <vector>

namespace pneumatic::diagnosis {

// Sample autocorrelation of x at lags 0..max_lag (x's mean removed; 1 at lag 0).
std::vector<double> Autocorrelation(const std::vector<double>& x, int max_lag);

// Ljung-Box statistic Q = n (n + 2) sum_{l=1..L} rho_l^2 / (n - l) (Ljung and Box, Biometrika 65,
// 1978, eq. 2.1) and its p-value under whiteness (chi-square with L degrees of freedom).
struct Whiteness {
  double q = 0, p_value = 1;
  int lags = 0;
  double lag1 = 0;  // rho_1
};
Whiteness LjungBox(const std::vector<double>& x, int lags);

// Largest |correlation| of residual r(t) with input u(t - l) over lags 0..max_lag: residual
// structure that follows the commands.
double MaxCrossCorrelation(const std::vector<double>& r, const std::vector<double>& u, int max_lag);

// Integrated autocorrelation time tau = 1 + 2 sum_{l>=1} rho_l, summed until rho first falls
// below 0 (Geyer's initial positive sequence, simplified; Statistical Science 7, 1992): n / tau is
// the effective number of independent samples.
double IntegratedAutocorrelationTime(const std::vector<double>& x, int max_lag);

// Upper tail of the chi-square distribution with k degrees of freedom.
double ChiSquareUpperTail(double q, int k);

// The residual r against a state q, by bins of q of equal count: the correlation ratio
// eta^2 = sum_b n_b (mean_b r - mean r)^2 / sum_i (r_i - mean r)^2 (Pearson 1905; Fisher,
// "Statistical methods", 1925, sec. 45), the fraction of r's variance that q's bins explain, which
// catches a dependence of any shape (a dead band, a step at a position), not only a linear one;
// with each bin's centre (mean q) and mean r, for plots. Pairs where either is NaN are left out.
struct BinnedDependence {
  double eta2 = 0;
  std::vector<double> centre, mean, count;
};
BinnedDependence CorrelationRatio(const std::vector<double>& r, const std::vector<double>& q, int bins);

}  // namespace pneumatic::diagnosis

#endif  // PNEUMATIC_DIAGNOSIS_RESIDUAL_TESTS_H_
