// Mass flow through one valve port: the three flow laws of the papers.
//
// Every law is written for an upstream pressure pu >= downstream pd; when
// pd > pu the same law runs in reverse, Q(pu, pd) = -Q(pd, pu), so flows are
// signed, positive from the first argument to the second.
#ifndef PNEUMATIC_FLOW_H_
#define PNEUMATIC_FLOW_H_

#include <algorithm>
#include <cmath>

#include "config.h"

namespace pneumatic {

// The thin-plate law's pressure-ratio factor sqrt(r^(2/k) - r^((k+1)/k)) on the
// subsonic range r in [1/theta, 1], written sqrt(1 - r) f(r) with f smooth, and f
// interpolated by cubic Hermite polynomials between tabulated values and slopes (the
// project's own evaluation: within 5e-14 of the formula where the formula is exact,
// tests/flow_valve_test; nearer r = 1 the formula's own cancellation dominates, and
// cheaper than its two powers). Each interval's cubic is stored by its coefficients in
// u = (r - r_i) / step, so an evaluation is two short Horner sums.
// One table per heat capacity ratio, built at attach time and shared.
struct ThinPlateTable {
  static constexpr int kIntervals = 512;
  double r_min = 0, step = 0, step_inverse = 0;
  // f(r_i + u step) = c[0] + u (c[1] + u (c[2] + u c[3])) on interval i
  struct Cubic {
    double c[4];
  };
  Cubic cubic[kIntervals] = {};
  // sqrt(r^(2/k) - r^((k+1)/k)) and its derivative by r, for r in [r_min, 1]
  double Shape(double r, double* d_shape) const;
};
const ThinPlateTable* ThinPlateTableFor(double kappa);

// constants of one port's flow law, computed once at attach time
struct FlowLawConstants {
  FlowLaw law = FlowLaw::kIso6358;
  // elliptic laws (iso6358, sanville): Q = gain * opening * pu * sqrt(1 - ((pd/pu - b)/(1 - b))^2)
  double gain = 0;            // iso6358: 1 (opening is C_val); sanville: C1 C_d / sqrt(T), s/m
  double critical_ratio = 0;  // b, P_cr
  // thin plate (paper 000 eq. 1c and Appendix eqs. 11-13)
  double alpha = 0, beta = 0, theta = 0, kappa = 0, kappa_inverse = 0;
  const ThinPlateTable* table = nullptr;  // for kappa
};

// ISO 6358 law (paper 002 eq. 4, paper 003 eq. 3): opening = C_val, kg/(s Pa).
FlowLawConstants Iso6358Constants(double critical_ratio);

// Paper 001 eq. 2: opening = orifice area (m^2);
// C1 = sqrt(gamma/r (2/(gamma+1))^((gamma+1)/(gamma-1))).
FlowLawConstants SanvilleConstants(double discharge_coefficient, double critical_ratio, double gamma,
                                   double gas_constant, double temperature);

// Paper 000 eq. 1 with eqs. 11-13; opening = orifice area (m^2). With the
// specific gas constant r = R/M, 2M/(Z R T) = 2/(Z r T).
FlowLawConstants ThinPlateConstants(double discharge_coefficient, double kappa, double compressibility,
                                    double gas_constant, double temperature);

// Signed mass flow (kg/s) from pressure p_from to p_to (Pa abs) through a port
// of the given opening (C_val for iso6358, area for the others).
inline double MassFlow(const FlowLawConstants& law, double opening, double p_from, double p_to);

// MassFlow and its derivative by p_to (kg/(s Pa), <= 0): the flow's slope seen from the
// downstream side; it grows without bound as the two pressures meet
[[gnu::always_inline]] inline double MassFlowAndSlope(const FlowLawConstants& law, double opening, double p_from,
                                                     double p_to, double* slope_to);

//---------------------------------------------------------------------------------------------------
// The definitions of the evaluations above, here so that the chamber steps, which call them four times
// per chamber and step, can inline them.

inline double ThinPlateTable::Shape(double r, double* d_shape) const {
  // the cubic of the interval holding r, and its derivative by r
  double x = (r - r_min) * step_inverse;
  int i = std::clamp(static_cast<int>(x), 0, kIntervals - 1);
  double u = x - i;
  const double* c = cubic[i].c;
  double value = c[0] + u * (c[1] + u * (c[2] + u * c[3]));
  double d_value = (c[1] + u * (2 * c[2] + u * (3 * c[3]))) * step_inverse;
  // sqrt(1 - r) f(r): the square root carries the infinite slope at r = 1
  double t = std::max(1 - r, 0.0), root = std::sqrt(t);
  *d_shape = t > 0 ? root * d_value - value / (2 * root) : 0;
  return root * value;
}

namespace flow_detail {

// flow for pu >= pd >= 0 and opening >= 0, and its partial derivatives by pu and pd (kg/(s Pa)); the
// derivatives grow without bound as pd reaches pu, where the laws go as sqrt(pu - pd)
inline double ForwardFlow(const FlowLawConstants& law, double opening, double pu, double pd, double* d_pu,
                          double* d_pd) {
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

}  // namespace flow_detail

inline double MassFlow(const FlowLawConstants& law, double opening, double p_from, double p_to) {
  double slope = 0;
  return MassFlowAndSlope(law, opening, p_from, p_to, &slope);
}

[[gnu::always_inline]] inline double MassFlowAndSlope(const FlowLawConstants& law, double opening, double p_from,
                                                     double p_to, double* slope_to) {
  // negative absolute pressures are unphysical: treat them as vacuum
  p_from = std::max(p_from, 0.0);
  p_to = std::max(p_to, 0.0);
  // reversed flow, docs/rigs.md: Q(pu, pd) = -Q(pd, pu); paper 000 eq. (1b)
  double d_pu = 0, d_pd = 0;
  if (p_from >= p_to) {
    double q = flow_detail::ForwardFlow(law, opening, p_from, p_to, &d_pu, &d_pd);
    *slope_to = d_pd;
    return q;
  }
  double q = -flow_detail::ForwardFlow(law, opening, p_to, p_from, &d_pu, &d_pd);
  *slope_to = -d_pu;
  return q;
}

}  // namespace pneumatic

#endif  // PNEUMATIC_FLOW_H_
