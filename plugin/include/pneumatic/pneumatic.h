// Pneumatic actuators for MuJoCo 2.2.
//
// A pneumatic cylinder is written into an MJCF model as a few ordinary
// <general> actuators named "<cylinder>.<role>" plus one <custom><text> element
// "pneumatic:<cylinder>" holding its parameters (see plugin/README.md). Attach()
// reads and validates them and stores them in the model itself (the actuators'
// user data), so a copy made with mj_copyModel steps exactly like its original.
// From then on every mj_step advances each chamber pressure, stored as an
// activation in d->act (gauge pressure, Pa), over the step, and MuJoCo applies
// the force A_P (p_P - p_atm) - A_N (p_N - p_atm) through the actuators'
// transmission (fixed gains +A_P and -A_N on the gauge pressures).
//
// All state lives in mjData (d->act, d->qpos, d->qvel, d->ctrl, d->time): the
// callbacks are pure functions of (m, d), so mj_resetData, mj_copyData,
// keyframes, finite differences and stepping different mjData from several
// threads work as they do for MuJoCo's own actuators.
#ifndef PNEUMATIC_PNEUMATIC_H_
#define PNEUMATIC_PNEUMATIC_H_

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <mujoco/mujoco.h>

namespace pneumatic {

// The number of actuator user values the extension needs: a model with cylinders
// declares <size nuser_actuator="ActuatorUserSize()"/> (or more) in its MJCF.
int ActuatorUserSize();

// Reads the pneumatic cylinders of m, validates their configuration, stores it in
// m (actuator_user; the gains of the cylinders' actuators become fixed) and
// installs MuJoCo's actuator callbacks mjcb_act_dyn and mjcb_act_bias (and
// mjcb_act_gain for a model with mount=hinge_sites), once per process; callbacks
// installed before keep serving every actuator that is not pneumatic. Returns
// false and fills *error (naming the cylinder, actuator and key) if the
// configuration is invalid; m is unchanged then. A model without any
// "pneumatic:" element attaches with no cylinders. Attaching again re-reads the
// MJCF text, discarding values set with SetParameter.
//
// A callback the program installs in place of the extension's after Attach is
// found at the extension's next look at the model (Cylinders, IsAttached, the
// parameter functions, or a forward pass whose first callback is still the
// extension's: seal friction, mount=hinge_sites): the extension's goes back in
// front, passing every other actuator to it, and MuJoCo warns once. Install
// callbacks before Attach: a program that replaces mjcb_act_dyn afterwards and
// calls none of these is not seen.
bool Attach(mjModel* m, std::string* error);

// Makes m an ordinary model again: its actuators lose their pneumatic tags (and
// keep their fixed gains). Optional: a model may be freed without it.
void Detach(mjModel* m);

// True if m (or the model it was copied from) is attached.
bool IsAttached(const mjModel* m);

// A parameter of cylinder `cylinder` by its MJCF key ("stroke", "P.area"; a
// choice as its index among the choices of Parameters()). nullopt and *error if
// the model is not attached, or the cylinder or key is unknown or does not apply.
std::optional<double> GetParameter(const mjModel* m, const std::string& cylinder, const std::string& key,
                                   std::string* error);

// A choice parameter as its text ("valve" -> "proportional_per_chamber"); nullopt and *error as
// GetParameter, or if the key is not a choice.
std::optional<std::string> GetChoice(const mjModel* m, const std::string& cylinder, const std::string& key,
                                     std::string* error);

// Sets a parameter, checked exactly as the MJCF is (range, unit, the keys that
// apply, relations such as p_supply > p_exhaust); a chamber key without prefix
// sets both chambers. On success the model's stored parameters change and the
// next step uses them; on failure m is unchanged and *error says why. Choices
// ("valve", "flow", ...) take the text overload. Call it between steps, not
// while another thread steps m.
bool SetParameter(mjModel* m, const std::string& cylinder, const std::string& key, double value, std::string* error);
bool SetParameter(mjModel* m, const std::string& cylinder, const std::string& key, const std::string& value,
                  std::string* error);

// Sets several parameters of one cylinder at once, checked together (text values as in
// MJCF), e.g. {{"P.pressure_model", "identified"}, {"P.c1", "5.02"}, ...}: keys that only
// apply, or are only required, together. All or nothing, as SetParameter.
bool SetParameters(mjModel* m, const std::string& cylinder,
                   const std::vector<std::pair<std::string, std::string>>& values, std::string* error);

// The cylinder's configuration as the text of its MJCF element "pneumatic:<cylinder>": every
// key that applies, numbers written so they read back to the same bits. With SetParameter,
// how a tool writes a model with changed parameters. nullopt and *error as GetParameter.
std::optional<std::string> ConfigurationText(const mjModel* m, const std::string& cylinder, std::string* error);

// Chambers of a cylinder: P is the one whose pressure pushes x positive.
enum class Chamber { kP = 0, kN = 1 };

// Where a cylinder's signals live in mjModel/mjData, for tools and tests.
// Ids are actuator ids (-1 when the role is absent).
struct CylinderInfo {
  std::string name;                    // "<cylinder>"
  int chamber_actuator[2] = {-1, -1};  // "<name>.P", "<name>.N": act = p - p_atm (Pa)
  // command actuators by log signal name ("u", "uP", "uN", "u1".."u4", "duty"):
  // their ctrl is the command of docs/log_format.md (with commands=chambers these are the
  // chamber actuators themselves: write the commands here, not by actuator name)
  std::vector<std::pair<std::string, int>> command_actuators;
  // the actuator whose ctrl is command `signal` ("uP", ...), or -1 if this cylinder has none
  int CommandActuator(const std::string& signal) const {
    for (const auto& [command, id] : command_actuators) {
      if (command == signal) return id;
    }
    return -1;
  }
  double p_atm = 0;       // Pa abs: the reference of the gauge activations
  double p_supply = 0;    // Pa abs
  double p_exhaust = 0;   // Pa abs
  double x_mid = 0;       // actuator length at mid-stroke (m or rad); with mount=hinge_sites, |rod - cap| there
  // mount=hinge_sites: the sites "<name>.cap" and "<name>.rod" the cylinder spans and the hinge it turns
  // (its chamber actuators' joint); -1 for a cylinder that moves with its transmission
  int cap_site = -1, rod_site = -1, hinge = -1;
  // supply=<reservoir>: that reservoir's "<reservoir>.pressure" actuator (act = p - p_supply), or -1
  // for a cylinder fed at p_supply
  int supply_actuator = -1;
  // line_volume > 0: the actuators "<name>.LP", "<name>.LN" holding chamber P's, N's line pressure
  // (act = p_line - p_atm), or -1 for a chamber the valve feeds directly
  int line_actuator[2] = {-1, -1};
};

// The cylinders of an attached model (empty if m is not attached).
std::vector<CylinderInfo> Cylinders(const mjModel* m);

// Piston position x (m, or rad for a rotary cylinder): actuator length minus
// the length at mid-stroke, or |rod - cap| minus it with mount=hinge_sites; requires
// d->actuator_length (d->site_xpos) to be current (mj_forward or mj_step has run).
double PistonPosition(const mjModel* m, const mjData* d, const CylinderInfo& c);

// Piston velocity dx/dt, from d->actuator_velocity (with mount=hinge_sites: the lever arm times the
// hinge's velocity).
double PistonVelocity(const mjModel* m, const mjData* d, const CylinderInfo& c);

// The piston's Jacobian dx/dq (nv numbers into `row`): the chamber actuator's moment row, or with
// mount=hinge_sites the lever arm d|rod - cap|/dq on the hinge's dof. Requires the position stage
// (mj_kinematics, mj_comPos, mj_tendon, mj_transmission) to be current.
void PistonJacobian(const mjModel* m, const mjData* d, const CylinderInfo& c, mjtNum* row);

// mount=hinge_sites: the hinge angle (rad) at which the piston is at x, |rod - cap| = x + x_mid, the
// nearest to the hinge's angle in d (wrapped into (-pi, pi] about it), and in *lever_arm dL/dq there
// (a velocity v is then q' = v / dL/dq). Requires d's kinematics to be current for its qpos
// (mj_kinematics). nullopt and *error for any other cylinder, or when no angle gives that length.
std::optional<double> HingeAngleAt(const mjModel* m, const mjData* d, const CylinderInfo& c, double x,
                                   double* lever_arm, std::string* error);

// The joint whose coordinate the piston position is proportional to (x = gear q - x_mid: a slide or
// hinge joint transmission), or -1 (a tendon, a slider-crank, or mount=hinge_sites).
int DrivenJoint(const mjModel* m, const CylinderInfo& c);

// Absolute pressure (Pa) at the cylinder's supply ports, the log's p_S: its reservoir's (a state,
// d->act) when one feeds it, else p_supply.
double SupplyPressure(const mjModel* m, const mjData* d, const CylinderInfo& c);

// Sets the pressure (Pa abs) of the reservoir that feeds the cylinder, as SetReservoirPressure does
// (the reservoir's other cylinders see it too); false, and nothing written, for a cylinder fed at
// the constant p_supply.
bool SetSupplyPressure(const mjModel* m, mjData* d, const CylinderInfo& c, double pressure);

// Absolute chamber pressure (Pa) read from, or written to, d->act.
double ChamberPressure(const mjModel* m, const mjData* d, const CylinderInfo& c, Chamber k);
void SetChamberPressure(const mjModel* m, mjData* d, const CylinderInfo& c, Chamber k,
                        double pressure);

// Absolute pressure (Pa) in chamber k's line (line_volume > 0), read from, or written to, d->act;
// nullopt, or false and nothing written, for a chamber without a line.
std::optional<double> LinePressure(const mjModel* m, const mjData* d, const CylinderInfo& c, Chamber k);
bool SetLinePressure(const mjModel* m, mjData* d, const CylinderInfo& c, Chamber k, double pressure);

// One documented parameter of the MJCF configuration, for documentation and
// tools ("pneumo params").
struct ParameterDoc {
  std::string key;
  std::string unit;
  std::string default_value;   // "required" if it has none
  std::string valid;           // range or choices
  std::string scope;           // "cylinder" or "chamber" (may take a P. or N. prefix)
  std::string meaning;
  bool is_choice = false;      // a word from `valid`, not a number
  double min = 0, max = 0;     // numeric bounds (numbers only)
  bool min_open = false, max_open = false;  // true: the bound itself is excluded
};
const std::vector<ParameterDoc>& Parameters();

// Supply reservoirs: a state of the model shared by the cylinders it feeds (plugin/README.md,
// "Supply reservoirs"). MJCF: <text name="pneumatic_reservoir:<name>" data="volume=...
// line_conductance=..."/>, an actuator "<name>.pressure" (dyntype="user", no force) and
// supply=<name> in the text of each cylinder it feeds.
struct ReservoirInfo {
  std::string name;
  int actuator = -1;       // "<name>.pressure": act = p - p_source (Pa)
  double p_source = 0;     // Pa abs: the compressor behind the line, the fed cylinders' p_supply
  double volume = 0;       // m^3
  std::vector<std::string> cylinders;  // the cylinders it feeds
};
// The reservoirs of an attached model (empty if none or not attached).
std::vector<ReservoirInfo> Reservoirs(const mjModel* m);
// Absolute reservoir pressure (Pa) read from, or written to, d->act.
double ReservoirPressure(const mjModel* m, const mjData* d, const ReservoirInfo& r);
void SetReservoirPressure(const mjModel* m, mjData* d, const ReservoirInfo& r, double pressure);
// The reservoir keys (scope "reservoir"), for documentation and tools. Kept apart from
// Parameters(), whose every row is a key of a cylinder's text.
const std::vector<ParameterDoc>& ReservoirParameters();
// Sets one key of reservoir `name` on an attached model, checked as in its MJCF text (the key's
// range, and the volume against the chambers it feeds); the next step uses it, a copy of the model too.
// False and *error ("reservoir 'tank': key 'volume': ...") on failure, m unchanged.
// Call it between steps, as SetParameter.
bool SetReservoirParameter(mjModel* m, const std::string& name, const std::string& key, double value,
                           std::string* error);

}  // namespace pneumatic

#endif  // PNEUMATIC_PNEUMATIC_H_
