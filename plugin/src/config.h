// Configuration of one pneumatic cylinder, read from the MJCF text element
// "pneumatic:<cylinder>" and validated against the parameter table of
// config.cc (which also documents every key: plugin/README.md, pneumo params).
#ifndef PNEUMATIC_CONFIG_H_
#define PNEUMATIC_CONFIG_H_

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace pneumatic {

// what meters air into the chambers
enum class ValveKind {
  kOnOff,                   // four on/off solenoid valves (paper 002 Fig. 1, Table I)
  kProportional53,          // one 5/3 proportional valve (paper 001, Festo MPYE)
  kProportionalPerChamber,  // one proportional 3/3 valve per chamber (paper 000 eq. 3)
};

// how the on/off valves are commanded
enum class CommandInput {
  kValves,  // u1..u4 in {0, 1}
  kPwm,     // duty in [-1, 1] (paper 003 eqs. 12-13)
};

// where a switched PWM pulse sits in its carrier period
enum class PwmAlignment {
  kCenter,   // centred on the period's middle (symmetric, triangle-carrier PWM)
  kLeading,  // from the period's start (edge-aligned, sawtooth-carrier PWM)
};

// where a cylinder's valve commands are read from
enum class CommandPlace {
  kActuators,  // their own actuators, "<name>.uP", "<name>.uN", "<name>.u", "<name>.duty", "<name>.u1".."u4"
  kChambers,   // the ctrl of the chamber actuators: uP, u and duty in "<name>.P", uN in "<name>.N"
};

// how a cylinder's piston position follows the robot's joints
enum class Mount {
  kTransmission,  // x = actuator_length - x_mid: MuJoCo's joint, slider-crank or tendon transmission
  kHingeSites,    // x = |rod - cap| - x_mid between sites "<name>.cap" and "<name>.rod" on the two bodies of
                  // one hinge, computed by the extension (no MuJoCo tendon to pay for)
};

// mass flow through one valve port
enum class FlowLaw {
  kIso6358,    // sonic conductance and critical ratio (paper 002 eq. 4, paper 003 eq. 3)
  kSanville,   // area form of paper 001 eq. 2
  kThinPlate,  // isentropic thin-plate orifice (paper 000 eq. 1, Appendix)
};

// how a chamber's pressure evolves
enum class PressureModel {
  kPhysical,    // flow law + polytropic chamber (paper 000 eq. 4, paper 001 eq. 1)
  kIdentified,  // identified p' = (s - p) r (paper 000 eqs. 6, 10, exact step 7)
};

// seal friction model of a cylinder with coulomb_friction
enum class FrictionModel {
  kCoulombStribeck,  // Stribeck curve as bias, static level from the transmission's frictionloss (default)
  kLuGre,            // dynamic bristle model (Canudas de Wit et al. 1995), state "<cyl>.z"
};

// how the gas temperature of the chambers is modelled
enum class ThermalModel {
  kPolytropic,  // p V^n = const for a sealed chamber, T fixed in the flow laws (default)
  kEnergy,      // the energy equation of an open chamber with wall heat (Richer and Hurmuzlu 2000), states "<cyl>.TP/TN"
};

// how the chamber ODE is advanced over one MuJoCo step
enum class ChamberStep {
  kLinearized,  // exponential step of the flow linearised at the step's start, adaptive fallback (default)
  kExact,       // adaptive implicit integration inside the step, always
  kExplicit,    // act_dot = dp/dt at the start of the step: MuJoCo's plain Euler, for comparison only
};

// paper 000 eq. 10 parameters; v is the piston position x, v' its rate
struct IdentifiedParams {
  double c[10] = {0};     // c[1]..c[9]; c[0] unused so indices match the paper
  double c_gamma = 0.1;   // V, fixed globally in the paper
  double c_b = 0;         // Pa abs, (P_c + P_r)/2 unless given
  double c_s = 0;         // Pa, (P_c - P_r)/2 unless given
};

struct ChamberConfig {
  double area = 0;               // m^2 (m^3/rad for a rotary cylinder): piston area on this side
  double dead_volume = 0;        // m^3: volume at the end of stroke (ports and tube included)
  double polytropic_index = 0;   // n of p V^n = const for a sealed chamber
  double work_factor = 0;        // alpha of paper 001 eq. 1 on the piston-work term (1: none)
  PressureModel model = PressureModel::kPhysical;
  FlowLaw flow = FlowLaw::kIso6358;
  double discharge_coefficient = 0;  // C_d (sanville) or C (thin plate)
  double critical_ratio = 0;         // b (iso6358) or P_cr (sanville)
  double sonic_conductance = 0;      // C_val = C rho0, kg/(s Pa), per open on/off valve (iso6358)
  double port_area = 0;              // m^2 per open on/off valve (sanville, thin plate)
  // paper 000 eq. 3 valve of this chamber (kProportionalPerChamber)
  double area_gain = 0;          // B, m^2/V
  double u_supply_seal = 0;      // U_c, V
  double u_exhaust_seal = 0;     // U_r, V
  double leak_area_supply = 0;   // L_c, m^2
  double leak_area_exhaust = 0;  // L_r, m^2
  double area_smoothing = 0;     // m^2: the unit inside smax (the paper's mm^2)
  double atmosphere_leak_conductance = 0;  // kg/(s Pa): laminar leak G (p - p_atm) out of the chamber
  double atmosphere_leak_area = 0;         // m^2: orifice leak to p_atm (Sanville form, C_d 1, b 0.528)
  double wall_heat_conductance = 0;        // h A, W/K, between the gas and the wall (thermal_model=energy)
  double line_volume = 0;                  // m^3: tube between valve and chamber (0: none)
  double line_conductance = 0;             // kg/(s Pa): ISO 6358 sonic conductance of the line's restriction
  IdentifiedParams identified;
};

struct CylinderConfig {
  std::string name;
  ValveKind valve = ValveKind::kOnOff;
  CommandInput input = CommandInput::kValves;
  double stroke = 0;           // m (rad for a rotary cylinder)
  double x_mid = 0;            // actuator length at mid-stroke
  double p_supply = 0;         // Pa abs
  double p_exhaust = 0;        // Pa abs
  double p_atm = 0;            // Pa abs, outside the piston; reference of the gauge activations
  double temperature = 0;      // K, gas temperature (supply, chambers and exhaust alike)
  double gas_constant = 0;     // J/(kg K), specific gas constant r
  double heat_capacity_ratio = 0;  // gamma (kappa) of the flow laws
  double compressibility = 0;      // Z of the thin-plate law
  // kProportional53 spool (paper 001 eq. 1)
  double spool_gain = 0;           // k_v, m/V
  double spool_time_constant = 0;  // tau_v, s (0: spool follows the command at once); also per chamber
  // kProportional53 and kProportionalPerChamber: dead time of the command, (1,2) Pade approximant (valves.h)
  double spool_dead_time = 0;      // T, s (0: none)
  // line_dynamics' transport delay L/c of the tubes to the chambers, s (0: none): the project's own
  // form, a dead time of the command like spool_dead_time and added to it (the same delay line)
  double line_delay = 0;
  double CommandDeadTime() const { return spool_dead_time + line_delay; }
  double u_max = 0;                // V, command saturation
  double orifice_gradient = 0;     // w, m^2/m
  double deadband = 0;             // fraction of the full spool range 2 k_v u_max with no flow
  // kProportionalPerChamber: voltage band added on both sides of the sealed band [U_r, U_c] of eq. 3
  double deadband_voltage = 0;     // V
  // kOnOff switching
  double delay_open = 0;       // s, opening delay of each valve (paper 002: 1.3 ms)
  double delay_close = 0;      // s, closing delay (paper 002: 0.2 ms)
  double pwm_frequency = 0;    // Hz; 0 with input=pwm: the averaged model of paper 003 eq. 14
  PwmAlignment pwm_alignment = PwmAlignment::kCenter;
  CommandPlace commands = CommandPlace::kActuators;
  Mount mount = Mount::kTransmission;
  // seal friction on top of the joint's (or tendon's) frictionloss
  std::optional<double> coulomb_friction;  // N (N m): sliding friction level
  double stribeck_velocity = 0;            // m/s (rad/s)
  FrictionModel friction_model = FrictionModel::kCoulombStribeck;
  // LuGre (friction_model=lugre): F = sigma0 z + sigma1 dz/dt + sigma2 v, Canudas de Wit et al. 1995
  double static_friction = 0;    // F_s, N (N m): breakaway level
  double bristle_stiffness = 0;  // sigma0, N/m (N m/rad)
  double bristle_damping = 0;    // sigma1, N s/m (N m s/rad)
  double viscous_friction = 0;   // sigma2, N s/m (N m s/rad)
  ThermalModel thermal_model = ThermalModel::kPolytropic;
  double piston_leak_conductance = 0;      // kg/(s Pa): laminar leak G (p_P - p_N) from P to N
  double piston_leak_area = 0;             // m^2: orifice leak across the piston (Sanville form, C_d 1, b 0.528)
  // the supply reservoir ("pneumatic_reservoir:<supply>") feeding the supply ports; empty: the
  // compressor at p_supply feeds them directly
  std::string supply;
  // numerical method
  ChamberStep step = ChamberStep::kLinearized;
  double step_tolerance = 0;   // local error per substep, fraction of p_supply - p_exhaust
  ChamberConfig chamber[2];    // [0] = P, [1] = N
};

// Parses "key=value key=value ..." (whitespace separated) for cylinder `name`,
// fills defaults and checks every value against the parameter table.
// Returns nullopt and sets *error ("cylinder 'cyl': key 'x': ...") on failure.
std::optional<CylinderConfig> ParseCylinderConfig(const std::string& name, const std::string& text,
                                                  std::string* error);

// The configuration as MJCF text: every key that applies, numbers in their shortest exact form,
// so ParseCylinderConfig(name, FormatConfig(c)) gives c back exactly.
std::string FormatConfig(const CylinderConfig& c);

// A configuration as numbers, one per table row (two for chamber rows: P, N):
// numbers as they are, choices as their index, coulomb_friction -1 when unset.
// This is how a cylinder's parameters are stored in mjModel.
int PackedConfigSize();
void PackConfig(const CylinderConfig& c, double* out);  // writes PackedConfigSize() numbers
// back from numbers, validated by the parser as MJCF text would be; the supply reservoir's name is
// not a number, and the engine stores it apart (as its actuator's id)
std::optional<CylinderConfig> UnpackConfig(const std::string& name, const double* values, std::string* error,
                                           const std::string& supply = "");

// The value of one key ("stroke", "P.area"; choices as their index), or nullopt and
// *error when the key is unknown, needs a P./N. prefix, or does not apply.
std::optional<double> ConfigValue(const CylinderConfig& c, const std::string& key, std::string* error);

// A copy of c with each key set to its value (text, as in MJCF; a chamber key without
// prefix sets both chambers), in order, checked together exactly as the MJCF is.
std::optional<CylinderConfig> WithValues(const CylinderConfig& c,
                                         const std::vector<std::pair<std::string, std::string>>& values,
                                         std::string* error);

// the shortest text that reads back to the same double
std::string FormatNumber(double v);

}  // namespace pneumatic

#endif  // PNEUMATIC_CONFIG_H_
