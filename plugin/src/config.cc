// Parameter table, parsing and validation of "pneumatic:<cylinder>" text.
#include "config.h"

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <map>
#include <set>
#include <sstream>
#include <vector>

#include "pneumatic/pneumatic.h"

namespace pneumatic {
namespace {

enum class Scope { kCylinder, kChamber };

// which configurations a key applies to; giving it elsewhere is an error
enum class AppliesTo {
  kAll,
  kOnOff,            // valve=onoff
  kPwm,              // valve=onoff input=pwm
  kProportional53,   // valve=proportional_5_3
  kPerChamber,       // valve=proportional_per_chamber
  kProportional,     // valve=proportional_5_3 or proportional_per_chamber
  kIso6358,          // flow=iso6358
  kEllipticLaw,      // flow=iso6358 or sanville
  kAreaLaw,          // flow=sanville or thin_plate
  kOnOffAreaLaw,     // valve=onoff with flow=sanville or thin_plate
  kThinPlate,        // flow=thin_plate
  kIdentified,       // pressure_model=identified
  kFriction,         // coulomb_friction given
  kLuGre,            // friction_model=lugre
  kGamma,            // flow=sanville or thin_plate, or thermal_model=energy
  kEnergy,           // thermal_model=energy
  kLine,             // line_volume > 0 (this chamber)
};

// one row of the table: documentation and checks in one place
struct Param {
  const char* key;
  Scope scope;
  AppliesTo applies;
  const char* unit;
  const char* default_value;  // nullptr: required; "derived": computed from others
  const char* choices;        // space separated, nullptr for numbers
  double min, max;            // valid range for numbers
  bool min_open, max_open;    // true: the bound itself is excluded
  const char* meaning;
  // the value in a configuration (k: chamber); nullptr for choices, names and coulomb_friction
  double& (*field)(CylinderConfig& c, int k);
  bool is_name = false;  // the value is a name (supply), neither a number nor a choice; not packed
};

// accessors of a row's value in a configuration; k is the chamber (0 = P, 1 = N) for chamber keys
#define CYL(field) [](CylinderConfig& c, int) -> double& { return c.field; }
#define CHAMBER(field) [](CylinderConfig& c, int k) -> double& { return c.chamber[k].field; }
#define IDENTIFIED(field) [](CylinderConfig& c, int k) -> double& { return c.chamber[k].identified.field; }

// every key of the MJCF configuration. Ranges are what is physically plausible, so that a
// mistyped exponent is refused here rather than diverging at the first step: pressures from 1 kPa
// to 100 bar absolute, strokes from 1 mm (1 mrad) to 10 m, piston areas from 0.1 mm^2 (a 0.36 mm
// bore) to 0.1 m^2 (a 36 cm bore), dead volumes from 1 mm^3 to 100 litres.
const Param kParams[] = {
    // cylinder
    {"valve", Scope::kCylinder, AppliesTo::kAll, "", nullptr, "onoff proportional_5_3 proportional_per_chamber", 0, 0, false, false,
     "valve arrangement: four on/off valves (paper 002), one 5/3 proportional valve (paper 001), or one proportional valve per chamber (paper 000)", nullptr},
    {"input", Scope::kCylinder, AppliesTo::kOnOff, "", "valves", "valves pwm", 0, 0, false, false,
     "on/off valves commanded one by one (u1..u4) or by one duty in [-1, 1] (paper 003 eqs. 12-13)", nullptr},
    {"stroke", Scope::kCylinder, AppliesTo::kAll, "m (rad)", nullptr, nullptr, 1e-3, 10, false, false,
     "stroke length l; x in [-l/2, l/2]", CYL(stroke)},
    {"x_mid", Scope::kCylinder, AppliesTo::kAll, "m (rad)", "0", nullptr, -100, 100, false, false,
     "actuator length at mid-stroke, so x = actuator_length - x_mid", CYL(x_mid)},
    {"p_supply", Scope::kCylinder, AppliesTo::kAll, "Pa abs", "600000", nullptr, 1e3, 1e7, false, false,
     "supply (compressor) pressure", CYL(p_supply)},
    {"p_exhaust", Scope::kCylinder, AppliesTo::kAll, "Pa abs", "101325", nullptr, 1e3, 1e7, false, false,
     "exhaust pressure; must be below p_supply", CYL(p_exhaust)},
    {"p_atm", Scope::kCylinder, AppliesTo::kAll, "Pa abs", "p_exhaust", nullptr, 1e3, 1e7, false, false,
     "ambient pressure on the outer piston faces; the activations are p - p_atm", CYL(p_atm)},
    {"temperature", Scope::kCylinder, AppliesTo::kAll, "K", "293.15", nullptr, 150, 1500, false, false,
     "gas temperature T, the same in supply, chambers and exhaust", CYL(temperature)},
    {"gas_constant", Scope::kCylinder, AppliesTo::kAll, "J/(kg K)", "287", nullptr, 50, 5000, false, false,
     "specific gas constant r of the gas (R/M): 287 for air, 2077 for helium", CYL(gas_constant)},
    {"heat_capacity_ratio", Scope::kCylinder, AppliesTo::kGamma, "", "1.4", nullptr, 1, 1.7, true, false,
     "ratio of specific heats gamma (kappa) in the sanville and thin-plate flow laws, and in the energy equation of thermal_model=energy", CYL(heat_capacity_ratio)},
    {"compressibility", Scope::kCylinder, AppliesTo::kThinPlate, "", "1", nullptr, 0.5, 1.5, false, false,
     "compressibility factor Z of the thin-plate law (paper 000 Table II: 0.99)", CYL(compressibility)},
    {"spool_gain", Scope::kCylinder, AppliesTo::kProportional53, "m/V", "0.00025", nullptr, 0, 0.01, true, false,
     "spool position gain k_v (paper 001 Table I)", CYL(spool_gain)},
    {"spool_time_constant", Scope::kCylinder, AppliesTo::kProportional, "s", "derived", nullptr, 0, 1, false, false,
     "spool first-order lag tau_v (paper 001 eq. 1); 0 = no lag. Default 0.0042 for proportional_5_3 (act of <name>.u: the spool position), 0 for proportional_per_chamber (when > 0 the act of <name>.uP / <name>.uN is each valve's lagged voltage)", CYL(spool_time_constant)},
    {"spool_dead_time", Scope::kCylinder, AppliesTo::kProportional, "s", "0", nullptr, 0, 0.1, false, false,
     "valve dead time T: the command reaches the spool through the (1,2) Pade approximant of exp(-s T), (1 - s T/3)/(1 + 2 s T/3 + (s T)^2/6) (states <name>.d1, <name>.d2 for proportional_5_3; <name>.dP1, <name>.dP2, <name>.dN1, <name>.dN2 per chamber); 0 = none", CYL(spool_dead_time)},
    {"line_delay", Scope::kCylinder, AppliesTo::kProportional, "s", "0", nullptr, 0, 0.1, false, false,
     "transport delay L/c of the tubes between the valve and the chambers (about 3 ms per metre of tube): the chambers feel a change of the command this much later. The project's own form: a dead time of the command added to spool_dead_time, through the same (1,2) Pade delay line and states (the wave's return from the chamber to the valve is not delayed); 0 = none", CYL(line_delay)},
    {"u_max", Scope::kCylinder, AppliesTo::kProportional53, "V", "5", nullptr, 0, 100, true, false,
     "command saturation: the spool is driven by clip(u, -u_max, u_max)", CYL(u_max)},
    {"orifice_gradient", Scope::kCylinder, AppliesTo::kProportional53, "m^2/m", "0.0226", nullptr, 0, 1, true, false,
     "orifice area per spool displacement w (paper 001 Table I: 22.6 mm^2/mm)", CYL(orifice_gradient)},
    {"deadband", Scope::kCylinder, AppliesTo::kProportional53, "", "0", nullptr, 0, 1, false, true,
     "flow deadband as a fraction of the full spool range 2 k_v u_max (paper 001: 0.12)", CYL(deadband)},
    {"deadband_voltage", Scope::kCylinder, AppliesTo::kPerChamber, "V", "0", nullptr, 0, 100, false, false,
     "spool deadband of each chamber's valve: the supply port opens only above U_c + deadband_voltage and the exhaust only below U_r - deadband_voltage (paper 000 eq. 3 with the seals shifted)", CYL(deadband_voltage)},
    {"delay_open", Scope::kCylinder, AppliesTo::kOnOff, "s", "0", nullptr, 0, 0.1, false, false,
     "opening delay of each on/off valve (paper 002: 1.3e-3); the armature model that realises it is the project's own", CYL(delay_open)},
    {"delay_close", Scope::kCylinder, AppliesTo::kOnOff, "s", "0", nullptr, 0, 0.1, false, false,
     "closing delay of each on/off valve (paper 002: 0.2e-3); the armature model that realises it is the project's own", CYL(delay_close)},
    {"pwm_frequency", Scope::kCylinder, AppliesTo::kPwm, "Hz", "0", nullptr, 0, 1e5, false, false,
     "PWM carrier frequency; 0 = the averaged model of paper 003 eq. 14", CYL(pwm_frequency)},
    {"pwm_alignment", Scope::kCylinder, AppliesTo::kPwm, "", "center", "center leading", 0, 0, false, false,
     "where each pulse of switched PWM sits in its carrier period: centred on the period's middle (symmetric PWM; its pulse has the same centroid as the averaged model's spread-out opening, so eq. 14 matches it to second order in the period) or from the period's start (edge-aligned PWM, as many microcontroller timers do by default; it shifts each pulse by up to half a period against eq. 14)", nullptr},
    {"commands", Scope::kCylinder, AppliesTo::kAll, "", "actuators", "actuators chambers", 0, 0, false, false,
     "where the valve commands are: their own actuators (<name>.uP and <name>.uN, <name>.u, <name>.duty, <name>.u1..u4), or the ctrl of the chamber actuators (uP, u and duty in <name>.P, uN in <name>.N): two actuators per cylinder instead of three or four, which saves MuJoCo's work on each actuator (a dense moment row each). chambers takes valves without state (no spool_time_constant, no delay_open or delay_close) and at most two commands (not valve=onoff with input=valves)", nullptr},
    {"mount", Scope::kCylinder, AppliesTo::kAll, "", "transmission", "transmission hinge_sites", 0, 0, false, false,
     "how the piston follows the joints: through the chamber actuators' transmission (x = actuator length - x_mid: a slide or hinge joint, a slider-crank or a tendon), or hinge_sites: a linear cylinder between the sites <name>.cap (on the parent body of a hinge) and <name>.rod (on the hinge's body), x = |rod - cap| - x_mid, whose length and lever arm the extension computes from the hinge (the chamber actuators drive that hinge, gear 1, gaintype user: their force is the torque the cylinder exerts). The same physics as a two-site spatial tendon, without MuJoCo's tendon work (Jacobians of both sites, a dense moment row) on every step", nullptr},
    {"thermal_model", Scope::kCylinder, AppliesTo::kAll, "", "polytropic", "polytropic energy", 0, 0, false, false,
     "gas temperature: polytropic chambers at a fixed temperature (default), or the energy equation of an open chamber with heat exchange with the wall at temperature (Richer and Hurmuzlu 2000; state actuators <name>.TP, <name>.TN; needs wall_heat_conductance)", nullptr},
    {"coulomb_friction", Scope::kCylinder, AppliesTo::kAll, "N (N m)", "none", nullptr, 0, 1e6, false, false,
     "sliding seal friction; static friction is the transmission's frictionloss (needs actuator <name>.friction)", nullptr},
    {"stribeck_velocity", Scope::kCylinder, AppliesTo::kFriction, "m/s (rad/s)", "0.01", nullptr, 0, 10, true, false,
     "v_s of the project's own Stribeck curve: friction falls from the static to the Coulomb level over this speed", CYL(stribeck_velocity)},
    {"friction_model", Scope::kCylinder, AppliesTo::kAll, "", "coulomb_stribeck", "coulomb_stribeck lugre", 0, 0, false, false,
     "seal friction: the Stribeck curve on top of the transmission's frictionloss (default), or the LuGre bristle model of Canudas de Wit et al. 1995 (state actuator <name>.z, frictionloss 0, needs coulomb_friction and static_friction)", nullptr},
    {"static_friction", Scope::kCylinder, AppliesTo::kLuGre, "N (N m)", nullptr, nullptr, 0, 1e6, true, false,
     "F_s of LuGre: the breakaway level; g(v) = F_c + (F_s - F_c) exp(-(v/v_s)^2) (Canudas de Wit et al. 1995 eq. 3); at least coulomb_friction", CYL(static_friction)},
    {"bristle_stiffness", Scope::kCylinder, AppliesTo::kLuGre, "N/m (N m/rad)", "1e5", nullptr, 0, 1e9, true, false,
     "sigma0 of LuGre: the presliding stiffness; a force F < F_s holds the piston after a creep of about F/sigma0 (1e5: 0.2 mm at 20 N)", CYL(bristle_stiffness)},
    {"bristle_damping", Scope::kCylinder, AppliesTo::kLuGre, "N s/m (N m s/rad)", "300", nullptr, 0, 1e6, false, false,
     "sigma1 of LuGre: bristle damping (the paper's choice 2 sqrt(sigma0 m) needs the moving mass; 300 damps sigma0 = 1e5 on about 0.2 kg)", CYL(bristle_damping)},
    {"viscous_friction", Scope::kCylinder, AppliesTo::kLuGre, "N s/m (N m s/rad)", "0", nullptr, 0, 1e6, false, false,
     "sigma2 of LuGre: viscous friction, F = sigma0 z + sigma1 dz/dt + sigma2 v", CYL(viscous_friction)},
    {"piston_leak_conductance", Scope::kCylinder, AppliesTo::kAll, "kg/(s Pa)", "0", nullptr, 0, 1e-6, false, false,
     "laminar leakage across the piston seal, mass flow G (p_P - p_N) from P to N (the project's own form)", CYL(piston_leak_conductance)},
    {"piston_leak_area", Scope::kCylinder, AppliesTo::kAll, "m^2", "0", nullptr, 0, 1e-4, false, false,
     "orifice leakage across the piston seal: the compressible orifice law of paper 001 eq. 2 (Sanville 1971) with C_d = 1 and critical ratio 0.528", CYL(piston_leak_area)},
    {"supply", Scope::kCylinder, AppliesTo::kAll, "", "none", nullptr, 0, 0, false, false,
     "supply reservoir feeding the valves' supply ports: the name of a <text name=\"pneumatic_reservoir:NAME\"> element (its keys below); none = the compressor at p_supply feeds them directly", nullptr, true},
    {"step", Scope::kCylinder, AppliesTo::kAll, "", "linearized", "linearized exact explicit", 0, 0, false, false,
     "chamber integration inside a MuJoCo step: linearized exponential with an adaptive fallback (default), always adaptive implicit (exact), or plain explicit Euler (comparison only)", nullptr},
    {"step_tolerance", Scope::kCylinder, AppliesTo::kAll, "", "1e-4", nullptr, 0, 0.1, true, false,
     "local error allowed per step (linearized) or substep (exact), as a fraction of p_supply - p_exhaust", CYL(step_tolerance)},
    // chamber (key applies to both chambers; P.key or N.key to one)
    {"area", Scope::kChamber, AppliesTo::kAll, "m^2 (m^3/rad)", nullptr, nullptr, 1e-7, 0.1, false, false,
     "piston area on this side (cap side P, rod side N); displacement per radian for a rotary cylinder", CHAMBER(area)},
    {"dead_volume", Scope::kChamber, AppliesTo::kAll, "m^3", nullptr, nullptr, 1e-9, 0.1, false, false,
     "chamber volume at the end of its stroke, ports and tube included", CHAMBER(dead_volume)},
    {"polytropic_index", Scope::kChamber, AppliesTo::kAll, "", "1.4", nullptr, 1, 1.7, false, false,
     "n: a sealed chamber follows p V^n = const (paper 002: 1.2; adiabatic air: 1.4); not used with thermal_model=energy", CHAMBER(polytropic_index)},
    {"work_factor", Scope::kChamber, AppliesTo::kAll, "", "1", nullptr, 0, 2, true, false,
     "alpha on the piston-work term of paper 001 eq. 1 (0.89 there); 1 elsewhere; not used with thermal_model=energy", CHAMBER(work_factor)},
    {"wall_heat_conductance", Scope::kChamber, AppliesTo::kEnergy, "W/K", nullptr, nullptr, 0, 1000, false, false,
     "h A: heat flow hA (T_wall - T) from the wall (at temperature) into the gas (Richer and Hurmuzlu 2000); 0 = adiabatic", CHAMBER(wall_heat_conductance)},
    {"line_volume", Scope::kChamber, AppliesTo::kAll, "m^3", "0", nullptr, 0, 1, false, false,
     "volume of the tube between the valve and the chamber, an isothermal state at temperature (state actuator <name>.LP / <name>.LN); 0 = no line, the valve feeds the chamber", CHAMBER(line_volume)},
    {"line_conductance", Scope::kChamber, AppliesTo::kLine, "kg/(s Pa)", nullptr, nullptr, 0, 1e-5, true, false,
     "sonic conductance C rho0 of the restriction between the line and the chamber, ISO 6358 with b = 0.433 as paper 002 eq. 4", CHAMBER(line_conductance)},
    {"atmosphere_leak_conductance", Scope::kChamber, AppliesTo::kAll, "kg/(s Pa)", "0", nullptr, 0, 1e-6, false, false,
     "laminar leakage to the atmosphere, mass flow G (p - p_atm) out of the chamber (the project's own form)", CHAMBER(atmosphere_leak_conductance)},
    {"atmosphere_leak_area", Scope::kChamber, AppliesTo::kAll, "m^2", "0", nullptr, 0, 1e-4, false, false,
     "orifice leakage to the atmosphere: the compressible orifice law of paper 001 eq. 2 (Sanville 1971) with C_d = 1 and critical ratio 0.528", CHAMBER(atmosphere_leak_area)},
    {"pressure_model", Scope::kChamber, AppliesTo::kAll, "", "physical", "physical identified", 0, 0, false, false,
     "physical flow and chamber model, or the identified model of paper 000 eq. 10", nullptr},
    {"flow", Scope::kChamber, AppliesTo::kAll, "", "derived", "iso6358 sanville thin_plate", 0, 0, false, false,
     "port flow law; default iso6358 (onoff), sanville (5/3), thin_plate (per chamber)", nullptr},
    {"discharge_coefficient", Scope::kChamber, AppliesTo::kAreaLaw, "", "0.72", nullptr, 0, 1, true, false,
     "C_d (sanville, paper 001: 0.7) or C (thin plate, paper 000: 0.72)", CHAMBER(discharge_coefficient)},
    {"critical_ratio", Scope::kChamber, AppliesTo::kEllipticLaw, "", "derived", nullptr, 0, 1, false, true,
     "critical pressure ratio b: default 0.433 for iso6358 (paper 002), 0.2 for sanville (paper 001)", CHAMBER(critical_ratio)},
    {"sonic_conductance", Scope::kChamber, AppliesTo::kIso6358, "kg/(s Pa)", "3.4e-9", nullptr, 0, 1e-5, true, false,
     "C_val = C rho0 of one open on/off valve (paper 002 eq. 4)", CHAMBER(sonic_conductance)},
    {"port_area", Scope::kChamber, AppliesTo::kOnOffAreaLaw, "m^2", nullptr, nullptr, 0, 0.01, true, false,
     "orifice area of one open on/off valve, for the sanville and thin-plate laws", CHAMBER(port_area)},
    {"area_gain", Scope::kChamber, AppliesTo::kPerChamber, "m^2/V", "2e-6", nullptr, 0, 1e-3, true, false,
     "B of paper 000 eq. 3", CHAMBER(area_gain)},
    {"u_supply_seal", Scope::kChamber, AppliesTo::kPerChamber, "V", "5.3", nullptr, -100, 100, false, false,
     "U_c: voltage at which the supply port seals (paper 000 eq. 3a)", CHAMBER(u_supply_seal)},
    {"u_exhaust_seal", Scope::kChamber, AppliesTo::kPerChamber, "V", "4.7", nullptr, -100, 100, false, false,
     "U_r: voltage at which the exhaust port seals (paper 000 eq. 3b)", CHAMBER(u_exhaust_seal)},
    {"leak_area_supply", Scope::kChamber, AppliesTo::kPerChamber, "m^2", "5e-8", nullptr, 0, 1e-3, false, false,
     "L_c: leakage area of the sealed supply port", CHAMBER(leak_area_supply)},
    {"leak_area_exhaust", Scope::kChamber, AppliesTo::kPerChamber, "m^2", "5e-8", nullptr, 0, 1e-3, false, false,
     "L_r: leakage area of the sealed exhaust port", CHAMBER(leak_area_exhaust)},
    {"area_smoothing", Scope::kChamber, AppliesTo::kPerChamber, "m^2", "1e-6", nullptr, 0, 1e-3, true, false,
     "area unit inside smax of eq. 3 (the paper's mm^2)", CHAMBER(area_smoothing)},
    {"c1", Scope::kChamber, AppliesTo::kIdentified, "V", nullptr, nullptr, -100, 100, false, false, "valve-voltage origin (paper 000 Table I)", IDENTIFIED(c[1])},
    {"c2", Scope::kChamber, AppliesTo::kIdentified, "1/V", nullptr, nullptr, -1e3, 1e3, false, false, "valve-voltage scale", IDENTIFIED(c[2])},
    {"c3", Scope::kChamber, AppliesTo::kIdentified, "1/V^3", nullptr, nullptr, -1, 1e3, true, false, "kink factor, > -1", IDENTIFIED(c[3])},
    {"c4", Scope::kChamber, AppliesTo::kIdentified, "Pa s/m", nullptr, nullptr, -1e9, 1e9, false, false, "ds/dv'", IDENTIFIED(c[4])},
    {"c5", Scope::kChamber, AppliesTo::kIdentified, "1/m", nullptr, nullptr, -1e6, 1e6, false, false, "dr/dv'", IDENTIFIED(c[5])},
    {"c6", Scope::kChamber, AppliesTo::kIdentified, "1/m", nullptr, nullptr, -1e4, 1e4, false, false, "volume-sensor scale; 1 + c6 x > 0 over the stroke", IDENTIFIED(c[6])},
    {"c7", Scope::kChamber, AppliesTo::kIdentified, "1/(V s)", nullptr, nullptr, 0, 1e6, true, false, "rate gain (B of eq. 3), > 0", IDENTIFIED(c[7])},
    {"c8", Scope::kChamber, AppliesTo::kIdentified, "", nullptr, nullptr, -1, 1, true, true, "rate asymmetry, in (-1, 1)", IDENTIFIED(c[8])},
    {"c9", Scope::kChamber, AppliesTo::kIdentified, "V", nullptr, nullptr, 0, 100, true, false, "leakage, > 0", IDENTIFIED(c[9])},
    {"c_gamma", Scope::kChamber, AppliesTo::kIdentified, "V", "0.1", nullptr, 0, 10, true, false, "voltage range of the leaky regime", IDENTIFIED(c_gamma)},
    {"c_b", Scope::kChamber, AppliesTo::kIdentified, "Pa abs", "(p_supply+p_exhaust)/2", nullptr, -1e8, 1e8, false, false, "pressure bias of s", IDENTIFIED(c_b)},
    {"c_s", Scope::kChamber, AppliesTo::kIdentified, "Pa", "(p_supply-p_exhaust)/2", nullptr, 0, 1e8, true, false, "pressure scale of s", IDENTIFIED(c_s)},
};

#undef CYL
#undef CHAMBER
#undef IDENTIFIED

const Param* FindParam(const std::string& key) {
  for (const Param& p : kParams) {
    if (key == p.key) return &p;
  }
  return nullptr;
}

std::string FormatBound(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  std::ostringstream s;
  s << v;
  return s.str();
}

std::string ValidText(const Param& p) {
  if (p.choices) return p.choices;
  if (p.is_name) return "a reservoir name";
  return std::string(p.min_open ? "(" : "[") + FormatBound(p.min) + ", " + FormatBound(p.max) +
         (p.max_open ? ")" : "]");
}

// the default of a row when it is a number ("1.4"), not "derived", "none" or a formula
bool LiteralDefault(const Param& p, double* out) {
  if (!p.default_value) return false;
  char* end = nullptr;
  *out = std::strtod(p.default_value, &end);
  return end != p.default_value && *end == '\0';
}

// the values given for one cylinder, before defaults
struct RawValues {
  std::map<std::string, std::string> cylinder;
  std::map<std::string, std::string> chamber[2];
};

class Parser {
 public:
  Parser(const std::string& name, std::string* error) : name_(name), error_(error) {}

