// An independent, MuJoCo-free reference implementation of the three benchmark rigs of
// docs/rigs.md: the full ODEs (mechanics, chamber pressures, rig B's spool) integrated
// with a fine fixed-step classical RK4. Tests and benchmarks use it as the "fine-step
// reference" against which the MuJoCo extension is checked.
//
// Units are SI throughout: m, m/s, kg, s, N, K, V; pressures are ABSOLUTE, in Pa; mass flows
// in kg/s, counted positive INTO a chamber (or from the first pressure argument to the second).
#pragma once

#include <cstdint>
#include <vector>

namespace pneumatic::reference {

// the rigs of docs/rigs.md
enum class Rig {
  kOnOff,         // rig A: four on/off solenoid valves (papers 002, 003)
  kProportional,  // rig B: one proportional 5/3 valve with spool lag (paper 001)
  kPerChamber,    // rig C: one proportional 3/3 valve per chamber (paper 000)
};

// Every number of docs/rigs.md for one rig. Fields that a rig does not use are 0.
struct RigParams {
  Rig rig = Rig::kOnOff;

  // geometry and mechanics (all rigs)
  double stroke = 0;            // m; l (A) or L (B, C); x in [-stroke/2, stroke/2]
  double area_P = 0;            // m^2; A (A, B) or A_P (C), chamber P (pushes x positive)
  double area_N = 0;            // m^2; A (A, B) or A_N (C), chamber N
  double dead_volume = 0;       // m^3; V0, each chamber
  double mass = 0;              // kg; M, moving mass
  double friction = 0;          // N s/m; b, viscous friction

  // gas and reservoirs (all rigs)
  double supply_pressure = 0;   // Pa abs; P_S (A), P_s (B), P_c (C)
  double exhaust_pressure = 0;  // Pa abs; P_E (A), P_atm (B), P_r (C)
  double temperature = 0;       // K; T, equal in chambers, supply and exhaust
  double polytropic_index = 0;  // 1; k (A, polytropic index), gamma (B) or kappa (C)
  double control_period = 0;    // s; zero-order hold period of the commands

  // rig A and B: specific gas constant
  double gas_constant = 0;           // J/(kg K); r (A) or R (B)

  // rig A: ISO 6358 valves (paper 002 eq. 4)
  double valve_conductance = 0;      // kg/(s Pa); C_val
  double valve_critical_ratio = 0;   // 1; b_crit

  // rig B: proportional valve with spool (paper 001)
  double work_factor = 0;            // 1; alpha, on the piston-work term only
  double discharge_coefficient = 0;  // 1; C_d (B) or C (C)
  double area_gradient = 0;          // m^2/m; w
  double spool_gain = 0;             // m/V; k_v
  double spool_time_constant = 0;    // s; tau_v
  double spool_critical_ratio = 0;   // 1; P_cr
  double voltage_limit = 0;          // V; |u| saturates here (5 V)
  double spool_deadband = 0;         // 1; fraction of the full spool range 2 k_v 5 V; 0 nominal
                                     //    (paper 001: 0.12). Not part of docs/rigs.md's nominal model.

