#include "flow.h"

#include <algorithm>
#include <cmath>

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
  return c;
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
    double q = std::exp(std::log(ratio) * law.kappa_inverse);  // ratio^(1/kappa), cheaper than pow
    double radicand = std::max(q * (q - ratio), 0.0);          // ratio^(2/kappa) - ratio^((kappa+1)/kappa)
    double root = std::sqrt(radicand);
    if (root > 0) {
      // d root / d ratio = (q / kappa) (2 q / ratio - kappa - 1) / (2 root)
      double slope = q * law.kappa_inverse * (2 * q * pu / pd - law.kappa - 1) * (0.5 / root);
      *d_pd = opening * law.alpha * slope;
      *d_pu = opening * law.alpha * (root - ratio * slope);
    }
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
