#include "chamber.h"

#include "exponential.h"

#include <algorithm>
#include <cmath>
#include <complex>

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
  m.atmosphere_leak_area = k.atmosphere_leak_area;
  // orifice leaks: paper 001 eq. 2 (Sanville 1971) with C_d = 1 and the critical ratio 0.528 of air
  m.leak_law = SanvilleConstants(1.0, 0.528, c.heat_capacity_ratio, c.gas_constant, c.temperature);
  m.tolerance = c.step_tolerance * (c.p_supply - c.p_exhaust);
  m.gamma = c.heat_capacity_ratio;
  m.gas_constant = c.gas_constant;
  m.temperature = c.temperature;
  m.wall_conductance = k.wall_heat_conductance;
  m.line_volume = k.line_volume;
  m.line_conductance = k.line_conductance;
  m.line = Iso6358Constants(0.433);
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
  double q = ChamberMassFlow(k, o, p) + k.atmosphere_leak * (k.p_atm - p) + piston_leak * (p_other - p);
  if (k.atmosphere_leak_area > 0) q += MassFlow(k.leak_law, k.atmosphere_leak_area, k.p_atm, p);
  return q;
}

double PressureRate(const ChamberModel& k, const PortOpenings& o, double p, double volume,
                    double volume_rate, double piston_leak, double p_other) {
  // paper 000 eq. (4a); alpha on the piston-work term as in paper 001 eq. (1)
  double n = k.polytropic_index;
  return n * k.gas_rt * NetMassFlow(k, o, p, piston_leak, p_other) / volume - k.work_factor * n * p * volume_rate / volume;
}

