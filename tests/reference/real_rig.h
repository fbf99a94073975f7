// A "real rig" for the diagnosis suite (issue 55, item 3): the three benchmark rigs of
// docs/rigs.md as a robot in a lab would have them, with the unmodelled effects of
// docs/effects.md, effects that no library holds, parameters off their nominal values and
// sensors with noise, lag and quantisation. Written apart from the extension and its diagnosis: it
// includes nothing from plugin/ or pneumo/, only rig_reference.h for the flow laws of docs/rigs.md and
// its parameter struct, and every effect is in a form of its own, not one of the diagnosis'
// candidates (pneumo/diagnosis/candidates.cc; the form of each is stated below and in real_rig.cc).
//
// State: x, v, p_P, p_N and rig B's spool as in rig_reference.h, plus what the effects need
// (LuGre bristle z, gas temperatures, tube segment pressures, supply tank and manifold pressures,
// load position and velocity, spool rate, valve voltages, lagged sensor readings). Integrated by
// classical RK4 at a fixed fine step; commands, their delays, the valves' armature switching and the
// hysteresis act at exact breakpoints, between which the inputs are held.
//
// Units are SI throughout: m, m/s, kg, s, N, K, V; pressures are ABSOLUTE, in Pa; mass flows in
// kg/s, counted positive INTO a chamber or node (or from the first pressure argument to the second).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "rig_reference.h"

