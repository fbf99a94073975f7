// Paper 003 (Laib, Pham, Lin-Shi, Meghnous, "Average modeling and nonlinear observer design for
// pneumatic actuators with on/off solenoid valves", JDSMC 2021): the sliding-mode position
// controller (18-20) on the three-mode averaged model (14-15), fed by the high-gain observer (22)
// or the sliding-mode observer (23), for a cylinder whose four on/off valves are driven by PWM
// from one duty u in [-1, 1] (input=pwm: mode 6 for u >= 0, mode 7 for u < 0, eqs. 12-13).
//
// The averaged state (15): X = (x1, x2, x3, x4) = (y, y', y'', p_P), absolute pressures, with
//   L_P = l/2 + x1 + V0/A_P, L_N = l/2 - x1 + V0/A_N   (the paper's l/2 +- y, plus the rig's dead
//                                                       volume as a length; V0 = 0 is the paper)
//   psi(X) = (A_P x4 - m x3 - b x2) / A_N                  (p_N from the piston balance, below 15)
//   phi1 = -(k/m) (A_P x4 / L_P + A_N psi / L_N) x2 - (b/m) x3
//   g1   = (k r T/m) (Q(P_S, x4)/L_P + Q(psi, P_E)/L_N)    u >= 0
//          (k r T/m) (Q(x4, P_E)/L_P + Q(P_S, psi)/L_N)    u <  0
//   phi2 = -k x4 x2 / L_P
//   g2   = (k r T/(A_P L_P)) Q(P_S, x4)  u >= 0;   (k r T/(A_P L_P)) Q(x4, P_E)  u < 0
//   X' = (x2, x3, phi1 + g1 u, phi2 + g2 u)                                        (15)
// (the paper prints g2's two branches swapped, a typo: with u >= 0 mode 6 opens P to supply,
// eq. 13, and with u < 0 mode 7 vents it, so g2 u < 0). Q is eq. (3) with T_u = T.
//
// The controller (one cylinder, every tick t_k of period T), from the estimate X^:
//   e_p = x1^ - y_d,  s_p = (d/dt + lambda)^3 int e_p = e_p'' + 3 lambda e_p' + 3 lambda^2 e_p + lambda^3 int e_p
//   u~  = y_d''' - phi1 - 3 lambda e_p'' - 3 lambda^2 e_p' - lambda^3 e_p                   (19)
//   K_c = beta (gamma |phi1| + eta) + (beta - 1) |u~|                                        (20)
//   u   = (u~ - K_c sign(s_p)) / g1,  clipped to [-1, 1]                                     (18)
// with e_p' = x2^ - y_d', e_p'' = x3^ - y_d''; the derivatives of y_d are backward differences of
// the reference over the ticks (the controller sees y_d only), the integral a rectangle sum.
// (18) picks g1's branch by the sign of u~; we pick it by the sign of the numerator u~ - K_c
// sign(s_p), i.e. by the sign of u, which is the branch the model (15) applies (our reading).
//
// The observers use the measured z = (x, p_P) only (p_N is never read, as in the paper, Fig. 7):
//   high gain (22):    X^' = F(X^, u) - Theta G (C X^ - z),  Theta G = (theta1 g11, theta1^2 g12,
//                      theta1^3 g13 | theta2 g2): the standard high-gain correction of [26, 27]
//                      (the paper writes Theta^-1 G, which with its Theta = diag(10^2, 10^4, 10^6,
//                      200) gives poles near -1.4 and -0.07 1/s: no observer; our reading)
//   sliding mode (23): X^' = F(X^, u) - K (C X^ - z) - L sign(C X^ - z)
// Each tick integrates the observer from t_{k-1} to t_k (forward Euler, `substeps` steps) under the
// duty held over that interval, with z interpolated linearly between the samples at t_{k-1} and
// t_k, so the estimate at t_k has seen the measurement at t_k; then u(t_k) follows from it.
//
// Paper values (Section 7, Table 2; Appendix C, Table 3): lambda = 60, beta = 1.1, gamma = 0.1,
// eta = 20; G = (150, 1900, 10000 | 30), Theta = diag(10^2, 10^4, 10^6 | 200); K = (100, 1840,
// 12000 | 10), L = (5, 2, 15 | 20); m = 0.9 kg, b_v = 50 N s/m, A = 1.81e-4 m^2, k = 1.2,
// r = 286.68 J/(kg K), T = 296 K, P_S = 3.01 bar, P_E = 1.01 bar, b_crit = 0.493,
// C_val = 3.4e-9 kg/(s Pa); Table 3's l = 0.01 m is read as 0.1 m (it could not hold the 40 mm
// sine of Section 7); the paper has no dead volume (V0 = 0). 500 Hz control (Section 7).
#ifndef PNEUMATIC_CONTROLLERS_LAIB_SMC_H_
#define PNEUMATIC_CONTROLLERS_LAIB_SMC_H_

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "config_parser.h"
#include "controller.h"
#include "position_pid.h"

