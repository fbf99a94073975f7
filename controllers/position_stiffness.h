// Position and stiffness for a cylinder with one proportional valve per chamber (paper 000's
// set-up, rig C): the difference of the two valve commands drives the position, their common
// part drives the sum of the chamber pressures, the co-contraction that sets the joint's
// stiffness, each by its own PI(D) loop (the project's own form; paper 000 Section I motivates
// the independent chamber valves by exactly this stiffness control).
//
//   position:  e_x = (ref - x) / (l/2),  d = PID(e_x) in [-1, 1]          (pid.h, derivative on x)
//   stiffness: e_s = (s* - (p_P + p_N) / 2) / (p_supply - p_exhaust),  c = PI(e_s) in [-c_max, c_max] V
//   valves:    uP = u_c + c + swing d,  uN = u_c + c - swing d,  clipped to the actuators' ctrlrange
// with u_c = (U_c + U_r) / 2 the valve centre and s* the target mean chamber pressure (Pa abs).
//
// The loops must run well above the chambers' pressure bandwidth: rig C's 1 cm^3 chambers fill in
// about 10 ms, and at 100 Hz the stiffness loop limit-cycles between exhaust and supply (measured);
// at 1 kHz both loops settle (tests/closed_loop_test). Larger chambers (paper 000's humanoid, with
// its tubes) allow slower loops.
#ifndef PNEUMATIC_CONTROLLERS_POSITION_STIFFNESS_H_
#define PNEUMATIC_CONTROLLERS_POSITION_STIFFNESS_H_

#include <memory>
#include <string>
#include <vector>

#include "controller.h"
#include "pid.h"
#include "position_pid.h"

namespace pneumatic {

struct PositionStiffnessParams {
  double kp = 1.5, ki = 1.5, kd = 0.0375;  // position loop on the error over the half stroke (as PositionPidGains)
  double swing = 2;                         // V of differential command per unit of demand
  // target mean chamber pressure (p_P + p_N) / 2 as a fraction of the way from p_exhaust to p_supply
  double mean_pressure = 0.5;
  double stiffness_kp = 4;                  // V per unit of normalised mean-pressure error
  double stiffness_ki = 20;                 // V per unit of error and second
  double max_common = 2;                    // V: |c| at most
};

// "key=value ..." into params (keys: kp ki kd swing mean_pressure stiffness_kp stiffness_ki
// max_common); "" or the error naming the key; params unchanged on error
std::string ParsePositionStiffnessConfig(const std::string& text, PositionStiffnessParams* params);

class PositionStiffness : public Controller {
 public:
  // null and *error unless every cylinder has one proportional valve per chamber
  static std::unique_ptr<PositionStiffness> Create(const std::vector<ValveDrive>& drives,
                                                   const PositionStiffnessParams& params, double period,
                                                   std::string* error);
  double Period() const override { return period_; }
  void Update(double time, const std::vector<CylinderMeasurement>& measured,
              std::vector<CylinderCommands>* commands) override;
  std::vector<double> State() const override;
  bool SetState(const std::vector<double>& state) override;

 private:
  PositionStiffness(std::vector<ValveDrive> drives, const PositionStiffnessParams& params, double period);
  std::vector<ValveDrive> drives_;
  PositionStiffnessParams params_;
  std::vector<Pid> position_, stiffness_;
  double period_;
};

}  // namespace pneumatic

#endif  // PNEUMATIC_CONTROLLERS_POSITION_STIFFNESS_H_
