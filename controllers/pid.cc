#include "pid.h"

#include <algorithm>

namespace pneumatic {

double Pid::Update(double reference, double position) {
  double error = reference - position;
  double rate = has_previous_ ? (position - previous_position_) / period_ : 0;
  previous_position_ = position;
  has_previous_ = true;
  double unclipped = gains_.u_offset + gains_.kp * error + gains_.ki * (integral_ + error * period_) - gains_.kd * rate;
  double u = std::clamp(unclipped, gains_.u_min, gains_.u_max);
  // anti-windup: integrate only while the output is not pushed further into saturation
  bool saturated = (unclipped > gains_.u_max && error > 0) || (unclipped < gains_.u_min && error < 0);
  if (!saturated) integral_ += error * period_;
  return u;
}

}  // namespace pneumatic
