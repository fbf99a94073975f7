// The 3-mode and 7-mode sliding controllers of paper 002 (Hodgson, Le, Tavakoli, Pham, "Improved
// tracking and switching performance of an electro-pneumatic positioning system") for a cylinder
// with four on/off valves: U1 P-supply, U2 P-exhaust, U3 N-supply, U4 N-exhaust (rig A).
//
// Every control tick j (period T), per cylinder, from the measured x, p_P, p_N and the reference y_d:
//   e = x - y_d                                                   (paper 002, below eq. 7)
//   e_filt = a 2nd-order Butterworth low-pass of e, cut-off 50 Hz   (VI.A)
//   e_dot(j)  = (e_filt(j) - e_filt(j-1)) / T                      (29)
//   e_ddot(j) = (e_filt(j) - 2 e_filt(j-1) + e_filt(j-2)) / T^2    (30)
//   s = e_ddot / w^2 + 2 xi e_dot / w + e_filt                     (31), the switching function (7)
// and the valves take one of the modes of Table I:
//   mode  M1    M2    M3    M4    M5    M6    M7
//   u1    0     1     0     0     0     1     0        M2: P to supply, N closed   M3: P to exhaust
//   u2    0     0     1     0     0     0     1        M4: N to exhaust, P closed  M5: N to supply
//   u3    0     0     0     0     1     0     1        M6: P supply + N exhaust (push hardest)
//   u4    0     0     0     1     0     1     0        M7: P exhaust + N supply (pull hardest)
// so supply and exhaust of one chamber are never open together.
//
// 3 modes (Nguyen et al., paper 002's ref. [17] and Fig. 6): M7 when s > e_min, M6 when s < -e_min,
//   M1 (all closed) in between.
// 7 modes (paper 002, Table II), read in this order:
//   |s| <= eps                 M1
//   s > beta                   M7;   s < -beta: M6
//   eps < s <= beta            M5 if E1 > 0, else M3
//   -beta <= s < -eps          M2 if E1 > 0, else M4
//   with E1 = (P_S + P_E) - (p_P + p_N) (15) = E2 (16), and the timeout tau (IV.C.1): a change
//   M2 <-> M4 or M3 <-> M5 waits until the current mode has been held tau.
//   The threshold eps is variable (22-25):
//     s_stop = | p_N y'_d l / (p_N y'_d + p_P (l - y'_d)) - y'_d |,  y'_d = y_d + l/2     (24)
//     eps = kappa s_stop when s e_dot < 0 and |y_d_dot| < y_d_dot_min, else e_min      (25)
//   y_d_dot is the backward difference of the reference (29 applied to y_d). Table II does not
//   say which row wins when eps > beta (the rows overlap); the M1 row is read first, because the
//   purpose of (25) is to remove actuation early enough for the piston to coast onto y_d (Fig. 5).
//
// The paper's parameters (Section V, simulation): w = 100 rad/s, xi = 0.5, tau = 40 ms,
// beta = 3.0 mm, e_min = 1.0 mm; (25): kappa = 2, y_d_dot_min = 20 mm/s; Table V: P_S = 3 bar,
// P_E = 1 bar. The experiments (Section VI) used w = 60 rad/s at 500 Hz. Eq. (18) gives beta from
// the rig: beta = 3 xi A (P_S - P_E) / (4 b w) (SlidingModeBetaEq18).
#ifndef PNEUMATIC_CONTROLLERS_SLIDING_MODE_H_
#define PNEUMATIC_CONTROLLERS_SLIDING_MODE_H_

#include <memory>
#include <string>
#include <vector>

#include "config_parser.h"
#include "controller.h"
#include "position_pid.h"

