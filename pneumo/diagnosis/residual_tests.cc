#include "diagnosis/residual_tests.h"

#include <algorithm>
#include <cmath>

namespace pneumatic::diagnosis {
namespace {

// regularised lower incomplete gamma P(a, x) by its series (Numerical Recipes, 3rd ed., 6.2.5)
// and the upper one by the continued fraction (6.2.7)
double GammaP(double a, double x) {
  if (x <= 0) return 0;
  if (x < a + 1) {
    double sum = 1 / a, term = sum;
    for (int n = 1; n < 1000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::fabs(term) < 1e-15 * std::fabs(sum)) break;
    }
    return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
  }
  double b = x + 1 - a, c = 1e300, d = 1 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::fabs(d) < 1e-300) d = 1e-300;
    c = b + an / c;
    if (std::fabs(c) < 1e-300) c = 1e-300;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::fabs(del - 1) < 1e-15) break;
  }
  return 1 - std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}

}  // namespace

std::vector<double> Autocorrelation(const std::vector<double>& x, int max_lag) {
  const int n = static_cast<int>(x.size());
  double mean = 0;
  for (double v : x) mean += v;
  mean /= std::max(n, 1);
  double c0 = 0;
  for (double v : x) c0 += (v - mean) * (v - mean);
  std::vector<double> rho(static_cast<size_t>(max_lag) + 1, 0.0);
  if (c0 <= 0) return rho;
  for (int l = 0; l <= max_lag && l < n; ++l) {
    double c = 0;
    for (int i = l; i < n; ++i) c += (x[i] - mean) * (x[i - l] - mean);
    rho[l] = c / c0;
  }
  return rho;
}

double ChiSquareUpperTail(double q, int k) { return 1 - GammaP(0.5 * k, 0.5 * q); }

Whiteness LjungBox(const std::vector<double>& x, int lags) {
  Whiteness w;
  const double n = static_cast<double>(x.size());
  lags = std::min(lags, static_cast<int>(x.size()) - 2);
  if (lags < 1) return w;
  const std::vector<double> rho = Autocorrelation(x, lags);
  for (int l = 1; l <= lags; ++l) w.q += rho[l] * rho[l] / (n - l);
  w.q *= n * (n + 2);
  w.lags = lags;
  w.p_value = ChiSquareUpperTail(w.q, lags);
  w.lag1 = rho[1];
  return w;
}

double MaxCrossCorrelation(const std::vector<double>& r, const std::vector<double>& u, int max_lag) {
  const int n = static_cast<int>(std::min(r.size(), u.size()));
  auto mean = [n](const std::vector<double>& v) {
    double s = 0;
    for (int i = 0; i < n; ++i) s += v[i];
    return s / std::max(n, 1);
  };
  const double mr = mean(r), mu = mean(u);
  double best = 0;
  for (int l = 0; l <= max_lag && l < n - 2; ++l) {
    double srr = 0, suu = 0, sru = 0;
    for (int i = l; i < n; ++i) {
      const double a = r[i] - mr, b = u[i - l] - mu;
      srr += a * a, suu += b * b, sru += a * b;
    }
    if (srr > 0 && suu > 0) best = std::max(best, std::fabs(sru / std::sqrt(srr * suu)));
  }
  return best;
}

double IntegratedAutocorrelationTime(const std::vector<double>& x, int max_lag) {
  const std::vector<double> rho = Autocorrelation(x, max_lag);
  double tau = 1;
  for (int l = 1; l <= max_lag; ++l) {
    if (rho[l] <= 0) break;
    tau += 2 * rho[l];
  }
  return tau;
}

BinnedDependence CorrelationRatio(const std::vector<double>& r, const std::vector<double>& q, int bins) {
  BinnedDependence out;
  std::vector<std::pair<double, double>> pairs;  // (q, r)
  for (size_t i = 0; i < std::min(r.size(), q.size()); ++i) {
    if (std::isfinite(r[i]) && std::isfinite(q[i])) pairs.push_back({q[i], r[i]});
  }
  if (pairs.size() < static_cast<size_t>(2 * bins) || bins < 2) return out;
  // by q alone, and equal values of q in one bin (an on/off command has two): sorting the pairs
  // would order a tie by r and make bins of r itself
  std::stable_sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  double mean = 0;
  for (const auto& [qi, ri] : pairs) mean += ri;
  mean /= static_cast<double>(pairs.size());
  double total = 0, between = 0;
  for (const auto& [qi, ri] : pairs) total += (ri - mean) * (ri - mean);
  for (size_t from = 0; from < pairs.size();) {
    size_t to = std::min(pairs.size(), from + std::max<size_t>(1, pairs.size() / bins));
    while (to < pairs.size() && pairs[to].first == pairs[to - 1].first) ++to;
    if (pairs.size() - to < pairs.size() / bins / 2) to = pairs.size();  // no sliver of a last bin
    double qs = 0, rs = 0;
    for (size_t i = from; i < to; ++i) qs += pairs[i].first, rs += pairs[i].second;
    const double n = static_cast<double>(to - from);
    out.centre.push_back(qs / n), out.mean.push_back(rs / n), out.count.push_back(n);
    between += n * (rs / n - mean) * (rs / n - mean);
    from = to;
  }
  out.eta2 = total > 0 ? between / total : 0;
  return out;
}

}  // namespace pneumatic::diagnosis
