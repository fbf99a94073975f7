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
  // paper 000 Appendix eqs. (11), (12), (13)
  c.alpha = discharge_coefficient * std::sqrt(2 / zrt * kappa / (kappa - 1));
  c.beta = discharge_coefficient *
           std::sqrt(kappa / zrt * std::pow(2 / (kappa + 1), (kappa + 1) / (kappa - 1)));
  c.theta = std::pow((kappa + 1) / 2, kappa / (kappa - 1));
  return c;
}

namespace {

// flow for pu >= pd >= 0 and opening >= 0
double ForwardFlow(const FlowLawConstants& law, double opening, double pu, double pd) {
  if (pu <= 0 || opening <= 0) return 0;
  double ratio = pd / pu;
  if (law.law == FlowLaw::kThinPlate) {
    // thin-plate flow, paper 000 eq. (1c): choked when pu/pd > theta
    if (pd * law.theta < pu) return opening * law.beta * pu;
    double q = std::pow(ratio, 1 / law.kappa);  // ratio^(1/kappa)
    double radicand = q * q - ratio * q;         // ratio^(2/kappa) - ratio^((kappa+1)/kappa)
    return opening * law.alpha * pu * std::sqrt(std::max(radicand, 0.0));
  }
  // elliptic law, paper 002 eq. (4) / paper 001 eq. (2): choked when pd/pu <= b
  double b = law.critical_ratio;
  double shape = 1.0;
  if (ratio > b) {
    double s = (ratio - b) / (1 - b);
    shape = std::sqrt(std::max(1 - s * s, 0.0));
  }
  return law.gain * opening * pu * shape;
}

}  // namespace

double MassFlow(const FlowLawConstants& law, double opening, double p_from, double p_to) {
  // negative absolute pressures are unphysical: treat them as vacuum
  p_from = std::max(p_from, 0.0);
  p_to = std::max(p_to, 0.0);
  // reversed flow, rigs.md: Q(pu, pd) = -Q(pd, pu); paper 000 eq. (1b)
  if (p_from >= p_to) return ForwardFlow(law, opening, p_from, p_to);
  return -ForwardFlow(law, opening, p_to, p_from);
}

}  // namespace pneumatic
