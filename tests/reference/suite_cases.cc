// The suite's cases and their logs (see suite_cases.h). Magnitudes are stated against each rig's
// own scales (RigScales): its largest force, a chamber's mid-stroke volume and its valve's full flow.
#include "suite_cases.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>

#include "reference_log.h"

namespace pneumatic::reference {
namespace {

constexpr double kPi = 3.14159265358979323846;

// --- each rig's scales ----------------------------------------------------------------------------

struct RigScales {
  double half_stroke = 0;  // m
  double max_force = 0;    // N: A_P (P_S - P_E)
  double mid_volume = 0;   // m^3: a chamber at mid-stroke, A_P L/2 + V0
  double full_flow = 0;    // kg/s: one valve port wide open from the supply to the atmosphere
  double gauge = 0;        // Pa: P_S - P_E
  double r_gas = 0, temperature = 0;
};

RigScales Scales(const RigParams& p) {
  RigScales s;
  s.half_stroke = 0.5 * p.stroke;
  s.gauge = p.supply_pressure - p.exhaust_pressure;
  s.max_force = p.area_P * s.gauge;
  s.mid_volume = p.area_P * s.half_stroke + p.dead_volume;
  s.temperature = p.temperature;
  s.r_gas = p.rig == Rig::kPerChamber ? p.universal_gas_constant / p.molar_mass : p.gas_constant;
  switch (p.rig) {
    case Rig::kOnOff: s.full_flow = FlowIso6358(p.valve_conductance, p.valve_critical_ratio, p.supply_pressure, p.exhaust_pressure); break;
    case Rig::kProportional:
      s.full_flow = FlowSanville(p.discharge_coefficient * p.area_gradient * p.spool_gain * p.voltage_limit, p.temperature,
                                 p.polytropic_index, p.gas_constant, p.spool_critical_ratio, p.supply_pressure, p.exhaust_pressure);
      break;
    case Rig::kPerChamber:
      s.full_flow = FlowThinPlate(SupplyPortArea(p, 7.0), p.polytropic_index, p.discharge_coefficient, p.molar_mass,
                                  p.universal_gas_constant, p.compressibility, p.temperature, p.supply_pressure, p.exhaust_pressure);
      break;
  }
  return s;
}

// The series restriction (real_rig.h) passing `flow` kg/s at a drop `dp` Pa about a mean pressure
// `mean_p`, `laminar_share` of the drop laminar: g = q / (s dp), C_d A = q sqrt(rho / (2 (1 - s) dp)),
// q = flow / rho, rho = mean_p / (r T)
SeriesRestriction RestrictionFor(const RigScales& s, double flow, double dp, double mean_p, double laminar_share) {
  const double rho = mean_p / (s.r_gas * s.temperature);
  const double q = flow / rho;
  SeriesRestriction r;
  r.laminar = q / (laminar_share * dp);
  r.orifice = laminar_share < 1 ? q * std::sqrt(rho / (2 * (1 - laminar_share) * dp)) : 0;
  return r;
}

// a leak passing `fraction` of the valve's full flow at half the gauge pressure, half laminar
SeriesRestriction Leak(const RigScales& s, const RigParams& p, double fraction) {
  return RestrictionFor(s, fraction * s.full_flow, 0.5 * s.gauge, 0.5 * (p.supply_pressure + p.exhaust_pressure), 0.5);
}

// --- effects, each a function of the case's rig and a magnitude (1 or 2) ---------------------------

using Effect = std::function<void(RealRigParams*, Sensors*, const RigScales&)>;

struct EffectCase {
  std::string truth, description;
  Effect apply;
};

std::string Num(double v) {
  char t[32];
  std::snprintf(t, sizeof(t), "%.3g", v);
  return t;
}

EffectCase Friction(Rig rig, int magnitude) {
  // LuGre with a Stribeck curve; paper 001's seal (20 N Coulomb, 40 N static) on rig B at magnitude 2
  const double fc = rig == Rig::kProportional ? (magnitude == 1 ? 10.0 : 20.0) : 0;
  const double fc_share = magnitude == 1 ? 0.03 : 0.07, fs_ratio = magnitude == 1 ? 1.6 : 1.9;
  const double vs = magnitude == 1 ? 0.01 : 0.004, delta = magnitude == 1 ? 1.0 : 0.6;
  return {"friction", "", [=](RealRigParams* p, Sensors*, const RigScales& s) {
            LuGreFriction& f = p->friction;
            f.on = true;
            f.coulomb = fc > 0 ? fc : fc_share * s.max_force;
            f.stiction = fs_ratio * f.coulomb;
            f.stribeck_velocity = vs;
            f.stribeck_exponent = delta;
            f.damping_velocity = vs;
            f.bristle_stiffness = f.stiction / 30e-6;  // 30 um of pre-sliding at break-away
          }};
}

EffectCase LeakageCase(int magnitude) {
  return {"leakage", "", [=](RealRigParams* p, Sensors*, const RigScales& s) {
            p->leakage.piston = Leak(s, p->rig, magnitude == 1 ? 0.005 : 0.012);
            if (magnitude == 2) p->leakage.atmosphere_P = Leak(s, p->rig, 0.005);
          }};
}

EffectCase LineDynamics(int magnitude) {
  // a tube of half (one) mid-stroke chamber volume dropping 15 % (30 %) of the gauge pressure at the
  // valve's full flow, 70 % of it laminar, in 4 segments
  return {"line_dynamics", "", [=](RealRigParams* p, Sensors*, const RigScales& s) {
            p->tube.volume = (magnitude == 1 ? 0.5 : 1.0) * s.mid_volume;
            p->tube.segments = 4;
            p->tube.restriction = RestrictionFor(s, s.full_flow, (magnitude == 1 ? 0.15 : 0.3) * s.gauge,
                                                 0.5 * (p->rig.supply_pressure + p->rig.exhaust_pressure), 0.7);
          }};
}

EffectCase SupplyDrop(int magnitude) {
  // a tank of 20 (6) chamber pairs behind a hose dropping 10 % (25 %) of the gauge at the valve's
  // full flow; a compressor giving half (a third) of that flow at the rated supply, switched on 5 %
  // (10 %) of the gauge below it and off at it; a manifold of half a chamber
  return {"supply_drop", "", [=](RealRigParams* p, Sensors*, const RigScales& s) {
            SupplySystem& sup = p->supply;
            const double ps = p->rig.supply_pressure;
            sup.on = true;
            sup.tank_volume = (magnitude == 1 ? 20 : 6) * 2 * s.mid_volume;
            sup.manifold_volume = 0.5 * s.mid_volume;
            sup.hose = RestrictionFor(s, s.full_flow, (magnitude == 1 ? 0.1 : 0.25) * s.gauge, ps, 0.3);
            sup.stall_pressure = ps + s.gauge;
            sup.compressor_flow = (magnitude == 1 ? 0.5 : 0.33) * s.full_flow * 2;  // half of it left at P_S
            sup.switch_off = ps;
            sup.switch_on = ps - (magnitude == 1 ? 0.05 : 0.1) * s.gauge;
          }};
}

EffectCase ValveDelay(Rig rig, int magnitude) {
  return {"valve_delay", "", [=](RealRigParams* p, Sensors*, const RigScales&) {
            ValveTiming& t = p->timing;
            switch (rig) {
              case Rig::kOnOff:  // armature delays and travel: 3 / 1.5 ms and 1 / 0.5 ms, or twice that
                t.open_delay = magnitude * 3e-3, t.close_delay = magnitude * 1.5e-3;
                t.open_travel = magnitude * 1e-3, t.close_travel = magnitude * 0.5e-3;
                break;
              case Rig::kProportional:  // a field bus' 5.3 ms, or a second-order spool at 20 Hz behind 1.5 ms
                if (magnitude == 1) t.command_delay = 5.3e-3;
                else t.spool_natural_frequency = 2 * kPi * 20, t.spool_damping_ratio = 0.6, t.command_delay = 1.5e-3;
                break;
              case Rig::kPerChamber:  // 7.3 ms, or a 6 ms voltage lag behind 2.5 ms
                if (magnitude == 1) t.command_delay = 7.3e-3;
                else t.voltage_lag = 6e-3, t.command_delay = 2.5e-3;
                break;
            }
          }};
}

EffectCase HeatTransfer(int magnitude) {
  // the wall's time constant m c_v / (h A_wall) for a mid-stroke chamber at the mean of supply and
  // exhaust: 0.15 s (0.6 s)
  return {"heat_transfer", "", [=](RealRigParams* p, Sensors*, const RigScales& s) {
            const RigParams& r = p->rig;
            const double gamma = 1.4, mean_p = 0.5 * (r.supply_pressure + r.exhaust_pressure);
            const double heat_capacity = mean_p * s.mid_volume / (s.r_gas * s.temperature) * s.r_gas / (gamma - 1);
            const double wall = 2 * r.area_P + 2 * std::sqrt(kPi * r.area_P) * (s.half_stroke + r.dead_volume / r.area_P);
            p->heat.on = true;
            p->heat.heat_capacity_ratio = gamma;
            p->heat.coefficient = heat_capacity / ((magnitude == 1 ? 0.15 : 0.6) * wall);
          }};
}

EffectCase Payload(int magnitude) {
  return {"payload", "", [=](RealRigParams* p, Sensors*, const RigScales&) {
            p->added_mass = (magnitude == 1 ? 0.35 : 1.0) * p->rig.mass;
          }};
}

EffectCase SensorBias(Rig rig, int magnitude) {
  struct Bias { const char* signal; double offset, gain; };
  // per rig and magnitude: a pressure offset, a pressure gain, a position offset
  static const Bias kBias[3][2] = {{{"p_P", 6e3, 1.0}, {"p_N", -3e3, 0.96}},
                                   {{"x", 5e-3, 1.0}, {"p_P", 10e3, 1.02}},
                                   {{"p_N", -8e3, 1.0}, {"x", 1.5e-3, 1.03}}};
  const Bias b = kBias[static_cast<int>(rig)][magnitude - 1];
  return {"sensor_bias", "", [=](RealRigParams*, Sensors* sensors, const RigScales&) {
            sensors->biased = b.signal, sensors->offset = b.offset, sensors->gain = b.gain;
          }};
}

EffectCase ValveDeadband(Rig rig, int magnitude) {
  return {"valve_deadband", "", [=](RealRigParams* p, Sensors*, const RigScales&) {
            if (rig == Rig::kProportional) p->rig.spool_deadband = magnitude == 1 ? 0.06 : 0.12;
            else p->voltage_deadband = magnitude == 1 ? 0.15 : 0.35;
          }};
}

// --- effects outside the library -------------------------------------------------------------------

EffectCase BacklashCase(double gap) {
  return {"unexplained", "backlash of " + Num(gap * 1e3) + " mm in the load's linkage, position sensed on the load",
          [=](RealRigParams* p, Sensors*, const RigScales&) { p->backlash.gap = gap; }};
}

EffectCase FlowDrift(double drop) {
  return {"unexplained", "valve flow gain drifting " + Num(100 * drop) + " % down as the coils warm (4 s)",
          [=](RealRigParams* p, Sensors*, const RigScales&) { p->drift.drop = drop; }};
}

EffectCase Hysteresis(double half_width) {
  return {"unexplained", "valve hysteresis: a play of +-" + Num(half_width) + " V on the command",
          [=](RealRigParams* p, Sensors*, const RigScales&) { p->hysteresis.half_width = half_width; }};
}

EffectCase TightSpotIn(double share, double from, double to) {
  return {"unexplained",
          "a tight spot in the bore, " + Num(100 * share) + " % of the largest force over x in [" + Num(from) + ", " + Num(to) +
              "] of the half stroke",
          [=](RealRigParams* p, Sensors*, const RigScales& s) {
            p->tight_spot.force = share * s.max_force;
            p->tight_spot.from = from * s.half_stroke, p->tight_spot.to = to * s.half_stroke;
          }};
}

EffectCase CrackingLeakAbove(double crack_share, double flow_share) {
  return {"unexplained",
          "a leak from P to the atmosphere opening above " + Num(100 * crack_share) + " % of the gauge pressure, " +
              Num(100 * flow_share) + " % of the valve's flow when open",
          [=](RealRigParams* p, Sensors*, const RigScales& s) {
            p->cracking_leak.cracking_pressure = p->rig.exhaust_pressure + crack_share * s.gauge;
            p->cracking_leak.opening = 0.05 * s.gauge;
            p->cracking_leak.conductance = flow_share * s.full_flow / p->rig.supply_pressure;
          }};
}

EffectCase SpringOver(double force_share, double from) {
  return {"unexplained",
          "a spring met beyond " + Num(from) + " of the half stroke, " + Num(100 * force_share) +
              " % of the largest force at the stroke's end",
          [=](RealRigParams* p, Sensors*, const RigScales& s) {
            p->spring.from = from * s.half_stroke;
            p->spring.stiffness = force_share * s.max_force / (s.half_stroke - p->spring.from);
          }};
}

// --- building a case ---------------------------------------------------------------------------------

// FNV-1a of the case's id: its seed
uint64_t IdSeed(const std::string& id) {
  uint64_t h = 1469598103934665603ull;
  for (char c : id) h = (h ^ static_cast<unsigned char>(c)) * 1099511628211ull;
  return h;
}

constexpr double kRates[4] = {100, 200, 500, 1000};

// the case's real rig: docs/rigs.md's numbers perturbed (suite_cases.h), drawn from its seed
Perturbation DrawPerturbation(Rig rig, NormalSource* random) {
  const RigParams nominal = DefaultParams(rig);
  Perturbation p;
  p.flow = random->Uniform(0.8, 1.2);
  p.critical_ratio = rig == Rig::kPerChamber ? 1 : random->Uniform(0.8, 1.2);
  p.polytropic_index = std::clamp(nominal.polytropic_index * random->Uniform(0.8, 1.2), 1.0, 1.4);
  p.dead_volume_P = random->Uniform(0.7, 1.3);
  p.dead_volume_N = random->Uniform(0.7, 1.3);
  p.damping = random->Uniform(0.7, 1.3);
  return p;
}

void ApplyPerturbation(const Perturbation& d, RealRigParams* p) {
  RigParams& r = p->rig;
  if (r.rig == Rig::kOnOff) r.valve_conductance *= d.flow, r.valve_critical_ratio *= d.critical_ratio;
  else r.discharge_coefficient *= d.flow;
  if (r.rig == Rig::kProportional) r.spool_critical_ratio *= d.critical_ratio;
  r.polytropic_index = d.polytropic_index;
  p->dead_volume_P = r.dead_volume * d.dead_volume_P;
  p->dead_volume_N = r.dead_volume * d.dead_volume_N;
  r.friction *= d.damping;
  // the flow laws keep the gas's ratio of specific heats (real_rig.h RealRigParams::flow_gamma)
  p->flow_gamma = 1.4;
}

SuiteCase MakeCase(Rig rig, int index, const EffectCase& e) {
  SuiteCase c;
  c.rig = rig;
  char id[96];
  std::snprintf(id, sizeof(id), "%s%02d-%s", RigLetter(rig), index, e.truth.c_str());
  c.id = id;
  c.truth = e.truth;
  c.description = e.description;
  NormalSource random(IdSeed(c.id));
  // rates spread over each rig's list, the two magnitudes of an effect at different rates
  c.rate = kRates[(index + static_cast<int>(rig) + index / 5) % 4];
  c.noise = std::exp(random.Uniform(std::log(0.5), std::log(2.0)));
  c.perturbation = DrawPerturbation(rig, &random);
  c.params = NominalRealRig(rig);
  const RigScales scales = Scales(c.params.rig);  // nominal scales: magnitudes do not follow the draw
  ApplyPerturbation(c.perturbation, &c.params);
  c.sensors.noise_pressure = 500 * c.noise;
  c.sensors.noise_position = 5e-5 * c.noise;
  // a pressure transducer's lag of 30-100 us (1.6-5 kHz): rig A's chambers move at up to 1e7 Pa/s, so a
  // lag of 0.3-1 ms left 1.3-4.5 kPa RMS on its parameters-only logs (3-10 times the noise), which the
  // diagnosis rightly took for a valve delay; at 0.1 ms it leaves about a third of that
  c.sensors.pressure_lag = random.Uniform(0.03e-3, 0.1e-3);
  c.sensors.position_quantum = 5e-6;
  if (e.apply) e.apply(&c.params, &c.sensors, scales);
  for (int i = 0; i < 3; ++i) c.seeds[i] = static_cast<uint32_t>(random.Next() >> 32);
  return c;
}

// the in-library effects' descriptions, from what they set
std::string Describe(const SuiteCase& c) {
  const RealRigParams& p = c.params;
  const RigScales s = Scales(DefaultParams(c.rig));
  if (c.truth == "none") return "parameters off nominal only";
  if (c.truth == "friction")
    return "LuGre friction, F_c " + Num(p.friction.coulomb) + " N, F_s " + Num(p.friction.stiction) + " N, Stribeck " +
           Num(1e3 * p.friction.stribeck_velocity) + " mm/s, exponent " + Num(p.friction.stribeck_exponent);
  if (c.truth == "leakage")
    return std::string("piston leak, half laminar and half turbulent in series") +
           (p.leakage.atmosphere_P.laminar > 0 ? ", and a leak from P to the atmosphere" : "");
  if (c.truth == "line_dynamics")
    return "tubes of " + Num(p.tube.volume / s.mid_volume) + " mid-stroke chamber volumes in " + std::to_string(p.tube.segments) +
           " segments";
  if (c.truth == "supply_drop")
    return "supply tank of " + Num(p.supply.tank_volume / s.mid_volume) + " chamber volumes, on/off compressor, hose to a manifold";
  if (c.truth == "valve_delay") {
    const ValveTiming& t = p.timing;
    if (c.rig == Rig::kOnOff)
      return "armature delays " + Num(1e3 * t.open_delay) + " / " + Num(1e3 * t.close_delay) + " ms, travel " +
             Num(1e3 * t.open_travel) + " / " + Num(1e3 * t.close_travel) + " ms";
    std::string d = "command delay " + Num(1e3 * t.command_delay) + " ms";
    if (t.spool_natural_frequency > 0) d += ", second-order spool at " + Num(t.spool_natural_frequency / (2 * kPi)) + " Hz";
    if (t.voltage_lag > 0) d += ", valve voltage lag " + Num(1e3 * t.voltage_lag) + " ms";
    return d;
  }
  if (c.truth == "heat_transfer") return "gas energy equation with wall heat, h = " + Num(p.heat.coefficient) + " W/(m^2 K)";
  if (c.truth == "payload") return "payload of " + Num(p.added_mass) + " kg";
  if (c.truth == "sensor_bias")
    return c.sensors.biased + " sensor offset " + Num(c.sensors.offset) + ", gain " + Num(c.sensors.gain);
  if (c.truth == "valve_deadband")
    return c.rig == Rig::kProportional ? "spool deadband " + Num(100 * p.rig.spool_deadband) + " %"
                                       : "voltage deadband +-" + Num(p.voltage_deadband) + " V about 5 V";
  return c.description;
}

// --- the excitation ---------------------------------------------------------------------------------

// paper 002 Table I: (U1, U2, U3, U4) of modes M1..M9
constexpr int kModes[9][4] = {{0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 0, 1}, {0, 0, 1, 0},
                              {1, 0, 0, 1}, {0, 1, 1, 0}, {0, 1, 0, 1}, {1, 0, 1, 0}};

RigCommand Mode(int m) {
  RigCommand c;
  c.u1 = kModes[m - 1][0], c.u2 = kModes[m - 1][1], c.u3 = kModes[m - 1][2], c.u4 = kModes[m - 1][3];
  return c;
}

// The suite's own excitation, one command per row, closed on the logged measurements: segments of
// 0.25-1 s, each tracking a set point (a step, sometimes near a stroke end, or a slow sine), driven
// open loop with random commands, holding the valves closed, or giving small commands. A non-tracking
// segment hands over to tracking mid-stroke once the predicted position x + 0.05 s v leaves 70 % of
// the half stroke, a tracking one (overshooting a set point near a stroke end) at 92 %. The velocity is a first-order filtered (15 Hz) finite difference of the logged x.
class SuiteExcitation {
 public:
  SuiteExcitation(Rig rig, double rate, uint64_t seed) : rig_(rig), period_(1 / rate), random_(seed) {
    half_ = 0.5 * DefaultParams(rig).stroke;
    // the loops' gains fall with the rate, so that the sampled loop stays stable at 100 Hz
    const double slow = std::clamp(rate / 1000, 0.2, 1.0);
    gain_x_ = rig == Rig::kProportional ? 30 * std::sqrt(slow) : 40 * std::sqrt(slow);
    gain_v_ = rig == Rig::kProportional ? 1.5 * slow : 0.3 * slow;
  }

