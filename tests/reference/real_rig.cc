// The diagnosis suite's "real rig" (see real_rig.h). Only the C++ standard library and the flow
// laws of rig_reference.h are used; each equation names its source.
#include "real_rig.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pneumatic::reference {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTimeTolerance = 1e-12;  // s: breakpoints closer than this are the same instant
constexpr double kContactRamp = 20e-6;    // m: a contact's damping grows in over this penetration

// the specific gas constant: r (A), R (B), Rg / Mm (C): docs/rigs.md
double SpecificGasConstant(const RigParams& r) {
  return r.rig == Rig::kPerChamber ? r.universal_gas_constant / r.molar_mass : r.gas_constant;
}

// mass and enthalpy flowing into a node: each flow carries its upstream gas's temperature (in-flows
// the source's, out-flows the node's), as the energy equation of Richer and Hurmuzlu (2000) needs
struct Inflow {
  double mass = 0;      // kg/s
  double enthalpy = 0;  // kg K/s: sum of Q T_upstream

  void Add(double q, double t_source, double t_node) {
    mass += q;
    enthalpy += q * (q > 0 ? t_source : t_node);
  }
};

// A flow law evaluated at the rig's temperature t_ref, corrected to its upstream gas's temperature:
// every law of docs/rigs.md passes a mass flow proportional to 1 / sqrt(T_upstream) at given pressures
// (paper 001 eq. 2, paper 000 eq. 1, ISO 6358's sqrt(T0 / T1)). q_ref > 0 flows from a to b.
double AtUpstreamTemperature(double q_ref, double t_ref, double t_a, double t_b) {
  const double t_up = q_ref > 0 ? t_a : t_b;
  return t_up == t_ref ? q_ref : q_ref * std::sqrt(t_ref / t_up);
}

// smoothstep of s clamped to [0, 1]: 3 s^2 - 2 s^3 (the suite's own opening curve)
double Smoothstep(double s) {
  s = std::clamp(s, 0.0, 1.0);
  return s * s * (3 - 2 * s);
}

// the play operator of width 2 w on input u: Krasnosel'skii and Pokrovskii's backlash operator
double Play(double y, double u, double w) { return std::clamp(y, u - w, u + w); }

// the tight spot's weight over the stroke: 1 on [from, to], raised cosines over `edge` outside
double TightSpotWeight(const TightSpot& t, double x) {
  if (x < t.from - t.edge || x > t.to + t.edge) return 0;
  if (x < t.from) return 0.5 * (1 - std::cos(kPi * (x - t.from + t.edge) / t.edge));
  if (x > t.to) return 0.5 * (1 - std::cos(kPi * (t.to + t.edge - x) / t.edge));
  return 1;
}

// s + h d over the whole state
RealRig::State Axpy(const RealRig::State& s, double h, const RealRig::State& d) {
  RealRig::State out;
  for (int i = 0; i < RealRig::kStates; ++i) out[i] = s[i] + h * d[i];
  return out;
}

}  // namespace

double SeriesRestrictionFlow(const SeriesRestriction& r, double r_gas, double t, double p1, double p2) {
  if (!(r.laminar > 0)) return 0;
  // dp = q / g + a q |q|, a = rho / (2 (C_d A)^2), rho the mean density: the suite's own form
  // (Hagen-Poiseuille in series with an orifice's incompressible loss), solved for q in the form
  // that keeps its precision at small dp: q = 2 dp / (1/g + sqrt(1/g^2 + 4 a |dp|))
  const double dp = p1 - p2;
  const double rho = (p1 + p2) / (2 * r_gas * t);
  const double a = r.orifice > 0 ? rho / (2 * r.orifice * r.orifice) : 0;
  const double b = 1 / r.laminar;
  const double q = 2 * dp / (b + std::sqrt(b * b + 4 * a * std::fabs(dp)));
  return rho * q;
}

RealRigParams NominalRealRig(Rig rig) {
  RealRigParams p;
  p.rig = DefaultParams(rig);
  p.dead_volume_P = p.dead_volume_N = p.rig.dead_volume;
  p.flow_gamma = p.rig.polytropic_index;  // docs/rigs.md uses one gamma (B) or kappa (C) for both
  return p;
}

