// Independent reference implementation of docs/rigs.md (see rig_reference.h).
// Written straight from docs/rigs.md; only the C++ standard library is used.
#include "rig_reference.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <utility>

namespace pneumatic::reference {
namespace {

constexpr double kPi = 3.14159265358979323846;

// docs/rigs.md "every flow law is written for Pu >= Pd ... Q(Pu, Pd) = -Q(Pd, Pu)"
template <typename Law>
double Reversible(double pu, double pd, Law law) {
  if (pu >= pd) return law(pu, pd);
  return -law(pd, pu);
}

// smooth max of paper 000 eq. (3): smax(y) = (sqrt(y^2 + 1) + y) / 2, y in mm^2
double Smax(double y) { return 0.5 * (std::sqrt(y * y + 1.0) + y); }

}  // namespace

RigParams DefaultParams(Rig rig) {
  RigParams p;
  p.rig = rig;
  switch (rig) {
    // docs/rigs.md rig A table (papers 002, 003)
    case Rig::kOnOff:
      p.stroke = 0.1;
      p.area_P = p.area_N = 1.814e-4;
      p.dead_volume = 2.0e-6;
      p.mass = 0.9;
      p.friction = 50.0;
      p.supply_pressure = 3.0e5;
      p.exhaust_pressure = 1.0e5;
      p.temperature = 296.0;
      p.gas_constant = 287.0;
      p.polytropic_index = 1.2;
      p.valve_conductance = 3.4e-9;
      p.valve_critical_ratio = 0.433;
      p.control_period = 2e-3;
      break;
    // docs/rigs.md rig B table (paper 001)
    case Rig::kProportional:
      p.stroke = 0.5;
      p.area_P = p.area_N = 10.6e-4;
      p.dead_volume = 1.0e-5;
      p.mass = 1.91;
      p.friction = 70.0;
      p.supply_pressure = 5.0e5;
      p.exhaust_pressure = 1.0e5;
      p.gas_constant = 287.0;
      p.temperature = 300.0;
      p.polytropic_index = 1.4;
      p.work_factor = 0.89;
      p.discharge_coefficient = 0.7;
      p.area_gradient = 0.0226;
      p.spool_gain = 2.5e-4;
      p.spool_time_constant = 4.2e-3;
      p.spool_critical_ratio = 0.2;
      p.voltage_limit = 5.0;
      p.control_period = 1e-3;
      break;
    // docs/rigs.md rig C table (paper 000)
    case Rig::kPerChamber:
      p.stroke = 0.1;
      p.area_P = 7.854e-5;
      p.area_N = 6.597e-5;
      p.dead_volume = 1.0e-6;
      p.mass = 0.5;
      p.friction = 20.0;
      p.supply_pressure = 6.2e5;
      p.exhaust_pressure = 1.0e5;
      p.temperature = 293.0;
      p.polytropic_index = 1.4;
      p.discharge_coefficient = 0.72;
      p.molar_mass = 0.029;
      p.universal_gas_constant = 8.31;
      p.compressibility = 0.99;
      p.area_per_volt = 2e-6;  // 2 mm^2/V
      p.supply_seal_voltage = 5.3;
      p.exhaust_seal_voltage = 4.7;
      p.supply_leak_area = 0.05e-6;
      p.exhaust_leak_area = 0.05e-6;
      p.control_period = 10e-3;
      break;
  }
  return p;
}

double ControlPeriod(Rig rig) { return DefaultParams(rig).control_period; }

// iso 6358 valve: docs/rigs.md rig A; paper 002 eq. (4)
double FlowIso6358(double c_val, double b_crit, double pu, double pd) {
  return Reversible(pu, pd, [&](double hi, double lo) {
    if (hi <= 0.0) return 0.0;
    const double ratio = lo / hi;
    if (ratio <= b_crit) return c_val * hi;
    const double s = (ratio - b_crit) / (1.0 - b_crit);
    return c_val * hi * std::sqrt(std::max(0.0, 1.0 - s * s));
  });
}

namespace {

// c1 = sqrt(g/R (2/(g+1))^((g+1)/(g-1))): docs/rigs.md rig B; paper 001 eq. (2)
double SanvilleC1(double gamma, double gas_constant) {
  return std::sqrt(gamma / gas_constant *
                   std::pow(2.0 / (gamma + 1.0), (gamma + 1.0) / (gamma - 1.0)));
}

// m = c1 a pu / sqrt(T) psi(pd/pu): docs/rigs.md rig B; paper 001 eq. (2)
double Sanville(double c1, double area, double sqrt_t, double p_cr, double pu, double pd) {
  return Reversible(pu, pd, [&](double hi, double lo) {
    if (hi <= 0.0) return 0.0;
    const double ratio = lo / hi;
    double psi = 1.0;
    if (ratio > p_cr) {
      const double s = (ratio - p_cr) / (1.0 - p_cr);
      psi = std::sqrt(std::max(0.0, 1.0 - s * s));
    }
    return c1 * area * hi / sqrt_t * psi;
  });
}

// thin-plate constants alpha, beta, theta: docs/rigs.md rig C; paper 000 Appendix
struct ThinPlate {
  double alpha = 0, beta = 0, theta = 0, inv_kappa = 0;