  RigCommand Next(int row, const Reading& m) {
    const double t = row * period_;
    // velocity: a filtered finite difference
    if (row > 0) v_ += (1 - std::exp(-2 * kPi * 15 * period_)) * ((m.x - x_) / period_ - v_);
    x_ = m.x;
    p_P_ = m.p_P, p_N_ = m.p_N;
    if (t >= segment_end_) NewSegment(t);
    const double ahead = std::fabs(x_ + 0.05 * v_);
    if ((kind_ != kTrack && ahead > 0.7 * half_) || ahead > 0.92 * half_) kind_ = kTrack, target_ = 0, amplitude_ = 0;
    switch (kind_) {
      case kTrack: return Track(t);
      case kOpen: return Open(row);
      case kHoldValves: return Hold();
      case kSmall: return Small(row);
    }
    return {};
  }

 private:
  enum Kind { kTrack, kOpen, kHoldValves, kSmall };

  void NewSegment(double t) {
    segment_end_ = t + random_.Uniform(0.25, 1.0);
    const double pick = random_.Uniform();
    kind_ = pick < 0.5 ? kTrack : pick < 0.7 ? kOpen : pick < 0.85 ? kHoldValves : kSmall;
    const double where = random_.Uniform();
    target_ = where < 0.15 ? (random_.Uniform() < 0.5 ? -1 : 1) * random_.Uniform(0.7, 0.85) * half_
                           : random_.Uniform(-0.6, 0.6) * half_;
    amplitude_ = random_.Uniform() < 0.3 ? random_.Uniform(0.1, 0.3) * half_ : 0;
    frequency_ = random_.Uniform(0.5, 3);
    common_ = random_.Uniform(-0.8, 0.8);
    held_mode_ = random_.Uniform() < 0.7 ? 1 : 9;
    next_change_ = 0;
  }