// --- noise ---------------------------------------------------------------------------------------

// splitmix64 (Steele, Lea and Flood, OOPSLA 2014)
uint64_t NormalSource::Next() {
  uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

double NormalSource::Uniform() { return static_cast<double>(Next() >> 11) * (1.0 / 9007199254740992.0); }

// Box-Muller, both values used
double NormalSource::Normal() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  const double u1 = 1.0 - Uniform(), u2 = Uniform();
  const double radius = std::sqrt(-2 * std::log(u1));
  spare_ = radius * std::sin(2 * kPi * u2);
  has_spare_ = true;
  return radius * std::cos(2 * kPi * u2);
}

// --- the rig -------------------------------------------------------------------------------------

RealRig::RealRig(const RealRigParams& params, const Sensors& sensors, double fine_step)
    : p_(params), sensors_(sensors), fine_step_(fine_step) {
  auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("RealRig: ") + what);
  };
  const RigParams& r = p_.rig;
  require(fine_step > 0, "fine_step must be > 0");
  require(r.stroke > 0 && r.area_P > 0 && r.area_N > 0 && r.mass > 0, "stroke, areas and mass must be > 0");
  require(p_.dead_volume_P > 0 && p_.dead_volume_N > 0, "dead volumes must be > 0");
  require(r.polytropic_index >= 1, "polytropic index must be >= 1");
  require(p_.tube.segments >= 1 && p_.tube.segments <= kMaxSegments, "tube segments must be in [1, 8]");
  require(p_.tube.volume == 0 || p_.tube.restriction.laminar > 0, "a tube needs a laminar conductance");
  require(!p_.supply.on || (p_.supply.tank_volume > 0 && p_.supply.manifold_volume > 0 && p_.supply.hose.laminar > 0 &&
                            p_.supply.stall_pressure > r.exhaust_pressure && p_.supply.switch_on < p_.supply.switch_off),
          "supply: tank and manifold volumes, a hose, a stall pressure and switch_on < switch_off");
  require(p_.friction.stiction >= p_.friction.coulomb && p_.friction.bristle_stiffness > 0, "LuGre: F_s >= F_c, sigma0 > 0");
  require(p_.backlash.gap == 0 || (p_.backlash.load_fraction > 0 && p_.backlash.load_fraction < 1),
          "backlash: the load's fraction of the mass must be in (0, 1)");
  require(p_.timing.command_delay >= 0 && p_.timing.open_delay >= 0 && p_.timing.close_delay >= 0 &&
              p_.timing.open_travel >= 0 && p_.timing.close_travel >= 0 && p_.timing.voltage_lag >= 0,
          "valve timing must be >= 0");
  mass_ = r.mass + p_.added_mass;
  // at rest at mid-stroke, both chambers and tubes at the atmosphere, gas at the rig's temperature
  state_[kPP] = state_[kPN] = r.exhaust_pressure;
  state_[kVoltP] = state_[kVoltN] = 5;
  state_[kTP] = state_[kTN] = r.temperature;
  const double supply = p_.supply.on ? p_.supply.switch_off : r.supply_pressure;
  state_[kTank] = state_[kManifold] = supply;
  state_[kSensorP] = state_[kSensorN] = r.exhaust_pressure;
  state_[kSensorS] = supply;
  for (int j = 0; j < 2 * kMaxSegments; ++j) state_[kTubeP + j] = r.exhaust_pressure;
  Hold(0);
}

double RealRig::SensedPosition() const { return p_.backlash.gap > 0 ? state_[kLoadX] : state_[kX]; }

RigCommand RealRig::EffectiveCommand(double t) const {
  // the command issued last at least command_delay before t: an exact transport delay
  for (auto it = commands_.rbegin(); it != commands_.rend(); ++it) {
    if (it->first + p_.timing.command_delay <= t + kTimeTolerance) return it->second;
  }
  return RigCommand{};
}

