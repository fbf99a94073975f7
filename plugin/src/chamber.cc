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
                            double s, double piston_leak, double p_other) {
  double p_compressed = p0 * std::pow(v0 / v1, k.work_factor * k.polytropic_index);
  double c = s * k.polytropic_index * k.gas_rt / v1;
  auto residual = [&](double p) { return p - p_compressed - c * NetMassFlow(k, o, p, piston_leak, p_other); };
  Range range = ReachableRange(k, p_compressed, piston_leak, p_other);
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
                            double p0, double h, double piston_leak, double p_other) {
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
      double full = BackwardEulerSubstep(k, at_next, p, v_start, v_next, s, piston_leak, p_other);
      double half = BackwardEulerSubstep(k, at_mid, p, v_start, v_mid, s / 2, piston_leak, p_other);
      half = BackwardEulerSubstep(k, at_next, half, v_mid, v_next, s / 2, piston_leak, p_other);
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
      Range range = ReachableRange(k, p_compressed, piston_leak, p_other);
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
double Phi1(double x) { return std::fabs(x) < 1e-5 ? 1 + x / 2 + x * x / 6 : std::expm1(x) / x; }
double Phi1Slope(double x) {
  return std::fabs(x) < 1e-3 ? 0.5 + x / 3 + x * x / 8 : (std::exp(x) * (x - 1) + 1) / (x * x);
}
double Phi2(double x) { return std::fabs(x) < 1e-3 ? 0.5 + x / 6 + x * x / 24 : (std::expm1(x) - x) / (x * x); }
double Phi2Slope(double x) {
  return std::fabs(x) < 1e-2 ? 1.0 / 6 + x / 12 + x * x / 40 : (x * std::exp(x) - 2 * std::expm1(x) + x) / (x * x * x);
}

// conductance of one port at chamber pressure p: the chord G = Q(p_port -> p) / (p_port - p) >= 0,
// the project's own form. The laws' slope is infinite where the pressures meet; there the chord is
// taken over a small difference, and its large G settles the chamber at p_port within the step.
double PortConductance(const FlowLawConstants& law, double opening, double p_port, double p) {
  if (opening <= 0) return 0;
  double dp = p_port - p;
  double smallest = 1e-9 * p_port;
  if (std::fabs(dp) < smallest) dp = smallest;
  return MassFlow(law, opening, p_port, p_port - dp) / dp;
}

// a chamber's flow with frozen conductances: Q = source - conductance p (leak to the piston apart)
struct LinearFlow {
  double conductance = 0;  // kg/(s Pa)
  double source = 0;       // kg/s
};

LinearFlow Linearize(const ChamberModel& k, const PortOpenings& o, double p) {
  double supply = PortConductance(k.flow, o.supply, k.p_supply, p);
  double exhaust = PortConductance(k.flow, o.exhaust, k.p_exhaust, p);
  return {supply + exhaust + k.atmosphere_leak,
          supply * k.p_supply + exhaust * k.p_exhaust + k.atmosphere_leak * k.p_atm};
}

// dp/dt = B p + f of both chambers, with D = n r T / V (paper 000 eq. 4a with the flow linear in p)
struct LinearSystem {
  double b[2][2] = {{0, 0}, {0, 0}};
  double f[2] = {0, 0};
  double Rate(int i, const double p[2]) const { return b[i][0] * p[0] + b[i][1] * p[1] + f[i]; }
};

LinearSystem System(const ChamberModel k[2], const PortOpenings o[2], const double volume[2], double piston_leak,
                    const double p[2]) {
  LinearSystem s;
  for (int i = 0; i < 2; ++i) {
    double d = k[i].polytropic_index * k[i].gas_rt / volume[i];
    LinearFlow q = Linearize(k[i], o[i], p[i]);
    s.b[i][i] = -d * (q.conductance + piston_leak);
    s.b[i][1 - i] = d * piston_leak;
    s.f[i] = d * q.source;
  }
  return s;
}

// phi(B t) v for a function phi of the 2x2 matrix B t: phi(l2) v + phi[l1, l2] (B - l2 I) v
// (Newton's form, exact for 2x2), with the eigenvalues l1 >= l2 of B, real and <= 0 (B is similar
// to a symmetric negative semidefinite matrix); phi_slope is phi' for near-equal eigenvalues
void ApplyMatrixFunction(double (*phi)(double), double (*phi_slope)(double), const LinearSystem& s, double t,
                         const double v[2], double out[2]) {
  if (s.b[0][1] == 0 && s.b[1][0] == 0) {
    // uncoupled chambers: one scalar function each
    for (int i = 0; i < 2; ++i) out[i] = phi(s.b[i][i] * t) * v[i];
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

// (v_from / v_to)^exponent, the polytropic compression factor: a binomial series where the volumes
// are within 1 % of each other (most steps; the remainder is below 1e-16), pow otherwise
double CompressionFactor(double v_from, double v_to, double exponent) {
  double e = (v_from - v_to) / v_to;
  if (std::fabs(e) > 1e-2) return std::pow(v_from / v_to, exponent);
  static constexpr double kInverse[] = {0, 1, 1 / 2.0, 1 / 3.0, 1 / 4.0, 1 / 5.0, 1 / 6.0, 1 / 7.0, 1 / 8.0};
  double term = 1, sum = 1;
  for (int k = 1; k <= 8; ++k) {
    term *= (exponent - (k - 1)) * kInverse[k] * e;
    sum += term;
  }
  return sum;
}

// a chamber's pressure kept within what it can reach from its compressed pressure
double KeepReachable(const ChamberModel k[2], int i, const double compressed[2], double piston_leak, double p) {
  Range range = ReachableRange(k[i], compressed[i], piston_leak, compressed[1 - i]);
  return std::clamp(p, range.lo, range.hi);
}

}  // namespace

int LinearizedPressureStep(const ChamberModel k[2], const PortSchedule* ports[2], const VolumePath volume[2],
                           double piston_leak, const double p0[2], double h, double p1[2]) {
  // substeps end at every valve switching instant of either chamber
  SwitchInstants ends = MergedBreakpoints(*ports[0], *ports[1]);
  ends.push_back(h);
  const double min_substep = h / 4096;
  const double tolerance = std::min(k[0].tolerance, k[1].tolerance);
  double p[2] = {p0[0], p0[1]};
  double tau = 0, substep = h;
  int substeps = 0;
  for (double end : ends) {
    while (tau < end) {
      double next = std::min(tau + substep, end);
      if (end - next < 1e-12 * h) next = end;
      double s = next - tau, mid = tau + s / 2;
      ++substeps;
      // half the compression (exact in y = p V^(alpha n)), the flow over the whole substep, the other half
      double v_start[2], v_mid[2], v_end[2], exponent[2], compressed[2];
      PortOpenings at_mid[2];
      for (int i = 0; i < 2; ++i) {
        v_start[i] = volume[i].At(tau), v_mid[i] = volume[i].At(mid), v_end[i] = volume[i].At(next);
        exponent[i] = k[i].work_factor * k[i].polytropic_index;
        compressed[i] = v_start[i] == v_mid[i] ? p[i] : p[i] * CompressionFactor(v_start[i], v_mid[i], exponent[i]);
        at_mid[i] = ports[i]->At(mid);
      }
      // exponential Euler with the conductances frozen at the start: exact for the linear system
      LinearSystem system = System(k, at_mid, v_mid, piston_leak, compressed);
      double rate[2] = {system.Rate(0, compressed), system.Rate(1, compressed)}, change[2], flowed[2];
      ApplyMatrixFunction(Phi1, Phi1Slope, system, s, rate, change);
      for (int i = 0; i < 2; ++i) flowed[i] = KeepReachable(k, i, compressed, piston_leak, compressed[i] + s * change[i]);
      // second-order correction (ETD2RK, Cox and Matthews 2002): s phi2(B s) times the rate the frozen
      // conductances miss at the predicted end; its size is the local error estimate of the first-order step
      LinearSystem at_end = System(k, at_mid, v_mid, piston_leak, flowed);
      double missed[2], correction[2];
      for (int i = 0; i < 2; ++i) missed[i] = at_end.Rate(i, flowed) - system.Rate(i, flowed);
      ApplyMatrixFunction(Phi2, Phi2Slope, system, s, missed, correction);
      double error = std::max(std::fabs(s * correction[0]), std::fabs(s * correction[1]));
      if (!(error <= tolerance) && substep > min_substep) {
        substep = std::max(s * std::max(0.2, 0.9 * std::sqrt(tolerance / error)), min_substep);
        continue;
      }
      for (int i = 0; i < 2; ++i) flowed[i] = KeepReachable(k, i, compressed, piston_leak, flowed[i] + s * correction[i]);
      for (int i = 0; i < 2; ++i) {
        p[i] = v_mid[i] == v_end[i] ? flowed[i] : flowed[i] * CompressionFactor(v_mid[i], v_end[i], exponent[i]);
      }
      tau = next;
      double grow = error > 0 ? 0.9 * std::sqrt(tolerance / error) : 4.0;
      substep = std::max(s * std::clamp(grow, 0.2, 4.0), min_substep);
    }
  }
  p1[0] = p[0], p1[1] = p[1];
  return substeps;
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
