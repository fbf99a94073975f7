// The interface between a rollout and a feedback controller.
//
// A controller sees only what a real rig's controller sees, the measured signals of each
// cylinder at its own control ticks, and writes the valve commands of the log format
// (docs/log_format.md: uP/uN, u, u1..u4 or duty), which the rollout holds until the next
// tick (zero-order hold). Its state is explicit (State/SetState), so a rollout can be saved and
// resumed, and two controllers built alike with the same state give the same commands.
#ifndef PNEUMATIC_CONTROLLERS_CONTROLLER_H_
#define PNEUMATIC_CONTROLLERS_CONTROLLER_H_

#include <string>
#include <utility>
#include <vector>

namespace pneumatic {

// The signals of one cylinder sampled at a control tick (SI units, absolute pressures).
struct CylinderMeasurement {
  double p_P = 0, p_N = 0;  // Pa abs
  double x = 0;             // m or rad: piston position, 0 at mid-stroke
  double reference = 0;     // the target for x at this tick
  // 1/kg (1/(kg m^2) for a rotary cylinder): the piston's acceleration per unit of its own force
  // at this tick's pose with the joints it does not move held still, |J|^4 / (J M J'), J the
  // actuator's moment (dx/dq) and M the mass matrix: what a model-based controller computes from
  // the joint encoders and the robot's model; 0 where the rollout gives none
  double mobility = 0;
};

// The commands a controller writes for one cylinder: (log signal, value) pairs, e.g. {"uP", 5.6}.
using CylinderCommands = std::vector<std::pair<std::string, double>>;

class Controller {
 public:
  virtual ~Controller() = default;
  // the control period (s): the rollout calls Update every period
  virtual double Period() const = 0;
  // commands for every cylinder (same order as `measured`) from this tick's measurements
  virtual void Update(double time, const std::vector<CylinderMeasurement>& measured,
                      std::vector<CylinderCommands>* commands) = 0;
  // the controller's whole state as numbers, and back
  virtual std::vector<double> State() const = 0;
  // false (and no change) if `state` is not one this controller's State() gives
  virtual bool SetState(const std::vector<double>& state) = 0;
  // whether Update reads CylinderMeasurement::mobility; a rollout computes it only then (it costs
  // a pass over the model's kinematics and mass matrix per tick)
  virtual bool UsesMobility() const { return false; }
};

}  // namespace pneumatic

#endif  // PNEUMATIC_CONTROLLERS_CONTROLLER_H_
