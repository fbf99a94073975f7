// Pneumatic actuators for MuJoCo 2.2.
//
// A pneumatic cylinder is written into an MJCF model as a few ordinary
// <general> actuators named "<cylinder>.<role>" plus one <custom><text> element
// "pneumatic:<cylinder>" holding its parameters (see plugin/README.md). Attach()
// reads and validates them and installs MuJoCo 2.2's global actuator callbacks
// (mjcb_act_dyn, mjcb_act_gain, mjcb_act_bias). From then on every mj_step
// advances each chamber pressure, stored as an activation in d->act (gauge
// pressure, Pa), over the step and applies the force
//   A_P (p_P - p_atm) - A_N (p_N - p_atm)
// through the actuators' transmission.
//
// All state lives in mjData (d->act, d->qpos, d->qvel, d->ctrl, d->time): the
// callbacks are pure functions of (m, d), so mj_resetData, mj_copyData,
// keyframes, finite differences and stepping different mjData from several
// threads work as they do for MuJoCo's own actuators.
#ifndef PNEUMATIC_PNEUMATIC_H_
#define PNEUMATIC_PNEUMATIC_H_

#include <string>
#include <vector>

#include <mujoco/mujoco.h>

namespace pneumatic {

// Reads the pneumatic cylinders of m, validates their configuration and
// installs the callbacks. Several models may be attached at once; callbacks
// installed before the first Attach keep serving every actuator that is not
// pneumatic. Returns false and fills *error (naming the cylinder, actuator
// and key) if the configuration is invalid; nothing is attached then.
// A model without any "pneumatic:" element attaches with no cylinders.
bool Attach(const mjModel* m, std::string* error);

// Forgets m. When the last model is detached, the callbacks that were
// installed before the first Attach are restored. Call it before
// mj_deleteModel(m). Detaching a model that is not attached does nothing.
void Detach(const mjModel* m);

// True if m is attached.
bool IsAttached(const mjModel* m);

// Chambers of a cylinder: P is the one whose pressure pushes x positive.
enum class Chamber { kP = 0, kN = 1 };

// Where a cylinder's signals live in mjModel/mjData, for tools and tests.
// Ids are actuator ids (-1 when the role is absent).
struct CylinderInfo {
  std::string name;                    // "<cylinder>"
  int chamber_actuator[2] = {-1, -1};  // "<name>.P", "<name>.N": act = p - p_atm (Pa)
  // command actuators by log signal name ("u", "uP", "uN", "u1".."u4", "duty"):
  // their ctrl is the command of log_format.md
  std::vector<std::pair<std::string, int>> command_actuators;
  double p_atm = 0;       // Pa abs: the reference of the gauge activations
  double p_supply = 0;    // Pa abs
  double p_exhaust = 0;   // Pa abs
  double x_mid = 0;       // actuator length at mid-stroke (m or rad)
};

// The cylinders of an attached model (empty if m is not attached).
std::vector<CylinderInfo> Cylinders(const mjModel* m);

// Piston position x (m, or rad for a rotary cylinder): actuator length minus
// the length at mid-stroke; requires d->actuator_length to be current
// (mj_forward or mj_step has run).
double PistonPosition(const mjModel* m, const mjData* d, const CylinderInfo& c);

// Piston velocity dx/dt, from d->actuator_velocity.
double PistonVelocity(const mjModel* m, const mjData* d, const CylinderInfo& c);

// Absolute chamber pressure (Pa) read from, or written to, d->act.
double ChamberPressure(const mjModel* m, const mjData* d, const CylinderInfo& c, Chamber k);
void SetChamberPressure(const mjModel* m, mjData* d, const CylinderInfo& c, Chamber k,
                        double pressure);

// One documented parameter of the MJCF configuration, for documentation and
// tools ("pneumo params").
struct ParameterDoc {
  std::string key;
  std::string unit;
  std::string default_value;   // "required" if it has none
  std::string valid;           // range or choices
  std::string scope;           // "cylinder" or "chamber" (may take a P. or N. prefix)
  std::string meaning;
};
const std::vector<ParameterDoc>& Parameters();

}  // namespace pneumatic

#endif  // PNEUMATIC_PNEUMATIC_H_
