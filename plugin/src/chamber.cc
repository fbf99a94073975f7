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

double PressureRate(const ChamberModel& k, const PortOpenings& o, double p, double volume,
                    double volume_rate) {
  // paper 000 eq. (4a); alpha on the piston-work term as in paper 001 eq. (1)
  double n = k.polytropic_index;
  return n * k.gas_rt * ChamberMassFlow(k, o, p) / volume - k.work_factor * n * p * volume_rate / volume;
}

namespace {

// Backward Euler over [a, a + s] in y = p V^(alpha n):
//   p1 = p_compressed + (s n r T / V1) Q(p1),  p_compressed = p0 (V0 / V1)^(alpha n)
// The residual is increasing in p1 (Q falls as the chamber pressure rises), so the root is
// unique and lies between p_compressed and the port pressures; Illinois regula falsi finds it.
double BackwardEulerSubstep(const ChamberModel& k, const PortOpenings& o, double p0, double v0, double v1,
                            double s) {
  double p_compressed = p0 * std::pow(v0 / v1, k.work_factor * k.polytropic_index);
  double c = s * k.polytropic_index * k.gas_rt / v1;
  auto residual = [&](double p) { return p - p_compressed - c * ChamberMassFlow(k, o, p); };
  double lo = std::min(p_compressed, k.p_exhaust), hi = std::max(p_compressed, k.p_supply);
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
  std::vector<double> ends = ports.breakpoints();
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
      p = std::clamp(p_next, std::min(k.p_exhaust, p_compressed), std::max(k.p_supply, p_compressed));
      tau = next;
      double grow = error > 0 ? 0.9 * std::sqrt(k.tolerance / error) : 4.0;
      substep = std::max(s * std::clamp(grow, 0.2, 4.0), min_substep);
    }
  }
  return p;
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