  ThinPlate() = default;
  ThinPlate(double kappa, double discharge, double molar_mass, double universal_gas_constant,
            double compressibility, double temperature) {
    const double m_zrt = molar_mass / (compressibility * universal_gas_constant * temperature);
    alpha = discharge * std::sqrt(2.0 * m_zrt * kappa / (kappa - 1.0));
    beta = discharge * std::sqrt(kappa * m_zrt *
                                 std::pow(2.0 / (kappa + 1.0), (kappa + 1.0) / (kappa - 1.0)));
    theta = std::pow((kappa + 1.0) / 2.0, kappa / (kappa - 1.0));
    inv_kappa = 1.0 / kappa;
  }
  explicit ThinPlate(const RigParams& p)
      : ThinPlate(p.polytropic_index, p.discharge_coefficient, p.molar_mass,
                  p.universal_gas_constant, p.compressibility, p.temperature) {}

  // phi(pu, pd), kg/(s m^2): z(pu, pd) for pu >= pd, -z(pd, pu) otherwise (paper 000 eq. 1)
  double Phi(double pu, double pd) const {
    return Reversible(pu, pd, [&](double hi, double lo) {
      if (hi <= 0.0) return 0.0;
      if (lo <= 0.0 || hi / lo > theta) return beta * hi;  // choked
      // (lo/hi)^(2/k) - (lo/hi)^((k+1)/k) = q^2 - r q with q = r^(1/k)
      const double r = lo / hi;
      const double q = std::pow(r, inv_kappa);
      return alpha * hi * std::sqrt(std::max(0.0, q * q - r * q));
    });
  }
};

}  // namespace

// sanville orifice: docs/rigs.md rig B; paper 001 eq. (2)
double FlowSanville(double area, double temperature, double gamma, double gas_constant,
                    double p_cr, double pu, double pd) {
  return Sanville(SanvilleC1(gamma, gas_constant), area, std::sqrt(temperature), p_cr, pu, pd);
}

// thin plate: docs/rigs.md rig C; paper 000 eq. (1) and Appendix
double FlowThinPlate(double area, double kappa, double discharge, double molar_mass,
                     double universal_gas_constant, double compressibility, double temperature,
                     double pu, double pd) {
  const ThinPlate tp(kappa, discharge, molar_mass, universal_gas_constant, compressibility,
                     temperature);
  return area * tp.Phi(pu, pd);
}

// port area: docs/rigs.md rig C; paper 000 eq. (3), smax in mm^2
double ValveAreaPaper000(double opening, double leak) {
  const double leak_mm2 = leak * 1e6;
  return (leak_mm2 + Smax(opening * 1e6 - leak_mm2)) * 1e-6;
}

// a_c(u) = L_c + smax((u - U_c) B - L_c); docs/rigs.md rig C
double SupplyPortArea(const RigParams& p, double u) {
  return ValveAreaPaper000((u - p.supply_seal_voltage) * p.area_per_volt, p.supply_leak_area);
}

// a_r(u) = L_r + smax((U_r - u) B - L_r); docs/rigs.md rig C
double ExhaustPortArea(const RigParams& p, double u) {
  return ValveAreaPaper000((p.exhaust_seal_voltage - u) * p.area_per_volt, p.exhaust_leak_area);
}

// volumes: docs/rigs.md "V_P = A (l/2 + x) + V0, V_N = A (l/2 - x) + V0" (A_P, A_N for rig C)
double ChamberVolumeP(const RigParams& p, double x) {
  return p.area_P * (0.5 * p.stroke + x) + p.dead_volume;
}
double ChamberVolumeN(const RigParams& p, double x) {
  return p.area_N * (0.5 * p.stroke - x) + p.dead_volume;
}

namespace {

// what stays constant while a command is held, hoisted out of the RK4 loop (same arithmetic)
struct Held {
  ThinPlate thin_plate;            // rig C constants
  double a_cP, a_rP, a_cN, a_rN;   // rig C port areas, m^2
  double c1, sqrt_t;               // rig B orifice constant and sqrt(T)
  double u;                        // rig B command saturated at +-5 V