  // rig C: thin-plate ports (paper 000 eq. 1, 3)
  double molar_mass = 0;             // kg/mol; Mm
  double universal_gas_constant = 0; // J/(mol K); Rg
  double compressibility = 0;        // 1; Z
  double area_per_volt = 0;          // m^2/V; B (2 mm^2/V)
  double supply_seal_voltage = 0;    // V; U_c
  double exhaust_seal_voltage = 0;   // V; U_r
  double supply_leak_area = 0;       // m^2; L_c
  double exhaust_leak_area = 0;      // m^2; L_r
};

// exactly docs/rigs.md's numbers for `rig` (spool_deadband = 0)
RigParams DefaultParams(Rig rig);

// the control period of `rig`: 2 ms (A), 1 ms (B), 10 ms (C)
double ControlPeriod(Rig rig);

// State: x (m, 0 at mid-stroke), v (m/s), p_P and p_N (Pa abs), spool x_v (m, rig B only).
// Derivative() returns d/dt of each field in the same struct.
struct RigState {
  double x = 0, v = 0, p_P = 1e5, p_N = 1e5, spool = 0;
};

// Commands, held over a control period. Rig A uses u1..u4 (0 or 1: U1 P-supply, U2 P-exhaust,
// U3 N-supply, U4 N-exhaust); rig B uses u (V relative to valve centre, saturated at +-5 V);
// rig C uses uP, uN (V, one valve per chamber, used in [3, 7]).
struct RigCommand {
  double u1 = 0, u2 = 0, u3 = 0, u4 = 0;
  double u = 0;
  double uP = 5, uN = 5;
};

// --- flow laws, each written for pu >= pd and run in reverse otherwise: Q(pu,pd) = -Q(pd,pu) ---

// ISO 6358 on/off valve (rig A; paper 002 eq. 4). c_val in kg/(s Pa), b_crit critical ratio,
// pressures in Pa abs; returns kg/s from pu to pd.
double FlowIso6358(double c_val, double b_crit, double pu, double pd);

// Sanville-type orifice (rig B; paper 001 eq. 2): C1 a pu / sqrt(T) psi. `area` in m^2,
// temperature in K, p_cr critical ratio, gamma and gas_constant (J/(kg K)) give C1;
// returns kg/s from pu to pd.
double FlowSanville(double area, double temperature, double gamma, double gas_constant,
                    double p_cr, double pu, double pd);

// Thin-plate port flow phi(pu, pd) times area (rig C; paper 000 eq. 1 and Appendix).
// `area` in m^2; kappa, discharge coefficient C, molar mass Mm (kg/mol), Rg (J/(mol K)),
// compressibility Z, temperature T (K); returns kg/s from pu to pd.
double FlowThinPlate(double area, double kappa, double discharge, double molar_mass,
                     double universal_gas_constant, double compressibility, double temperature,
                     double pu, double pd);

// Paper 000 eq. (3) port area L + smax(y - L) with smax(y) = (sqrt(y^2 + 1) + y) / 2 evaluated
// in mm^2: `opening` is (u - U_c) B for the supply port or (U_r - u) B for the exhaust port
// and `leak` is L_c or L_r, both in m^2. Returns m^2.
double ValveAreaPaper000(double opening, double leak);

// rig C's supply-port area a_c(u) and exhaust-port area a_r(u), m^2, for a command u in V
double SupplyPortArea(const RigParams& p, double u);
double ExhaustPortArea(const RigParams& p, double u);

// Chamber volumes V_P = A_P (L/2 + x) + V0, V_N = A_N (L/2 - x) + V0 in m^3 (docs/rigs.md).
double ChamberVolumeP(const RigParams& p, double x);
double ChamberVolumeN(const RigParams& p, double x);

// --- dynamics and integration ---

// d/dt of (x, v, p_P, p_N, spool) per docs/rigs.md for p.rig under a held command.
RigState Derivative(const RigParams& p, const RigState& s, const RigCommand& cmd);

// Classical RK4 with step fine_dt (s) over `duration` (s), the command held (ZOH); the last
// step is shortened so that it ends exactly at `duration`. Returns the state at `duration`.
RigState Integrate(const RigParams& p, RigState s, const RigCommand& cmd, double duration,
                   double fine_dt);

// One row of a log (docs/log_format.md): the command applied from `time` on, and the state
// sampled at `time`, before that command acts.
struct Sample {
  double time;  // s
  RigCommand command;
  RigState state;
};

// Simulates a command sequence: commands[k] is held on [k period, (k+1) period). Returns one
// sample per command, taken at the START of its interval (time k * period).
std::vector<Sample> Simulate(const RigParams& p, const RigState& initial,
                             const std::vector<RigCommand>& commands, double period,
                             double fine_dt);

// A reproducible excitation of `rig` (nominal DefaultParams, starting from the default
// RigState) over `duration` s at ControlPeriod(rig): one command per period. Deterministic
// for a `seed` (own LCG, no std distributions). Each generator closes a loose position loop on
// its own copy of the reference, integrated with kExcitationStep, so that the piston wanders
// over the stroke but stays inside |x| < 0.8 L/2 (tested); see rig_reference.cc for details.
// A: random modes of paper 002 Table I, held 2-8 periods, overridden by the Table II choice
//    when a predicted position error leaves a band around a random set point;
// B: multi-sine plus random steps in V, minus position/velocity feedback, saturated at +-5 V;
// C: common-mode sweep/steps plus differential steps and feedback, clamped to [3, 7] V.
// `period` > 0 replaces the rig's control period: the commands are then meant to be held that long.
// `pattern` kFastSwitching gives FastSwitchingExcitation() instead (then `period` must be 0).
enum class ExcitationPattern { kDefault, kFastSwitching };
std::vector<RigCommand> Excitation(Rig rig, double duration, uint32_t seed, double period = 0,
                                   ExcitationPattern pattern = ExcitationPattern::kDefault);

// Fast mode switching, as a sliding-mode controller switches: piecewise-constant commands, each
// held a random whole number of control periods uniform in [10 ms, 80 ms] (A: 5-40 periods,
// B: 10-80, C: 1-8), one command per control period over `duration` s. Deterministic per `seed`
// (own LCG); different from Excitation()'s sequence for the same seed.
// A: any of paper 002 Table I's nine modes at random, overridden by the Table II choice when the
//    predicted position error leaves a band around a random set point (as Excitation());
// B: u = sat(r - 10 V/m x - 0.5 V s/m v), r uniform in [-2.5, 2.5] V, x and v at the segment's
//    start (a quarter of Excitation()'s feedback gains, which are made for 1 kHz updates: see
//    rig_reference.cc);
// C: uP = 5 + c + d, uN = 5 + c - d clamped to [3, 7] V, c uniform in [-1, 1] V,
//    d = r - 40 V/m x - 0.3 V s/m v (Excitation()'s feedback) with r uniform in [-2, 2] V.
// A command is never followed by the same one, so none is held longer than 80 ms.
// Each segment is first simulated on the generator's own copy of the reference (RK4 at
// kExcitationStep); if |x + kFastSwitchingLead v| would leave 0.7 L/2 at a period's end, the
// other candidates are tried (A: the other modes in a random order; B, C: r halved, then r = 0),
// then the shortest hold; failing all, the candidate that stays nearest the centre is used.
// So the piston stays inside |x| < 0.8 L/2 (checked by tests/rig_replay_test.cc).
std::vector<RigCommand> FastSwitchingExcitation(Rig rig, double duration, uint32_t seed);

// shortest and longest hold of FastSwitchingExcitation(), s
inline constexpr double kFastSwitchingMinHold = 10e-3;
inline constexpr double kFastSwitchingMaxHold = 80e-3;
// its look-ahead on the velocity, s
inline constexpr double kFastSwitchingLead = 0.02;

// the RK4 step the excitation generators use internally, s
inline constexpr double kExcitationStep = 1e-5;

}  // namespace pneumatic::reference
