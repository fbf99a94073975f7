// A PID on each cylinder's position that drives whatever valves the cylinder has: the default
// closed-loop controller of `pneumo rollout --controller pid`.
//
// Per cylinder, with the error normalised by the half stroke (so one set of gains suits a 10 mm
// finger and a 1 rad hip), e = (ref - x) / (l/2), the PID of pid.h gives a demand
//   d = kp e + ki sum(e) T - kd (e_x rate),  d in [-1, 1]  (derivative on the measurement),
// turned into the valve commands of the cylinder's arrangement (the project's own mapping):
//   one proportional valve per chamber (paper 000): uP = c0 + c + s d, uN = c0 + c - s d, with
//     c0 = (U_c + U_r)/2 the valve centre, c the co-contraction offset and s the command swing,
//     clipped to each actuator's ctrlrange (paper 000 used 3..7 V: c0 = 5, s = 2);
//   one 5/3 proportional valve (paper 001): u = u_max d;
//   four on/off valves (paper 002): P to supply and N to exhaust (u1 = u4 = 1) when d > band,
//     the reverse (u2 = u3 = 1) when d < -band, all closed in between;
//   on/off valves on PWM (paper 003): duty = d.
// The defaults kp = 1.5, ki = 1.5 1/s, kd = 0.0375 s with s = 2 V are, on rig C (l/2 = 50 mm),
// the gains `pneumo generate` uses there: s kp / (l/2) = 60 V/m, 60 V/(m s), 1.5 V s/m.
//
// One set of normalised gains cannot suit a robot whose joints differ a thousandfold in inertia per
// unit of force (a humanoid's toe and its waist): on the waist they leave the loop undamped. With
// bandwidth w > 0 the gains are raised per cylinder and per tick where its load needs it (the
// project's own form). The cylinder is taken as a double integrator from demand to normalised
// position, x''/(l/2) = a d, whose authority
//   a = F_span * mobility / (l/2)   (1/s^2)
// is that acceleration at full demand, with F_span = mean piston area * (p_supply - p_exhaust) and
// mobility the inverse inertia the piston sees at the measured pose (CylinderMeasurement). The gains
// that put the three closed-loop poles of s^3 + a kd s^2 + a kp s + a ki at -w,
//   kp = 3 w^2 / a,  kd = 3 w / a,  ki = w^3 / a,
// replace kp, kd, ki where they are larger. Where they are smaller (a light joint on a strong
// cylinder) the fixed gains stay: the design leaves out the valve's seal band, and a demand that
// small would leave the valve inside it. It also leaves out the pressure dynamics, so it holds while
// the chambers fill faster than 1/w.
//
// With per-chamber valves the mapping above holds a chamber at p_supply whenever its command stays
// above the valve centre (the co-contraction does so for both), and a chamber held at p_supply that
// the motion compresses rises above it: the air flows back to the supply only from above. With
// pressure_margin m > 0 the demand sets pressure targets instead (the project's own form):
//   p*_P = p_mid + h d,  p*_N = p_mid - h d,  p_mid = (p_supply + p_exhaust)/2,  h = (p_supply - p_exhaust)/2 - m,
// so the force follows the demand as the design above takes it (force_span shrinks by 2m / span).
// Each chamber's command is the one whose two ports (paper 000 eq. 3, leaks and smoothing included)
// pass, at the measured pressure p (eq. 1c), the net mass flow that would close a fraction
// f = pressure_step of the error in one control period T if it were held:
//   mdot* = f (p* - p) V / (T n r T_gas)   (eq. 2 with the volume held),
// V the chamber's volume at the measured x. The net flow rises with the command, so a bracketed root
// finder (Brent's method, within 1e-11 V) finds it; a flow beyond the valve's reach takes the end of the command range. As the pressure nears its
// target the held flow shrinks (subsonic), so a step falls short of its aim rather than overshooting.
// A chamber of paper 000's identified model gets the command whose predicted pressure one period on
// (eq. 7 with s and r of eq. 10, the volume sensor held) is p + f (p* - p), found the same way.
// f = 0.25 gives the pressure loop a time constant of -T / ln(1 - f) = 3.5 periods. A faster loop
// corrects the pressure a light vane's motion changes a period late, and the vane rings on its
// pneumatic spring: on the humanoid's wave f = 0.15 to 0.4 keep the waving vane within 0.063 to
// 0.069 rad, f = 0.5 to 1 let it ring (0.088 to 0.094 rad; README).
#ifndef PNEUMATIC_CONTROLLERS_POSITION_PID_H_
#define PNEUMATIC_CONTROLLERS_POSITION_PID_H_