  double Reference(double t) const { return target_ + amplitude_ * std::sin(2 * kPi * frequency_ * t); }

  // a position loop on the measurement: paper 002 Table II's mode choice (A), or proportional and
  // derivative feedback in volts (B; C differentially about a common level)
  RigCommand Track(double t) {
    const double r = Reference(t);
    RigCommand c;
    switch (rig_) {
      case Rig::kOnOff: {
        const double e = x_ - r + 0.03 * v_, eps = 0.06 * half_, beta = 0.3 * half_;
        // E1 = P_S + P_E - p_P - p_N of paper 002 eq. (15), from the logged pressures
        const double e1 = 4e5 - p_P_ - p_N_;
        int mode = held_mode_;
        if (e > beta) mode = 7;
        else if (e < -beta) mode = 6;
        else if (e > eps) mode = e1 > 0 ? 5 : 3;
        else if (e < -eps) mode = e1 > 0 ? 2 : 4;
        return Mode(mode);
      }
      case Rig::kProportional: c.u = std::clamp(gain_x_ * (r - x_) - gain_v_ * v_, -5.0, 5.0); return c;
      case Rig::kPerChamber: {
        const double d = gain_x_ * (r - x_) - gain_v_ * v_;
        c.uP = std::clamp(5 + common_ + d, 3.0, 7.0);
        c.uN = std::clamp(5 + common_ - d, 3.0, 7.0);
        return c;
      }
    }
    return c;
  }