namespace pneumatic::reference {

// --- restrictions --------------------------------------------------------------------------------

// A restriction with a laminar and a turbulent part in series, the suite's own form for leaks,
// tubes and the supply hose (neither the orifice nor the laminar leak of the diagnosis, nor the two
// side by side): the pressure drop is the sum of a Hagen-Poiseuille term and an orifice's
// incompressible loss,
//   dp = q / g + rho q |q| / (2 (C_d A)^2),   q = Q / rho the volume flow, rho = (p1 + p2) / (2 r T),
// so the flow is laminar (Q = rho g dp) at small drops and grows as sqrt(dp) at large ones, and its
// slope at dp = 0 is finite (no stiffness near equalisation).
struct SeriesRestriction {
  double laminar = 0;  // g, m^3/(s Pa): the laminar part's volume conductance (> 0 when used)
  double orifice = 0;  // C_d A, m^2: the turbulent part's effective area (0: no turbulent part)
};

// mass flow (kg/s) from p1 to p2 (negative when p2 > p1) through `r`, gas constant r_gas (J/(kg K))
// at temperature t (K)
double SeriesRestrictionFlow(const SeriesRestriction& r, double r_gas, double t, double p1, double p2);

// --- effects of docs/effects.md (the right verdict is the effect's name) --------------------------------

// friction: the LuGre model of Canudas de Wit, Olsson, Astrom and Lischinsky (IEEE TAC 40, 1995),
// eqs. (1)-(4), with its velocity-dependent micro-damping (their eq. 8) and a Stribeck curve of
// exponent delta (Armstrong-Helouvry's generalised form): g(v) = F_c + (F_s - F_c) exp(-|v / v_s|^delta).
// The candidates are Coulomb friction (a joint frictionloss), Coulomb plus viscous, and LuGre with
// delta = 2, a fixed v_s of a twentieth of a stroke per second and constant micro-damping.
struct LuGreFriction {
  bool on = false;
  double coulomb = 0;               // F_c, N
  double stiction = 0;              // F_s, N (>= F_c)
  double stribeck_velocity = 0.01;  // v_s, m/s
  double stribeck_exponent = 1;     // delta, 1
  double bristle_stiffness = 1e5;   // sigma0, N/m
  double bristle_damping = 0;       // sigma1 at rest, N s/m (0: 2 sqrt(sigma0 M), Canudas de Wit's choice)
  double damping_velocity = 0.01;   // v_d of sigma1(v) = sigma1 exp(-(v / v_d)^2), m/s
  double viscous = 0;               // sigma2, N s/m, on top of the rig's b
};

// leakage: across the piston seal (P <-> N) and from chamber P to the atmosphere (a rod seal or a
// fitting), each a SeriesRestriction, partly laminar and partly turbulent. Zero conductance: none.
struct Leakage {
  SeriesRestriction piston;
  SeriesRestriction atmosphere_P;
};

// line_dynamics: a tube between each valve port and its chamber, resolved into `segments` volumes
// in a row, each joined to the next (and the last to the chamber) by a SeriesRestriction with
// 1/segments of the tube's resistance (laminar conductance x segments, orifice area x sqrt(segments)).
// The tube's gas follows the chambers' polytropic law at the rig's temperature. A diffusive line of
// several volumes, where the candidate is one volume behind one restriction (and a Pade delay).
struct Tube {
  double volume = 0;  // m^3, each chamber's tube; 0: no tube
  int segments = 4;
  SeriesRestriction restriction;  // of the whole tube
};

// supply_drop: the valves are fed from a manifold, filled through a hose (SeriesRestriction) from a
// tank that a compressor charges: the compressor's flow falls linearly with the tank pressure to 0
// at its stall pressure, and a pressure switch runs it between two pressures (on below switch_on,
// off above switch_off; the switch is read after every fine step). Tank and manifold are
// isothermal at the rig's temperature. The logged p_S is the tank's pressure (the regulator's gauge),
// not the valves' inlet. The candidates are a lower constant supply, one tank behind one line, and the
// logged p_S as the valves' supply.
struct SupplySystem {
  bool on = false;
  double tank_volume = 0;         // m^3
  double manifold_volume = 0;     // m^3
  SeriesRestriction hose;         // tank -> manifold
  double compressor_flow = 0;     // kg/s into the tank at atmospheric tank pressure
  double stall_pressure = 0;      // Pa abs: the compressor's flow falls to 0 here
  double switch_on = 0, switch_off = 0;  // Pa abs: the pressure switch's band
};

// valve_delay, in forms of the suite's own:
// - every valve: an exact transport delay of the commands (a field bus), breakpoints exact, so a
//   delay of a fraction of a row shifts every switch within the row;
// - rig A: the armature of each on/off valve starts to move only after an opening (closing) delay
//   with the coil energised (de-energised) all along, so a pulse shorter than the delay is lost, and
//   then opens (closes) its conductance linearly over a travel time (the candidate switches at once);
// - rig B: a second-order spool, x_v'' = w^2 (k_v u - x_v) - 2 zeta w x_v', instead of docs/rigs.md's lag;
// - rig C: each valve's voltage behind a first-order lag (docs/rigs.md's valve has none).
struct ValveTiming {
  double command_delay = 0;                     // s
  double open_delay = 0, close_delay = 0;       // s, rig A
  double open_travel = 0, close_travel = 0;     // s, rig A: 0 switches the conductance at once
  double spool_natural_frequency = 0;           // rad/s, rig B (0: docs/rigs.md's first-order spool)
  double spool_damping_ratio = 0.7;             // 1, rig B
  double voltage_lag = 0;                       // s, rig C (0: none)
};

// heat_transfer: the gas energy equation of each chamber (Richer and Hurmuzlu, J. Dyn. Syst. 122,
// 2000, eqs. 11-12, with its heat term), a chamber's temperature a state, in-flows at the supply's
// temperature, out-flows at the chamber's, and wall heat h A_wall(x) (T_wall - T) through the barrel
// wall the chamber's length exposes: A_wall = 2 A + perimeter (length + V0 / A). The chamber's
// polytropic index is not used then (nor rig B's work factor). The candidate has one wall
// conductance per chamber, independent of the position.
struct WallHeat {
  bool on = false;
  double coefficient = 0;       // h, W/(m^2 K)
  double heat_capacity_ratio = 1.4;
  double wall_temperature = 0;  // K; 0: the rig's temperature
};

// --- effects outside the library (the right verdict is `unexplained`) ------------------------------

// backlash in the load's linkage: a load of a fraction of the moving mass joined to the piston
// through a play (a clevis pin in a worn hole): no force within the gap, a stiff damped contact at
// its ends; the load's guide carries part of the viscous friction, and the position sensor sits on
// the load. The moving mass is the rig's.
struct Backlash {
  double gap = 0;                    // m, the whole play (0: rigid)
  double load_fraction = 0.6;        // of the moving mass
  double contact_frequency = 300;    // Hz, of the load on the contact's stiffness
  double contact_damping_ratio = 0.3;
  double load_damping_fraction = 0.3;  // of b, on the load's guide
};

// a valve flow gain that drifts as the valves' coils warm over a log: every valve's flow times
// 1 - drop (1 - exp(-t / time_constant)), t from the log's start (each log starts cold)
struct FlowGainDrift {
  double drop = 0;             // 1, the fraction of flow lost once warm
  double time_constant = 4.0;  // s
};

// hysteresis of the valve opening against its command: a play operator (backlash operator) of
// half-width w on the command voltage, y = min(max(y, u - w), u + w) (Krasnosel'skii and Pokrovskii),
// applied to rig B's saturated voltage and to each of rig C's valve voltages
struct ValveHysteresis {
  double half_width = 0;  // V
};

// a tight spot in the bore: a Coulomb-like force F tanh(v / v_eps) over [from, to] of the stroke,
// faded in and out over `edge` with a raised cosine, none elsewhere
struct TightSpot {
  double force = 0;      // N
  double from = 0, to = 0;  // m, of x
  double edge = 2e-3;    // m
  double velocity = 2e-3;  // v_eps, m/s
};

// a leak from chamber P to the atmosphere that opens only above a cracking pressure (a relief
// valve, a seal lip lifting): an ISO 6358 law (critical ratio 0.5) whose conductance grows from 0 at
// the cracking pressure to its full value over `opening` Pa (smoothstep)
struct CrackingLeak {
  double conductance = 0;       // kg/(s Pa), fully open
  double cracking_pressure = 0; // Pa abs
  double opening = 2e4;         // Pa
};

// a spring the piston meets over part of its stroke (a bumper, a cable's slack taken up):
// F = -k (x - from) for x > from, none below
struct PartialSpring {
  double stiffness = 0;  // N/m
  double from = 0;       // m, of x
};

// --- the real rig ---------------------------------------------------------------------------------

struct RealRigParams {
  RigParams rig;  // docs/rigs.md's physics, perturbed (rig.dead_volume is not used: the two below are)
  double dead_volume_P = 0, dead_volume_N = 0;  // m^3
  // the flow laws' ratio of specific heats (rig B's C1, rig C's thin plate): the gas's, not the
  // chambers' polytropic index, so that perturbing the latter leaves the valves alone
  double flow_gamma = 1.4;
  double end_stop_stiffness = 1e6;  // N/m at x = +-stroke/2, damped near critically on the moving mass