namespace {

// the root of an increasing function f on [lo, hi] (f(lo) <= 0 <= f(hi) expected; the nearer end
// otherwise), by Illinois regula falsi to `tolerance` in x
template <typename F>
double IncreasingRoot(const F& f, double lo, double hi, double tolerance) {
  double f_lo = f(lo), f_hi = f(hi);
  if (f_lo >= 0) return lo;
  if (f_hi <= 0) return hi;
  int side = 0;
  double width = hi - lo;
  for (int i = 0; i < 300; ++i) {
    double x = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
    // a bisection wherever two secant steps have not halved the bracket (the laws' square roots)
    if (i % 2 == 0) {
      if (hi - lo > width / 2) x = (lo + hi) / 2;
      width = hi - lo;
    }
    if (!(x > lo && x < hi)) x = (lo + hi) / 2;
    double fx = f(x);
    if (fx == 0 || hi - lo <= tolerance) return x;
    if (fx > 0) {
      hi = x, f_hi = fx;
      if (side == 1) f_lo /= 2;
      side = 1;
    } else {
      lo = x, f_lo = fx;
      if (side == -1) f_hi /= 2;
      side = -1;
    }
  }
  return (lo + hi) / 2;
}

// the pressures a chamber can reach from p_compressed within a step: its ports', and the
// pressures its leaks pull toward (p_atm, the other chamber's p_other)
struct Range {
  double lo, hi;
};
Range ReachableRange(const ChamberModel& k, double p_compressed, double piston_leak, double p_other) {
  Range r{std::min(p_compressed, k.p_exhaust), std::max(p_compressed, k.p_supply)};
  if (k.atmosphere_leak > 0 || k.atmosphere_leak_area > 0) r.lo = std::min(r.lo, k.p_atm), r.hi = std::max(r.hi, k.p_atm);
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

// One substep of the adaptive driver below: its length, the valve openings of its two halves
// (sampled at their ends: backward in time) and the chamber's volume at its start, middle and end.
struct Substep {
  double length;
  PortOpenings at_mid, at_next;
  double v_start, v_mid, v_next;
};

// The project's own adaptive driver of the implicit chamber steps: step doubling with Richardson
// extrapolation over [0, h], segment by segment between valve switching instants (a substep never
// crosses one). `attempt(substep)` advances its state once over the substep and twice over its halves
// and returns the difference of the two results (Pa); the driver then either calls `accept()`, which
// keeps the extrapolated result, or shrinks the substep and asks again. At the smallest substep,
// h / 4096, it accepts anyway.
template <typename Attempt, typename Accept>
void StepDoubling(const PortSchedule& ports, const VolumePath& volume, double h, double tolerance, Attempt attempt,
                  Accept accept) {
  const double min_substep = h / 4096;
  double tau = 0, substep = h;
  SwitchInstants ends = ports.breakpoints();
  ends.push_back(h);
  for (double end : ends) {
    while (tau < end) {
      double s = std::min(substep, end - tau);
      bool last = s >= end - tau;
      double mid = tau + s / 2, next = last ? end : tau + s;
      s = next - tau;
      const Substep step{s, ports.At(mid - 1e-12 * h), ports.At(next - 1e-12 * h),
                         volume.At(tau), volume.At(mid), volume.At(next)};
      double error = attempt(step);
      // compare the requested size: s = next - tau may round above it
      if ((!std::isfinite(error) || error > tolerance) && substep > min_substep) {
        substep = std::max(s * (std::isfinite(error) ? std::max(0.2, 0.9 * std::sqrt(tolerance / error)) : 0.2),
                           min_substep);
        continue;
      }
      accept();
      tau = next;
      double grow = error > 0 ? 0.9 * std::sqrt(tolerance / error) : 4.0;
      substep = std::max(s * std::clamp(grow, 0.2, 4.0), min_substep);
    }
  }
}

}  // namespace

double PhysicalPressureStep(const ChamberModel& k, const PortSchedule& ports, const VolumePath& volume,
                            double p0, double h) {
  double p = p0, extrapolated = p0;
  auto attempt = [&](const Substep& step) {
    const double s = step.length;
    double full = BackwardEulerSubstep(k, step.at_next, p, step.v_start, step.v_next, s);
    double half = BackwardEulerSubstep(k, step.at_mid, p, step.v_start, step.v_mid, s / 2);
    half = BackwardEulerSubstep(k, step.at_next, half, step.v_mid, step.v_next, s / 2);
    // Richardson extrapolation of the two backward Euler results: second order, kept in the reachable
    // range (between the port pressures and the sealed-chamber path)
    double p_compressed = p * std::pow(step.v_start / step.v_next, k.work_factor * k.polytropic_index);
    Range range = ReachableRange(k, p_compressed, 0, 0);
    extrapolated = std::clamp(2 * half - full, range.lo, range.hi);
    return std::fabs(half - full);
  };
  StepDoubling(ports, volume, h, k.tolerance, attempt, [&] { p = extrapolated; });
  return p;
}

double Log1p(double x) {
  return std::fabs(x) <= exponential::kLog1pSeriesLimit ? exponential::Log1pSeries(x) : std::log1p(x);
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
  double e = exponential::Expm1(x);
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

[[gnu::always_inline]] inline PortFlow Port(const FlowLawConstants& law, double opening, double p_port, double p) {
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
// conductances and the leaks times D = n r T / V (`gain`, per chamber), and N the remainder
struct LinearSystem {
  double b[2][2] = {{0, 0}, {0, 0}};
  double rate[2] = {0, 0};  // dp/dt at the pressures the system was built at (Pa/s)
};

// (n chambers, a constant: the loops over them unroll)
template <int n>
LinearSystem System(const ChamberModel k[], const PortOpenings o[], const double gain[], const double compression[],
                    double piston_leak, const double p[], double substep) {
  LinearSystem s;
  for (int i = 0; i < n; ++i) {
    const ChamberModel& c = k[i];
    const double d = gain[i];
    double p_other = n == 2 ? p[1 - i] : p[i];
    PortFlow supply = Port(c.flow, o[i].supply, c.p_supply, p[i]);
    PortFlow exhaust = Port(c.flow, o[i].exhaust, c.p_exhaust, p[i]);
    // the laminar leaks (the project's own form) are linear: their conductance is exact
    double flow = supply.flow + exhaust.flow + c.atmosphere_leak * (c.p_atm - p[i]) + piston_leak * (p_other - p[i]);
    // the orifice leak to the atmosphere: one more port, at p_atm
    PortFlow orifice = Port(c.leak_law, c.atmosphere_leak_area, c.p_atm, p[i]);
    if (c.atmosphere_leak_area > 0) flow += orifice.flow;
    double travel = substep * d * flow;
    UseChordNearThePort(c.flow, o[i].supply, c.p_supply, p[i], travel, &supply);
    UseChordNearThePort(c.flow, o[i].exhaust, c.p_exhaust, p[i], travel, &exhaust);
    double conductance = supply.conductance + exhaust.conductance + c.atmosphere_leak + piston_leak;
    if (c.atmosphere_leak_area > 0) {
      UseChordNearThePort(c.leak_law, c.atmosphere_leak_area, c.p_atm, p[i], travel, &orifice);
      conductance += orifice.conductance;
    }
    s.b[i][i] = compression[i] - d * conductance;
    if (n == 2) s.b[i][1 - i] = d * piston_leak;
    s.rate[i] = compression[i] * p[i] + d * flow;
  }
  return s;
}

// phi(B t) v for a function phi of the 2x2 matrix B t: phi(l2) v + phi[l1, l2] (B - l2 I) v
// (Newton's form, exact for 2x2), with the eigenvalues l1 >= l2 of B, real and <= 0 (B is similar
// to a symmetric negative semidefinite matrix); phi_slope is phi' for near-equal eigenvalues
template <int n>
void ApplyMatrixFunction(double (*phi)(double), double (*phi_slope)(double), const LinearSystem& s, double t,
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

// LinearizedPressureStep for n chambers, a constant
// (the valve openings at the start and the end of the step, and whether they are held: no switching inside)
template <int n>
void LinearizedStep(const ChamberModel k[], const PortOpenings open_start[], const PortOpenings open_end[],
                    const bool held[], const VolumePath volume[], double piston_leak, const double p0[], double h,
                    double p1[], bool done[]) {
  const bool coupled = n == 2 && piston_leak > 0;
  if (!coupled) piston_leak = 0;
  // a valve switching within the step: the adaptive step splits there
  bool ok[2] = {true, true};
  for (int i = 0; i < n; ++i) ok[i] = held[i];
  // the polytropic compression as a constant rate, -alpha n ln(V(h)/V(0)) / h, so that a sealed chamber
  // follows p V^(alpha n) exactly; the flow term with the volume at mid-step
  double v_mid[2] = {1, 1}, compression[2] = {0, 0}, compressed[2] = {0, 0};
  for (int i = 0; i < n; ++i) {
    double v_start = volume[i].At(0), v_end = volume[i].At(h), exponent = k[i].work_factor * k[i].polytropic_index;
    v_mid[i] = volume[i].At(h / 2);
    compressed[i] = p0[i];
    if (v_end != v_start) {
      double log_ratio = -exponent * Log1p((v_end - v_start) / v_start);  // ln (V(0)/V(h))^(alpha n)
      compression[i] = log_ratio / h;
      compressed[i] = p0[i] * exponential::Exp(log_ratio);
    }
  }
  // exponential Rosenbrock-Euler: p + h phi1(B h) rate, B the slope (exact where the flow is linear)
  // D = n r T / V at mid-step, the pressure rate per unit of mass flow
  double gain[2] = {0, 0};
  for (int i = 0; i < n; ++i) gain[i] = k[i].polytropic_index * k[i].gas_rt / v_mid[i];
  LinearSystem start = System<n>(k, open_start, gain, compression, piston_leak, p0, h);
  double change[2] = {0, 0}, predicted[2] = {0, 0}, phi1[2] = {1, 1}, phi2[2] = {0.5, 0.5};
  if (coupled) {
    ApplyMatrixFunction<n>(Phi1, Phi1Slope, start, h, start.rate, change);
  } else {
    // chambers on their own: the scalar functions of b h, from one exponential each
    for (int i = 0; i < n; ++i) {
      Phi1And2(start.b[i][i] * h, &phi1[i], &phi2[i]);
      change[i] = phi1[i] * start.rate[i];
    }
  }
  // each chamber's pressure kept within what it can reach from its compressed pressure
  Range reachable[2];
  for (int i = 0; i < n; ++i) {
    reachable[i] = ReachableRange(k[i], compressed[i], piston_leak, piston_leak > 0 ? compressed[1 - i] : 0);
    predicted[i] = std::clamp(p0[i] + h * change[i], reachable[i].lo, reachable[i].hi);
  }
  // second-order correction (ETD2RK, Cox and Matthews 2002): h phi2(B h) times the change of the
  // remainder N = rate - B p over the step, valve openings moving from their start to their end
  // value (a spool)
  LinearSystem at_end = System<n>(k, open_end, gain, compression, piston_leak, predicted, h);
  double missed[2] = {0, 0}, correction[2] = {0, 0};
  for (int i = 0; i < n; ++i) {
    double linear_change = start.b[i][i] * (predicted[i] - p0[i]);
    if (coupled) linear_change += start.b[i][1 - i] * (predicted[1 - i] - p0[1 - i]);
    missed[i] = at_end.rate[i] - start.rate[i] - linear_change;
  }
  if (coupled) {
    ApplyMatrixFunction<n>(Phi2, Phi2Slope, start, h, missed, correction);
  } else {
    for (int i = 0; i < n; ++i) correction[i] = phi2[i] * missed[i];
  }
  for (int i = 0; i < n; ++i) {
    // error indicators: the correction (ETD1's local error), half the step times the remainder's change
    // (which stiffness would hide from the correction), and how far the slope changed over the step:
    // near a port pressure the laws go as sqrt, and a linearization holds for a short way only
    const double tolerance = coupled ? std::min(k[0].tolerance, k[1].tolerance) : k[i].tolerance;
    double error = std::max(std::fabs(h * correction[i]), std::fabs(h / 2 * missed[i]));
    double b_start = compression[i] - start.b[i][i], b_end = compression[i] - at_end.b[i][i];
    ok[i] = ok[i] && error <= tolerance && std::fabs(b_end - b_start) <= kLinearizedMaxSlopeChange * std::max(b_start, b_end);
  }
  if (coupled) ok[0] = ok[1] = ok[0] && ok[1];
  for (int i = 0; i < n; ++i) {
    done[i] = ok[i];
    if (ok[i]) p1[i] = std::clamp(predicted[i] + h * correction[i], reachable[i].lo, reachable[i].hi);
  }
}

}  // namespace

void LinearizedPressureStep(int n, const ChamberModel k[], const PortSchedule* ports[], const VolumePath volume[],
                            double piston_leak, const double p0[], double h, double p1[], bool done[]) {
  PortOpenings open_start[2], open_end[2];
  bool held[2];
  for (int i = 0; i < n; ++i) {
    open_start[i] = ports[i]->At(0), open_end[i] = ports[i]->At(h);
    held[i] = ports[i]->breakpoints().empty();
  }
  if (n == 2) {
    LinearizedStep<2>(k, open_start, open_end, held, volume, piston_leak, p0, h, p1, done);
  } else {
    LinearizedStep<1>(k, open_start, open_end, held, volume, piston_leak, p0, h, p1, done);
  }
}

void LinearizedChamberStep(const ChamberModel& k, const PortOpenings& open_start, const PortOpenings& open_end,
                           bool held, const VolumePath& volume, double p0, double h, double* p1, bool* done) {
  LinearizedStep<1>(&k, &open_start, &open_end, &held, &volume, 0, &p0, h, p1, done);
}

void PistonOrificeExchange(const ChamberModel k[2], const double volume[2], double area, double t, double p[2]) {
  if (area <= 0 || t <= 0) return;
  const double a[2] = {k[0].polytropic_index * k[0].gas_rt / volume[0], k[1].polytropic_index * k[1].gas_rt / volume[1]};
  const double tolerance = std::min(k[0].tolerance, k[1].tolerance);
  // one backward Euler substep of length s from (p_P, p_N): the mass flow q from P to N
  auto substep = [&](const double from[2], double s, double to[2]) {
    double bound = k[0].leak_law.gain * area * std::max(from[0], from[1]);  // |Q| <= gain a max(p)
    auto residual = [&](double q) {
      return q - MassFlow(k[0].leak_law, area, std::max(from[0] - a[0] * s * q, 0.0), std::max(from[1] + a[1] * s * q, 0.0));
    };
    double q = bound > 0 ? IncreasingRoot(residual, -bound, bound, 1e-15 * bound) : 0.0;
    to[0] = from[0] - a[0] * s * q, to[1] = from[1] + a[1] * s * q;
  };
  double tau = 0, step = t;
  const double min_step = t / 4096;
  while (tau < t) {
    double s = std::min(step, t - tau);
    double full[2], mid[2], half[2];
    substep(p, s, full);
    substep(p, s / 2, mid);
    substep(mid, s / 2, half);
    double error = std::max(std::fabs(half[0] - full[0]), std::fabs(half[1] - full[1]));
    if (error > tolerance && step > min_step) {
      step = std::max(s * std::max(0.2, 0.9 * std::sqrt(tolerance / error)), min_step);
      continue;
    }
    // Richardson extrapolation: linear, so p_P / a_P + p_N / a_N stays
    for (int i = 0; i < 2; ++i) p[i] = 2 * half[i] - full[i] > 0 ? 2 * half[i] - full[i] : half[i];
    tau += s;
    double grow = error > 0 ? 0.9 * std::sqrt(tolerance / error) : 4.0;
    step = std::max(s * std::clamp(grow, 0.2, 4.0), min_step);
  }
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

void EnergyLeakExchange(const ChamberModel k[2], const double volume[2], double piston_leak, double area, double t,
                        GasState gas[2]) {
  // upstream u, downstream w: the higher pressure passes gas to the lower
  const int u = gas[0].p >= gas[1].p ? 0 : 1, w = 1 - u;
  const double gap = gas[u].p - gas[w].p;
  if (!(gap > 0) || !(t > 0) || (!(piston_leak > 0) && !(area > 0))) return;
  const ChamberModel& ku = k[u];
  const double gamma = ku.gamma, r = ku.gas_constant, cp = gamma * r / (gamma - 1);
  // the flow at the start, rated at the model's temperature and passing sqrt(T_ref / T_u) of it (a nozzle
  // passes mass as 1/sqrt(T0)), as EnergyPressureStep rates it
  const double scale = std::sqrt(ku.temperature / gas[u].t);
  double rate = piston_leak * gap;
  if (area > 0) rate += MassFlow(ku.leak_law, area, gas[u].p, gas[w].p);
  rate *= scale;
  // the mass that would equalize the pressures, each kilogram taking c_p T_u with it:
  // dp_u = -gamma r T_u q / V_u, dp_w = +gamma r T_u q / V_w
  const double equalizing = gap / (gamma * r * gas[u].t * (1 / volume[u] + 1 / volume[w]));
  const double moved = -equalizing * std::expm1(-rate * t / equalizing);
  double mass[2], energy[2];
  for (int i = 0; i < 2; ++i) {
    mass[i] = gas[i].p * volume[i] / (k[i].gas_constant * gas[i].t);
    energy[i] = gas[i].p * volume[i] / (k[i].gamma - 1);
  }
  const double enthalpy = cp * gas[u].t * moved;
  mass[u] -= moved, energy[u] -= enthalpy;
  mass[w] += moved, energy[w] += enthalpy;
  for (int i = 0; i < 2; ++i) {
    gas[i].p = (k[i].gamma - 1) * energy[i] / volume[i];
    gas[i].t = gas[i].p * volume[i] / (k[i].gas_constant * mass[i]);
  }
}

double SupplyMassOverStep(const ChamberModel& k, const PortOpenings& o0, const PortOpenings& o1,
                          const VolumePath& volume, double p0, double p1, double piston_leak, double p_other0,
                          double p_other1, double h) {
  // the net mass from the pressure change the flow made (the compression's share removed)
  double v0 = volume.At(0), v1 = volume.At(h), exponent = k.work_factor * k.polytropic_index;
  double compressed = v1 != v0 ? p0 * exponential::Exp(-exponent * Log1p((v1 - v0) / v0)) : p0;  // as the step takes it
  double net = (p1 - compressed) * volume.At(h / 2) / (k.polytropic_index * k.gas_rt);
  // each part by the trapezoid rule
  auto supply = [&](const PortOpenings& o, double p) {
    return o.supply > 0 ? MassFlow(k.flow, o.supply, k.p_supply, p) : 0.0;
  };
  auto exhaust = [&](const PortOpenings& o, double p) {
    return o.exhaust > 0 ? -MassFlow(k.flow, o.exhaust, p, k.p_exhaust) : 0.0;
  };
  auto leaks = [&](double p, double p_other) {
    double q = k.atmosphere_leak * (k.p_atm - p) + piston_leak * (p_other - p);
    if (k.atmosphere_leak_area > 0) q += MassFlow(k.leak_law, k.atmosphere_leak_area, k.p_atm, p);
    return q;
  };
  double by_supply = h / 2 * (supply(o0, p0) + supply(o1, p1));
  double by_exhaust = h / 2 * (exhaust(o0, p0) + exhaust(o1, p1));
  double by_leaks = h / 2 * (leaks(p0, p_other0) + leaks(p1, p_other1));
  double size = std::fabs(by_supply) + std::fabs(by_exhaust) + std::fabs(by_leaks);
  if (!(size > 0)) return 0;
  return by_supply + (net - by_supply - by_exhaust - by_leaks) * (std::fabs(by_supply) / size);
}

namespace {

// the gas of a chamber as the conserved quantities of a backward Euler substep: mass and internal energy
struct GasContent {
  double mass = 0;    // kg
  double energy = 0;  // J, c_v m T = p V / (gamma - 1)
  double supply = 0;  // kg that entered through the supply port
};

// One backward Euler substep of length s of the energy equation (EnergyPressureStep) from `start`
// in volume v0 to volume v1, openings o held. With the flows evaluated at the end pressure p1:
//   m1 = m0 + s (in(p1) - out(p1))
//   E1 = E0 + s (c_p H_in(p1) - c_p T1 out(p1) + hA (T_w - T1)) - p1 (v1 - v0),   T1 = p1 v1 / (r m1)
// and E1 = p1 v1 / (gamma - 1). The residual E1(p1) - right-hand side increases with p1 (inflows fall,
// outflows and T1 rise with it), so its root is unique; it is bracketed between a near-vacuum and the
// highest pressure the flows and the compression can give, and found by Illinois regula falsi.
GasContent EnergySubstep(const ChamberModel& k, const PortOpenings& o, double piston_leak, double piston_area,
                         GasState other,
                         GasState start, double v0, double v1, double s, GasState* end) {
  const double gamma = k.gamma, r = k.gas_constant, t_ref = k.temperature;
  const double cp = gamma * r / (gamma - 1);
  const double m0 = start.p * v0 / (r * start.t), e0 = start.p * v0 / (gamma - 1);
  // an outflow leaves at the chamber's temperature: the law rated at t_ref passes sqrt(t_ref / T) of it
  const double out_scale = std::sqrt(t_ref / start.t);
  const double other_scale = other.t > 0 ? std::sqrt(t_ref / other.t) : 1.0;
  struct Flows {
    double in = 0, out = 0, enthalpy_in = 0, supply = 0;  // kg/s, kg/s, kg K/s, kg/s
  };
  auto flows = [&](double p) {
    Flows f;
    auto add = [&](double into, double t_upstream_in, double in_scale) {
      if (into >= 0) {
        f.in += into * in_scale, f.enthalpy_in += into * in_scale * t_upstream_in;
      } else {
        f.out -= into * out_scale;
      }
    };
    double supply = o.supply > 0 ? MassFlow(k.flow, o.supply, k.p_supply, p) : 0.0;
    add(supply, t_ref, 1.0);
    f.supply = supply >= 0 ? supply : supply * out_scale;
    if (o.exhaust > 0) add(-MassFlow(k.flow, o.exhaust, p, k.p_exhaust), t_ref, 1.0);
    // the laminar leaks (the project's own form), with the same upstream temperatures
    if (k.atmosphere_leak > 0) add(k.atmosphere_leak * (k.p_atm - p), t_ref, 1.0);
    if (k.atmosphere_leak_area > 0) add(MassFlow(k.leak_law, k.atmosphere_leak_area, k.p_atm, p), t_ref, 1.0);
    if (piston_area > 0) add(MassFlow(k.leak_law, piston_area, other.p, p), other.t, other_scale);
    if (piston_leak > 0) add(piston_leak * (other.p - p), other.t, other_scale);
    return f;
  };
  struct Result {
    double residual, mass, t;
    Flows f;
  };
  auto evaluate = [&](double p) {
    Result x;
    x.f = flows(p);
    x.mass = m0 + s * (x.f.in - x.f.out);
    if (!(x.mass > 0)) {
      x.residual = HUGE_VAL, x.t = HUGE_VAL;  // more gas leaves than there is: p1 lies below
      return x;
    }
    x.t = p * v1 / (r * x.mass);
    double rhs = e0 + s * (cp * x.f.enthalpy_in - cp * x.t * x.f.out + k.wall_conductance * (t_ref - x.t)) -
                 p * (v1 - v0);
    x.residual = p * v1 / (gamma - 1) - rhs;
    return x;
  };
  // bracket: a near-vacuum below, and above the highest of the port and leak pressures and the
  // adiabatic compression of the start, doubled until the residual is positive
  double lo = 1e-9 * k.p_supply;
  double hi = std::max({k.p_supply, k.p_exhaust, k.p_atm, piston_leak > 0 ? other.p : 0.0,
                        start.p * std::pow(v0 / v1, gamma) * std::max(1.0, t_ref / start.t)});
  Result r_lo = evaluate(lo), r_hi = evaluate(hi);
  for (int i = 0; i < 60 && r_hi.residual <= 0; ++i) hi *= 2, r_hi = evaluate(hi);
  Result best = r_lo;
  double p = lo;
  if (r_lo.residual >= 0) {
    p = lo;
  } else {
    double f_lo = r_lo.residual, f_hi = r_hi.residual;
    const double tolerance = 1e-12 * k.p_supply;
    int side = 0;
    p = hi, best = r_hi;
    for (int i = 0; i < 200; ++i) {
      double next = std::isfinite(f_hi) ? (lo * f_hi - hi * f_lo) / (f_hi - f_lo) : (lo + hi) / 2;
      if (!(next > lo && next < hi)) next = (lo + hi) / 2;
      Result x = evaluate(next);
      p = next, best = x;
      if (x.residual == 0 || hi - lo <= tolerance) break;
      if (x.residual > 0) {
        hi = next, f_hi = x.residual;
        if (side == 1) f_lo /= 2;  // Illinois
        side = 1;
      } else {
        lo = next, f_lo = x.residual;
        if (side == -1 && std::isfinite(f_hi)) f_hi /= 2;
        side = -1;
      }
    }
  }
  end->p = p;
  end->t = best.t;
  GasContent content;
  content.mass = best.mass;
  content.energy = p * v1 / (gamma - 1);
  content.supply = s * best.f.supply;
  return content;
}

}  // namespace

GasState EnergyPressureStep(const ChamberModel& k, const PortSchedule& ports, const VolumePath& volume,
                            double piston_leak, double piston_area, GasState other, GasState start, double h,
                            double* supply_mass) {
  const double r = k.gas_constant, gamma = k.gamma;
  GasState gas = start, next_gas = start;
  double supplied = 0, supplied_here = 0;
  auto attempt = [&](const Substep& step) {
    const double s = step.length;
    GasState full_end, half_mid, half_end;
    GasContent full = EnergySubstep(k, step.at_next, piston_leak, piston_area, other, gas, step.v_start, step.v_next, s,
                                    &full_end);
    GasContent half = EnergySubstep(k, step.at_mid, piston_leak, piston_area, other, gas, step.v_start, step.v_mid,
                                    s / 2, &half_mid);
    GasContent half2 = EnergySubstep(k, step.at_next, piston_leak, piston_area, other, half_mid, step.v_mid,
                                     step.v_next, s / 2, &half_end);
    // Richardson extrapolation in the conserved quantities (second order); a result that would leave
    // the gas without mass or energy keeps the two half steps
    double mass = 2 * half2.mass - full.mass, energy = 2 * half2.energy - full.energy;
    supplied_here = 2 * (half.supply + half2.supply) - full.supply;
    if (mass > 0 && energy > 0) {
      next_gas.p = (gamma - 1) * energy / step.v_next;
      next_gas.t = next_gas.p * step.v_next / (r * mass);
    } else {
      next_gas = half_end;
      supplied_here = half.supply + half2.supply;
    }
    // the error in pressure, and in temperature weighted by p / T (Pa)
    return std::max(std::fabs(half_end.p - full_end.p), std::fabs(half_end.t - full_end.t) * half_end.p / half_end.t);
  };
  StepDoubling(ports, volume, h, k.tolerance, attempt, [&] {
    gas = next_gas;
    supplied += supplied_here;
  });
  if (supply_mass) *supply_mass = supplied;
  return gas;
}

namespace {


// one exponential Euler substep of LinePressureStep (exponential Rosenbrock-Euler: y1 = y0 + s phi1(s J) F(y0),
// F the pressures' rates and J their Jacobian at the substep's start; Hochbruck, Ostermann and Schweitzer,
// SIAM J. Numer. Anal. 47, 2009): line and chamber pressures at its end, and the mass that entered the line
// through the supply port. The chamber's compression by the piston is taken exactly, p_c = p0 (v0/v1)^(alpha n)
// as in the polytropic step; then y = (p_L, p) follows
//   dp_L/dt = (r T / V_L) (Q_valve(p_L) - q),      q = Q_r(p_L, p) the restriction's flow,
//   dp/dt   = (n r T / v1) (q - G_atm (p - p_atm)),
// which the step solves exactly where the flows are linear: a stiff line (a small volume behind a wide
// restriction: time constants of microseconds) costs no more substeps than a soft one. J's two rows use the
// same slopes of q, so V_L p_L + V p (the gas of an isothermal chamber at fixed volume behind closed valves)
// is kept exactly: it is a left null vector of J and of F. The slopes are one-sided differences (the laws'
// square roots have unbounded slopes where the pressures meet: RestrictionFlow is laminar there).
struct LineSubstep {
  double line = 0, p = 0, supply = 0;
  double p_compressed = 0;  // the chamber's pressure compressed over the substep, before the flows
};
// The restriction's mass flow from the line (p_line) into the chamber (p), signed: ISO 6358 (paper 002
// eq. 4) down to a pressure ratio of 0.999, linear in the pressure difference above it, as
// MATLAB Simscape's pneumatic local restriction does with its laminar flow pressure ratio (0.999 by
// default): the elliptic law's slope is unbounded where the pressures meet, which no linearised step
// can follow, and a real restriction is laminar there.
double RestrictionFlow(const ChamberModel& k, double p_line, double p) {
  constexpr double kLaminarRatio = 0.999;
  const double hi = std::max(p_line, p), lo = std::min(p_line, p);
  if (hi <= 0) return 0.0;
  double q;
  if (lo / hi <= kLaminarRatio) {
    q = MassFlow(k.line, k.line_conductance, hi, lo);
  } else {
    q = MassFlow(k.line, k.line_conductance, hi, kLaminarRatio * hi) * (1 - lo / hi) / (1 - kLaminarRatio);
  }
  return p_line >= p ? q : -q;
}
// phi1(A) v = A^-1 (e^A - I) v for a real 2 x 2 matrix A, by Newton's divided-difference form of a
// matrix function, f(A) = f(l1) I + f[l1, l2] (A - l1 I) with l1, l2 the eigenvalues of A (real or a
// complex pair), f[l1, l2] = (f(l1) - f(l2)) / (l1 - l2), or f'(l) when they (nearly) coincide (Higham,
// Functions of Matrices, 2008, Section 1.2 and Problem 1.9)
void Phi1Times(const double A[2][2], const double v[2], double out[2]) {
  using Complex = std::complex<double>;
  auto phi1 = [](Complex x) { return std::abs(x) < 1e-8 ? 1.0 + x / 2.0 : (std::exp(x) - 1.0) / x; };
  auto phi1_slope = [](Complex x) {  // d phi1 / dx = (e^x (x - 1) + 1) / x^2
    return std::abs(x) < 1e-4 ? 0.5 + x / 3.0 : (std::exp(x) * (x - 1.0) + 1.0) / (x * x);
  };
  const double trace = A[0][0] + A[1][1], det = A[0][0] * A[1][1] - A[0][1] * A[1][0];
  const Complex root = std::sqrt(Complex(trace * trace / 4 - det, 0.0));
  const Complex l1 = trace / 2 + root, l2 = trace / 2 - root;
  const Complex divided = std::abs(l1 - l2) < 1e-6 * (1 + std::abs(l1)) ? phi1_slope((l1 + l2) / 2.0)
                                                                       : (phi1(l1) - phi1(l2)) / (l1 - l2);
  const Complex f1 = phi1(l1);
  // (A - l1 I) v
  const Complex w0 = (A[0][0] - l1) * v[0] + A[0][1] * v[1], w1 = A[1][0] * v[0] + (A[1][1] - l1) * v[1];
  out[0] = (f1 * v[0] + divided * w0).real();
  out[1] = (f1 * v[1] + divided * w1).real();
}

// the pressures a line and its chamber can reach over a substep from line0 and p (the chamber's
// compressed pressure): between the lowest and the highest of them and of the open ports' and leaks' pressures
Range LineRange(const ChamberModel& k, const PortOpenings& o, double line0, double p) {
  Range r{std::min(line0, p), std::max(line0, p)};
  if (o.supply > 0) r.hi = std::max(r.hi, k.p_supply);
  if (o.exhaust > 0) r.lo = std::min(r.lo, k.p_exhaust);
  if (k.atmosphere_leak > 0 || k.atmosphere_leak_area > 0) r.lo = std::min(r.lo, k.p_atm), r.hi = std::max(r.hi, k.p_atm);
  return r;
}

LineSubstep LineExponentialEuler(const ChamberModel& k, const PortOpenings& o, double line0, double p0, double v0,
                                 double v1, double s) {
  const double k_line = k.gas_rt / k.line_volume;
  const double p_compressed = p0 * std::pow(v0 / v1, k.work_factor * k.polytropic_index);
  const double c = k.polytropic_index * k.gas_rt / v1;
  const double delta = 1e-7 * k.p_supply;
  const double valve = ChamberMassFlow(k, o, line0);
  const double valve_slope = (ChamberMassFlow(k, o, line0 + delta) - valve) / delta;  // <= 0
  const double q = RestrictionFlow(k, line0, p_compressed);
  const double a = (RestrictionFlow(k, line0 + delta, p_compressed) - q) / delta;  // >= 0
  const double b = (RestrictionFlow(k, line0, p_compressed + delta) - q) / delta;  // <= 0
  // the chamber's leaks to the atmosphere: laminar, G (p_atm - p), and through an orifice (paper 001
  // eq. 2), its slope by the same difference as the valve's
  const double g = k.atmosphere_leak;
  double leak = g * (k.p_atm - p_compressed), leak_slope = -g;  // kg/s, kg/(s Pa)
  if (k.atmosphere_leak_area > 0) {
    const double orifice = MassFlow(k.leak_law, k.atmosphere_leak_area, k.p_atm, p_compressed);
    leak += orifice;
    leak_slope += (MassFlow(k.leak_law, k.atmosphere_leak_area, k.p_atm, p_compressed + delta) - orifice) / delta;
  }
  const double rate[2] = {k_line * (valve - q), c * (q + leak)};
  const double sJ[2][2] = {{s * k_line * (valve_slope - a), -s * k_line * b}, {s * c * a, s * c * (b + leak_slope)}};
  double change[2];
  Phi1Times(sJ, rate, change);
  // both kept between the lowest and the highest pressure the gas can come from: near a port's pressure the
  // laws go as sqrt, and the slope taken at the substep's start carries the line past it (it once left a
  // line oscillating short of the supply pressure, its chamber with it)
  const Range range = LineRange(k, o, line0, p_compressed);
  LineSubstep out;
  out.p_compressed = p_compressed;
  out.line = std::clamp(line0 + s * change[0], range.lo, range.hi);
  out.p = std::clamp(p_compressed + s * change[1], range.lo, range.hi);
  out.supply = o.supply > 0 ? s * MassFlow(k.flow, o.supply, k.p_supply, out.line) : 0.0;
  return out;
}

}  // namespace

void LinePressureStep(const ChamberModel& k, const PortSchedule& ports, const VolumePath& volume, double line0,
                      double p0, double h, double* line1, double* p1, double* supply_mass) {
  double line = line0, p = p0, supplied = 0;
  double next_line = line0, next_p = p0, supplied_here = 0;
  auto attempt = [&](const Substep& step) {
    const double s = step.length;
    LineSubstep full = LineExponentialEuler(k, step.at_next, line, p, step.v_start, step.v_next, s);
    LineSubstep half = LineExponentialEuler(k, step.at_mid, line, p, step.v_start, step.v_mid, s / 2);
    LineSubstep half2 = LineExponentialEuler(k, step.at_next, half.line, half.p, step.v_mid, step.v_next, s / 2);
    // Richardson extrapolation (linear: keeps p_L V_L + p V of an isothermal chamber at fixed volume), kept
    // in the range the substep's gas can reach
    const double p_end = full.p_compressed;
    Range range = LineRange(k, step.at_mid, line, p_end);
    const Range at_next = LineRange(k, step.at_next, line, p_end);
    range.lo = std::min({range.lo, at_next.lo, p}), range.hi = std::max({range.hi, at_next.hi, p});
    next_line = std::clamp(2 * half2.line - full.line, range.lo, range.hi);
    next_p = std::clamp(2 * half2.p - full.p, range.lo, range.hi);
    supplied_here = 2 * (half.supply + half2.supply) - full.supply;
    return std::max(std::fabs(half2.line - full.line), std::fabs(half2.p - full.p));
  };
  StepDoubling(ports, volume, h, k.tolerance, attempt, [&] {
    line = next_line, p = next_p;
    supplied += supplied_here;
  });
  *line1 = line, *p1 = p;
  if (supply_mass) *supply_mass = supplied;
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
