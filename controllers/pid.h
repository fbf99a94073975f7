// Discrete PID position controller that writes a valve command.
//
//   e = ref - x
//   u = u_offset + kp e + ki sum(e) T - kd (x - x_prev) / T,  clipped to [u_min, u_max]
//
// The derivative acts on the measurement (no kick on reference steps); the
// integral stops growing while the output is saturated (anti-windup). The
// controller runs at its own sample period T, as on a real rig (zero-order
// hold between samples). Its state lives in the object: one per rollout.
#ifndef PNEUMATIC_CONTROLLERS_PID_H_
#define PNEUMATIC_CONTROLLERS_PID_H_

namespace pneumatic {

struct PidGains {
  double kp = 0;        // command per unit of position error (V/m for a valve in volts)
  double ki = 0;        // per unit of error and second
  double kd = 0;        // per unit of velocity
  double u_offset = 0;  // command at zero error (e.g. 5 V: the centre of a 0..10 V valve)
  double u_min = -1e300, u_max = 1e300;
};

class Pid {
 public:
  Pid(const PidGains& gains, double period) : gains_(gains), period_(period) {}

  // command for this sample, given reference and measured position
  double Update(double reference, double position);
  void Reset() { integral_ = 0, has_previous_ = false; }
  // new gains from the next sample on; the state (integral of the error) is kept
  void SetGains(const PidGains& gains) { gains_ = gains; }

  // the state: {integral of the error (error unit x s), previous position, 1 if there is one}
  static constexpr int kStateSize = 3;
  void GetState(double* out) const { out[0] = integral_, out[1] = previous_position_, out[2] = has_previous_; }
  void SetState(const double* in) { integral_ = in[0], previous_position_ = in[1], has_previous_ = in[2] != 0; }

 private:
  PidGains gains_;
  double period_;
  double integral_ = 0;
  double previous_position_ = 0;
  bool has_previous_ = false;
};

}  // namespace pneumatic

#endif  // PNEUMATIC_CONTROLLERS_PID_H_
