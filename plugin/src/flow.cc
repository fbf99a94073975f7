#include "flow.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>

namespace pneumatic {

FlowLawConstants Iso6358Constants(double critical_ratio) {
  FlowLawConstants c;
  c.law = FlowLaw::kIso6358;
  c.gain = 1.0;
  c.critical_ratio = critical_ratio;
  return c;
}

FlowLawConstants SanvilleConstants(double discharge_coefficient, double critical_ratio, double gamma,
                                   double gas_constant, double temperature) {
  // C1 of paper 001 eq. 2
  double c1 = std::sqrt(gamma / gas_constant * std::pow(2 / (gamma + 1), (gamma + 1) / (gamma - 1)));
  FlowLawConstants c;
  c.law = FlowLaw::kSanville;
  c.gain = c1 * discharge_coefficient / std::sqrt(temperature);
  c.critical_ratio = critical_ratio;
  return c;
}

FlowLawConstants ThinPlateConstants(double discharge_coefficient, double kappa, double compressibility,
                                    double gas_constant, double temperature) {
  double zrt = compressibility * gas_constant * temperature;
  FlowLawConstants c;
  c.law = FlowLaw::kThinPlate;
  c.kappa = kappa;
  c.kappa_inverse = 1 / kappa;
  // paper 000 Appendix eqs. (11), (12), (13)
  c.alpha = discharge_coefficient * std::sqrt(2 / zrt * kappa / (kappa - 1));
  c.beta = discharge_coefficient *
           std::sqrt(kappa / zrt * std::pow(2 / (kappa + 1), (kappa + 1) / (kappa - 1)));
  c.theta = std::pow((kappa + 1) / 2, kappa / (kappa - 1));
  c.table = ThinPlateTableFor(kappa);
  return c;
}

namespace {

// g(r) = (r^(2/k) - r^((k+1)/k)) / (1 - r) and dg/dr: exact for r < 1, the limit at r = 1
// from the binomial series of r^a around 1 (t = 1 - r: r^a = 1 - a t + a(a-1)/2 t^2 - ...)
void SmoothFactorSquared(double kappa, double r, double* g, double* dg) {
  double a1 = 2 / kappa, a2 = (kappa + 1) / kappa;
  double t = 1 - r;
  if (t <= 0) {
    *g = (kappa - 1) / kappa;
    *dg = -(a1 * (a1 - 1) - a2 * (a2 - 1)) / 2;
    return;
  }
  double radicand = std::pow(r, a1) - std::pow(r, a2);
  double d_radicand = a1 * std::pow(r, a1 - 1) - a2 * std::pow(r, a2 - 1);
  *g = radicand / t;
  *dg = (d_radicand * t + radicand) / (t * t);
}

}  // namespace

const ThinPlateTable* ThinPlateTableFor(double kappa) {
  // built once per kappa at attach time, never freed: a handful of kilobytes
  static std::mutex mutex;
  static std::map<double, std::unique_ptr<ThinPlateTable>> tables;
  std::lock_guard<std::mutex> lock(mutex);
  std::unique_ptr<ThinPlateTable>& table = tables[kappa];
  if (table) return table.get();
  table = std::make_unique<ThinPlateTable>();
  double theta = std::pow((kappa + 1) / 2, kappa / (kappa - 1));
  table->r_min = 1 / theta;
  table->step = (1 - table->r_min) / ThinPlateTable::kIntervals;
  table->step_inverse = 1 / table->step;
  // f and df/dr at the nodes, then each interval's cubic Hermite polynomial in monomial form
  double f[ThinPlateTable::kIntervals + 1], slope[ThinPlateTable::kIntervals + 1];
  for (int i = 0; i <= ThinPlateTable::kIntervals; ++i) {
    double r = i == ThinPlateTable::kIntervals ? 1.0 : table->r_min + i * table->step;
    double g = 0, dg = 0;
    SmoothFactorSquared(kappa, r, &g, &dg);
    f[i] = std::sqrt(g);
    slope[i] = dg / (2 * f[i]);
  }
  for (int i = 0; i < ThinPlateTable::kIntervals; ++i) {
    // p(u) = f0 h00 + s m0 h10 + f1 h01 + s m1 h11 with s the step and m the slopes
    double f0 = f[i], f1 = f[i + 1], m0 = table->step * slope[i], m1 = table->step * slope[i + 1];
    double* c = table->cubic[i].c;
    c[0] = f0;
    c[1] = m0;
    c[2] = 3 * (f1 - f0) - 2 * m0 - m1;
    c[3] = 2 * (f0 - f1) + m0 + m1;
  }
  return table.get();
}

}  // namespace pneumatic
