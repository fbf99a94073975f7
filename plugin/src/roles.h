// The table of actuator roles: every actuator the extension gives a meaning to is
// "<owner>.<suffix>", where the owner is a cylinder ("pneumatic:<name>") or a
// supply reservoir ("pneumatic_reservoir:<name>"), and its suffix is one row of
// this table. A row says what the actuator is to a step (a state whose act the
// extension integrates, a command whose ctrl it reads, a force it applies), which
// configuration needs it, its unit and what act = 0 (mj_resetData) means.
//
// Binding (Cylinder::FromModel, BindReservoir) asks the table which roles a
// configuration needs, and refuses a model that lacks one ("missing: ... (role
// 'u1', required by valve=onoff with input=valves)") or has one it does not use.
// Dispatch does not read the table: the engine's leader pass steps every cylinder
// and reservoir of the model, and each writes the act_dot of all its states. A new
// state role is one row here plus the physics that writes its act_dot.
#ifndef PNEUMATIC_ROLES_H_
#define PNEUMATIC_ROLES_H_

#include <string>

#include <mujoco/mujoco.h>

#include "config.h"

namespace pneumatic {

// what a MuJoCo actuator is to the extension's callbacks
enum class Role {
  kNone,       // not pneumatic: callbacks chain to the ones installed before
  kChamber,    // "<cyl>.P" / "<cyl>.N": act = p - p_atm, force = +A_P act or -A_N act
  kCommand,    // valve command in ctrl; act (if any) = valve state (spool, armature)
  kFriction,   // "<cyl>.friction": seal friction as bias
  kState,      // an extra state of a cylinder (a row of kind state with no other role): act_dot from its step
  kReservoir,  // "<res>.pressure": act = p - p_source of a supply reservoir
};

struct ActuatorRole {
  Role role = Role::kNone;
  int cylinder = -1;  // index into the model's cylinders (or reservoirs, for kReservoir)
  int index = 0;      // chamber (0 = P, 1 = N), valve index (u1..u4 -> 0..3), or extra-state slot
};

enum class RoleOwner { kCylinder, kReservoir };

// one row of the role table
struct RoleSpec {
  const char* suffix;  // the actuator is "<owner>.<suffix>"
  RoleOwner owner;
  Role role;
  int index;  // ActuatorRole::index: chamber, valve (ValveInputs::command / ::state slot) or extra-state slot
  // for a cylinder's configuration (null for a reservoir's rows): whether its ctrl is a command the
  // step reads, whether its act is a state the step integrates (dyntype="user"), whether it applies
  // a force through its bias; the role is required when any holds
  bool (*command)(const CylinderConfig* c);
  bool (*state)(const CylinderConfig* c);
  bool (*bias)(const CylinderConfig* c);
  const char* required_by;  // the keys that need it, as errors and documentation name them
  const char* unit;         // of the state (act) or command (ctrl)
  const char* initial;      // states: what act = 0 (mj_resetData) means
  const char* meaning;
  const char* missing;      // why it must be there, for the error when it is not ("{}" = owner name)
};

// every row, cylinder rows first
const RoleSpec* RoleTable(int* count);
// the row of `suffix` for `owner`, or null
const RoleSpec* FindRole(RoleOwner owner, const std::string& suffix);
// true if the configuration needs the row (c null for reservoir rows)
bool RoleRequired(const RoleSpec& r, const CylinderConfig* c);
// why actuator `id` cannot hold a state of row r that applies no force (a reservoir's or an extra
// state's), or "" if it can: dyntype="user" (the extension's pass writes its act_dot), no force
// (gaintype="user" or gainprm 0, biastype="none"; Attach fixes the gain at 0), not actlimited
std::string StateActuatorProblem(const mjModel* m, int id, const RoleSpec& r);
// "state", "command", "command + state", "force", "state + force"
std::string RoleKindText(const RoleSpec& r);

// the index in mjData::act (and act_dot) of a stateful actuator `id`: MuJoCo orders the actuators
// with dynamics last, so act holds actuators nu - na ... nu - 1
inline int ActIndex(const mjModel* m, int id) { return id - (m->nu - m->na); }

}  // namespace pneumatic

#endif  // PNEUMATIC_ROLES_H_