void RealRig::Hold(double t) {
  const RigCommand c = EffectiveCommand(t);
  const RigParams& r = p_.rig;
  const ValveTiming& vt = p_.timing;
  switch (r.rig) {
    case Rig::kOnOff: {
      // the armature: it moves only once the coil has held its new state for the delay (a shorter
      // pulse is lost), then travels linearly (the suite's own form, real_rig.h ValveTiming)
      const double cmd[4] = {c.u1, c.u2, c.u3, c.u4};
      for (int i = 0; i < 4; ++i) {
        opening_[i] = std::clamp(opening_[i] + opening_rate_[i] * (t - hold_start_), 0.0, 1.0);
        const double coil = cmd[i] >= 0.5 ? 1 : 0;
        if (coil != coil_[i]) coil_[i] = coil, coil_edge_[i] = t;
        const double delay = coil_[i] > 0 ? vt.open_delay : vt.close_delay;
        if (drive_[i] != coil_[i] && t >= coil_edge_[i] + delay - kTimeTolerance) drive_[i] = coil_[i];
        const double travel = drive_[i] > 0 ? vt.open_travel : vt.close_travel;
        if (travel == 0) opening_[i] = drive_[i], opening_rate_[i] = 0;
        else if (drive_[i] > 0) opening_rate_[i] = opening_[i] < 1 ? 1 / travel : 0;
        else opening_rate_[i] = opening_[i] > 0 ? -1 / travel : 0;
      }
      break;
    }
    case Rig::kProportional: {
      // sat(u): docs/rigs.md rig B; then the play operator (hysteresis, real_rig.h)
      const double u = std::clamp(c.u, -r.voltage_limit, r.voltage_limit);
      play_u_ = Play(play_u_, u, p_.hysteresis.half_width);
      held_u_ = p_.hysteresis.half_width > 0 ? play_u_ : u;
      break;
    }
    case Rig::kPerChamber: {
      // the play operator, then a deadband of the voltage about 5 V (the valve driver's):
      // u_eff = 5 + sign(u - 5) max(|u - 5| - d, 0), the suite's own form of rig C's valve_deadband
      auto valve_input = [&](double u, double* play) {
        *play = Play(*play, u, p_.hysteresis.half_width);
        const double v = p_.hysteresis.half_width > 0 ? *play : u;
        const double d = p_.voltage_deadband;
        return d > 0 ? 5 + std::copysign(std::max(std::fabs(v - 5) - d, 0.0), v - 5) : v;
      };
      held_uP_ = valve_input(c.uP, &play_uP_);
      held_uN_ = valve_input(c.uN, &play_uN_);
      break;
    }
  }
  hold_start_ = t;
}

double RealRig::NextBreakpoint(double t, double t_end) const {
  double next = t_end;
  auto consider = [&](double b) {
    if (b > t + kTimeTolerance && b < next) next = b;
  };
  for (const auto& [issued, command] : commands_) consider(issued + p_.timing.command_delay);
  if (p_.rig.rig == Rig::kOnOff) {
    for (int i = 0; i < 4; ++i) {
      if (drive_[i] != coil_[i]) consider(coil_edge_[i] + (coil_[i] > 0 ? p_.timing.open_delay : p_.timing.close_delay));
      if (opening_rate_[i] > 0) consider(hold_start_ + (1 - opening_[i]) / opening_rate_[i]);
      if (opening_rate_[i] < 0) consider(hold_start_ + opening_[i] / -opening_rate_[i]);
    }
  }
  return next;
}

void RealRig::Advance(const RigCommand& command, double duration) {
  if (!(duration > 0)) throw std::invalid_argument("RealRig::Advance: duration must be > 0");
  commands_.push_back({time_, command});
  // a delay of at most a few rows needs a few commands back
  if (commands_.size() > 256) commands_.erase(commands_.begin(), commands_.begin() + 128);
  const double t_end = time_ + duration;
  while (time_ < t_end - kTimeTolerance) {
    Hold(time_);
    const double next = NextBreakpoint(time_, t_end);
    Integrate(next - time_);
    time_ = next;
  }
  time_ = t_end;
}