namespace pneumatic {

// Every parameter, SI units, paper 003's values as defaults.
struct LaibSmcParams {
  // the model (15) the controller and observers are built on (Table 3)
  double mass = 0.9;              // kg, m
  double viscous = 50;            // N s/m, b_v
  double stroke = 0.1;            // m, l (Table 3 prints 0.01)
  double area_P = 1.81e-4;        // m^2, A_P
  double area_N = 1.81e-4;        // m^2, A_N
  double dead_volume = 0;         // m^3, V0 of each chamber (not in the paper: 0)
  double polytropic_index = 1.2;  // k
  double gas_constant = 286.68;   // J/(kg K), r
  double temperature = 296;       // K, T
  double p_supply = 3.01e5;       // Pa abs, P_S
  double p_exhaust = 1.01e5;      // Pa abs, P_E
  double critical_ratio = 0.493;  // b_crit of (3)
  double sonic_conductance = 3.4e-9;  // kg/(s Pa), C_val of (3)
  // the controller (18-20), Table 2
  double lambda = 60;   // 1/s
  double beta = 1.1;    // > 1: gain uncertainty bound of (17)
  double gamma = 0.1;   // drift uncertainty bound of (17)
  double eta = 20;      // m/s^3: reaching gain of (20)
  // the observer: 0 high gain (22), 1 sliding mode (23)
  int observer = 0;
  double g11 = 150, g12 = 1900, g13 = 10000, g2 = 30;  // G of (22)
  double theta1 = 100, theta2 = 200;                   // Theta of (22)
  double k11 = 100, k12 = 1840, k13 = 12000, k2 = 10;  // K of (23)
  double l11 = 5, l12 = 2, l13 = 15, l2 = 20;          // L of (23)
  int substeps = 40;    // observer Euler steps per control period
};

// One key of LaibSmcParams: name, unit, meaning, valid range (config_parser.h); observer and substeps
// are whole numbers.
using LaibSmcKey = ControllerKey<LaibSmcParams>;
const std::vector<LaibSmcKey>& LaibSmcKeys();

// "" or "laib controller: key 'KEY': ..." for the first parameter out of range.
std::string ValidateLaibSmcParams(const LaibSmcParams& params);
bool SetLaibSmcParameter(LaibSmcParams* params, const std::string& key, double value, std::string* error);
// "key=value ..." (spaces, tabs, newlines or commas between); `observer` also takes high_gain or
// sliding. False, *error naming the key and `params` unchanged on any error.
bool ParseLaibSmcConfig(const std::string& text, LaibSmcParams* params, std::string* error);

// The averaged model (15) of LaibSmcParams, X = {y, y', y'', p_P}.
using LaibState = std::array<double, 4>;
struct LaibModel {
  double psi, phi1, g1, phi2, g2;  // at X for the sign of u
};
LaibModel LaibEvaluate(const LaibSmcParams& p, const LaibState& X, double u);
// eq. (3): mass flow from pu to pd (0 if pd >= pu), kg/s
double LaibFlow(const LaibSmcParams& p, double pu, double pd);

// The observer (22) or (23) alone, on one cylinder.
class LaibObserver {
 public:
  explicit LaibObserver(const LaibSmcParams& params) : params_(params) {}
  // integrate over `dt` under duty u, z = (x, p_P) going linearly from z0 to z1
  void Advance(double dt, double u, double x0, double pP0, double x1, double pP1);
  const LaibState& estimate() const { return X_; }
  void set_estimate(const LaibState& X) { X_ = X; }
  double p_N() const;  // psi(X^), Pa abs

 private:
  LaibSmcParams params_;
  LaibState X_{};
};

class LaibSmcController : public Controller {
 public:
  // Null and *error if a drive is not PWM on/off valves (input=pwm), the period is not positive,
  // or a parameter is out of range (the message names the key).
  static std::unique_ptr<LaibSmcController> Create(std::vector<ValveDrive> drives, const LaibSmcParams& params,
                                                   double period, std::string* error);
  double Period() const override { return period_; }
  // writes {"duty", u} per cylinder
  void Update(double time, const std::vector<CylinderMeasurement>& measured,
              std::vector<CylinderCommands>* commands) override;
  // kStateSize numbers per cylinder: {started, x1^, x2^, x3^, x4^, x(k-1), p_P(k-1), u(k-1),
  // int e_p, y_d(k-1), y_d(k-2), y_d(k-3), s_p}
  std::vector<double> State() const override;
  bool SetState(const std::vector<double>& state) override;
  static constexpr int kStateSize = 13;

  const LaibSmcParams& params() const { return params_; }
  // the estimate after the last tick of cylinder i: {y, y', y'', p_P} and psi = p_N
  LaibState Estimate(size_t i) const;
  double EstimatedPN(size_t i) const;
  void SetEstimate(size_t i, const LaibState& X);  // e.g. a wrong initial state (after the first tick)
  double SlidingSurface(size_t i) const { return cylinders_[i].s; }

 private:
  struct Cylinder {
    double started = 0;
    LaibState X{};
    double x1 = 0, pP1 = 0, u1 = 0;
    double integral = 0;
    double yd1 = 0, yd2 = 0, yd3 = 0;
    double s = 0;
  };
  LaibSmcController(std::vector<ValveDrive> drives, const LaibSmcParams& params, double period)
      : drives_(std::move(drives)), params_(params), period_(period), cylinders_(drives_.size()) {}
  double Control(const CylinderMeasurement& y, Cylinder* c);

  std::vector<ValveDrive> drives_;
  LaibSmcParams params_;
  double period_;
  std::vector<Cylinder> cylinders_;
};

}  // namespace pneumatic

#endif  // PNEUMATIC_CONTROLLERS_LAIB_SMC_H_