  bool Fail(const std::string& key, const std::string& message) {
    *error_ = "cylinder '" + name_ + "': key '" + key + "': " + message;
    return false;
  }

  // split "key=value" tokens into cylinder and per-chamber maps
  bool Split(const std::string& text, RawValues* raw) {
    std::istringstream in(text);
    std::string token;
    while (in >> token) {
      size_t eq = token.find('=');
      if (eq == std::string::npos || eq == 0) {
        return Fail(token, "expected key=value");
      }
      std::string key = token.substr(0, eq), value = token.substr(eq + 1);
      if (value.empty()) return Fail(key, "missing value");
      int chamber = -1;
      std::string base = key;
      if (key.rfind("P.", 0) == 0 || key.rfind("N.", 0) == 0) {
        chamber = key[0] == 'P' ? 0 : 1;
        base = key.substr(2);
      }
      const Param* p = FindParam(base);
      if (!p) return Fail(key, "unknown key (see plugin/README.md or 'pneumo params')");
      if (chamber >= 0 && p->scope != Scope::kChamber) {
        return Fail(key, "'" + base + "' is a cylinder parameter and takes no P./N. prefix");
      }
      auto& target = chamber < 0 ? (p->scope == Scope::kChamber ? shared_chamber_ : raw->cylinder)
                                 : raw->chamber[chamber];
      if (target.count(base)) return Fail(key, "given twice");
      target[base] = value;
    }
    // a plain chamber key fills both chambers unless a prefixed one overrides it
    for (auto& [key, value] : shared_chamber_) {
      for (auto& chamber : raw->chamber) chamber.emplace(key, value);
    }
    return true;
  }