void RealRig::Integrate(double duration) {
  const int n = std::max(1, static_cast<int>(std::ceil(duration / fine_step_ - 1e-9)));
  const double h = duration / n;
  for (int i = 0; i < n; ++i) {
    const double t = time_ + i * h;
    State next = Rk4Step(state_, t, h);
    // the compressor's pressure switch (real_rig.h SupplySystem): where the tank crosses a switching
    // pressure within the step, the step is split at the crossing (linear in the step)
    if (p_.supply.on) {
      const double threshold = compressor_on_ ? p_.supply.switch_off : p_.supply.switch_on;
      const bool crosses = compressor_on_ ? next[kTank] > threshold : next[kTank] < threshold;
      if (crosses) {
        const double share = std::clamp((threshold - state_[kTank]) / (next[kTank] - state_[kTank]), 0.0, 1.0);
        const State at = Rk4Step(state_, t, share * h);
        compressor_on_ = !compressor_on_;
        next = share < 1 ? Rk4Step(at, t + share * h, (1 - share) * h) : at;
      }
    }
    state_ = next;
  }
}

// classical RK4
RealRig::State RealRig::Rk4Step(const State& s, double t, double h) const {
  const State k1 = Derivative(s, t);
  const State k2 = Derivative(Axpy(s, 0.5 * h, k1), t + 0.5 * h);
  const State k3 = Derivative(Axpy(s, 0.5 * h, k2), t + 0.5 * h);
  const State k4 = Derivative(Axpy(s, h, k3), t + h);
  State out;
  for (int i = 0; i < kStates; ++i) out[i] = s[i] + h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
  return out;
}

