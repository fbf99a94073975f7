#include "roles.h"

#include <iterator>

#include "valves.h"

namespace pneumatic {
namespace {

bool Never(const CylinderConfig*) { return false; }
bool Always(const CylinderConfig*) { return true; }
bool OnOffValves(const CylinderConfig* c) { return c->valve == ValveKind::kOnOff && c->input == CommandInput::kValves; }
bool OnOffStates(const CylinderConfig* c) { return c->valve == ValveKind::kOnOff && ValvesHaveState(*c); }
bool Pwm(const CylinderConfig* c) { return c->valve == ValveKind::kOnOff && c->input == CommandInput::kPwm; }
bool Proportional53(const CylinderConfig* c) { return c->valve == ValveKind::kProportional53; }
bool SpoolLag(const CylinderConfig* c) { return c->valve == ValveKind::kProportional53 && ValvesHaveState(*c); }
bool PerChamber(const CylinderConfig* c) { return c->valve == ValveKind::kProportionalPerChamber; }
bool PerChamberLag(const CylinderConfig* c) { return PerChamber(c) && ValvesHaveState(*c); }
bool DeadTime53(const CylinderConfig* c) { return c->valve == ValveKind::kProportional53 && DelayChannels(*c) > 0; }
bool DeadTimePerChamber(const CylinderConfig* c) { return PerChamber(c) && DelayChannels(*c) > 0; }
bool Friction(const CylinderConfig* c) { return c->coulomb_friction.has_value(); }
bool LuGre(const CylinderConfig* c) { return c->friction_model == FrictionModel::kLuGre; }
bool Energy(const CylinderConfig* c) { return c->thermal_model == ThermalModel::kEnergy; }
bool LineP(const CylinderConfig* c) { return c->chamber[0].line_volume > 0; }
bool LineN(const CylinderConfig* c) { return c->chamber[1].line_volume > 0; }

constexpr char kCommanded[] = "this valve arrangement is commanded through its ctrl";
constexpr char kOnOffRequired[] =
    "valve=onoff with input=valves (command); delay_open or delay_close > 0 (armature state)";
constexpr char kPerChamberRequired[] =
    "valve=proportional_per_chamber (command); spool_time_constant > 0 (lagged voltage)";
// the delay line of spool_dead_time (valves.h, ValveSignal: the (1,2) Pade approximant of exp(-s T))
constexpr char kDelayLine1[] =
    "delay line at rest on a 0 V command (act = x1, the delayed command, V: mj_resetData's ctrl = 0); at rest on u: x1 = u";
constexpr char kDelayLine2[] = "delay line at rest (x2 = 0 at rest on any command)";
constexpr char kArmature[] =
    "on/off valve command (0 closed, 1 open); with delays its act is the armature position, the project's own model";

const RoleSpec kRoles[] = {
    // cylinder: chambers
    {"P", RoleOwner::kCylinder, Role::kChamber, 0, Never, Always, Never, "every cylinder", "Pa",
     "p = p_atm (act = p - p_atm, gauge)", "cap-side chamber pressure; force +A_P act (fixed gain)",
     "each cylinder needs actuators '{}.P' and '{}.N'"},
    {"N", RoleOwner::kCylinder, Role::kChamber, 1, Never, Always, Never, "every cylinder", "Pa",
     "p = p_atm (act = p - p_atm, gauge)", "rod-side chamber pressure; force -A_N act (fixed gain)",
     "each cylinder needs actuators '{}.P' and '{}.N'"},
    // cylinder: valve commands, and the valve states their act holds
    {"u1", RoleOwner::kCylinder, Role::kCommand, 0, OnOffValves, OnOffStates, Never, kOnOffRequired, "1 (ctrl), 1 (act)",
     "closed (armature at rest)", kArmature, kCommanded},
    {"u2", RoleOwner::kCylinder, Role::kCommand, 1, OnOffValves, OnOffStates, Never, kOnOffRequired, "1 (ctrl), 1 (act)",
     "closed (armature at rest)", kArmature, kCommanded},
    {"u3", RoleOwner::kCylinder, Role::kCommand, 2, OnOffValves, OnOffStates, Never, kOnOffRequired, "1 (ctrl), 1 (act)",
     "closed (armature at rest)", kArmature, kCommanded},
    {"u4", RoleOwner::kCylinder, Role::kCommand, 3, OnOffValves, OnOffStates, Never, kOnOffRequired, "1 (ctrl), 1 (act)",
     "closed (armature at rest)", kArmature, kCommanded},
    {"duty", RoleOwner::kCylinder, Role::kCommand, 0, Pwm, Never, Never, "valve=onoff with input=pwm", "1 (ctrl)", "",
     "PWM duty in [-1, 1] (paper 003 eqs. 12-13)", kCommanded},
    {"u", RoleOwner::kCylinder, Role::kCommand, 0, Proportional53, SpoolLag, Never,
     "valve=proportional_5_3 (command); spool_time_constant > 0 (spool state)", "V (ctrl), m (act)",
     "spool centred (x_v = 0)", "5/3 valve voltage; with a lag its act is the spool position x_v (paper 001 eq. 1)",
     kCommanded},
    {"uP", RoleOwner::kCylinder, Role::kCommand, 0, PerChamber, PerChamberLag, Never, kPerChamberRequired,
     "V (ctrl), V (act)", "lagged voltage 0 V, at rest on the 0 V command mj_resetData gives",
     "voltage of chamber P's valve (paper 000 eq. 3); with a lag its act is the lagged voltage (paper 001 eq. 1's spool lag)",
     kCommanded},
    {"uN", RoleOwner::kCylinder, Role::kCommand, 1, PerChamber, PerChamberLag, Never, kPerChamberRequired,
     "V (ctrl), V (act)", "lagged voltage 0 V, at rest on the 0 V command mj_resetData gives",
     "voltage of chamber N's valve (paper 000 eq. 3); with a lag its act is the lagged voltage (paper 001 eq. 1's spool lag)",
     kCommanded},
    // cylinder: forces
    {"friction", RoleOwner::kCylinder, Role::kFriction, 0, Never, Never, Friction, "coulomb_friction", "N (N m)", "",
     "seal friction as bias: the Stribeck give-back below the transmission's frictionloss (the static level), or the whole LuGre force (friction_model=lugre)",
     "coulomb_friction is applied through it"},
    // cylinder: extra states (index = extra-state slot, Cylinder::kMaxExtraStates)
    {"z", RoleOwner::kCylinder, Role::kState, 0, Never, LuGre, Never, "friction_model=lugre", "m (rad)",
     "bristles relaxed (z = 0)",
     "LuGre bristle deflection z (Canudas de Wit et al. 1995); its force acts through <cyl>.friction",
     "its act is the LuGre bristle deflection"},
    {"TP", RoleOwner::kCylinder, Role::kState, 1, Never, Energy, Never, "thermal_model=energy", "K",
     "gas at the cylinder's temperature (act = T - temperature)",
     "gas temperature of chamber P, energy equation of an open chamber (Richer and Hurmuzlu 2000)",
     "its act is chamber P's gas temperature"},
    {"TN", RoleOwner::kCylinder, Role::kState, 2, Never, Energy, Never, "thermal_model=energy", "K",
     "gas at the cylinder's temperature (act = T - temperature)",
     "gas temperature of chamber N, energy equation of an open chamber (Richer and Hurmuzlu 2000)",
     "its act is chamber N's gas temperature"},
    {"LP", RoleOwner::kCylinder, Role::kState, 3, Never, LineP, Never, "P.line_volume > 0", "Pa",
     "p_line = p_atm (act = p_line - p_atm, gauge)", "pressure in the line between chamber P's valve ports and chamber P",
     "its act is the pressure in chamber P's line"},
    {"LN", RoleOwner::kCylinder, Role::kState, 4, Never, LineN, Never, "N.line_volume > 0", "Pa",
     "p_line = p_atm (act = p_line - p_atm, gauge)", "pressure in the line between chamber N's valve ports and chamber N",
     "its act is the pressure in chamber N's line"},
    {"d1", RoleOwner::kCylinder, Role::kState, 5, Never, DeadTime53, Never, "valve=proportional_5_3 with spool_dead_time + line_delay > 0",
     "V", kDelayLine1, "dead time of the 5/3 valve's command: state x1 of the (1,2) Pade approximant of exp(-s T), the delayed command",
     "its act is the first state of the valve's dead-time delay line"},
    {"d2", RoleOwner::kCylinder, Role::kState, 6, Never, DeadTime53, Never, "valve=proportional_5_3 with spool_dead_time + line_delay > 0",
     "V", kDelayLine2, "dead time of the 5/3 valve's command: state x2 of the (1,2) Pade approximant of exp(-s T)",
     "its act is the second state of the valve's dead-time delay line"},
    {"dP1", RoleOwner::kCylinder, Role::kState, 7, Never, DeadTimePerChamber, Never,
     "valve=proportional_per_chamber with spool_dead_time + line_delay > 0", "V", kDelayLine1,
     "dead time of uP: state x1 of the (1,2) Pade approximant of exp(-s T), the delayed command",
     "its act is the first state of chamber P's valve dead-time delay line"},
    {"dP2", RoleOwner::kCylinder, Role::kState, 8, Never, DeadTimePerChamber, Never,
     "valve=proportional_per_chamber with spool_dead_time + line_delay > 0", "V", kDelayLine2,
     "dead time of uP: state x2 of the (1,2) Pade approximant of exp(-s T)",
     "its act is the second state of chamber P's valve dead-time delay line"},
    {"dN1", RoleOwner::kCylinder, Role::kState, 9, Never, DeadTimePerChamber, Never,
     "valve=proportional_per_chamber with spool_dead_time + line_delay > 0", "V", kDelayLine1,
     "dead time of uN: state x1 of the (1,2) Pade approximant of exp(-s T), the delayed command",
     "its act is the first state of chamber N's valve dead-time delay line"},
    {"dN2", RoleOwner::kCylinder, Role::kState, 10, Never, DeadTimePerChamber, Never,
     "valve=proportional_per_chamber with spool_dead_time + line_delay > 0", "V", kDelayLine2,
     "dead time of uN: state x2 of the (1,2) Pade approximant of exp(-s T)",
     "its act is the second state of chamber N's valve dead-time delay line"},
    // supply reservoir
    {"pressure", RoleOwner::kReservoir, Role::kReservoir, 0, Never, Always, Never, "every reservoir", "Pa",
     "p = p_supply of the cylinders it feeds, a charged reservoir (act = p - p_supply)",
     "reservoir pressure, stepped with the chambers it feeds; applies no force (fixed gain 0)",
     "its act is the reservoir's pressure"},
};

}  // namespace

const RoleSpec* RoleTable(int* count) {
  *count = static_cast<int>(std::size(kRoles));
  return kRoles;
}

const RoleSpec* FindRole(RoleOwner owner, const std::string& suffix) {
  for (const RoleSpec& r : kRoles) {
    if (r.owner == owner && suffix == r.suffix) return &r;
  }
  return nullptr;
}

bool RoleRequired(const RoleSpec& r, const CylinderConfig* c) {
  if (r.owner == RoleOwner::kCylinder && !c) return false;
  return r.command(c) || r.state(c) || r.bias(c);
}

std::string StateActuatorProblem(const mjModel* m, int id, const RoleSpec& r) {
  if (m->actuator_dyntype[id] != mjDYN_USER) {
    return std::string("needs dyntype=\"user\": its act is the ") + r.meaning + " (act = 0: " + r.initial + ")";
  }
  bool zero_gain = m->actuator_gaintype[id] == mjGAIN_USER ||
                   (m->actuator_gaintype[id] == mjGAIN_FIXED && m->actuator_gainprm[id * mjNGAIN] == 0);
  if (!zero_gain || m->actuator_biastype[id] != mjBIAS_NONE) {
    return "applies no force: use gaintype=\"user\" (or gainprm=\"0\") and biastype=\"none\"";
  }
  if (m->actuator_actlimited[id]) return "must not be actlimited: MuJoCo would clip the state";
  return "";
}

std::string RoleKindText(const RoleSpec& r) {
  bool command = r.command != Never, state = r.state != Never, bias = r.bias != Never;
  if (r.role == Role::kChamber) return "state + force";
  if (bias) return "force";
  if (command && state) return "command (+ state)";
  if (command) return "command";
  return state ? "state" : "";
}

}  // namespace pneumatic