  // random commands, each held 2-150 ms
  RigCommand Open(int row) {
    if (row >= next_change_) {
      const double hold = rig_ == Rig::kOnOff ? random_.Uniform(0.002, 0.03) : random_.Uniform(0.02, 0.15);
      next_change_ = row + std::max(1, static_cast<int>(std::lround(hold / period_)));
      open_ = Mode(1 + static_cast<int>(random_.Uniform() * 9));
      open_.u = random_.Uniform(-5, 5);
      open_.uP = random_.Uniform(3, 7), open_.uN = random_.Uniform(3, 7);
    }
    return open_;
  }

  // valves closed: A all four, B the spool centred, C both valves at 5 V
  RigCommand Hold() const { return rig_ == Rig::kOnOff ? Mode(1) : RigCommand{}; }

  // small commands: A single-row pulses between closed rows, B |u| < 0.8 V, C 5 +- 0.4 V
  RigCommand Small(int row) {
    if (row >= next_change_) {
      const double hold = random_.Uniform(0.03, 0.2);
      next_change_ = row + std::max(1, static_cast<int>(std::lround(hold / period_)));
      open_ = Mode(2 + static_cast<int>(random_.Uniform() * 4));
      open_.u = random_.Uniform(-0.8, 0.8);
      open_.uP = 5 + random_.Uniform(-0.4, 0.4), open_.uN = 5 + random_.Uniform(-0.4, 0.4);
    }
    if (rig_ == Rig::kOnOff) return row == next_change_ - 1 ? open_ : Mode(1);
    return open_;
  }

