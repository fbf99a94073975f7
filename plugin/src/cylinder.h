// One pneumatic cylinder bound to the actuators of a compiled mjModel: the
// validated configuration, the actuator ids of its roles, and the pure
// functions of (m, d) that the callbacks return for each role.
#ifndef PNEUMATIC_CYLINDER_H_
#define PNEUMATIC_CYLINDER_H_

#include <optional>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "chamber.h"
#include "config.h"
#include "pneumatic/pneumatic.h"
#include "valves.h"

namespace pneumatic {

// what a MuJoCo actuator is to the extension
enum class Role {
  kNone,      // not pneumatic: callbacks chain to the ones installed before
  kChamber,   // "<cyl>.P" / "<cyl>.N": act = p - p_atm, force = +A_P act or -A_N act
  kCommand,   // valve command in ctrl; act (if any) = valve state (spool, armature)
  kFriction,  // "<cyl>.friction": seal friction as bias
};

struct ActuatorRole {
  Role role = Role::kNone;
  int cylinder = -1;  // index into the model's cylinders
  int index = 0;      // chamber (0 = P, 1 = N) or valve index (u1..u4 -> 0..3)
};

class Cylinder {
 public:
  // Binds the configuration to m's actuators named "<name>.<role>", checks
  // their types and transmissions; nullopt with *error on failure.
  static std::optional<Cylinder> FromModel(const mjModel* m, CylinderConfig config, std::string* error);

  const CylinderConfig& config() const { return config_; }
  const CylinderInfo& info() const { return info_; }
  // (actuator id, role) of every actuator of this cylinder
  const std::vector<std::pair<int, ActuatorRole>>& actuators() const { return actuators_; }

  // act_dot of a chamber actuator: (p(t + h) - p(t)) / h with the exact step
  double ChamberActDot(const mjModel* m, const mjData* d, int chamber) const;
  // act_dot of a valve-state actuator (spool or armature)
  double ValveActDot(const mjModel* m, const mjData* d, int valve) const;
  // gain of a chamber actuator: force = gain * act
  double ChamberGain(int chamber) const;
  // seal friction (bias of "<cyl>.friction"), on top of the transmission's frictionloss
  double FrictionBias(const mjModel* m, const mjData* d) const;

 private:
  ValveInputs ReadValves(const mjModel* m, const mjData* d) const;
  VolumePath Volume(const mjModel* m, const mjData* d, int chamber) const;
  // piston velocity at the end of the step, predicted from the smooth dynamics (constraint forces
  // and the Euler integrator's implicit damping left out)
  double EndOfStepVelocity(const mjModel* m, const mjData* d) const;

  CylinderConfig config_;
  CylinderInfo info_;
  ChamberModel chamber_model_[2];
  int command_id_[4] = {-1, -1, -1, -1};  // ctrl sources, in ValveInputs::command order
  int state_id_[4] = {-1, -1, -1, -1};    // act sources, in ValveInputs::state order
  double static_friction_ = 0;            // transmission frictionloss in actuator units
  std::vector<std::pair<int, ActuatorRole>> actuators_;
};

}  // namespace pneumatic

#endif  // PNEUMATIC_CYLINDER_H_