RealRig::State RealRig::Derivative(const State& s, double t) const {
  const RigParams& r = p_.rig;
  State d{};
  const double x = s[kX], v = s[kV];
  const double pe = r.exhaust_pressure, temp = r.temperature, k = r.polytropic_index;
  const double r_gas = SpecificGasConstant(r);
  const bool heat = p_.heat.on, tube = p_.tube.volume > 0;
  const int segments = p_.tube.segments;

  // volumes V_P = A_P (L/2 + x) + V0_P, V_N = A_N (L/2 - x) + V0_N: docs/rigs.md, a dead volume per chamber
  const double vol_P = r.area_P * (0.5 * r.stroke + x) + p_.dead_volume_P;
  const double vol_N = r.area_N * (0.5 * r.stroke - x) + p_.dead_volume_N;
  const double dvol_P = r.area_P * v, dvol_N = -r.area_N * v;
  const double temp_P = heat ? s[kTP] : temp, temp_N = heat ? s[kTN] : temp;
  // the valves' supply: the manifold (supply_drop) or docs/rigs.md's constant P_S
  const double ps = p_.supply.on ? s[kManifold] : r.supply_pressure;
  // each valve's port: the tube's first segment, or the chamber itself
  const double port_P = tube ? s[kTubeP] : s[kPP], port_N = tube ? s[kTubeN] : s[kPN];
  const double tport_P = tube ? temp : temp_P, tport_N = tube ? temp : temp_N;
  // the valves' flow gain as their coils warm: 1 - drop (1 - exp(-t / tau)) (real_rig.h FlowGainDrift)
  const double gain = p_.drift.drop > 0 ? 1 - p_.drift.drop * (1 - std::exp(-t / p_.drift.time_constant)) : 1;

  Inflow into_port_P, into_port_N;
  double drawn = 0;  // kg/s from the supply
  // q_ref > 0 flowing from the supply into a port node
  auto supply_to = [&](Inflow* node, double q_ref, double t_node) {
    const double q = AtUpstreamTemperature(q_ref, temp, temp, t_node);
    node->Add(q, temp, t_node);
    drawn += q;
  };
  // q_ref > 0 flowing from a port node to the exhaust
  auto to_exhaust = [&](Inflow* node, double q_ref, double t_node) {
    node->Add(-AtUpstreamTemperature(q_ref, temp, t_node, temp), temp, t_node);
  };
  switch (r.rig) {
    case Rig::kOnOff: {
      // four on/off valves, Q_P = U1 Q(P_S, P_P) - U2 Q(P_P, P_E), Q_N likewise: docs/rigs.md rig A;
      // paper 002 eqs. (3), (4); U_i the armature's opening fraction (real_rig.h ValveTiming)
      double open[4];
      for (int i = 0; i < 4; ++i) {
        open[i] = std::clamp(opening_[i] + opening_rate_[i] * (t - hold_start_), 0.0, 1.0);
      }
      auto q = [&](double pu, double pd) { return FlowIso6358(r.valve_conductance * gain, r.valve_critical_ratio, pu, pd); };
      if (open[0] > 0) supply_to(&into_port_P, open[0] * q(ps, port_P), tport_P);
      if (open[1] > 0) to_exhaust(&into_port_P, open[1] * q(port_P, pe), tport_P);
      if (open[2] > 0) supply_to(&into_port_N, open[2] * q(ps, port_N), tport_N);
      if (open[3] > 0) to_exhaust(&into_port_N, open[3] * q(port_N, pe), tport_N);
      break;
    }
    case Rig::kProportional: {
      // spool: docs/rigs.md's lag dx_v/dt = (k_v u - x_v) / tau_v, or the suite's second-order spool
      const double target = r.spool_gain * held_u_;
      const ValveTiming& vt = p_.timing;
      if (vt.spool_natural_frequency > 0) {
        const double w = vt.spool_natural_frequency;
        d[kSpool] = s[kSpoolRate];
        d[kSpoolRate] = w * w * (target - s[kSpool]) - 2 * vt.spool_damping_ratio * w * s[kSpoolRate];
      } else {
        d[kSpool] = (target - s[kSpool]) / r.spool_time_constant;
      }
      // deadband x_eff = sign(x_v) max(|x_v| - db k_v 5 V, 0): rig_reference.cc (paper 001)
      const double half_band = r.spool_deadband * r.spool_gain * r.voltage_limit;
      const double x_eff = std::copysign(std::max(std::fabs(s[kSpool]) - half_band, 0.0), s[kSpool]);
      // a = C_d w |x_v|, m = C1 a pu / sqrt(T) psi: docs/rigs.md rig B; paper 001 eq. (2)
      const double area = r.discharge_coefficient * r.area_gradient * std::fabs(x_eff) * gain;
      auto m = [&](double pu, double pd) {
        return FlowSanville(area, temp, p_.flow_gamma, r.gas_constant, r.spool_critical_ratio, pu, pd);
      };
      if (area > 0 && x_eff >= 0) {
        supply_to(&into_port_P, m(ps, port_P), tport_P);
        to_exhaust(&into_port_N, m(port_N, pe), tport_N);
      } else if (area > 0) {
        to_exhaust(&into_port_P, m(port_P, pe), tport_P);
        supply_to(&into_port_N, m(ps, port_N), tport_N);
      }
      break;
    }
    case Rig::kPerChamber: {
      // each valve's voltage, behind the suite's first-order lag when valve_delay has one
      const double lag = p_.timing.voltage_lag;
      const double u_P = lag > 0 ? s[kVoltP] : held_uP_, u_N = lag > 0 ? s[kVoltN] : held_uN_;
      if (lag > 0) {
        d[kVoltP] = (held_uP_ - s[kVoltP]) / lag;
        d[kVoltN] = (held_uN_ - s[kVoltN]) / lag;
      }
      // Q = a_c(u) phi(P_c, p) - a_r(u) phi(p, P_r): docs/rigs.md rig C; paper 000 eqs. (1)-(3)
      auto phi = [&](double area, double pu, double pd) {
        return FlowThinPlate(area * gain, p_.flow_gamma, r.discharge_coefficient, r.molar_mass, r.universal_gas_constant,
                             r.compressibility, temp, pu, pd);
      };
      supply_to(&into_port_P, phi(SupplyPortArea(r, u_P), ps, port_P), tport_P);
      to_exhaust(&into_port_P, phi(ExhaustPortArea(r, u_P), port_P, pe), tport_P);
      supply_to(&into_port_N, phi(SupplyPortArea(r, u_N), ps, port_N), tport_N);
      to_exhaust(&into_port_N, phi(ExhaustPortArea(r, u_N), port_N, pe), tport_N);
      break;
    }
  }

  Inflow into_P, into_N;
  if (tube) {
    // the tube's segments, each a rigid volume of the chambers' polytropic gas,
    // dp_j/dt = k r T / V_j (Q_in - Q_out) (docs/rigs.md's chamber law at a fixed volume), joined by
    // 1/n of the tube's restriction (real_rig.h Tube)
    SeriesRestriction segment = p_.tube.restriction;
    segment.laminar *= segments;
    segment.orifice *= std::sqrt(static_cast<double>(segments));
    const double per_pressure = k * r_gas * temp / (p_.tube.volume / segments);
    auto line = [&](int first, const Inflow& port, double chamber_p, double chamber_t, Inflow* chamber) {
      double in = port.mass;
      for (int j = 0; j < segments; ++j) {
        const double downstream = j + 1 < segments ? s[first + j + 1] : chamber_p;
        const double q = AtUpstreamTemperature(SeriesRestrictionFlow(segment, r_gas, temp, s[first + j], downstream), temp,
                                               temp, j + 1 < segments ? temp : chamber_t);
        d[first + j] = per_pressure * (in - q);
        in = q;
      }
      chamber->Add(in, temp, chamber_t);
    };
    line(kTubeP, into_port_P, s[kPP], temp_P, &into_P);
    line(kTubeN, into_port_N, s[kPN], temp_N, &into_N);
  } else {
    into_P = into_port_P;
    into_N = into_port_N;
  }

  // leakage across the piston and from P to the atmosphere (real_rig.h Leakage), the density at
  // the upstream gas's temperature
  const Leakage& leak = p_.leakage;
  if (leak.piston.laminar > 0) {
    const double q = SeriesRestrictionFlow(leak.piston, r_gas, s[kPP] >= s[kPN] ? temp_P : temp_N, s[kPP], s[kPN]);
    into_P.Add(-q, temp_N, temp_P);
    into_N.Add(q, temp_P, temp_N);
  }
  if (leak.atmosphere_P.laminar > 0) {
    into_P.Add(-SeriesRestrictionFlow(leak.atmosphere_P, r_gas, s[kPP] >= pe ? temp_P : temp, s[kPP], pe), temp, temp_P);
  }
  // the cracking leak: ISO 6358 (b = 0.5) with a conductance opening above the cracking pressure
  const CrackingLeak& crack = p_.cracking_leak;
  if (crack.conductance > 0) {
    const double c = crack.conductance * Smoothstep((s[kPP] - crack.cracking_pressure) / crack.opening);
    if (c > 0) into_P.Add(-AtUpstreamTemperature(FlowIso6358(c, 0.5, s[kPP], pe), temp, temp_P, temp), temp, temp_P);
  }

  // chambers
  if (!heat) {
    // dp/dt = k r T / V Q - k p / V dV/dt: docs/rigs.md rig A (paper 002 eq. 1), rig C (paper 000 eq. 4);
    // rig B with its work factor alpha on the second term (paper 001 eq. 1)
    const double work = r.rig == Rig::kProportional ? r.work_factor : 1;
    d[kPP] = k * r_gas * temp / vol_P * into_P.mass - work * k * s[kPP] / vol_P * dvol_P;
    d[kPN] = k * r_gas * temp / vol_N * into_N.mass - work * k * s[kPN] / vol_N * dvol_N;
  } else {
    // energy equation of an open chamber with wall heat (Richer and Hurmuzlu 2000, eqs. 11-12):
    // dp/dt = g r / V sum(Q T_up) - g p / V dV/dt + (g - 1) / V h A_w (T_w - T),
    // dT/dt = T / (p V) (V dp/dt + p dV/dt - r T Q); A_w = 2 A + perimeter (length + V0 / A) (real_rig.h)
    const double g = p_.heat.heat_capacity_ratio;
    const double t_wall = p_.heat.wall_temperature > 0 ? p_.heat.wall_temperature : temp;
    const double perimeter = 2 * std::sqrt(kPi * r.area_P);
    auto chamber = [&](double p, double t_gas, double vol, double dvol, double area, double length, double dead,
                       const Inflow& in, double* dp, double* dt) {
      const double wall = 2 * area + perimeter * (length + dead / area);
      const double q_wall = p_.heat.coefficient * wall * (t_wall - t_gas);
      *dp = g * r_gas / vol * in.enthalpy - g * p / vol * dvol + (g - 1) / vol * q_wall;
      *dt = t_gas / (p * vol) * (vol * *dp + p * dvol - r_gas * t_gas * in.mass);
    };
    chamber(s[kPP], s[kTP], vol_P, dvol_P, r.area_P, 0.5 * r.stroke + x, p_.dead_volume_P, into_P, &d[kPP], &d[kTP]);
    chamber(s[kPN], s[kTN], vol_N, dvol_N, r.area_N, 0.5 * r.stroke - x, p_.dead_volume_N, into_N, &d[kPN], &d[kTN]);
  }

  // supply: tank dp/dt = r T / V_t (Q_compressor - Q_hose), manifold dp/dt = r T / V_m (Q_hose -
  // Q_drawn), isothermal; the compressor's flow falls linearly to 0 at its stall pressure (real_rig.h)
  if (p_.supply.on) {
    const SupplySystem& sup = p_.supply;
    const double hose = SeriesRestrictionFlow(sup.hose, r_gas, temp, s[kTank], s[kManifold]);
    const double compressor =
        compressor_on_ ? sup.compressor_flow * std::max(0.0, (sup.stall_pressure - s[kTank]) / (sup.stall_pressure - pe)) : 0;
    d[kTank] = r_gas * temp / sup.tank_volume * (compressor - hose);
    d[kManifold] = r_gas * temp / sup.manifold_volume * (hose - drawn);
  }

  // mechanics: M dv/dt = A (P_P - P_N) - b v (docs/rigs.md rigs A, B; equal areas) or
  // A_P (p_P - P_r) - A_N (p_N - P_r) - b v (rig C), plus the effects' forces
  const double pressure_force = r.rig == Rig::kPerChamber
                                    ? r.area_P * (s[kPP] - pe) - r.area_N * (s[kPN] - pe)
                                    : r.area_P * (s[kPP] - s[kPN]);
  const Backlash& bl = p_.backlash;
  const double piston_mass = bl.gap > 0 ? mass_ * (1 - bl.load_fraction) : mass_;
  const double piston_damping = bl.gap > 0 ? r.friction * (1 - bl.load_damping_fraction) : r.friction;
  double force = pressure_force - piston_damping * v;
  const LuGreFriction& f = p_.friction;
  if (f.on) {
    // LuGre: g(v) = F_c + (F_s - F_c) exp(-|v / v_s|^delta), dz/dt = v - sigma0 |v| z / g(v),
    // F = sigma0 z + sigma1(v) dz/dt + sigma2 v, sigma1(v) = sigma1 exp(-(v / v_d)^2):
    // Canudas de Wit et al. 1995 eqs. (1)-(4) and (8); the generalised Stribeck exponent delta
    const double stribeck = f.coulomb + (f.stiction - f.coulomb) * std::exp(-std::pow(std::fabs(v / f.stribeck_velocity), f.stribeck_exponent));
    const double dz = v - f.bristle_stiffness * std::fabs(v) * s[kZ] / stribeck;
    const double sigma1 = (f.bristle_damping > 0 ? f.bristle_damping : 2 * std::sqrt(f.bristle_stiffness * mass_)) *
                          std::exp(-(v / f.damping_velocity) * (v / f.damping_velocity));
    d[kZ] = dz;
    force -= f.bristle_stiffness * s[kZ] + sigma1 * dz + f.viscous * v;
  }
  if (p_.tight_spot.force > 0) {
    // the tight spot: F w(x) tanh(v / v_eps) (real_rig.h TightSpot)
    force -= p_.tight_spot.force * TightSpotWeight(p_.tight_spot, x) * std::tanh(v / p_.tight_spot.velocity);
  }
  if (p_.spring.stiffness > 0 && x > p_.spring.from) force -= p_.spring.stiffness * (x - p_.spring.from);
  // end stops at +-stroke/2: a stiff spring with damping at 0.7 of critical, pushing only; the
  // damping grows in over the first kContactRamp of penetration, so that the force is continuous
  // at the touch (a damper acting at once would jump by c v there: a first-order error in the step)
  const double half = 0.5 * r.stroke;
  const double stop_damping = 1.4 * std::sqrt(p_.end_stop_stiffness * mass_);
  if (x > half) {
    const double pen = x - half;
    force += std::min(0.0, -p_.end_stop_stiffness * pen - stop_damping * Smoothstep(pen / kContactRamp) * v);
  }
  if (x < -half) {
    const double pen = -half - x;
    force += std::max(0.0, p_.end_stop_stiffness * pen - stop_damping * Smoothstep(pen / kContactRamp) * v);
  }
  if (bl.gap > 0) {
    // the load behind the play: contact force k_c (|x - x_L| - gap/2) + c_c (v - v_L) at either end,
    // pushing only, the damping grown in as at the end stops (real_rig.h Backlash)
    const double load_mass = mass_ * bl.load_fraction;
    const double w = 2 * kPi * bl.contact_frequency;
    const double k_c = load_mass * w * w, c_c = 2 * bl.contact_damping_ratio * std::sqrt(k_c * load_mass);
    const double gap = x - s[kLoadX], relative_v = v - s[kLoadV];
    double contact = 0;
    if (gap > 0.5 * bl.gap) {
      const double pen = gap - 0.5 * bl.gap;
      contact = std::max(0.0, k_c * pen + c_c * Smoothstep(pen / kContactRamp) * relative_v);
    }
    if (gap < -0.5 * bl.gap) {
      const double pen = -0.5 * bl.gap - gap;
      contact = std::min(0.0, -k_c * pen + c_c * Smoothstep(pen / kContactRamp) * relative_v);
    }
    d[kLoadX] = s[kLoadV];
    d[kLoadV] = (contact - r.friction * bl.load_damping_fraction * s[kLoadV]) / load_mass;
    force -= contact;
  }
  d[kX] = v;
  d[kV] = force / piston_mass;

  // the pressure sensors' first-order lag (real_rig.h Sensors)
  if (sensors_.pressure_lag > 0) {
    const double supply_true = p_.supply.on ? s[kTank] : r.supply_pressure;
    d[kSensorP] = (s[kPP] - s[kSensorP]) / sensors_.pressure_lag;
    d[kSensorN] = (s[kPN] - s[kSensorN]) / sensors_.pressure_lag;
    d[kSensorS] = (supply_true - s[kSensorS]) / sensors_.pressure_lag;
  }
  return d;
}