  Rig rig_;
  double period_, half_ = 0, gain_x_ = 0, gain_v_ = 0;
  NormalSource random_;
  double x_ = 0, v_ = 0, p_P_ = 1e5, p_N_ = 1e5;
  Kind kind_ = kTrack;
  double segment_end_ = 0, target_ = 0, amplitude_ = 0, frequency_ = 1, common_ = 0;
  int held_mode_ = 1, next_change_ = 0;
  RigCommand open_;
};

}  // namespace

const char* RigLetter(Rig rig) { return rig == Rig::kOnOff ? "A" : rig == Rig::kProportional ? "B" : "C"; }

std::vector<SuiteCase> SuiteCases() {
  std::vector<SuiteCase> cases;
  const EffectCase none{"none", "", nullptr};
  for (Rig rig : {Rig::kOnOff, Rig::kProportional, Rig::kPerChamber}) {
    std::vector<EffectCase> list;
    // parameters only: four per rig
    for (int i = 0; i < 4; ++i) list.push_back(none);
    // the library's effects, each at two magnitudes
    for (int m : {1, 2}) {
      list.push_back(Friction(rig, m));
      list.push_back(LeakageCase(m));
      list.push_back(LineDynamics(m));
      list.push_back(SupplyDrop(m));
      list.push_back(ValveDelay(rig, m));
      list.push_back(HeatTransfer(m));
      list.push_back(Payload(m));
      list.push_back(SensorBias(rig, m));
      if (rig != Rig::kOnOff) list.push_back(ValveDeadband(rig, m));
    }
    // effects outside the library: six kinds at two magnitudes, four per rig
    switch (rig) {
      case Rig::kOnOff:
        list.push_back(BacklashCase(0.3e-3));
        list.push_back(TightSpotIn(0.08, 0.1, 0.4));
        list.push_back(CrackingLeakAbove(0.75, 0.03));
        list.push_back(SpringOver(0.3, 0.2));
        break;
      case Rig::kProportional:
        list.push_back(BacklashCase(1.5e-3));
        list.push_back(FlowDrift(0.12));
        list.push_back(Hysteresis(0.3));
        list.push_back(CrackingLeakAbove(0.6, 0.08));
        break;
      case Rig::kPerChamber:
        list.push_back(FlowDrift(0.25));
        list.push_back(Hysteresis(0.12));
        list.push_back(TightSpotIn(0.2, -0.5, -0.1));
        list.push_back(SpringOver(0.1, 0.3));
        break;
    }
    for (size_t i = 0; i < list.size(); ++i) {
      SuiteCase c = MakeCase(rig, static_cast<int>(i) + 1, list[i]);
      c.description = Describe(c);
      cases.push_back(std::move(c));
    }
  }
  return cases;
}

namespace {

// the log's columns: the rig's commands, then p_P, p_N, x, v and p_S of cylinder "cyl"
log::Log EmptyLog(const SuiteCase& c, const std::string& part) {
  log::Log out;
  out.comments.push_back("suite case " + c.id + ", " + part + " log; rig: models_mjcf/" + RigModelFile(c.rig));
  out.comments.push_back("made by tests/reference/real_rig (independent of the extension)");
  for (const auto& [signal, value] : NamedCommands(c.rig, RigCommand{})) out.columns.push_back({"cyl", signal});
  for (const char* m : {"p_P", "p_N", "x", "v", "p_S"}) out.columns.push_back({"cyl", m});
  out.values.assign(out.columns.size(), {});
  out.source = c.id + " " + part;
  return out;
}

// one row: the command applied from k / rate on and the reading before it acts; v is the backward
// difference of the logged x (0 on the first row)
void AddRow(const SuiteCase& c, int k, const RigCommand& command, const Reading& m, double last_x, log::Log* out) {
  std::vector<double> row;
  for (const auto& [signal, value] : NamedCommands(c.rig, command)) row.push_back(value);
  const double v = k > 0 ? (m.x - last_x) * c.rate : 0;
  for (double value : {m.p_P, m.p_N, m.x, v, m.p_S}) row.push_back(value);
  out->time.push_back(k / c.rate);
  for (size_t i = 0; i < row.size(); ++i) out->values[i].push_back(row[i]);
}

}  // namespace

log::Log SimulateCase(const SuiteCase& c, int which, double duration) {
  if (which < 0 || which > 2) throw std::invalid_argument("SimulateCase: which must be 0, 1 or 2");
  const uint64_t seed = c.seeds[static_cast<size_t>(which)];
  RealRig rig(c.params, c.sensors, kSuiteFineStep);
  NormalSource noise(seed * 0x9E3779B97F4A7C15ull + 1);
  SuiteExcitation excitation(c.rig, c.rate, seed);
  const int rows = static_cast<int>(std::floor(duration * c.rate + 1e-9));
  log::Log out = EmptyLog(c, LogPartName(which));
  double last_x = 0;
  for (int k = 0; k < rows; ++k) {
    const Reading m = rig.Read(&noise);
    const RigCommand command = excitation.Next(k, m);
    AddRow(c, k, command, m, last_x, &out);
    last_x = m.x;
    rig.Advance(command, 1 / c.rate);
  }
  return out;
}

std::vector<RigCommand> LogCommands(Rig rig, const log::Log& log) {
  std::vector<RigCommand> commands(log.rows());
  for (size_t k = 0; k < log.rows(); ++k) {
    auto at = [&](const char* signal) { return log.values[static_cast<size_t>(log.FindColumn("cyl", signal))][k]; };
    RigCommand& c = commands[k];
    if (rig == Rig::kOnOff) c.u1 = at("u1"), c.u2 = at("u2"), c.u3 = at("u3"), c.u4 = at("u4");
    if (rig == Rig::kProportional) c.u = at("u");
    if (rig == Rig::kPerChamber) c.uP = at("uP"), c.uN = at("uN");
  }
  return commands;
}

log::Log ReplayCase(const SuiteCase& c, const std::vector<RigCommand>& commands, double fine_step) {
  Sensors exact = c.sensors;
  exact.position_quantum = 0;
  RealRig rig(c.params, exact, fine_step);
  log::Log out = EmptyLog(c, "replay");
  double last_x = 0;
  for (size_t k = 0; k < commands.size(); ++k) {
    const Reading m = rig.Read(nullptr);
    AddRow(c, static_cast<int>(k), commands[k], m, last_x, &out);
    last_x = m.x;
    rig.Advance(commands[k], 1 / c.rate);
  }
  return out;
}

}  // namespace pneumatic::reference