  // number from text, checked against the table's range
  bool Number(const Param& p, const std::string& key, const std::string& text, double* out) {
    const char* begin = text.c_str();
    char* end = nullptr;
    double v = std::strtod(begin, &end);
    if (end == begin || *end != '\0') return Fail(key, "value '" + text + "' is not a number");
    if (!std::isfinite(v)) return Fail(key, "value '" + text + "' is not finite");
    bool below = p.min_open ? v <= p.min : v < p.min;
    bool above = p.max_open ? v >= p.max : v > p.max;
    if (below || above) {
      return Fail(key, "value " + text + " is out of range " + ValidText(p) + (p.unit[0] ? std::string(" ") + p.unit : ""));
    }
    *out = v;
    return true;
  }

  bool Choice(const Param& p, const std::string& key, const std::string& text, int* index) {
    std::istringstream choices(p.choices);
    std::string c;
    for (int i = 0; choices >> c; ++i) {
      if (c == text) {
        *index = i;
        return true;
      }
    }
    return Fail(key, "value '" + text + "' is not one of: " + p.choices);
  }

 private:
  std::string name_;
  std::string* error_;
  std::map<std::string, std::string> shared_chamber_;
};

bool Applies(AppliesTo a, const CylinderConfig& c, const ChamberConfig* k) {
  bool area_law = k && k->flow != FlowLaw::kIso6358;
  switch (a) {
    case AppliesTo::kAll: return true;
    case AppliesTo::kOnOff: return c.valve == ValveKind::kOnOff;
    case AppliesTo::kPwm: return c.valve == ValveKind::kOnOff && c.input == CommandInput::kPwm;
    case AppliesTo::kProportional53: return c.valve == ValveKind::kProportional53;
    case AppliesTo::kPerChamber: return c.valve == ValveKind::kProportionalPerChamber;
    case AppliesTo::kProportional: return c.valve != ValveKind::kOnOff;
    case AppliesTo::kIso6358: return k && k->flow == FlowLaw::kIso6358;
    case AppliesTo::kEllipticLaw: return k && k->flow != FlowLaw::kThinPlate;
    case AppliesTo::kAreaLaw:
      if (!k) return c.chamber[0].flow != FlowLaw::kIso6358 || c.chamber[1].flow != FlowLaw::kIso6358;
      return area_law;
    case AppliesTo::kOnOffAreaLaw: return c.valve == ValveKind::kOnOff && area_law;
    case AppliesTo::kThinPlate:
      return c.chamber[0].flow == FlowLaw::kThinPlate || c.chamber[1].flow == FlowLaw::kThinPlate;
    case AppliesTo::kIdentified: return k && k->model == PressureModel::kIdentified;
    case AppliesTo::kFriction: return c.coulomb_friction.has_value();
    case AppliesTo::kLuGre: return c.friction_model == FrictionModel::kLuGre;
    case AppliesTo::kGamma: return c.thermal_model == ThermalModel::kEnergy || Applies(AppliesTo::kAreaLaw, c, k);
    case AppliesTo::kEnergy: return c.thermal_model == ThermalModel::kEnergy;
    case AppliesTo::kLine: return k && k->line_volume > 0;
  }
  return false;
}

const char* AppliesText(AppliesTo a) {
  switch (a) {
    case AppliesTo::kAll: return "every cylinder";
    case AppliesTo::kOnOff: return "valve=onoff";
    case AppliesTo::kPwm: return "valve=onoff with input=pwm";
    case AppliesTo::kProportional53: return "valve=proportional_5_3";
    case AppliesTo::kPerChamber: return "valve=proportional_per_chamber";
    case AppliesTo::kProportional: return "valve=proportional_5_3 or valve=proportional_per_chamber";
    case AppliesTo::kIso6358: return "flow=iso6358";
    case AppliesTo::kEllipticLaw: return "flow=iso6358 or flow=sanville";
    case AppliesTo::kAreaLaw: return "flow=sanville or flow=thin_plate";
    case AppliesTo::kOnOffAreaLaw: return "valve=onoff with flow=sanville or thin_plate";
    case AppliesTo::kThinPlate: return "flow=thin_plate";
    case AppliesTo::kIdentified: return "pressure_model=identified";
    case AppliesTo::kFriction: return "cylinders with coulomb_friction";
    case AppliesTo::kLuGre: return "friction_model=lugre";
    case AppliesTo::kGamma: return "flow=sanville or flow=thin_plate, or thermal_model=energy";
    case AppliesTo::kEnergy: return "thermal_model=energy";
    case AppliesTo::kLine: return "line_volume > 0";
  }
  return "";
}

// ParseCylinderConfig's steps follow, in its order; a step that checks returns false once the error is
// written (Parser::Fail)

// a prefixed chamber key ("P.area", "N.area"), or the key itself for the cylinder (chamber -1)
std::string Prefixed(int chamber, const char* key) {
  return chamber < 0 ? std::string(key) : std::string(chamber == 0 ? "P." : "N.") + key;
}

// the value given for row p in `values`, if any
bool Given(const std::map<std::string, std::string>& values, const Param& p, std::string* out) {
  auto it = values.find(p.key);
  if (it == values.end()) return false;
  *out = it->second;
  return true;
}

// "<cylinder>.<role>" names the actuators and "<cylinder>.<signal>" the log columns: a name holds none of
// their separators
bool CheckName(const std::string& name, std::string* error) {
  if (name.find('.') != std::string::npos || name.find_first_of(" \t,") != std::string::npos) {
    *error = "cylinder '" + name + "': a cylinder name cannot contain '.', ',' or spaces "
             "(actuators are named <cylinder>.<role>, log columns <cylinder>.<signal>)";
    return false;
  }
  return true;
}

// choice `key` as given in `values` (shown as `shown` in errors) into *field, which keeps its default when
// the key is not given
template <typename Enum>
bool ReadChoice(Parser& parser, const std::map<std::string, std::string>& values, const char* key,
                const std::string& shown, Enum* field) {
  std::string text;
  int index = 0;
  const Param& p = *FindParam(key);
  if (!Given(values, p, &text)) return true;
  if (!parser.Choice(p, shown, text, &index)) return false;
  *field = static_cast<Enum>(index);
  return true;
}

// the enumerations first: they decide which other keys apply (valve is required; a chamber's flow law
// defaults to its valve's); then whether seal friction and a supply reservoir are given
bool ReadChoices(Parser& parser, const RawValues& raw, CylinderConfig* c) {
  const Param& valve = *FindParam("valve");
  if (!raw.cylinder.count("valve")) {
    return parser.Fail("valve", "required (one of: " + std::string(valve.choices) + ")");
  }
  if (!ReadChoice(parser, raw.cylinder, "valve", "valve", &c->valve) ||
      !ReadChoice(parser, raw.cylinder, "input", "input", &c->input) ||
      !ReadChoice(parser, raw.cylinder, "pwm_alignment", "pwm_alignment", &c->pwm_alignment) ||
      !ReadChoice(parser, raw.cylinder, "commands", "commands", &c->commands) ||
      !ReadChoice(parser, raw.cylinder, "mount", "mount", &c->mount) ||
      !ReadChoice(parser, raw.cylinder, "step", "step", &c->step) ||
      !ReadChoice(parser, raw.cylinder, "friction_model", "friction_model", &c->friction_model) ||
      !ReadChoice(parser, raw.cylinder, "thermal_model", "thermal_model", &c->thermal_model)) {
    return false;
  }
  for (int k = 0; k < 2; ++k) {
    ChamberConfig& ch = c->chamber[k];
    ch.flow = c->valve == ValveKind::kOnOff           ? FlowLaw::kIso6358
              : c->valve == ValveKind::kProportional53 ? FlowLaw::kSanville
                                                       : FlowLaw::kThinPlate;
    if (!ReadChoice(parser, raw.chamber[k], "flow", Prefixed(k, "flow"), &ch.flow) ||
        !ReadChoice(parser, raw.chamber[k], "pressure_model", Prefixed(k, "pressure_model"), &ch.model)) {
      return false;
    }
  }
  if (raw.cylinder.count("coulomb_friction")) c->coulomb_friction = 0.0;
  if (raw.cylinder.count("supply") && raw.cylinder.at("supply") != "none") {
    c->supply = raw.cylinder.at("supply");
    if (c->supply.find_first_of(".,=") != std::string::npos) {
      return parser.Fail("supply", "'" + c->supply + "' is not a reservoir name (no '.', ',' or '=')");
    }
  }
  return true;
}

// choices given where they do not apply, and choices that rule each other out
bool CheckChoices(Parser& parser, const RawValues& raw, const CylinderConfig& c) {
  for (const Param& p : kParams) {
    if (!p.choices || p.scope != Scope::kCylinder) continue;
    if (raw.cylinder.count(p.key) && !Applies(p.applies, c, nullptr)) {
      return parser.Fail(p.key, std::string("applies only to ") + AppliesText(p.applies));
    }
  }
  for (int k = 0; k < 2; ++k) {
    if (c.chamber[k].model == PressureModel::kIdentified && c.valve == ValveKind::kOnOff) {
      return parser.Fail(Prefixed(k, "pressure_model"), "the identified model of paper 000 needs a proportional valve command");
    }
  }
  return true;
}

// the value slots of a row: -1 for the cylinder's own value, 0 and 1 for chamber P's and N's
std::vector<int> ChambersOf(const Param& p) {
  return p.scope == Scope::kCylinder ? std::vector<int>{-1} : std::vector<int>{0, 1};
}

// the table's literal defaults, for every number key, so the struct is fully defined
void ApplyLiteralDefaults(CylinderConfig* c) {
  for (const Param& p : kParams) {
    double v = 0;
    if (!p.field || !LiteralDefault(p, &v)) continue;
    for (int k : ChambersOf(p)) p.field(*c, std::max(k, 0)) = v;
  }
}

// the numbers given, range-checked: a key given where it does not apply, or missing where it is required,
// is an error; *given_keys gets the prefixed keys given
bool ReadNumbers(Parser& parser, const RawValues& raw, CylinderConfig* c, std::set<std::string>* given_keys) {
  std::string text_value;
  for (const Param& p : kParams) {
    if (p.choices || p.is_name) continue;
    for (int k : ChambersOf(p)) {
      const auto& values = k < 0 ? raw.cylinder : raw.chamber[k];
      const ChamberConfig* chamber = k < 0 ? nullptr : &c->chamber[k];
      std::string key = Prefixed(k, p.key);
      bool given = Given(values, p, &text_value);
      if (!Applies(p.applies, *c, chamber)) {
        if (given) return parser.Fail(key, std::string("applies only to ") + AppliesText(p.applies));
        continue;
      }
      if (!given) {
        if (!p.default_value) return parser.Fail(key, std::string("required for ") + AppliesText(p.applies));
        continue;
      }
      double v = 0;
      if (!parser.Number(p, key, text_value, &v)) return false;
      if (p.field) p.field(*c, std::max(k, 0)) = v;
      if (std::string(p.key) == "coulomb_friction") c->coulomb_friction = v;
      given_keys->insert(key);
    }
  }
  return true;
}

// defaults derived from other keys, where the key was not given
void DeriveDefaults(const std::set<std::string>& given_keys, CylinderConfig* c) {
  if (!given_keys.count("p_atm")) c->p_atm = c->p_exhaust;
  // paper 001's spool lag for the 5/3 valve; none for the per-chamber valves (paper 000 has none)
  if (!given_keys.count("spool_time_constant")) {
    c->spool_time_constant = c->valve == ValveKind::kProportional53 ? 0.0042 : 0.0;
  }
  for (int k = 0; k < 2; ++k) {
    ChamberConfig& ch = c->chamber[k];
    auto given = [&](const char* key) { return given_keys.count(Prefixed(k, key)) > 0; };
    if (!given("critical_ratio")) ch.critical_ratio = ch.flow == FlowLaw::kSanville ? 0.2 : 0.433;
    if (!given("c_b")) ch.identified.c_b = (c->p_supply + c->p_exhaust) / 2;
    if (!given("c_s")) ch.identified.c_s = (c->p_supply - c->p_exhaust) / 2;
  }
}

// relations between keys: the supply above the exhaust; seal friction with the mount and LuGre's levels
bool CheckPressuresAndFriction(Parser& parser, const CylinderConfig& c) {
  if (c.p_supply <= c.p_exhaust) {
    return parser.Fail("p_supply", "must exceed p_exhaust (" + FormatBound(c.p_exhaust) + " Pa)");
  }
  if (c.mount == Mount::kHingeSites && c.coulomb_friction) {
    return parser.Fail("coulomb_friction", "seal friction takes its static level from the transmission's frictionloss, in "
                                           "piston units; with mount=hinge_sites the lever arm changes with the angle: "
                                           "use mount=transmission (a spatial tendon between the two sites)");
  }
  if (c.friction_model == FrictionModel::kLuGre) {
    if (!c.coulomb_friction) {
      return parser.Fail("coulomb_friction", "required for friction_model=lugre (F_c, the sliding level of g(v))");
    }
    if (c.static_friction < *c.coulomb_friction) {
      return parser.Fail("static_friction", "must be at least coulomb_friction (" + FormatBound(*c.coulomb_friction) +
                                                "): F_s is the breakaway level, F_c the sliding one");
    }
  }
  return true;
}

// relations between keys: the energy equation and the lines need the physical model and their own
// implicit steps
bool CheckThermalAndLines(Parser& parser, const CylinderConfig& c) {
  if (c.thermal_model == ThermalModel::kEnergy) {
    for (int k = 0; k < 2; ++k) {
      if (c.chamber[k].model != PressureModel::kPhysical) {
        return parser.Fail("thermal_model", "energy needs the physical pressure model in both chambers (" +
                                                Prefixed(k, "pressure_model") + " is identified)");
      }
    }
    if (c.step == ChamberStep::kExplicit) {
      return parser.Fail("thermal_model", "energy has its own implicit step: use step=linearized or step=exact (the same for it)");
    }
  }
  for (int k = 0; k < 2; ++k) {
    if (c.chamber[k].line_volume <= 0) continue;
    std::string key = Prefixed(k, "line_volume");
    if (c.chamber[k].model != PressureModel::kPhysical) return parser.Fail(key, "a line needs the physical pressure model");
    if (c.thermal_model == ThermalModel::kEnergy) return parser.Fail(key, "not combined with thermal_model=energy in this version");
    if (c.step == ChamberStep::kExplicit) return parser.Fail(key, "a line has its own implicit step: use step=linearized or step=exact");
  }
  return true;
}

// relations between keys: the identified model of paper 000 maps the command voltage itself (its valve's
// dynamics are in its fit), so no dead time or valve lag goes before it
bool CheckIdentifiedCommand(Parser& parser, const CylinderConfig& c) {
  for (int k = 0; k < 2; ++k) {
    if (c.chamber[k].model != PressureModel::kIdentified) continue;
    if (c.CommandDeadTime() > 0) {
      return parser.Fail(c.spool_dead_time > 0 ? "spool_dead_time" : "line_delay", "needs the physical pressure model in both chambers (" + Prefixed(k, "pressure_model") +
                                         " is identified: the identified model of paper 000 takes the command voltage)");
    }
    if (c.valve == ValveKind::kProportionalPerChamber && c.spool_time_constant > 0) {
      return parser.Fail("spool_time_constant", "needs the physical pressure model in both chambers (" + Prefixed(k, "pressure_model") +
                                             " is identified: the identified model of paper 000 takes the command voltage)");
    }
  }
  return true;
}

// relations between keys: where the valve commands live (commands=chambers) and what switched PWM needs
bool CheckCommandPlace(Parser& parser, const CylinderConfig& c) {
  bool delays = c.delay_open > 0 || c.delay_close > 0;
  if (c.commands == CommandPlace::kChambers) {
    // a chamber actuator has one ctrl and one act: room for one command, none for a valve state
    if (c.valve == ValveKind::kOnOff && c.input == CommandInput::kValves) {
      return parser.Fail("commands", "chambers holds two commands, one per chamber actuator; valve=onoff with input=valves has "
                                     "four (u1..u4): use input=pwm or commands=actuators");
    }
    if (delays) {
      return parser.Fail(c.delay_open > 0 ? "delay_open" : "delay_close",
                         "valve delays keep each armature in the act of its command actuator: use commands=actuators");
    }
    if (c.valve != ValveKind::kOnOff && c.spool_time_constant > 0) {
      return parser.Fail("spool_time_constant", "a spool lag keeps its state in the act of the command actuator: set "
                                                "spool_time_constant=0 or use commands=actuators");
    }
  }
  if (c.input == CommandInput::kPwm && delays && c.pwm_frequency == 0) {
    return parser.Fail(c.delay_open > 0 ? "delay_open" : "delay_close",
                       "valve delays need switched PWM (pwm_frequency > 0), the averaged model has no switching instants");
  }
  return true;
}

// relations between keys, chamber by chamber: a reservoir needs the physical model, iso6358 rates only
// on/off valves, and the identified model's volume sensor stays positive over the stroke
bool CheckChamberModels(Parser& parser, const CylinderConfig& c) {
  for (int k = 0; k < 2; ++k) {
    if (!c.supply.empty() && c.chamber[k].model == PressureModel::kIdentified) {
      return parser.Fail("supply", "a cylinder fed by a reservoir needs the physical pressure model in both chambers "
                                   "(the identified model of paper 000 has no supply pressure to follow)");
    }
  }
  for (int k = 0; k < 2; ++k) {
    const ChamberConfig& ch = c.chamber[k];
    std::string side = k == 0 ? "P." : "N.";
    if (ch.flow == FlowLaw::kIso6358 && c.valve != ValveKind::kOnOff) {
      return parser.Fail(side + "flow",
                         "iso6358 rates a fully open on/off valve; proportional valves take flow=sanville or flow=thin_plate");
    }
    if (ch.model == PressureModel::kIdentified) {
      // paper 000 eq. 10e: the rate's denominator 1 + c6 v must stay positive over the stroke
      double worst = 1 - std::fabs(ch.identified.c[6]) * c.stroke / 2;
      if (worst <= 0) {
        return parser.Fail(side + "c6", "1 + c6 x must stay positive for |x| <= stroke/2");
      }
    }
  }
  return true;
}

}  // namespace

std::optional<CylinderConfig> ParseCylinderConfig(const std::string& name, const std::string& text,
                                                  std::string* error) {
  // key=value tokens; the choices, which decide which keys apply; the numbers, range-checked against the
  // table; the defaults derived from other keys; the relations between keys
  Parser parser(name, error);
  RawValues raw;
  if (!parser.Split(text, &raw) || !CheckName(name, error)) return std::nullopt;
  CylinderConfig c;
  c.name = name;
  std::set<std::string> given_keys;
  if (!ReadChoices(parser, raw, &c) || !CheckChoices(parser, raw, c)) return std::nullopt;
  ApplyLiteralDefaults(&c);
  if (!ReadNumbers(parser, raw, &c, &given_keys)) return std::nullopt;
  DeriveDefaults(given_keys, &c);
  if (!CheckPressuresAndFriction(parser, c) || !CheckThermalAndLines(parser, c) || !CheckIdentifiedCommand(parser, c) ||
      !CheckCommandPlace(parser, c) || !CheckChamberModels(parser, c)) {
    return std::nullopt;
  }
  return c;
}

const std::vector<ParameterDoc>& Parameters() {
  static const std::vector<ParameterDoc> docs = [] {
    std::vector<ParameterDoc> out;
    for (const Param& p : kParams) {
      std::string scope = p.scope == Scope::kCylinder ? "cylinder" : "chamber";
      if (p.applies != AppliesTo::kAll) scope += std::string(", ") + AppliesText(p.applies);
      ParameterDoc doc{p.key, p.unit, p.default_value ? p.default_value : "required", ValidText(p), scope, p.meaning};
      doc.is_choice = p.choices != nullptr;
      doc.min = p.min, doc.max = p.max, doc.min_open = p.min_open, doc.max_open = p.max_open;
      out.push_back(doc);
    }
    return out;
  }();
  return docs;
}

namespace {

// the index of a choice row's value in its list of choices
int ChoiceIndex(const CylinderConfig& c, const std::string& key, int k) {
  if (key == "valve") return static_cast<int>(c.valve);
  if (key == "input") return static_cast<int>(c.input);
  if (key == "pwm_alignment") return static_cast<int>(c.pwm_alignment);
  if (key == "commands") return static_cast<int>(c.commands);
  if (key == "mount") return static_cast<int>(c.mount);
  if (key == "step") return static_cast<int>(c.step);
  if (key == "friction_model") return static_cast<int>(c.friction_model);
  if (key == "thermal_model") return static_cast<int>(c.thermal_model);
  if (key == "pressure_model") return static_cast<int>(c.chamber[k].model);
  return static_cast<int>(c.chamber[k].flow);  // "flow"
}

void SetChoiceIndex(CylinderConfig* c, const std::string& key, int k, int index) {
  if (key == "valve") c->valve = static_cast<ValveKind>(index);
  if (key == "input") c->input = static_cast<CommandInput>(index);
  if (key == "pwm_alignment") c->pwm_alignment = static_cast<PwmAlignment>(index);
  if (key == "commands") c->commands = static_cast<CommandPlace>(index);
  if (key == "mount") c->mount = static_cast<Mount>(index);
  if (key == "step") c->step = static_cast<ChamberStep>(index);
  if (key == "friction_model") c->friction_model = static_cast<FrictionModel>(index);
  if (key == "thermal_model") c->thermal_model = static_cast<ThermalModel>(index);
  if (key == "pressure_model") c->chamber[k].model = static_cast<PressureModel>(index);
  if (key == "flow") c->chamber[k].flow = static_cast<FlowLaw>(index);
}

std::string ChoiceText(const Param& p, int index) {
  std::istringstream choices(p.choices);
  std::string word;
  for (int i = 0; choices >> word; ++i) {
    if (i == index) return word;
  }
  return "?";
}

// "key=value" pairs of a configuration, by prefixed key, for the keys that apply to it
std::map<std::string, std::string> ConfigPairs(const CylinderConfig& config) {
  CylinderConfig c = config;  // the accessors take a mutable config
  std::map<std::string, std::string> pairs;
  for (const Param& p : kParams) {
    int first = p.scope == Scope::kCylinder ? -1 : 0, last = p.scope == Scope::kCylinder ? -1 : 1;
    for (int k = first; k <= last; ++k) {
      if (!Applies(p.applies, c, k < 0 ? nullptr : &c.chamber[k])) continue;
      std::string key = k < 0 ? p.key : std::string(k == 0 ? "P." : "N.") + p.key;
      if (p.is_name) {
        if (!c.supply.empty()) pairs[key] = c.supply;
      } else if (p.choices) {
        pairs[key] = ChoiceText(p, ChoiceIndex(c, p.key, std::max(k, 0)));
      } else if (p.field) {
        pairs[key] = FormatNumber(p.field(c, std::max(k, 0)));
      } else if (c.coulomb_friction) {  // coulomb_friction, when set
        pairs[key] = FormatNumber(*c.coulomb_friction);
      }
    }
  }
  return pairs;
}

std::string JoinPairs(const std::map<std::string, std::string>& pairs) {
  std::string text;
  for (const auto& [key, value] : pairs) text += (text.empty() ? "" : " ") + key + "=" + value;
  return text;
}

}  // namespace

std::string FormatNumber(double v) {
  // std::to_chars without a format: the shortest text that reads back to the same bits
  char buffer[32];
  auto [end, error] = std::to_chars(buffer, buffer + sizeof(buffer), v);
  return error == std::errc() ? std::string(buffer, end) : std::string("nan");
}

int PackedConfigSize() {
  int n = 0;
  for (const Param& p : kParams) n += p.is_name ? 0 : p.scope == Scope::kCylinder ? 1 : 2;
  return n;
}

void PackConfig(const CylinderConfig& config, double* out) {
  CylinderConfig c = config;
  for (const Param& p : kParams) {
    if (p.is_name) continue;
    int first = p.scope == Scope::kCylinder ? -1 : 0, last = p.scope == Scope::kCylinder ? -1 : 1;
    for (int k = first; k <= last; ++k) {
      if (p.choices) {
        *out++ = ChoiceIndex(c, p.key, std::max(k, 0));
      } else if (p.field) {
        *out++ = p.field(c, std::max(k, 0));
      } else {  // coulomb_friction: -1 when not set
        *out++ = c.coulomb_friction.value_or(-1);
      }
    }
  }
}

std::optional<CylinderConfig> UnpackConfig(const std::string& name, const double* values, std::string* error,
                                           const std::string& supply) {
  CylinderConfig c;
  c.supply = supply;
  for (const Param& p : kParams) {
    if (p.is_name) continue;
    int first = p.scope == Scope::kCylinder ? -1 : 0, last = p.scope == Scope::kCylinder ? -1 : 1;
    for (int k = first; k <= last; ++k) {
      double v = *values++;
      if (p.choices) {
        SetChoiceIndex(&c, p.key, std::max(k, 0), static_cast<int>(v));
      } else if (p.field) {
        p.field(c, std::max(k, 0)) = v;
      } else if (v >= 0) {
        c.coulomb_friction = v;
      }
    }
  }
  // through the parser again, so a packed configuration gets exactly the MJCF's checks
  return ParseCylinderConfig(name, FormatConfig(c), error);
}

std::string FormatConfig(const CylinderConfig& c) { return JoinPairs(ConfigPairs(c)); }

std::optional<double> ConfigValue(const CylinderConfig& config, const std::string& key, std::string* error) {
  std::string base = key.rfind("P.", 0) == 0 || key.rfind("N.", 0) == 0 ? key.substr(2) : key;
  const Param* p = FindParam(base);
  auto fail = [&](const std::string& message) -> std::optional<double> {
    *error = "cylinder '" + config.name + "': key '" + key + "': " + message;
    return std::nullopt;
  };
  if (!p) return fail("unknown key (see plugin/README.md or 'pneumo params')");
  if (p->scope == Scope::kChamber && base == key) return fail("a chamber key: give P." + key + " or N." + key);
  if (p->is_name) return fail("holds a name ('" + (config.supply.empty() ? "none" : config.supply) + "'), not a number");
  if (p->scope == Scope::kCylinder && base != key) return fail("a cylinder key: give " + base);
  // read from the configuration directly (ConfigPairs would format every key to answer one: the
  // closed loop reads a dozen keys of every cylinder when it starts)
  const int k = p->scope == Scope::kCylinder ? -1 : key[0] == 'N' ? 1 : 0;
  const bool unset = !p->choices && !p->field && !config.coulomb_friction;  // coulomb_friction, when not given
  if (!Applies(p->applies, config, k < 0 ? nullptr : &config.chamber[k]) || unset) {
    return fail(std::string("applies only to ") + AppliesText(p->applies));
  }
  if (p->choices) return ChoiceIndex(config, base, std::max(k, 0));
  if (!p->field) return *config.coulomb_friction;  // coulomb_friction, when set
  CylinderConfig c = config;  // the accessors take a mutable config
  return p->field(c, std::max(k, 0));
}

std::optional<CylinderConfig> WithValues(const CylinderConfig& config,
                                         const std::vector<std::pair<std::string, std::string>>& values,
                                         std::string* error) {
  std::map<std::string, std::string> pairs = ConfigPairs(config);
  for (const auto& [key, value] : values) {
    // a chamber key without prefix sets both chambers, as in MJCF
    std::string base = key.rfind("P.", 0) == 0 || key.rfind("N.", 0) == 0 ? key.substr(2) : key;
    const Param* p = FindParam(base);
    if (p && p->scope == Scope::kChamber && base == key) {
      pairs.erase("P." + key), pairs.erase("N." + key);
    }
    pairs[key] = value;
  }
  return ParseCylinderConfig(config.name, JoinPairs(pairs), error);
}

}  // namespace pneumatic
