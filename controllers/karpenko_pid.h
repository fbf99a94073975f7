// The nonlinear PI position controller of paper 001 (Karpenko, Sepehri, "Design and Experimental
// Evaluation of a Nonlinear Position Controller for a Pneumatic Actuator with Friction") for a
// cylinder with one 5/3 proportional valve (rig B), command u in V about the valve centre.
//
// Every control tick (period T = dt), per cylinder, from the measured x_p and the reference x_d:
//   e = x_d - x_p                                                   (12)
//   x_p' = (x_p(t) - x_p(t-dt)) / dt,  x_d' and x_d'' the backward differences of x_d (the paper
//   gives no estimator; zero on the first tick, x_d'' zero on the second too)
//   u = K_p e + K_i I(t), clipped to the valve's +-u_max (5 V: "the control valve saturates at 5 V")  (12)
// and the integral I follows, each addition switchable:
//   linear PI (all off):      I(t) = I(t-dt) + e dt
//   reset (Clegg, 13):        I(t) = 0 when |e| <= eps (and, with reset_when_still, only while x_d' = 0:
//                             Section VI, "only when the time derivative of the reference position is 0",
//                             and the last row of 15); else the row below
//   augmentation (14-15):     e_db' = (x_p' - x_d') x_d'^2 / (x_d'^2 + beta x_p'^2)     (14), 0 when both are 0
//                             with u* = K_p e + K_i I(t-dt) (the command before this tick's integral):
//                             e_db' >  e_min' and u* > -u_lower:  I = (-u_lower - K_p e) / K_i   (15, row 1)
//                             e_db' < -e_min' and u* <  u_upper:  I = ( u_upper - K_p e) / K_i   (15, row 3)
//                             otherwise the integration row (15, row 2)
//   braking (16-17):          the integration row becomes I(t-dt) + e dt + K_a x''_braking dt        (16)
//                             x''_braking = x_d'' if x_d'' x_d' < 0, else 0                         (17)
//                             (applied, as (16) says, while |e_db'| <= e_min', whether or not augmentation is on)
// Readings of the paper's text, where it is not explicit:
//  - (15) row 3 is printed with "e_db' > e_min'"; with row 1's condition it could never fire. The
//    piston lagging a reference that moves towards +x gives e_db' = -x_d' < 0 (14), which row 3's
//    u_upper (push towards +x) answers, so row 3 is read as e_db' < -e_min'.
//  - When |e_db'| > e_min' but the command is already beyond the threshold (u* <= -u_lower, or
//    u* >= u_upper), (15) gives no row; the integral integrates as in row 2 (16 with braking on).
//  - Order: the reset row first (it is the only way the integral is zeroed), then the augmentation
//    rows, then integration.
//  - There is no anti-windup besides the reset (the paper has none): the integral integrates while u saturates.
//
// The paper's parameters (SI): K_p = 10 V/m, K_i = 26 V/(m s) (QFT design, Section V), eps = 1 mm
// (Section VI; 4 mm for Fig. 9's S-curves), e_min' = 0.005 m/s, beta = 50, u_lower = u_upper = 0.65 V
// (15), K_a = 0.15 s^2 (16).
#ifndef PNEUMATIC_CONTROLLERS_KARPENKO_PID_H_
#define PNEUMATIC_CONTROLLERS_KARPENKO_PID_H_

#include <memory>
#include <string>
#include <vector>

#include "config_parser.h"
#include "controller.h"
#include "position_pid.h"

