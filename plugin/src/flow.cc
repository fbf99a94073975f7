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
  for (int i = 0; i <= ThinPlateTable::kIntervals; ++i) {
    double r = i == ThinPlateTable::kIntervals ? 1.0 : table->r_min + i * table->step;
    double g = 0, dg = 0;
    SmoothFactorSquared(kappa, r, &g, &dg);
    table->f[i] = std::sqrt(g);
    table->slope[i] = dg / (2 * table->f[i]);
  }
  return table.get();
}

double ThinPlateTable::Shape(double r, double* d_shape) const {
  // cubic Hermite interpolation of f on the interval holding r
  double x = (r - r_min) * step_inverse;
  int i = std::clamp(static_cast<int>(x), 0, kIntervals - 1);
  double u = x - i, u2 = u * u, u3 = u2 * u;
  double h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u, h01 = -2 * u3 + 3 * u2, h11 = u3 - u2;
  double value = h00 * f[i] + h10 * step * slope[i] + h01 * f[i + 1] + h11 * step * slope[i + 1];
  double d_value = ((6 * u2 - 6 * u) * (f[i] - f[i + 1])) * step_inverse + (3 * u2 - 4 * u + 1) * slope[i] +
                   (3 * u2 - 2 * u) * slope[i + 1];
  // sqrt(1 - r) f(r): the square root carries the infinite slope at r = 1
  double t = std::max(1 - r, 0.0), root = std::sqrt(t);
  *d_shape = t > 0 ? root * d_value - value / (2 * root) : 0;
  return root * value;
}

namespace {

// flow for pu >= pd >= 0 and opening >= 0, and its partial derivatives by pu and pd (kg/(s Pa)); the
// derivatives grow without bound as pd reaches pu, where the laws go as sqrt(pu - pd)
double ForwardFlow(const FlowLawConstants& law, double opening, double pu, double pd, double* d_pu, double* d_pd) {
  *d_pu = 0, *d_pd = 0;
  if (pu <= 0 || opening <= 0) return 0;
  double ratio = pd / pu;
  if (law.law == FlowLaw::kThinPlate) {
    // thin-plate flow, paper 000 eq. (1c): choked when pu/pd > theta
    if (pd * law.theta < pu) {
      *d_pu = opening * law.beta;
      return opening * law.beta * pu;
    }
    double slope = 0;
    double root = law.table->Shape(ratio, &slope);  // sqrt(ratio^(2/kappa) - ratio^((kappa+1)/kappa))
    *d_pd = opening * law.alpha * slope;
    *d_pu = opening * law.alpha * (root - ratio * slope);
    return opening * law.alpha * pu * root;
  }
  // elliptic law, paper 002 eq. (4) / paper 001 eq. (2): choked when pd/pu <= b
  double b = law.critical_ratio;
  if (ratio <= b) {
    *d_pu = law.gain * opening;
    return law.gain * opening * pu;
  }
  double s = (ratio - b) / (1 - b);
  double shape = std::sqrt(std::max(1 - s * s, 0.0));
  if (shape > 0) {
    double slope = -s / ((1 - b) * shape);  // d shape / d ratio
    *d_pd = law.gain * opening * slope;
    *d_pu = law.gain * opening * (shape - ratio * slope);
  }
  return law.gain * opening * pu * shape;
}

}  // namespace

double MassFlow(const FlowLawConstants& law, double opening, double p_from, double p_to) {
  double slope = 0;
  return MassFlowAndSlope(law, opening, p_from, p_to, &slope);
}

double MassFlowAndSlope(const FlowLawConstants& law, double opening, double p_from, double p_to, double* slope_to) {
  // negative absolute pressures are unphysical: treat them as vacuum
  p_from = std::max(p_from, 0.0);
  p_to = std::max(p_to, 0.0);
  // reversed flow, rigs.md: Q(pu, pd) = -Q(pd, pu); paper 000 eq. (1b)
  double d_pu = 0, d_pd = 0;
  if (p_from >= p_to) {
    double q = ForwardFlow(law, opening, p_from, p_to, &d_pu, &d_pd);
    *slope_to = d_pd;
    return q;
  }
  double q = -ForwardFlow(law, opening, p_to, p_from, &d_pu, &d_pd);
  *slope_to = -d_pu;
  return q;
}

}  // namespace pneumatic