namespace pneumatic {

// The parameters, with paper 002's values as defaults (SI units). One table (SlidingModeKeys)
// names, documents and range-checks them.
struct SlidingModeParams {
  int modes = 7;                // 3 (ref. [17], Fig. 6) or 7 (Table II)
  double omega = 100;           // rad/s, eq. (7): w, Section V (Section VI: 60)
  double xi = 0.5;              // eq. (7): xi
  double tau = 0.040;           // s, IV.C.1: timeout between M2<->M4 and M3<->M5 (7 modes)
  double beta = 0.003;          // m, Table II: threshold of the hardest modes M6, M7 (7 modes)
  double e_min = 0.001;         // m, eq. (25): the fixed eps (both controllers)
  double kappa = 2;             // eq. (25): gain on s_stop (7 modes)
  double yd_dot_min = 0.020;    // m/s, eq. (25): reference speed below which eps may grow (7 modes)
  bool variable_epsilon = true; // eqs. (22-25) on (7 modes); off: eps = e_min
  double filter_cutoff = 50;    // Hz, VI.A: 2nd-order Butterworth on the error
  double p_supply = 3.0e5;      // Pa abs, Table V: P_S in E1 (15)
  double p_exhaust = 1.0e5;     // Pa abs, Table V: P_E in E1 (15)
};

// One parameter of SlidingModeParams: its key, unit, meaning and valid range (config_parser.h); modes
// is 3 or 7, variable_epsilon 0 or 1.
using SlidingModeKey = ControllerKey<SlidingModeParams>;
const std::vector<SlidingModeKey>& SlidingModeKeys();

// "" if every parameter is in range, else "sliding-mode controller: key 'KEY': ..." for the first
// one that is not (its value and the valid range).
std::string ValidateSlidingModeParams(const SlidingModeParams& params);

// Sets one parameter by key (variable_epsilon: 0 or 1; modes: 3 or 7). False and *error naming
// the key if the key is unknown or the value out of range.
bool SetSlidingModeParameter(SlidingModeParams* params, const std::string& key, double value, std::string* error);

// Parses "key=value key=value ..." (spaces, tabs, newlines or commas between pairs) over `params`'
// current values. False and *error naming the key on an unknown key, a bad number or a value out
// of range; `params` is unchanged then.
bool ParseSlidingModeConfig(const std::string& text, SlidingModeParams* params, std::string* error);

// Eq. (18): beta = 3 xi A (P_S - P_E) / (4 b w), m; area A m^2, viscous friction b N s/m.
double SlidingModeBetaEq18(double xi, double omega, double area, double p_supply, double p_exhaust, double viscous);

// The valve states {u1, u2, u3, u4} of Table I's mode 1..7.
const double* SlidingModeValves(int mode);

class SlidingModeController : public Controller {
 public:
  // Null and *error when a drive is not on/off valves ("cylinder 2: ..."), the period is not
  // positive, or a parameter is out of range (the message names its key); the filter's cut-off
  // must lie below the Nyquist frequency 1/(2 period).
  static std::unique_ptr<SlidingModeController> Create(std::vector<ValveDrive> drives, const SlidingModeParams& params,
                                                       double period, std::string* error);

  double Period() const override { return period_; }
  // writes {"u1","u2","u3","u4"} (0 or 1) per cylinder
  void Update(double time, const std::vector<CylinderMeasurement>& measured,
              std::vector<CylinderCommands>* commands) override;
  // kStateSize numbers per cylinder: {started, e(j-1), e(j-2), e_filt(j-1), e_filt(j-2), y_d(j-1),
  // mode, ticks held in the mode, s, eps} (the last two: what the last tick saw)
  std::vector<double> State() const override;
  bool SetState(const std::vector<double>& state) override;
  static constexpr int kStateSize = 10;

  const SlidingModeParams& params() const { return params_; }
  // what the last tick of cylinder i computed: the mode (1..7), s (m) and eps (m)
  int Mode(size_t i) const { return static_cast<int>(cylinders_[i].mode); }
  double SwitchingFunction(size_t i) const { return cylinders_[i].s; }
  double Epsilon(size_t i) const { return cylinders_[i].eps; }

 private:
  struct Cylinder {
    double started = 0;
    double e1 = 0, e2 = 0;    // e(j-1), e(j-2)
    double f1 = 0, f2 = 0;    // e_filt(j-1), e_filt(j-2)
    double yd1 = 0;           // y_d(j-1)
    double mode = 1, held = 0;
    double s = 0, eps = 0;
  };
  SlidingModeController(std::vector<ValveDrive> drives, const SlidingModeParams& params, double period);
  int ChooseMode(const ValveDrive& drive, const CylinderMeasurement& y, Cylinder* c);

  std::vector<ValveDrive> drives_;
  SlidingModeParams params_;
  double period_;
  double b0_ = 1, b1_ = 0, b2_ = 0, a1_ = 0, a2_ = 0;  // the Butterworth filter, direct form I
  std::vector<Cylinder> cylinders_;
};

}  // namespace pneumatic

#endif  // PNEUMATIC_CONTROLLERS_SLIDING_MODE_H_