namespace pneumatic {

// The parameters, with paper 001's values as defaults (SI units). One table (KarpenkoPidKeys)
// names, documents and range-checks them.
struct KarpenkoPidParams {
  double kp = 10;            // V/m, (12): K_p
  double ki = 26;            // V/(m s), (12): K_i
  bool reset = true;         // (13): Clegg-type reset with threshold eps; off: the linear PI
  double epsilon = 0.001;    // m, (13): eps (Fig. 9: 0.004)
  bool reset_when_still = true;  // reset only while x_d' = 0 (Section VI, (15) row 4); off: (13) as printed
  bool augmentation = false; // (14-15): velocity-error-triggered integral augmentation
  double e_dot_min = 0.005;  // m/s, (15): e_min'
  double beta = 50;          // (14)
  double u_lower = 0.65;     // V, (15)
  double u_upper = 0.65;     // V, (15)
  bool braking = false;      // (16-17): braking-acceleration overshoot reduction
  double ka = 0.15;          // s^2, (16): K_a
};

// One parameter of KarpenkoPidParams: its key, unit, meaning and valid range (config_parser.h); the
// switches (reset, reset_when_still, augmentation, braking) are 0 or 1.
using KarpenkoPidKey = ControllerKey<KarpenkoPidParams>;
const std::vector<KarpenkoPidKey>& KarpenkoPidKeys();

// "" if every parameter is in range, else "karpenko PID controller: key 'KEY': ..." for the first one
// that is not (its value and the valid range).
std::string ValidateKarpenkoPidParams(const KarpenkoPidParams& params);

// Sets one parameter by key (switches: 0 or 1). False and *error naming the key if the key is
// unknown or the value out of range.
bool SetKarpenkoPidParameter(KarpenkoPidParams* params, const std::string& key, double value, std::string* error);

// Parses "key=value key=value ..." (spaces, tabs, newlines or commas between pairs) over `params`'
// current values. False and *error naming the key on an unknown key, a bad number or a value out
// of range; `params` is unchanged then.
bool ParseKarpenkoPidConfig(const std::string& text, KarpenkoPidParams* params, std::string* error);

// (14): the velocity error due to deadband and friction; 0 when x_d' = x_p' = 0.
double KarpenkoVelocityErrorEq14(double xp_dot, double xd_dot, double beta);
// (17): x_d'' when it brakes the reference (x_d'' x_d' < 0), else 0.
double KarpenkoBrakingEq17(double xd_dot, double xd_ddot);

class KarpenkoPid : public Controller {
 public:
  // Null and *error when a drive is not one 5/3 valve ("cylinder 2: ..."), the period is not
  // positive, or a parameter is out of range (the message names its key).
  static std::unique_ptr<KarpenkoPid> Create(std::vector<ValveDrive> drives, const KarpenkoPidParams& params,
                                             double period, std::string* error);

  double Period() const override { return period_; }
  // writes {"u", volts} per cylinder
  void Update(double time, const std::vector<CylinderMeasurement>& measured,
              std::vector<CylinderCommands>* commands) override;
  // kStateSize numbers per cylinder: {ticks seen (0, 1 or 2 = two or more), I (m s), x_p(t-dt),
  // x_d(t-dt), x_d(t-2dt), and what the last tick computed: e_db' (m/s), the branch, u (V)}
  std::vector<double> State() const override;
  bool SetState(const std::vector<double>& state) override;
  static constexpr int kStateSize = 8;

  // the branch the last tick took for the integral
  enum Branch { kIntegrate = 0, kReset = 1, kAugmentLower = 2, kAugmentUpper = 3 };

  const KarpenkoPidParams& params() const { return params_; }
  double Integral(size_t i) const { return cylinders_[i].integral; }
  double VelocityError(size_t i) const { return cylinders_[i].e_db; }
  int LastBranch(size_t i) const { return static_cast<int>(cylinders_[i].branch); }

 private:
  struct Cylinder {
    double ticks = 0, integral = 0, x1 = 0, r1 = 0, r2 = 0, e_db = 0, branch = 0, u = 0;
  };
  KarpenkoPid(std::vector<ValveDrive> drives, const KarpenkoPidParams& params, double period);

  std::vector<ValveDrive> drives_;
  KarpenkoPidParams params_;
  double period_;
  std::vector<Cylinder> cylinders_;
};

}  // namespace pneumatic

#endif  // PNEUMATIC_CONTROLLERS_KARPENKO_PID_H_
