#include "chamber_batch.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

// GCC notes that passing vectors of four doubles by value would differ between builds with and without
// AVX: every function here that does so is internal to this file (or inline, exponential.h)
#pragma GCC diagnostic ignored "-Wpsabi"

#include "exponential.h"

namespace pneumatic {

bool Batchable(const ChamberModel& k) {
  return k.flow.law == FlowLaw::kThinPlate && k.flow.table != nullptr && !(k.atmosphere_leak_area > 0);
}

#if PNEUMATIC_VECTOR_LANES  // the CMake option of that name, on x86-64 with GCC
namespace {

// Four chambers in the lanes of GCC vector types, compiled for AVX2 (StepLanes). Every operation is the
// lane-wise IEEE operation the scalar code does, in the same order (no fused multiply-adds: AVX2 alone
// does not enable them); a branch of the scalar code becomes both sides and a select (Select(m, a, b):
// a where m, else b); std::min/max/clamp/fabs are written out with their exact semantics (NaN and the
// sign of zero included); the exponentials are exponential.h's, in the lanes.
constexpr int kLanes = 4;
using Lanes = double __attribute__((vector_size(8 * kLanes)));
using Mask = std::int64_t __attribute__((vector_size(8 * kLanes)));

[[gnu::always_inline]] inline Lanes Splat(double x) { return Lanes{} + x; }
// (masks are all ones or all zeros in each lane, as comparisons give them: exponential.h's bitwise blend)
[[gnu::always_inline]] inline Lanes Select(Mask m, Lanes a, Lanes b) { return exponential::Choose(m, a, b); }
[[gnu::always_inline]] inline bool Any(Mask m) {
  for (int j = 0; j < kLanes; ++j) {
    if (m[j]) return true;
  }
  return false;
}
// std::max(a, b) = a < b ? b : a; std::min(a, b) = b < a ? b : a; std::clamp(v, lo, hi)
[[gnu::always_inline]] inline Lanes Max(Lanes a, Lanes b) { return Select(a < b, b, a); }
[[gnu::always_inline]] inline Lanes Min(Lanes a, Lanes b) { return Select(b < a, b, a); }
[[gnu::always_inline]] inline Lanes Clamp(Lanes v, Lanes lo, Lanes hi) { return Select(v < lo, lo, Select(hi < v, hi, v)); }
[[gnu::always_inline]] inline Lanes Fabs(Lanes a) { return (Lanes)((Mask)a & INT64_MAX); }
[[gnu::always_inline]] inline Lanes Sqrt(Lanes a) {
  Lanes out;
  for (int j = 0; j < kLanes; ++j) out[j] = std::sqrt(a[j]);
  return out;
}

// a lane's constants, gathered from its ChamberModel
struct Constants {
  Lanes alpha, beta, theta;                  // thin-plate law (paper 000 Appendix eqs. 11-13)
  Lanes r_min, step_inverse;                 // its table
  const ThinPlateTable* table[kLanes];
  Lanes p_supply, p_exhaust, p_atm, atmosphere_leak;
  Lanes tolerance;
};

// ThinPlateTable::Shape, lane by lane
[[gnu::always_inline]] inline Lanes Shape(const Constants& k, Lanes r, Lanes* d_shape) {
  Lanes x = (r - k.r_min) * k.step_inverse;
  // the interval: static_cast<int>(x) clamped to [0, kIntervals - 1], for x > -1 as Shape is called (and
  // any index in range for the lanes whose result is not selected)
  Lanes clamped = Min(Max(x, Splat(0.0)), Splat(ThinPlateTable::kIntervals - 1));
  Lanes c[4], index;
  for (int j = 0; j < kLanes; ++j) {
    int i = static_cast<int>(clamped[j]);
    index[j] = i;
    for (int m = 0; m < 4; ++m) c[m][j] = k.table[j]->cubic[i].c[m];
  }
  Lanes u = x - index;
  Lanes value = c[0] + u * (c[1] + u * (c[2] + u * c[3]));
  Lanes d_value = (c[1] + u * (2 * c[2] + u * (3 * c[3]))) * k.step_inverse;
  Lanes t = Max(1 - r, Splat(0.0)), root = Sqrt(t);
  *d_shape = Select(t > 0, root * d_value - value / (2 * root), Splat(0.0));
  return root * value;
}

// flow_detail::ForwardFlow of the thin-plate law, for pu >= pd
[[gnu::always_inline]] inline Lanes ForwardFlow(const Constants& k, Lanes opening, Lanes pu, Lanes pd, Lanes* d_pu, Lanes* d_pd) {
  Mask none = (pu <= 0) | (opening <= 0);
  Lanes ratio = pd / pu;
  Mask choked = pd * k.theta < pu;
  // the subsonic shape, unless no lane needs it (an exhaust port is choked above 1.9 p_exhaust)
  Lanes slope = Splat(0.0), root = Splat(0.0);
  if (Any(~(none | choked))) root = Shape(k, ratio, &slope);
  Lanes zero = Splat(0.0);
  *d_pd = Select(none | choked, zero, opening * k.alpha * slope);
  *d_pu = Select(none, zero, Select(choked, opening * k.beta, opening * k.alpha * (root - ratio * slope)));
  return Select(none, zero, Select(choked, opening * k.beta * pu, opening * k.alpha * pu * root));
}

// MassFlowAndSlope
[[gnu::always_inline]] inline Lanes MassFlowAndSlope(const Constants& k, Lanes opening, Lanes p_from, Lanes p_to, Lanes* slope_to) {
  p_from = Max(p_from, Splat(0.0));
  p_to = Max(p_to, Splat(0.0));
  Mask forward = p_from >= p_to;
  Lanes d_pu, d_pd;
  Lanes q = ForwardFlow(k, opening, Select(forward, p_from, p_to), Select(forward, p_to, p_from), &d_pu, &d_pd);
  *slope_to = Select(forward, d_pd, -d_pu);
  return Select(forward, q, -q);
}

// Port and UseChordNearThePort (chamber.cc)
struct PortFlow {
  Lanes flow, conductance;
};
[[gnu::always_inline]] inline PortFlow Port(const Constants& k, Lanes opening, Lanes p_port, Lanes p) {
  Lanes slope;
  Lanes flow = MassFlowAndSlope(k, opening, p_port, p, &slope);
  Mask open = ~(opening <= 0);
  return {Select(open, flow, Splat(0.0)), Select(open, -slope, Splat(0.0))};
}
[[gnu::always_inline]] inline void UseChordNearThePort(const Constants& k, Lanes opening, Lanes p_port, Lanes p, Lanes travel, PortFlow* port) {
  Mask near = ~((opening <= 0) | (Fabs(p_port - p) > Fabs(travel)));
  if (!Any(near)) return;
  Lanes dp = p_port - (p + travel);
  Lanes smallest = 1e-9 * p_port;
  dp = Select(Fabs(dp) < smallest, smallest, dp);
  Lanes unused;
  port->conductance = Select(near, MassFlowAndSlope(k, opening, p_port, p_port - dp, &unused) / dp, port->conductance);
}

// System<1> with no leak across the piston: the rate and its stiff linear part b
struct LinearSystem {
  Lanes b, rate;
};
[[gnu::always_inline]] inline LinearSystem System(const Constants& k, Lanes supply_opening, Lanes exhaust_opening, Lanes gain, Lanes compression,
                    Lanes p, double substep) {
  const Lanes piston_leak = Splat(0.0);
  PortFlow supply = Port(k, supply_opening, k.p_supply, p);
  PortFlow exhaust = Port(k, exhaust_opening, k.p_exhaust, p);
  Lanes flow = supply.flow + exhaust.flow + k.atmosphere_leak * (k.p_atm - p) + piston_leak * (p - p);
  Lanes travel = substep * gain * flow;
  UseChordNearThePort(k, supply_opening, k.p_supply, p, travel, &supply);
  UseChordNearThePort(k, exhaust_opening, k.p_exhaust, p, travel, &exhaust);
  Lanes conductance = supply.conductance + exhaust.conductance + k.atmosphere_leak + piston_leak;
  return {compression - gain * conductance, compression * p + gain * flow};
}

// Phi1And2 (chamber.cc): the series near 0, else from one expm1 per lane
[[gnu::always_inline]] inline void Phi1And2(Lanes x, Lanes* phi1, Lanes* phi2) {
  Lanes e = exponential::Expm1(x);
  Mask series = Fabs(x) < 1e-3;
  *phi1 = Select(series, 1 + x / 2 + x * x / 6, e / x);
  *phi2 = Select(series, 0.5 + x / 6 + x * x / 24, (e - x) / (x * x));
}

// the linearized step (LinearizedStep<1>, chamber.cc) of the four chambers in `lane`
__attribute__((target("avx2"))) void StepLanes(BatchedChamber* lane[kLanes], double h) {
  Constants k;
  Lanes p0, n, rt, exponent, open_start[2], open_end[2];
  Lanes dead_volume, area, stroke, swept, swept_rate;  // the VolumePath
  Mask held;
  for (int j = 0; j < kLanes; ++j) {
    const BatchedChamber& c = *lane[j];
    const ChamberModel& m = *c.model;
    k.alpha[j] = m.flow.alpha, k.beta[j] = m.flow.beta, k.theta[j] = m.flow.theta;
    k.table[j] = m.flow.table, k.r_min[j] = m.flow.table->r_min, k.step_inverse[j] = m.flow.table->step_inverse;
    k.p_supply[j] = m.p_supply, k.p_exhaust[j] = m.p_exhaust, k.p_atm[j] = m.p_atm;
    k.atmosphere_leak[j] = m.atmosphere_leak, k.tolerance[j] = m.tolerance;
    n[j] = m.polytropic_index, rt[j] = m.gas_rt, exponent[j] = m.work_factor * m.polytropic_index;
    held[j] = c.held ? -1 : 0;
    p0[j] = c.p0;
    dead_volume[j] = c.volume.dead_volume, area[j] = c.volume.area, stroke[j] = c.volume.stroke;
    swept[j] = c.volume.swept, swept_rate[j] = c.volume.swept_rate;
    open_start[0][j] = c.open_start.supply, open_start[1][j] = c.open_start.exhaust;
    open_end[0][j] = c.open_end.supply, open_end[1][j] = c.open_end.exhaust;
  }
  // VolumePath::At
  auto volume_at = [&](double tau) { return dead_volume + area * Clamp(swept + swept_rate * tau, Splat(0.0), stroke); };
  const Lanes v_start = volume_at(0), v_end = volume_at(h), v_mid = volume_at(h / 2);
  // the polytropic compression as a constant rate, -alpha n ln(V(h)/V(0)) / h, with Log1p's series in
  // the lanes (std::log1p beyond |x| = 1/64, lane by lane)
  const Lanes x = (v_end - v_start) / v_start;
  Lanes log1p = exponential::Log1pSeries(x);
  for (int j = 0; j < kLanes; ++j) {
    if (!(std::fabs(x[j]) <= exponential::kLog1pSeriesLimit)) log1p[j] = std::log1p(x[j]);
  }
  const Lanes log_ratio = -exponent * log1p;
  const Mask moved = v_end != v_start;
  const Lanes compression = Select(moved, log_ratio / h, Splat(0.0));
  const Lanes compressed = Select(moved, p0 * exponential::Exp(log_ratio), p0);
  // D = n r T / V at mid-step, the pressure rate per unit of mass flow
  const Lanes gain = n * rt / v_mid;
  // exponential Rosenbrock-Euler with the ETD2RK correction, as LinearizedStep
  LinearSystem start = System(k, open_start[0], open_start[1], gain, compression, p0, h);
  Lanes phi1, phi2;
  Phi1And2(start.b * h, &phi1, &phi2);
  Lanes change = phi1 * start.rate;
  // ReachableRange with no leak across the piston
  Mask to_atmosphere = k.atmosphere_leak > 0;
  Lanes lo = Min(compressed, k.p_exhaust), hi = Max(compressed, k.p_supply);
  lo = Select(to_atmosphere, Min(lo, k.p_atm), lo), hi = Select(to_atmosphere, Max(hi, k.p_atm), hi);
  Lanes predicted = Clamp(p0 + h * change, lo, hi);
  LinearSystem at_end = System(k, open_end[0], open_end[1], gain, compression, predicted, h);
  Lanes linear_change = start.b * (predicted - p0);
  Lanes missed = at_end.rate - start.rate - linear_change;
  Lanes correction = phi2 * missed;
  Lanes error = Max(Fabs(h * correction), Fabs(h / 2 * missed));
  Lanes b_start = compression - start.b, b_end = compression - at_end.b;
  Mask ok = held & (error <= k.tolerance) & (Fabs(b_end - b_start) <= kLinearizedMaxSlopeChange * Max(b_start, b_end));
  Lanes p1 = Clamp(predicted + h * correction, lo, hi);
  for (int j = 0; j < kLanes; ++j) {
    lane[j]->done = ok[j] != 0;
    if (ok[j]) lane[j]->p1 = p1[j];
  }
}

}  // namespace

bool VectorLanesAvailable() {
  // the vector lanes need AVX2 (the x86-64 processors of the last decade)
  static const bool available = __builtin_cpu_supports("avx2");
  return available;
}
#else   // built without the vector lanes: the scalar step alone
bool VectorLanesAvailable() { return false; }
#endif

void LinearizedChambers(BatchedChamber chambers[], int count, double h) {
  LinearizedChambers(chambers, count, h, VectorLanesAvailable());
}

void LinearizedChambers(BatchedChamber chambers[], int count, double h, bool in_lanes) {
  // without AVX2 (or built without the lanes), each chamber by the scalar step, with the same result
  if (!in_lanes || !VectorLanesAvailable()) {
    for (int i = 0; i < count; ++i) {
      BatchedChamber& c = chambers[i];
      LinearizedChamberStep(*c.model, c.open_start, c.open_end, c.held, c.volume, c.p0, h, &c.p1, &c.done);
    }
    return;
  }
#if PNEUMATIC_VECTOR_LANES
  BatchedChamber* lane[kLanes];
  int first = 0;
  for (; first + kLanes <= count; first += kLanes) {
    for (int j = 0; j < kLanes; ++j) lane[j] = &chambers[first + j];
    StepLanes(lane, h);
  }
  if (first == count) return;
  // fewer than four left: the spare lanes step a copy of the last chamber once more
  BatchedChamber spare = chambers[count - 1];
  for (int j = 0; j < kLanes; ++j) lane[j] = first + j < count ? &chambers[first + j] : &spare;
  StepLanes(lane, h);
#endif
}

}  // namespace pneumatic
