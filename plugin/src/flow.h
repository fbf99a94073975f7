// Mass flow through one valve port: the three flow laws of the papers.
//
// Every law is written for an upstream pressure pu >= downstream pd; when
// pd > pu the same law runs in reverse, Q(pu, pd) = -Q(pd, pu), so flows are
// signed, positive from the first argument to the second.
#ifndef PNEUMATIC_FLOW_H_
#define PNEUMATIC_FLOW_H_

#include "config.h"

namespace pneumatic {

// The thin-plate law's pressure-ratio factor sqrt(r^(2/k) - r^((k+1)/k)) on the
// subsonic range r in [1/theta, 1], written sqrt(1 - r) f(r) with f smooth, and f
// tabulated for cubic Hermite interpolation (the project's own evaluation: within
// 5e-14 of the formula where the formula is exact, tests/flow_valve_test; nearer
// r = 1 the formula's own cancellation dominates, and cheaper than its two powers).
// One table per heat capacity ratio, built at attach time and shared.
struct ThinPlateTable {
  static constexpr int kIntervals = 512;
  double r_min = 0, step = 0, step_inverse = 0;
  double f[kIntervals + 1] = {};      // f at r_min + i step
  double slope[kIntervals + 1] = {};  // df/dr there
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
double MassFlow(const FlowLawConstants& law, double opening, double p_from, double p_to);

// MassFlow and its derivative by p_to (kg/(s Pa), <= 0): the flow's slope seen from the
// downstream side; it grows without bound as the two pressures meet
double MassFlowAndSlope(const FlowLawConstants& law, double opening, double p_from, double p_to, double* slope_to);

}  // namespace pneumatic

#endif  // PNEUMATIC_FLOW_H_