  Held(const RigParams& p, const RigCommand& cmd) {
    if (p.rig == Rig::kPerChamber) thin_plate = ThinPlate(p);
    a_cP = SupplyPortArea(p, cmd.uP);
    a_rP = ExhaustPortArea(p, cmd.uP);
    a_cN = SupplyPortArea(p, cmd.uN);
    a_rN = ExhaustPortArea(p, cmd.uN);
    c1 = p.rig == Rig::kProportional ? SanvilleC1(p.polytropic_index, p.gas_constant) : 0.0;
    sqrt_t = std::sqrt(p.temperature);
    u = std::clamp(cmd.u, -p.voltage_limit, p.voltage_limit);
  }
};

RigState HeldDerivative(const RigParams& p, const Held& h, const RigState& s,
                        const RigCommand& cmd) {
  const double vp = ChamberVolumeP(p, s.x);
  const double vn = ChamberVolumeN(p, s.x);
  const double ps = p.supply_pressure;
  const double pe = p.exhaust_pressure;
  const double k = p.polytropic_index;
  RigState d;
  d.x = s.v;
  d.spool = 0.0;
  switch (p.rig) {
    case Rig::kOnOff: {
      // valve flows: docs/rigs.md rig A; paper 002 eq. (3), (4)
      auto q = [&](double pu, double pd) {
        return FlowIso6358(p.valve_conductance, p.valve_critical_ratio, pu, pd);
      };
      const double q_p = cmd.u1 * q(ps, s.p_P) - cmd.u2 * q(s.p_P, pe);
      const double q_n = cmd.u3 * q(ps, s.p_N) - cmd.u4 * q(s.p_N, pe);
      // chambers: docs/rigs.md rig A; paper 002 eq. (1)
      const double rt = p.gas_constant * p.temperature;
      d.p_P = k / vp * (rt * q_p - p.area_P * s.p_P * s.v);
      d.p_N = k / vn * (rt * q_n + p.area_N * s.p_N * s.v);
      // piston: docs/rigs.md rig A; paper 002 eq. (5)
      d.v = (p.area_P * (s.p_P - s.p_N) - p.friction * s.v) / p.mass;
      break;
    }
    case Rig::kProportional: {
      // spool lag on the saturated command: docs/rigs.md rig B; paper 001 eq. (1)
      d.spool = (p.spool_gain * h.u - s.spool) / p.spool_time_constant;
      // optional deadband (paper 001, not nominal): x_eff = sign(x_v) max(|x_v| - db k_v 5 V, 0)
      const double half_band = p.spool_deadband * p.spool_gain * p.voltage_limit;
      const double x_eff = std::copysign(std::max(std::fabs(s.spool) - half_band, 0.0), s.spool);
      // orifice flows, a = C_d w |x_v|: docs/rigs.md rig B; paper 001 eq. (2)
      const double a = p.discharge_coefficient * p.area_gradient * std::fabs(x_eff);
      auto m = [&](double pu, double pd) {
        return Sanville(h.c1, a, h.sqrt_t, p.spool_critical_ratio, pu, pd);
      };
      double q_p, q_n;
      if (x_eff >= 0.0) {
        q_p = m(ps, s.p_P);
        q_n = -m(s.p_N, pe);
      } else {
        q_p = -m(s.p_P, pe);
        q_n = m(ps, s.p_N);
      }
      // chambers, alpha on the piston-work term only: docs/rigs.md rig B; paper 001 eq. (1)
      const double grt = k * p.gas_constant * p.temperature;
      d.p_P = grt / vp * q_p - p.work_factor * k * s.p_P * p.area_P / vp * s.v;
      d.p_N = grt / vn * q_n + p.work_factor * k * s.p_N * p.area_N / vn * s.v;
      // piston: docs/rigs.md rig B; paper 001 eq. (1)
      d.v = (p.area_P * (s.p_P - s.p_N) - p.friction * s.v) / p.mass;
      break;
    }
    case Rig::kPerChamber: {
      // port flows Q = a_c phi(P_c, p) - a_r phi(p, P_r): docs/rigs.md rig C; paper 000 eq. (1)-(3)
      const ThinPlate& tp = h.thin_plate;
      const double q_p = h.a_cP * tp.Phi(ps, s.p_P) - h.a_rP * tp.Phi(s.p_P, pe);
      const double q_n = h.a_cN * tp.Phi(ps, s.p_N) - h.a_rN * tp.Phi(s.p_N, pe);
      // chambers, r = Rg/Mm, dV_P/dt = A_P v, dV_N/dt = -A_N v: docs/rigs.md rig C; paper 000 eq. (4)
      const double krt = k * p.universal_gas_constant / p.molar_mass * p.temperature;
      d.p_P = krt / vp * q_p - k * (p.area_P * s.v) / vp * s.p_P;
      d.p_N = krt / vn * q_n - k * (-p.area_N * s.v) / vn * s.p_N;
      // piston, gauge pressures on unequal areas: docs/rigs.md rig C
      d.v = (p.area_P * (s.p_P - pe) - p.area_N * (s.p_N - pe) - p.friction * s.v) / p.mass;
      break;
    }
  }
  return d;
}

// s + h d, field by field
RigState Axpy(const RigState& s, double h, const RigState& d) {
  return {s.x + h * d.x, s.v + h * d.v, s.p_P + h * d.p_P, s.p_N + h * d.p_N,
          s.spool + h * d.spool};
}

// one classical RK4 step of length dt
RigState Rk4Step(const RigParams& p, const Held& h, const RigState& s, const RigCommand& cmd,
                 double dt) {
  const RigState k1 = HeldDerivative(p, h, s, cmd);
  const RigState k2 = HeldDerivative(p, h, Axpy(s, 0.5 * dt, k1), cmd);
  const RigState k3 = HeldDerivative(p, h, Axpy(s, 0.5 * dt, k2), cmd);
  const RigState k4 = HeldDerivative(p, h, Axpy(s, dt, k3), cmd);
  const double w = dt / 6.0;
  return {s.x + w * (k1.x + 2 * k2.x + 2 * k3.x + k4.x),
          s.v + w * (k1.v + 2 * k2.v + 2 * k3.v + k4.v),
          s.p_P + w * (k1.p_P + 2 * k2.p_P + 2 * k3.p_P + k4.p_P),
          s.p_N + w * (k1.p_N + 2 * k2.p_N + 2 * k3.p_N + k4.p_N),
          s.spool + w * (k1.spool + 2 * k2.spool + 2 * k3.spool + k4.spool)};
}

}  // namespace

RigState Derivative(const RigParams& p, const RigState& s, const RigCommand& cmd) {
  return HeldDerivative(p, Held(p, cmd), s, cmd);
}

RigState Integrate(const RigParams& p, RigState s, const RigCommand& cmd, double duration,
                   double fine_dt) {
  if (!(fine_dt > 0.0)) throw std::invalid_argument("Integrate: fine_dt must be > 0");
  if (!(duration > 0.0)) return s;
  // n steps: n - 1 full ones, the last one shortened to end exactly at `duration`
  // (the 1e-9 tolerance keeps 0.002 / 1e-6 from rounding up to 2001 steps)
  const auto n = static_cast<std::size_t>(std::max(1.0, std::ceil(duration / fine_dt - 1e-9)));
  const Held held(p, cmd);
  for (std::size_t i = 0; i + 1 < n; ++i) s = Rk4Step(p, held, s, cmd, fine_dt);
  return Rk4Step(p, held, s, cmd, duration - static_cast<double>(n - 1) * fine_dt);
}

std::vector<Sample> Simulate(const RigParams& p, const RigState& initial,
                             const std::vector<RigCommand>& commands, double period,
                             double fine_dt) {
  std::vector<Sample> out;
  out.reserve(commands.size());
  RigState s = initial;
  for (std::size_t k = 0; k < commands.size(); ++k) {
    // log semantics: the state at k period, before commands[k] acts
    out.push_back({static_cast<double>(k) * period, commands[k], s});
    s = Integrate(p, s, commands[k], period, fine_dt);
  }
  return out;
}

namespace {

// numerical recipes LCG; the high bits give a uniform in [0, 1)
class Lcg {
 public:
  explicit Lcg(uint32_t seed) : state_(seed * 2654435761u + 0x9E3779B9u) {
    for (int i = 0; i < 4; ++i) Next();
  }
  uint32_t Next() { return state_ = 1664525u * state_ + 1013904223u; }
  double Uniform() { return static_cast<double>(Next() >> 8) / 16777216.0; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // integer in [lo, hi]
  int Int(int lo, int hi) {
    return lo + std::min(hi - lo, static_cast<int>(Uniform() * (hi - lo + 1)));
  }

 private:
  uint32_t state_;
};

// paper 002 Table I: (U1, U2, U3, U4) of modes M1..M9
constexpr int kModes[9][4] = {{0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 0, 1}, {0, 0, 1, 0},
                              {1, 0, 0, 1}, {0, 1, 1, 0}, {0, 1, 0, 1}, {1, 0, 1, 0}};

RigCommand ModeCommand(int mode) {
  const int* m = kModes[mode - 1];
  RigCommand c;
  c.u1 = m[0];
  c.u2 = m[1];
  c.u3 = m[2];
  c.u4 = m[3];
  return c;
}

// runs `policy(k, t, state) -> command` once per control period on the generator's own copy
// of the reference (RK4 at kExcitationStep), so that the policy can close a position loop
template <typename Policy>
std::vector<RigCommand> RunExcitation(const RigParams& p, double duration, Policy policy) {
  const int n = std::max(0, static_cast<int>(std::floor(duration / p.control_period + 1e-9)));
  std::vector<RigCommand> out;
  out.reserve(static_cast<std::size_t>(n));
  RigState s;
  for (int k = 0; k < n; ++k) {
    out.push_back(policy(k, k * p.control_period, s));
    s = Integrate(p, s, out.back(), p.control_period, kExcitationStep);
  }
  return out;
}

}  // namespace

std::vector<RigCommand> Excitation(Rig rig, double duration, uint32_t seed, double period,
                                   ExcitationPattern pattern) {
  if (pattern == ExcitationPattern::kFastSwitching) {
    if (period > 0) throw std::invalid_argument("Excitation: kFastSwitching uses the rig's control period");
    return FastSwitchingExcitation(rig, duration, seed);
  }
  RigParams p = DefaultParams(rig);
  if (period > 0) p.control_period = period;
  const double half = 0.5 * p.stroke;
  Lcg rng(seed);
  switch (rig) {
    // rig A: random paper 002 Table I modes held 2-8 periods; a random set point x_ref
    // (|x_ref| <= 0.4 L/2, new every 0.1-0.3 s) and the predicted error e = x - x_ref + 0.03 s v
    // choose Table II's mode instead when |e| leaves a band: M7/M6 beyond beta = 0.4 L/2,
    // M5/M3 or M2/M4 by the sign of E1 (paper 002 eq. 15) beyond eps = 0.2 L/2
    case Rig::kOnOff: {
      double x_ref = 0.0;
      int next_ref = 0, mode = 1, hold = 0;
      return RunExcitation(p, duration, [&](int k, double, const RigState& s) {
        if (k >= next_ref) {
          x_ref = rng.Uniform(-0.4, 0.4) * half;
          next_ref = k + rng.Int(50, 150);
        }
        if (hold-- <= 0) {
          mode = rng.Int(1, 9);
          hold = rng.Int(1, 7);
        }
        const double e = s.x - x_ref + 0.03 * s.v;
        const double eps = 0.2 * half, beta = 0.4 * half;
        const double e1 = p.supply_pressure + p.exhaust_pressure - s.p_P - s.p_N;
        int m = mode;
        if (e > beta) m = 7;
        else if (e < -beta) m = 6;
        else if (e > eps) m = e1 > 0 ? 5 : 3;
        else if (e < -eps) m = e1 > 0 ? 2 : 4;
        return ModeCommand(m);
      });
    }
    // rig B: u = three sines (0.3-3 Hz, 0.5-1.5 V each) + steps in [-3, 3] V held 0.1-0.4 s
    // - 40 V/m x - 2 V s/m v, saturated at +-5 V (reaches about +-5 V, rarely saturates)
    case Rig::kProportional: {
      double amp[3], freq[3], phase[3];
      for (int i = 0; i < 3; ++i) {
        amp[i] = rng.Uniform(0.5, 1.5);
        freq[i] = rng.Uniform(0.3, 3.0);
        phase[i] = rng.Uniform(0.0, 2.0 * kPi);
      }
      double level = 0.0;
      int next_level = 0;
      return RunExcitation(p, duration, [&](int k, double t, const RigState& s) {
        if (k >= next_level) {
          level = rng.Uniform(-3.0, 3.0);
          next_level = k + rng.Int(100, 400);
        }
        double u = level - 40.0 * s.x - 2.0 * s.v;
        for (int i = 0; i < 3; ++i) u += amp[i] * std::sin(2.0 * kPi * freq[i] * t + phase[i]);
        RigCommand c;
        c.u = std::clamp(u, -p.voltage_limit, p.voltage_limit);
        return c;
      });
    }
    // rig C: uP = 5 + c + d, uN = 5 + c - d, clamped to [3, 7] V. Common mode c: steps in
    // [-0.5, 0.5] V held 0.2-0.6 s plus a 0.3 V chirp sweeping 0.2-3 Hz over `duration`
    // (|c| <= 0.8 V keeps the differential's authority on the force); differential d: steps in
    // [-0.4, 0.4] V held 0.1-0.3 s - 40 V/m x - 0.3 V s/m v
    case Rig::kPerChamber: {
      double level = 0.0, diff = 0.0;
      int next_level = 0, next_diff = 0;
      const double span = std::max(duration, p.control_period);
      return RunExcitation(p, duration, [&](int k, double t, const RigState& s) {
        if (k >= next_level) {
          level = rng.Uniform(-0.5, 0.5);
          next_level = k + rng.Int(20, 60);
        }
        if (k >= next_diff) {
          diff = rng.Uniform(-0.4, 0.4);
          next_diff = k + rng.Int(10, 30);
        }
        const double common = level + 0.3 * std::sin(2.0 * kPi * (0.2 * t + 1.4 * t * t / span));
        const double d = diff - 40.0 * s.x - 0.3 * s.v;
        RigCommand c;
        c.uP = std::clamp(5.0 + common + d, 3.0, 7.0);
        c.uN = std::clamp(5.0 + common - d, 3.0, 7.0);
        return c;
      });
    }
  }
  return {};
}

namespace {

// runs FastSwitchingExcitation()'s segments: `candidates(t, state)` lists the commands a segment
// starting at time t from `state` may hold, the wanted one first, the most centring last
template <typename Candidates>
std::vector<RigCommand> RunHeldSegments(const RigParams& p, double duration, Lcg& rng,
                                        Candidates candidates) {
  const double period = p.control_period;
  const int n = std::max(0, static_cast<int>(std::floor(duration / period + 1e-9)));
  const int min_hold = std::max(1, static_cast<int>(std::lround(kFastSwitchingMinHold / period)));
  const int max_hold = std::max(min_hold, static_cast<int>(std::lround(kFastSwitchingMaxHold / period)));
  const double bound = 0.7 * 0.5 * p.stroke;
  std::vector<RigCommand> out;
  out.reserve(static_cast<std::size_t>(n));
  RigState s;
  while (static_cast<int>(out.size()) < n) {
    const int k = static_cast<int>(out.size());
    const int wanted = rng.Int(min_hold, max_hold);
    std::vector<RigCommand> list = candidates(k * period, s);
    // a new command every segment, so that no command is held longer than max_hold
    if (k > 0) {
      const RigCommand& last = out.back();
      auto same = [&](const RigCommand& c) {
        return c.u1 == last.u1 && c.u2 == last.u2 && c.u3 == last.u3 && c.u4 == last.u4 && c.u == last.u &&
               c.uP == last.uP && c.uN == last.uN;
      };
      std::vector<RigCommand> fresh;
      for (const RigCommand& c : list) {
        if (!same(c)) fresh.push_back(c);
      }
      if (!fresh.empty()) list = fresh;
    }
    // the largest |x + lead v| at the period ends of holding c for `hold` periods, and the end state
    auto look_ahead = [&](const RigCommand& c, int hold, RigState* end) {
      RigState q = s;
      double peak = 0.0;
      for (int i = 0; i < hold; ++i) {
        q = Integrate(p, q, c, period, kExcitationStep);
        peak = std::max(peak, std::fabs(q.x + kFastSwitchingLead * q.v));
      }
      *end = q;
      return peak;
    };
    int chosen = -1, hold = wanted;
    RigState end;
    for (int h : {wanted, min_hold}) {
      for (std::size_t i = 0; i < list.size() && chosen < 0; ++i) {
        if (look_ahead(list[i], h, &end) <= bound) chosen = static_cast<int>(i), hold = h;
      }
      if (chosen >= 0 || h == min_hold) break;
    }
    if (chosen < 0) {  // nothing stays inside the band: the one that stays nearest the centre
      double best = 0.0;
      hold = min_hold;
      for (std::size_t i = 0; i < list.size(); ++i) {
        RigState e;
        const double peak = look_ahead(list[i], hold, &e);
        if (chosen < 0 || peak < best) chosen = static_cast<int>(i), best = peak, end = e;
      }
    }
    const int count = std::min(hold, n - k);
    out.insert(out.end(), static_cast<std::size_t>(count), list[static_cast<std::size_t>(chosen)]);
    s = end;  // unused when the segment was cut at `duration`
  }
  return out;
}

}  // namespace

std::vector<RigCommand> FastSwitchingExcitation(Rig rig, double duration, uint32_t seed) {
  const RigParams p = DefaultParams(rig);
  const double half = 0.5 * p.stroke;
  // its own stream: a different seed mapping from Excitation()'s
  Lcg rng(seed ^ 0x5A17C4E5u);
  switch (rig) {
    // rig A: a random Table I mode, or Table II's when the predicted error e = x - x_ref + 0.03 s v
    // leaves the band (as Excitation()); x_ref random in 0.4 L/2, new every 0.1-0.3 s
    case Rig::kOnOff: {
      double x_ref = 0.0, next_ref = 0.0;
      return RunHeldSegments(p, duration, rng, [&](double t, const RigState& s) {
        if (t >= next_ref) {
          x_ref = rng.Uniform(-0.4, 0.4) * half;
          next_ref = t + rng.Uniform(0.1, 0.3);
        }
        int m = rng.Int(1, 9);
        const double e = s.x - x_ref + 0.03 * s.v;
        const double eps = 0.2 * half, beta = 0.4 * half;
        const double e1 = p.supply_pressure + p.exhaust_pressure - s.p_P - s.p_N;
        if (e > beta) m = 7;
        else if (e < -beta) m = 6;
        else if (e > eps) m = e1 > 0 ? 5 : 3;
        else if (e < -eps) m = e1 > 0 ? 2 : 4;
        // then the other modes in a random order
        int order[9] = {1, 2, 3, 4, 5, 6, 7, 8, 9};
        for (int i = 8; i > 0; --i) std::swap(order[i], order[rng.Int(0, i)]);
        std::vector<RigCommand> list{ModeCommand(m)};
        for (int o : order) {
          if (o != m) list.push_back(ModeCommand(o));
        }
        return list;
      });
    }
    // rig B: u = sat(r - 10 x - 0.5 v), r in [-2.5, 2.5] V; then r / 2, then 0. Excitation()'s
    // 40 V/m and 2 V s/m, sampled only every 10-80 ms, drive the piston through a full-stroke limit
    // cycle at 3-4 m/s, along which a 10 um offset grows 40-90 fold in 4 s (r in [-5, 5] V or in
    // [-2, 2] V alike): an open-loop replay would measure that growth, not the model
    case Rig::kProportional: {
      return RunHeldSegments(p, duration, rng, [&](double, const RigState& s) {
        const double r = rng.Uniform(-0.5 * p.voltage_limit, 0.5 * p.voltage_limit);
        std::vector<RigCommand> list;
        for (double scale : {1.0, 0.5, 0.0}) {
          RigCommand c;
          c.u = std::clamp(scale * r - 10.0 * s.x - 0.5 * s.v, -p.voltage_limit, p.voltage_limit);
          list.push_back(c);
        }
        return list;
      });
    }
    // rig C: uP = 5 + c + d, uN = 5 + c - d in [3, 7] V, d = r - 40 x - 0.3 v; then r / 2, then 0
    case Rig::kPerChamber: {
      return RunHeldSegments(p, duration, rng, [&](double, const RigState& s) {
        const double c = rng.Uniform(-1.0, 1.0), r = rng.Uniform(-2.0, 2.0);
        std::vector<RigCommand> list;
        for (double scale : {1.0, 0.5, 0.0}) {
          const double d = scale * r - 40.0 * s.x - 0.3 * s.v;
          RigCommand cmd;
          cmd.uP = std::clamp(5.0 + c + d, 3.0, 7.0);
          cmd.uN = std::clamp(5.0 + c - d, 3.0, 7.0);
          list.push_back(cmd);
        }
        return list;
      });
    }
  }
  return {};
}

}  // namespace pneumatic::reference