  LuGreFriction friction;
  Leakage leakage;
  Tube tube;
  SupplySystem supply;
  ValveTiming timing;
  WallHeat heat;
  double added_mass = 0;        // payload, kg
  double voltage_deadband = 0;  // valve_deadband of rig C: V around 5 V; rig B's is rig.spool_deadband

  Backlash backlash;
  FlowGainDrift drift;
  ValveHysteresis hysteresis;
  TightSpot tight_spot;
  CrackingLeak cracking_leak;
  PartialSpring spring;
};

// docs/rigs.md's rig with every effect off: per-chamber dead volumes V0, flow_gamma = the rig's index
RealRigParams NominalRealRig(Rig rig);

// The sensors: a first-order lag on each pressure sensor, then Gaussian noise; the position
// sensor's noise, then its quantisation; sensor_bias as zero + offset + gain (s - zero) on one
// signal (zero = the exhaust pressure for a pressure, 0 for x), before the noise.
struct Sensors {
  double noise_pressure = 500;  // Pa, standard deviation
  double noise_position = 5e-5; // m
  double pressure_lag = 0.05e-3; // s (0: none)
  double position_quantum = 5e-6; // m (0: none)
  std::string biased;           // "", "p_P", "p_N" or "x"
  double offset = 0, gain = 1;  // Pa or m, and 1
};

// A deterministic Gaussian source (splitmix64 and Box-Muller), the same bits on every platform.
class NormalSource {
 public:
  explicit NormalSource(uint64_t seed) : state_(seed) {}
  uint64_t Next();
  double Uniform();  // [0, 1)
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  double Normal();

 private:
  uint64_t state_;
  bool has_spare_ = false;
  double spare_ = 0;
};

// what the sensors read at one instant
struct Reading {
  double p_P = 0, p_N = 0, x = 0, p_S = 0;
};

class RealRig {
 public:
  // indices of the state vector
  enum : int {
    kX, kV, kPP, kPN, kSpool, kSpoolRate, kVoltP, kVoltN, kZ, kTP, kTN, kTank, kManifold, kLoadX, kLoadV,
    kSensorP, kSensorN, kSensorS, kTubeP, kTubeN = kTubeP + 8, kStates = kTubeN + 8
  };
  using State = std::array<double, kStates>;
  static constexpr int kMaxSegments = 8;

  // `fine_step` s of RK4; throws std::invalid_argument on a bad parameter set
  RealRig(const RealRigParams& params, const Sensors& sensors, double fine_step);

  // Applies `command` from Time() for `duration` s (a log row: zero-order hold).
  void Advance(const RigCommand& command, double duration);

  double Time() const { return time_; }
  const State& state() const { return state_; }
  // sets the state (the tests start from pressures of their own)
  void SetState(const State& s) { state_ = s; }
  // the rod position the position sensor sees: the load's with backlash, the piston's otherwise
  double SensedPosition() const;
  // the sensors now; `noise` draws their noise (nullptr: noise-free, quantised and biased still)
  Reading Read(NormalSource* noise) const;
  // d/dt of the state at time t under the held inputs (public for the tests)
  State Derivative(const State& s, double t) const;

 private:
  // the valves' inputs from time t to the next breakpoint: the delayed command, the armature,
  // the hysteresis and the deadband
  void Hold(double t);
  double NextBreakpoint(double t, double t_end) const;
  // RK4 over `duration` s with the inputs held, in equal steps of at most the fine step
  void Integrate(double duration);
  State Rk4Step(const State& s, double t, double h) const;
  RigCommand EffectiveCommand(double t) const;

  RealRigParams p_;
  Sensors sensors_;
  double fine_step_;
  double time_ = 0;
  State state_{};
  std::vector<std::pair<double, RigCommand>> commands_;  // issue time, command
  // rig A armature, per valve: the coil's command, when it last changed, whether the armature is driven
  std::array<double, 4> coil_{}, coil_edge_{}, drive_{}, opening_{}, opening_rate_{};
  double hold_start_ = 0;
  double play_u_ = 0, play_uP_ = 5, play_uN_ = 5;  // hysteresis outputs
  double held_u_ = 0, held_uP_ = 5, held_uN_ = 5;  // the valves' inputs over the current interval
  bool compressor_on_ = false;
  double mass_ = 0;  // the moving mass, kg
};

}  // namespace pneumatic::reference
