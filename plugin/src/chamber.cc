#include "chamber.h"

#include <algorithm>
#include <cmath>

namespace pneumatic {

ChamberModel MakeChamberModel(const CylinderConfig& c, int chamber) {
  const ChamberConfig& k = c.chamber[chamber];
  ChamberModel m;
  switch (k.flow) {
    case FlowLaw::kIso6358:
      m.flow = Iso6358Constants(k.critical_ratio);
      break;
    case FlowLaw::kSanville:
      m.flow = SanvilleConstants(k.discharge_coefficient, k.critical_ratio, c.heat_capacity_ratio,
                                 c.gas_constant, c.temperature);
      break;
    case FlowLaw::kThinPlate:
      m.flow = ThinPlateConstants(k.discharge_coefficient, c.heat_capacity_ratio, c.compressibility,
                                  c.gas_constant, c.temperature);
      break;
  }
  m.polytropic_index = k.polytropic_index;
  m.work_factor = k.work_factor;
  m.gas_rt = c.gas_constant * c.temperature;
  m.p_supply = c.p_supply;
  m.p_exhaust = c.p_exhaust;
  m.p_atm = c.p_atm;
  m.atmosphere_leak = k.atmosphere_leak_conductance;
  m.tolerance = c.step_tolerance * (c.p_supply - c.p_exhaust);
  return m;
}

double VolumePath::At(double tau) const {
  return dead_volume + area * std::clamp(swept + swept_rate * tau, 0.0, stroke);
}

double VolumePath::RateAt(double tau) const {
  double s = swept + swept_rate * tau;
  return (s > 0 && s < stroke) ? area * swept_rate : 0.0;
}

double ChamberMassFlow(const ChamberModel& k, const PortOpenings& o, double p) {
  // two-port chamber, paper 000 eq. (2): in from supply, out to exhaust
  return MassFlow(k.flow, o.supply, k.p_supply, p) - MassFlow(k.flow, o.exhaust, p, k.p_exhaust);
}

double NetMassFlow(const ChamberModel& k, const PortOpenings& o, double p, double piston_leak, double p_other) {
  // laminar leaks, the project's own form: linear in the pressure difference
  return ChamberMassFlow(k, o, p) + k.atmosphere_leak * (k.p_atm - p) + piston_leak * (p_other - p);
}

double PressureRate(const ChamberModel& k, const PortOpenings& o, double p, double volume,
                    double volume_rate, double piston_leak, double p_other) {
  // paper 000 eq. (4a); alpha on the piston-work term as in paper 001 eq. (1)
  double n = k.polytropic_index;
  return n * k.gas_rt * NetMassFlow(k, o, p, piston_leak, p_other) / volume - k.work_factor * n * p * volume_rate / volume;
}

namespace {

// the pressures a chamber can reach from p_compressed within a step: its ports', and the
// pressures its leaks pull toward (p_atm, the other chamber's p_other)
struct Range {
  double lo, hi;
};
Range ReachableRange(const ChamberModel& k, double p_compressed, double piston_leak, double p_other) {
  Range r{std::min(p_compressed, k.p_exhaust), std::max(p_compressed, k.p_supply)};
  if (k.atmosphere_leak > 0) r.lo = std::min(r.lo, k.p_atm), r.hi = std::max(r.hi, k.p_atm);
  if (piston_leak > 0) r.lo = std::min(r.lo, p_other), r.hi = std::max(r.hi, p_other);
  return r;
}

// Backward Euler over [a, a + s] in y = p V^(alpha n):
//   p1 = p_compressed + (s n r T / V1) Q(p1),  p_compressed = p0 (V0 / V1)^(alpha n)
// The residual is increasing in p1 (Q falls as the chamber pressure rises), so the root is
// unique and lies between p_compressed and the port pressures; Illinois regula falsi finds it.
double BackwardEulerSubstep(const ChamberModel& k, const PortOpenings& o, double p0, double v0, double v1,
                            double s) {
  double p_compressed = p0 * std::pow(v0 / v1, k.work_factor * k.polytropic_index);
  double c = s * k.polytropic_index * k.gas_rt / v1;
  auto residual = [&](double p) { return p - p_compressed - c * NetMassFlow(k, o, p, 0, 0); };
  Range range = ReachableRange(k, p_compressed, 0, 0);
  double lo = range.lo, hi = range.hi;
  double f_lo = residual(lo), f_hi = residual(hi);
  if (f_lo >= 0) return lo;
  if (f_hi <= 0) return hi;
  double tolerance = 1e-9 * k.p_supply;
  int side = 0;
  for (int i = 0; i < 100; ++i) {
    double p = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
    double f = residual(p);
    if (std::fabs(f) <= tolerance || hi - lo <= tolerance) return p;
    if (f > 0) {
      hi = p, f_hi = f;
      if (side == 1) f_lo /= 2;  // Illinois: halve the stale end so the bracket shrinks on both sides
      side = 1;
    } else {
      lo = p, f_lo = f;
      if (side == -1) f_hi /= 2;
      side = -1;
    }
  }
  return (lo + hi) / 2;
}

}  // namespace

double PhysicalPressureStep(const ChamberModel& k, const PortSchedule& ports, const VolumePath& volume,
                            double p0, double h) {
  const double min_substep = h / 4096;
  double p = p0, tau = 0;
  double substep = h;
  // integrate segment by segment between valve switching instants
  SwitchInstants ends = ports.breakpoints();
  ends.push_back(h);
  for (double end : ends) {
    while (tau < end) {
      double s = std::min(substep, end - tau);
      bool last = s >= end - tau;
      double mid = tau + s / 2, next = last ? end : tau + s;
      s = next - tau;
      // valve openings are sampled at the substep's end (backward Euler); segments never cross a jump
      PortOpenings at_mid = ports.At(mid - 1e-12 * h), at_next = ports.At(next - 1e-12 * h);
      double v_start = volume.At(tau), v_mid = volume.At(mid), v_next = volume.At(next);
      double full = BackwardEulerSubstep(k, at_next, p, v_start, v_next, s);
      double half = BackwardEulerSubstep(k, at_mid, p, v_start, v_mid, s / 2);
      half = BackwardEulerSubstep(k, at_next, half, v_mid, v_next, s / 2);
      double error = std::fabs(half - full);
      // at the smallest substep accept anyway (compare the requested size: s = next - tau may round above it)
      if (error > k.tolerance && substep > min_substep) {
        substep = std::max(s * std::max(0.2, 0.9 * std::sqrt(k.tolerance / error)), min_substep);
        continue;
      }
      // Richardson extrapolation of the two backward Euler results: second order
      double p_next = 2 * half - full;
      // keep the reachable range: between the port pressures and the sealed-chamber path
      double p_compressed = p * std::pow(v_start / v_next, k.work_factor * k.polytropic_index);
      Range range = ReachableRange(k, p_compressed, 0, 0);
      p = std::clamp(p_next, range.lo, range.hi);
      tau = next;
      double grow = error > 0 ? 0.9 * std::sqrt(k.tolerance / error) : 4.0;
      substep = std::max(s * std::clamp(grow, 0.2, 4.0), min_substep);
    }
  }
  return p;
}

namespace {

// phi1(x) = (e^x - 1)/x and phi2(x) = (e^x - 1 - x)/x^2 with their derivatives, accurate near 0;
// x <= 0 here (exponential integrators, e.g. Hochbruck and Ostermann 2010)
// phi1(x) and phi2(x) from one exponential, by their series near 0
void Phi1And2(double x, double* phi1, double* phi2) {
  if (std::fabs(x) < 1e-3) {
    *phi1 = 1 + x / 2 + x * x / 6, *phi2 = 0.5 + x / 6 + x * x / 24;
    return;
  }
  double e = std::expm1(x);
  *phi1 = e / x, *phi2 = (e - x) / (x * x);
}
double Phi1(double x) {
  double phi1 = 0, phi2 = 0;
  Phi1And2(x, &phi1, &phi2);
  return phi1;
}
double Phi2(double x) {
  double phi1 = 0, phi2 = 0;
  Phi1And2(x, &phi1, &phi2);
  return phi2;
}
double Phi1Slope(double x) {
  return std::fabs(x) < 1e-3 ? 0.5 + x / 3 + x * x / 8 : (std::exp(x) * (x - 1) + 1) / (x * x);
}
double Phi2Slope(double x) {
  return std::fabs(x) < 1e-2 ? 1.0 / 6 + x / 12 + x * x / 40 : (x * std::exp(x) - 2 * std::expm1(x) + x) / (x * x * x);
}

// One port's flow into a chamber at pressure p, and its conductance G >= 0 for the stiff part
// of the step: the flow's slope, G = -dQ/dp (exponential Rosenbrock).
struct PortFlow {
  double flow = 0;         // kg/s into the chamber
  double conductance = 0;  // kg/(s Pa)
};

PortFlow Port(const FlowLawConstants& law, double opening, double p_port, double p) {
  PortFlow out;
  if (opening <= 0) return out;
  double slope = 0;
  out.flow = MassFlowAndSlope(law, opening, p_port, p, &slope);
  out.conductance = -slope;
  return out;
}

// Where the chamber is closer to the port's pressure than the flow moves it over the substep
// (`travel`, Pa), the slope grows without bound (Q ~ sqrt|p_port - p|): the chord from the port
// pressure to p + travel stands in for it (the project's own choice).
void UseChordNearThePort(const FlowLawConstants& law, double opening, double p_port, double p, double travel,
                         PortFlow* port) {
  if (opening <= 0 || std::fabs(p_port - p) > std::fabs(travel)) return;
  double dp = p_port - (p + travel);
  double smallest = 1e-9 * p_port;
  if (std::fabs(dp) < smallest) dp = smallest;
  port->conductance = MassFlow(law, opening, p_port, p_port - dp) / dp;
}

// the chambers' pressure rates, and their stiff linear part B: the exponential step treats
// dp/dt = B p + N(p) (paper 000 eq. 4a), with B from the compression rate, and from the port
// conductances and the leaks times D = n r T / V, and N the remainder
struct LinearSystem {
  double b[2][2] = {{0, 0}, {0, 0}};
  double rate[2] = {0, 0};  // dp/dt at the pressures the system was built at (Pa/s)
};

LinearSystem System(int n, const ChamberModel k[], const PortOpenings o[], const double volume[],
                    const double compression[], double piston_leak, const double p[], double substep) {
  LinearSystem s;
  for (int i = 0; i < n; ++i) {
    const ChamberModel& c = k[i];
    double d = c.polytropic_index * c.gas_rt / volume[i];
    double p_other = n == 2 ? p[1 - i] : p[i];
    PortFlow supply = Port(c.flow, o[i].supply, c.p_supply, p[i]);
    PortFlow exhaust = Port(c.flow, o[i].exhaust, c.p_exhaust, p[i]);
    // the laminar leaks (the project's own form) are linear: their conductance is exact
    double flow = supply.flow + exhaust.flow + c.atmosphere_leak * (c.p_atm - p[i]) + piston_leak * (p_other - p[i]);
    double travel = substep * d * flow;
    UseChordNearThePort(c.flow, o[i].supply, c.p_supply, p[i], travel, &supply);
    UseChordNearThePort(c.flow, o[i].exhaust, c.p_exhaust, p[i], travel, &exhaust);
    s.b[i][i] = compression[i] - d * (supply.conductance + exhaust.conductance + c.atmosphere_leak + piston_leak);
    if (n == 2) s.b[i][1 - i] = d * piston_leak;
    s.rate[i] = compression[i] * p[i] + d * flow;
  }
  return s;
}

// phi(B t) v for a function phi of the 2x2 matrix B t: phi(l2) v + phi[l1, l2] (B - l2 I) v
// (Newton's form, exact for 2x2), with the eigenvalues l1 >= l2 of B, real and <= 0 (B is similar
// to a symmetric negative semidefinite matrix); phi_slope is phi' for near-equal eigenvalues
void ApplyMatrixFunction(int n, double (*phi)(double), double (*phi_slope)(double), const LinearSystem& s, double t,
                         const double v[], double out[]) {
  if (n == 1 || (s.b[0][1] == 0 && s.b[1][0] == 0)) {
    // uncoupled chambers: one scalar function each
    for (int i = 0; i < n; ++i) out[i] = phi(s.b[i][i] * t) * v[i];
    return;
  }
  double half_trace = (s.b[0][0] + s.b[1][1]) / 2;
  double half_gap = std::sqrt(std::max(0.0, 0.25 * (s.b[0][0] - s.b[1][1]) * (s.b[0][0] - s.b[1][1]) +
                                                s.b[0][1] * s.b[1][0]));
  double l1 = half_trace + half_gap, l2 = half_trace - half_gap;
  double at_l2 = phi(l2 * t);
  double divided = (l1 - l2) * t < 1e-3 ? t * phi_slope(half_trace * t) : (phi(l1 * t) - at_l2) / (l1 - l2);
  for (int i = 0; i < 2; ++i) {
    double b_minus_l2 = s.b[i][0] * v[0] + s.b[i][1] * v[1] - l2 * v[i];
    out[i] = at_l2 * v[i] + divided * b_minus_l2;
  }
}

// the linearized step holds where the flow's slope changes by at most this fraction over the step
constexpr double kMaxSlopeChange = 0.25;

// a chamber's pressure kept within what it can reach from its compressed pressure
double KeepReachable(const ChamberModel k[], int i, const double compressed[], double piston_leak, double p) {
  Range range = ReachableRange(k[i], compressed[i], piston_leak, piston_leak > 0 ? compressed[1 - i] : 0);
  return std::clamp(p, range.lo, range.hi);
}

}  // namespace

bool LinearizedPressureStep(int n, const ChamberModel k[], const PortSchedule* ports[], const VolumePath volume[],
                            double piston_leak, const double p0[], double h, double p1[]) {
  if (n == 1) piston_leak = 0;
  // a valve switching within the step: the adaptive step splits there
  for (int i = 0; i < n; ++i) {
    if (!ports[i]->breakpoints().empty()) return false;
  }
  // the polytropic compression as a constant rate, -alpha n ln(V(h)/V(0)) / h, so that a sealed chamber
  // follows p V^(alpha n) exactly; the flow term with the volume at mid-step
  double v_mid[2] = {1, 1}, compression[2] = {0, 0}, compressed[2] = {0, 0};
  PortOpenings open_start[2], open_end[2];
  for (int i = 0; i < n; ++i) {
    double v_start = volume[i].At(0), v_end = volume[i].At(h), exponent = k[i].work_factor * k[i].polytropic_index;
    v_mid[i] = volume[i].At(h / 2);
    compressed[i] = p0[i];
    if (v_end != v_start) {
      double log_ratio = -exponent * std::log1p((v_end - v_start) / v_start);  // ln (V(0)/V(h))^(alpha n)
      compression[i] = log_ratio / h;
      compressed[i] = p0[i] * std::exp(log_ratio);
    }
    open_start[i] = ports[i]->At(0), open_end[i] = ports[i]->At(h);
  }
  // exponential Rosenbrock-Euler: p + h phi1(B h) rate, B the slope (exact where the flow is linear)
  LinearSystem start = System(n, k, open_start, v_mid, compression, piston_leak, p0, h);
  double change[2] = {0, 0}, predicted[2] = {0, 0}, phi1 = 1, phi2 = 0.5;
  if (n == 1) {
    // one chamber: the scalar functions of b h, from one exponential
    Phi1And2(start.b[0][0] * h, &phi1, &phi2);
    change[0] = phi1 * start.rate[0];
  } else {
    ApplyMatrixFunction(n, Phi1, Phi1Slope, start, h, start.rate, change);
  }
  for (int i = 0; i < n; ++i) predicted[i] = KeepReachable(k, i, compressed, piston_leak, p0[i] + h * change[i]);
  // second-order correction (ETD2RK, Cox and Matthews 2002): h phi2(B h) times the change of the
  // remainder N = rate - B p over the step, valve openings moving from their start to their end
  // value (a spool)
  LinearSystem at_end = System(n, k, open_end, v_mid, compression, piston_leak, predicted, h);
  double missed[2] = {0, 0}, correction[2] = {0, 0};
  for (int i = 0; i < n; ++i) {
    double linear_change = start.b[i][0] * (predicted[0] - p0[0]) + (n == 2 ? start.b[i][1] * (predicted[1] - p0[1]) : 0);
    missed[i] = at_end.rate[i] - start.rate[i] - linear_change;
  }
  if (n == 1) {
    correction[0] = phi2 * missed[0];
  } else {
    ApplyMatrixFunction(n, Phi2, Phi2Slope, start, h, missed, correction);
  }
  const double tolerance = n == 2 ? std::min(k[0].tolerance, k[1].tolerance) : k[0].tolerance;
  for (int i = 0; i < n; ++i) {
    // error indicators: the correction (ETD1's local error), half the step times the remainder's change
    // (which stiffness would hide from the correction), and how far the slope changed over the step:
    // near a port pressure the laws go as sqrt, and a linearization holds for a short way only
    double error = std::max(std::fabs(h * correction[i]), std::fabs(h / 2 * missed[i]));
    double b_start = compression[i] - start.b[i][i], b_end = compression[i] - at_end.b[i][i];
    if (!(error <= tolerance) || std::fabs(b_end - b_start) > kMaxSlopeChange * std::max(b_start, b_end)) return false;
  }
  for (int i = 0; i < n; ++i) p1[i] = KeepReachable(k, i, compressed, piston_leak, predicted[i] + h * correction[i]);
  return true;
}

void PistonLeakExchange(const ChamberModel k[2], const double volume[2], double piston_leak, double t, double p[2]) {
  // dp_P/dt = -a (p_P - p_N), dp_N/dt = b (p_P - p_N), a = n_P r T G / V_P, b = n_N r T G / V_N:
  // the difference decays as exp(-(a + b) t) and b p_P + a p_N stays constant
  double a = k[0].polytropic_index * k[0].gas_rt * piston_leak / volume[0];
  double b = k[1].polytropic_index * k[1].gas_rt * piston_leak / volume[1];
  if (a + b <= 0) return;
  double decayed = (p[0] - p[1]) * std::expm1(-(a + b) * t) / (a + b);  // change of the difference, over a + b
  p[0] += a * decayed;
  p[1] -= b * decayed;
}

double SupplyMassOverStep(const ChamberModel& k, const PortOpenings& o0, const PortOpenings& o1,
                          const VolumePath& volume, double p0, double p1, double piston_leak, double p_other0,
                          double p_other1, double h) {
  // the net mass from the pressure change the flow made (the compression's share removed)
  double v0 = volume.At(0), v1 = volume.At(h), exponent = k.work_factor * k.polytropic_index;
  double compressed = v1 != v0 ? p0 * std::exp(-exponent * std::log1p((v1 - v0) / v0)) : p0;
  double net = (p1 - compressed) * volume.At(h / 2) / (k.polytropic_index * k.gas_rt);
  // each part by the trapezoid rule
  auto supply = [&](const PortOpenings& o, double p) {
    return o.supply > 0 ? MassFlow(k.flow, o.supply, k.p_supply, p) : 0.0;
  };
  auto exhaust = [&](const PortOpenings& o, double p) {
    return o.exhaust > 0 ? -MassFlow(k.flow, o.exhaust, p, k.p_exhaust) : 0.0;
  };
  auto leaks = [&](double p, double p_other) { return k.atmosphere_leak * (k.p_atm - p) + piston_leak * (p_other - p); };
  double by_supply = h / 2 * (supply(o0, p0) + supply(o1, p1));
  double by_exhaust = h / 2 * (exhaust(o0, p0) + exhaust(o1, p1));
  double by_leaks = h / 2 * (leaks(p0, p_other0) + leaks(p1, p_other1));
  double size = std::fabs(by_supply) + std::fabs(by_exhaust) + std::fabs(by_leaks);
  if (!(size > 0)) return 0;
  return by_supply + (net - by_supply - by_exhaust - by_leaks) * (std::fabs(by_supply) / size);
}

SteadyStateAndRate IdentifiedModel(const IdentifiedParams& c, double u, double v, double v_rate) {
  // paper 000 eqs. (10a)-(10e) with g of eq. (8) and k of eq. (9)
  double u_hat = u - c.c[1];
  double sigmoid_arg = c.c[2] * u_hat + c.c[3] * u_hat * u_hat * u_hat;
  double g = sigmoid_arg / std::sqrt(sigmoid_arg * sigmoid_arg + 1);
  double k = std::sqrt(u_hat * u_hat + c.c_gamma * c.c_gamma) - c.c_gamma + c.c[9] + c.c[8] * u_hat;
  SteadyStateAndRate out;
  out.s = c.c_b + c.c_s * g + c.c[4] * v_rate;
  out.r = (c.c[7] * k + c.c[5] * v_rate) / (1 + c.c[6] * v);
  return out;
}

double IdentifiedPressureStep(const SteadyStateAndRate& sr, double p0, double h) {
  // paper 000 eq. (7); a negative rate only arises outside the identified data: hold the pressure
  double r = std::max(sr.r, 0.0);
  return sr.s + (p0 - sr.s) * std::exp(-r * h);
}

}  // namespace pneumatic
