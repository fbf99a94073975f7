// Chamber pressure: the physical model (paper 000 eq. 4, paper 001 eq. 1,
// paper 002 eq. 1) and the identified model (paper 000 eqs. 6, 10), each with
// a step that is stable and accurate at MuJoCo timesteps.
#ifndef PNEUMATIC_CHAMBER_H_
#define PNEUMATIC_CHAMBER_H_

#include "config.h"
#include "flow.h"
#include "valves.h"

namespace pneumatic {

// what one chamber's pressure dynamics need, fixed at attach time
struct ChamberModel {
  FlowLawConstants flow;
  double polytropic_index = 1.4;  // n
  double work_factor = 1.0;       // alpha
  double gas_rt = 0;              // r T, J/kg
  double p_supply = 0, p_exhaust = 0;  // Pa abs
  double p_atm = 0;                    // Pa abs, outside the cylinder
  double atmosphere_leak = 0;          // kg/(s Pa): laminar leak G (p - p_atm) out of the chamber
  double tolerance = 0;                // Pa, local error allowed per substep
};

ChamberModel MakeChamberModel(const CylinderConfig& c, int chamber);

// the chamber volume over the step, from the piston's path: the swept length
// s(tau) = swept + swept_rate tau runs past the ends of the stroke when the
// piston does (joint limits are soft), and only its clamp to [0, stroke] counts:
// V(tau) = dead_volume + area clamp(s(tau), 0, stroke)
struct VolumePath {
  double dead_volume = 0;  // m^3
  double area = 0;         // m^2 (m^3/rad)
  double stroke = 0;       // m (rad)
  double swept = 0;        // m (rad): l/2 + x for chamber P, l/2 - x for N, at the start of the step
  double swept_rate = 0;   // m/s (rad/s), held over the step
  double At(double tau) const;
  // dV/dt at tau: zero while the piston is beyond an end of the stroke
  double RateAt(double tau) const;
};

// net mass flow into the chamber (kg/s) through its valve ports at pressure p (Pa abs), paper 000 eq. (2)
double ChamberMassFlow(const ChamberModel& k, const PortOpenings& o, double p);

// ChamberMassFlow plus the laminar leaks (the project's own form): to the atmosphere,
// G_atm (p_atm - p), and across the piston from the other chamber, G_piston (p_other - p)
double NetMassFlow(const ChamberModel& k, const PortOpenings& o, double p, double piston_leak, double p_other);

// dp/dt (Pa/s) of the physical model, with Q the NetMassFlow:
//   dp/dt = n r T Q / V - alpha n p (dV/dt) / V
// paper 000 eq. (4a) (alpha = 1), paper 001 eq. (1) (n = gamma), paper 002 eq. (1) (n = k)
double PressureRate(const ChamberModel& k, const PortOpenings& o, double p, double volume,
                    double volume_rate, double piston_leak = 0, double p_other = 0);

// Pressure (Pa abs) at the end of a step of length h from p0, for the physical
// model. Written for y = p V^(alpha n), the polytropic compression is exact and
// only the flow term is integrated: dy/dt = n r T V^(alpha n - 1) Q(p). Each
// substep is backward Euler (L-stable, the root bracketed between the
// compressed pressure and the port pressures), refined by step doubling with
// Richardson extrapolation; the substep adapts to `tolerance`, and splits at
// the instants where valves switch. The result lies in the reachable range
// [min(p_exhaust, p_compressed), max(p_supply, p_compressed)].
// The leak to the atmosphere is included; the leak across the piston is not (see
// PistonLeakExchange).
double PhysicalPressureStep(const ChamberModel& k, const PortSchedule& ports, const VolumePath& volume,
                            double p0, double h);

// The default step: pressures (Pa abs) of n chambers (1, or 2: a cylinder's P and N,
// coupled by the leak across the piston) at the end of a step of length h from p0.
// The polytropic compression enters as the constant rate -alpha n ln(V(h)/V(0)) / h,
// so a sealed chamber follows p V^(alpha n) exactly. The flow is split into a stiff
// linear part, B = the slope dQ/dp of each port's law and the leaks (times
// n r T / V at mid-step), and a remainder; the linear part is solved exactly, p + h phi1(B h) rate (exponential Rosenbrock-Euler:
// the exponential step of paper 000 eq. (7), p' = (s - p) r, with r and s from the
// slope), and a second-order correction h phi2(B h) adds the remainder's change over
// the step (ETD2RK). Near a port pressure, where the laws go as sqrt, the slope is
// replaced by the chord over the pressure change the flow makes in the step.
// Returns false, leaving p1 unset, where the step cannot be trusted and the adaptive
// PhysicalPressureStep must take over: a valve switching within the step, a local
// error indicator above k.tolerance, or a slope that changes by more than a quarter.
bool LinearizedPressureStep(int n, const ChamberModel k[], const PortSchedule* ports[], const VolumePath volume[],
                            double piston_leak, const double p0[], double h, double p1[]);

// The leak across the piston alone over a time t, solved exactly (the project's own
// laminar form, chambers at fixed volumes): p_P - p_N decays as exp(-(a + b) t) with
// a = n_P r T G / V_P and b = n_N r T G / V_N, and b p_P + a p_N (the gas exchanged)
// is conserved. The adaptive step takes it in two halves around the valve flows.
void PistonLeakExchange(const ChamberModel k[2], const double volume[2], double piston_leak, double t, double p[2]);

// The mass (kg) that entered the chamber through its supply port over a step from p0 to p1 (the
// project's own accounting, for a reservoir that feeds the port). The net mass through all ports
// and leaks follows from the step itself: in y = p V^(alpha n) only the flow changes y, so it is
// (p1 - p0 (V0/V1)^(alpha n)) V(h/2) / (n r T), exact for a chamber at rest. The trapezoid rule on
// each port's and leak's flow at the start (p0, o0) and end (p1, o1) splits it; the trapezoid's
// error is shared in proportion to each part's size, so a chamber whose only open port is the
// supply draws exactly the net mass (with n = 1: p_res V_res + p V conserved to round-off).
double SupplyMassOverStep(const ChamberModel& k, const PortOpenings& o0, const PortOpenings& o1,
                          const VolumePath& volume, double p0, double p1, double piston_leak, double p_other0,
                          double p_other1, double h);

// paper 000 eq. (10): steady-state pressure s (Pa abs) and rate r (1/s) at
// command u (V), volume sensor v = x and its rate
struct SteadyStateAndRate {
  double s = 0;
  double r = 0;
};
SteadyStateAndRate IdentifiedModel(const IdentifiedParams& c, double u, double v, double v_rate);

// paper 000 eq. (7): p(t + h) = s + (p(t) - s) e^(-r h), with r held at >= 0
double IdentifiedPressureStep(const SteadyStateAndRate& sr, double p0, double h);

}  // namespace pneumatic

#endif  // PNEUMATIC_CHAMBER_H_
