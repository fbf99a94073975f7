// Valves: the openings of a chamber's supply and exhaust ports over one step.
//
// Openings are in the units of the chamber's flow law (C_val in kg/(s Pa) for
// iso6358, area in m^2 for sanville and thin plate). Within a step, commands
// are held (zero-order hold); valve states (spool position, on/off armature)
// move as closed-form functions of time, so the openings are known exactly at
// any instant of the step and the chamber integrator can split the step at
// the instants where they jump.
#ifndef PNEUMATIC_VALVES_H_
#define PNEUMATIC_VALVES_H_

#include <vector>

#include "config.h"

namespace pneumatic {

struct PortOpenings {
  double supply = 0;   // port between supply and chamber
  double exhaust = 0;  // port between chamber and exhaust
};

// commands and valve states of one cylinder at the start of a step
struct ValveInputs {
  double time = 0;         // s, d->time
  double step = 0;         // s, the MuJoCo timestep h
  // onoff/valves: u1..u4; onoff/pwm: [0] = duty; 5/3: [0] = u (V); per chamber: [0] = uP, [1] = uN (V)
  double command[4] = {0, 0, 0, 0};
  // onoff with delays: armature positions of valves 1..4 in [0, 1]; 5/3 with a lag: [0] = spool x_v (m)
  double state[4] = {0, 0, 0, 0};
};

// full-open capacity of one on/off valve port in flow-law units, per chamber
double OnOffCapacity(const ChamberConfig& chamber);

// paper 000 eq. (3): supply and exhaust areas (m^2) of a chamber's own valve at command u (V)
PortOpenings ProportionalValveAreas(const ChamberConfig& chamber, double u);

// effective spool opening (m) after the deadband; paper 001, rigs.md rig B
double SpoolOpening(const CylinderConfig& c, double spool_position);

// The openings of one chamber's ports on [0, h], piecewise in time.
class PortSchedule {
 public:
  PortSchedule(const CylinderConfig& c, int chamber, const ValveInputs& in);
  PortOpenings At(double tau) const;
  // instants in (0, h) where the openings jump, increasing
  const std::vector<double>& breakpoints() const { return breakpoints_; }

 private:
  const CylinderConfig* config_;
  int chamber_;
  bool spool_ = false;                  // 5/3 valve: openings follow the spool
  double spool_start_ = 0, spool_target_ = 0;
  std::vector<double> breakpoints_;     // segment k starts at breakpoints_[k-1] (0 for k = 0)
  std::vector<PortOpenings> segments_;  // openings on each segment
};

// state of valve actuators at the end of the step (the value their act must reach)
// onoff: armature of valve i (0..3); 5/3: spool position (m)
double ValveStateAtEnd(const CylinderConfig& c, int valve, const ValveInputs& in);

// true if the cylinder's valves carry state in d->act (spool lag, on/off delays)
bool ValvesHaveState(const CylinderConfig& c);

}  // namespace pneumatic

#endif  // PNEUMATIC_VALVES_H_