#include <string>
#include <vector>

#include "controller.h"
#include "pid.h"

namespace pneumatic {

// How one cylinder's valves are commanded (from the model: pneumatic::Cylinders and GetParameter).
struct ValveDrive {
  enum class Kind { kPerChamber, kFiveThree, kOnOff, kDuty } kind = Kind::kPerChamber;
  double half_stroke = 0;           // l/2, m or rad
  double centre = 5;                // V: per chamber, (U_c + U_r)/2
  double u_max = 5;                 // V: 5/3 valve saturation
  double command_min = 0, command_max = 10;  // V: per chamber, the actuators' ctrlrange
  double p_supply = 0, p_exhaust = 0;        // Pa abs: the cylinder's supply and exhaust pressures
  double force_span = 0;  // N (N m): the piston's force with one chamber at p_supply and the other at
                          // p_exhaust, on the mean of its two faces' areas
  // Per chamber (P, N), per-chamber valves: what pressure targets (PositionPidGains::pressure_margin)
  // need to find the command whose valve (paper 000 eq. 3) passes a wanted mass flow (eq. 1c), or,
  // for paper 000's identified model, whose predicted pressure (eqs. 7-10) is the wanted one.
  struct ChamberValve {
    bool identified = false;  // pressure_model=identified: c, c_gamma, c_b, c_s; else the physical keys
    double c[10] = {0};       // c[1]..c[9] (V, 1/V, 1/V^3, Pa s/m, 1/m, 1/m, 1/(V s), -, V)
    double c_gamma = 0, c_b = 0, c_s = 0;  // V, Pa abs, Pa
    double area = 0, dead_volume = 0;  // m^2 (m^3/rad), m^3: V = dead_volume + area (l/2 +- x)
    double area_gain = 0;              // B, m^2/V
    double u_supply_seal = 0, u_exhaust_seal = 0;  // V: U_c and U_r, the spool deadband included
    double leak_supply = 0, leak_exhaust = 0;      // m^2: the ports' leak areas
    double area_smoothing = 0;                     // m^2: the unit inside eq. 3's smax
    // thin-plate flow (Appendix eqs. 11-13): alpha and beta (s/m), theta, kappa
    double flow_alpha = 0, flow_beta = 0, flow_theta = 0, kappa = 0;
    double rate_per_mass = 0;  // Pa m^3/kg: n r T, the pressure rate of a mass flow into a volume (eq. 2)
  };
  ChamberValve chamber[2];
  bool pressure_targets = false;  // chamber[] read: the physical model with thin-plate flow, or the identified one
};

struct PositionPidGains {
  double kp = 1.5;             // demand per unit of normalised error
  double ki = 1.5;             // 1/s
  double kd = 0.0375;          // s
  double co_contraction = 0.5; // V above the valve centre on both chambers (per-chamber valves): stiffness
  double swing = 2;            // V of command per unit of demand (per-chamber valves)
  double onoff_band = 0.05;    // demand below which on/off valves stay closed
  double bandwidth = 0;        // rad/s; > 0: kp, ki, kd raised per cylinder and tick to its load (above)
  // Pa; > 0 (per-chamber valves): the demand sets chamber pressure targets inside
  // [p_exhaust + margin, p_supply - margin] instead of valve commands (below)
  double pressure_margin = 0;
  // with pressure targets: the fraction of a chamber's pressure error its valve aims to close in one
  // control period, in (0, 1] (below)
  double pressure_step = 0.25;
};

class PositionPid : public Controller {
 public:
  PositionPid(std::vector<ValveDrive> drives, std::vector<PositionPidGains> gains, double period);

  double Period() const override { return period_; }
  void Update(double time, const std::vector<CylinderMeasurement>& measured,
              std::vector<CylinderCommands>* commands) override;
  std::vector<double> State() const override;
  bool SetState(const std::vector<double>& state) override;
  // true when some cylinder's gains follow its load (bandwidth > 0)
  bool UsesMobility() const override;

 private:
  // the gains of cylinder i for this tick's measurement
  PidGains GainsAt(size_t i, const CylinderMeasurement& measured) const;

  std::vector<ValveDrive> drives_;
  std::vector<PositionPidGains> gains_;
  std::vector<Pid> pids_;
  double period_;
};

}  // namespace pneumatic

#endif  // PNEUMATIC_CONTROLLERS_POSITION_PID_H_