Reading RealRig::Read(NormalSource* noise) const {
  const RigParams& r = p_.rig;
  const bool lag = sensors_.pressure_lag > 0;
  Reading out;
  out.p_P = lag ? state_[kSensorP] : state_[kPP];
  out.p_N = lag ? state_[kSensorN] : state_[kPN];
  out.p_S = lag ? state_[kSensorS] : p_.supply.on ? state_[kTank] : r.supply_pressure;
  out.x = SensedPosition();
  // sensor_bias: zero + offset + gain (s - zero), zero = the atmosphere for a pressure, 0 for x
  auto bias = [&](double value, double zero) { return zero + sensors_.offset + sensors_.gain * (value - zero); };
  if (sensors_.biased == "p_P") out.p_P = bias(out.p_P, r.exhaust_pressure);
  if (sensors_.biased == "p_N") out.p_N = bias(out.p_N, r.exhaust_pressure);
  if (sensors_.biased == "x") out.x = bias(out.x, 0);
  // noise, drawn in a fixed order, then the position encoder's quantisation
  if (noise) {
    out.p_P += sensors_.noise_pressure * noise->Normal();
    out.p_N += sensors_.noise_pressure * noise->Normal();
    out.x += sensors_.noise_position * noise->Normal();
    out.p_S += sensors_.noise_pressure * noise->Normal();
  }
  if (sensors_.position_quantum > 0) out.x = sensors_.position_quantum * std::round(out.x / sensors_.position_quantum);
  return out;
}

}  // namespace pneumatic::reference
