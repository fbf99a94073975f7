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
  double atmosphere_leak_area = 0;     // m^2: orifice leak to p_atm through `leak_law`
  FlowLawConstants leak_law;           // orifice leaks: paper 001 eq. 2 (Sanville) with C_d 1, b 0.528
  double tolerance = 0;                // Pa, local error allowed per substep
  // thermal_model=energy (EnergyPressureStep)
  double gamma = 1.4;              // ratio of specific heats
  double gas_constant = 287;       // r, J/(kg K)
  double temperature = 293.15;     // K: of the supply, the exhaust, the atmosphere and the wall
  double wall_conductance = 0;     // h A, W/K
  // line_volume > 0 (LinePressureStep): the tube between the valve ports and the chamber
  double line_volume = 0;          // m^3
  double line_conductance = 0;     // kg/(s Pa), ISO 6358 C rho0 of the restriction into the chamber
  FlowLawConstants line;           // ISO 6358, b = 0.433 (paper 002 eq. 4)
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

// ln(1 + x): by its series for |x| <= 1/64 (a chamber's volume change over one step, nearly always),
// cheaper than std::log1p and within 2 ulp of it (tests/chamber_test); std::log1p beyond
double Log1p(double x);

// the linearized step holds where the flow's slope changes by at most this fraction over the step
constexpr double kLinearizedMaxSlopeChange = 0.25;

// The default step: pressures (Pa abs) of n chambers (1, or 2: a cylinder's P and N,
// coupled by the leak across the piston when piston_leak > 0, else each on its own) at
// the end of a step of length h from p0. Two chambers on their own step exactly as each
// alone would; taken together, their work interleaves.
// The polytropic compression enters as the constant rate -alpha n ln(V(h)/V(0)) / h,
// so a sealed chamber follows p V^(alpha n) exactly. The flow is split into a stiff
// linear part, B = the slope dQ/dp of each port's law and the leaks (times
// n r T / V at mid-step), and a remainder; the linear part is solved exactly, p + h phi1(B h) rate (exponential Rosenbrock-Euler:
// the exponential step of paper 000 eq. (7), p' = (s - p) r, with r and s from the
// slope), and a second-order correction h phi2(B h) adds the remainder's change over
// the step (ETD2RK). Near a port pressure, where the laws go as sqrt, the slope is
// replaced by the chord over the pressure change the flow makes in the step.
// done[i] is false, p1[i] unset, where the step cannot be trusted and the adaptive
// PhysicalPressureStep must take over: a valve switching within the step, a local
// error indicator above k.tolerance, or a slope that changes by more than a quarter
// (coupled chambers are taken or refused together).
void LinearizedPressureStep(int n, const ChamberModel k[], const PortSchedule* ports[], const VolumePath volume[],
                            double piston_leak, const double p0[], double h, double p1[], bool done[]);
// LinearizedPressureStep(1, ...) of a chamber whose valve openings are given: open_start at the start of the
// step, open_end at its end, and held if no valve switches inside it (ports.At(0), ports.At(h) and
// ports.breakpoints().empty() of its PortSchedule)
void LinearizedChamberStep(const ChamberModel& k, const PortOpenings& open_start, const PortOpenings& open_end,
                           bool held, const VolumePath& volume, double p0, double h, double* p1, bool* done);

// An orifice leak of `area` across the piston (leak_law of k[0]) alone over a time t, chambers at fixed
// volumes: dp_P/dt = -a_P Q(p_P, p_N), dp_N/dt = a_N Q, a = n r T / V. Backward Euler substeps in the mass
// flow q over the substep (q - Q(p_P0 - a_P s q, p_N0 + a_N s q) increases with q), step doubling with
// Richardson extrapolation to k[0].tolerance: p_P / a_P + p_N / a_N (the gas, n = 1) is kept exactly
// (the project's own method). The steps take it in two halves around the valve flows (Strang splitting).
void PistonOrificeExchange(const ChamberModel k[2], const double volume[2], double area, double t, double p[2]);

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

// thermal_model=energy: the state of a chamber's gas
struct GasState {
  double p = 0;  // Pa abs
  double t = 0;  // K
};

// thermal_model=energy: pressure and temperature at the end of a step of length h from `start`.
// The energy equation of an open chamber (Richer and Hurmuzlu 2000, J. Dyn. Sys. Meas. Control
// 122:416, eqs. 1-7), with m = p V / (r T), written for the mass m and the internal energy
// E = c_v m T = p V / (gamma - 1):
//   dm/dt = sum of the inflows - sum of the outflows
//   dE/dt = c_p sum(inflow T_upstream) - c_p T outflows + hA (T_wall - T) - p dV/dt
// which is dp/dt = (gamma r / V)(mdot_in T_in - mdot_out T) - gamma p Vdot / V + (gamma - 1) hA (T_w - T) / V.
// Inflows come from the supply, the exhaust and the atmosphere at k.temperature, and across the
// piston from the other chamber at `other` (held over the step); outflows leave at the chamber's T.
// Each port's law (paper 001 eq. 2, paper 002 eq. 4, paper 000 eq. 1) is rated at k.temperature
// and scaled by sqrt(k.temperature / T_upstream) (a nozzle passes mass as 1/sqrt(T0)); for an
// outflow T_upstream is the chamber's temperature at the start of each substep.
// Each substep is backward Euler in (m, E): one increasing residual in p, bracketed and solved by
// Illinois regula falsi; step doubling with Richardson extrapolation (linear in m and E, so it keeps
// every linear balance) gives second order and the error estimate that adapts the substep to
// k.tolerance (temperature errors weighted by p/T); the step splits at valve switching instants.
// *supply_mass (if not null) gets the mass that entered through the supply port (kg).
GasState EnergyPressureStep(const ChamberModel& k, const PortSchedule& ports, const VolumePath& volume,
                            double piston_leak, double piston_area, GasState other, GasState start, double h,
                            double* supply_mass);

// thermal_model=energy: the leak across the piston alone over a time t (the laminar conductance
// piston_leak and the orifice `area`), chambers at fixed volumes, in mass and internal energy: a mass q
// leaves the upstream chamber u with its enthalpy c_p T_u and enters the other, so the gas's mass and
// energy are kept exactly. q = q_eq (1 - exp(-Q t / q_eq)), with Q the flow at the start (rated as
// EnergyPressureStep rates it) and q_eq the mass that equalizes the pressures at T_u: exact for the
// laminar leak at a held T_u, never past equalization (the project's own form). The energy step takes it
// in two halves around the chambers' own steps (Strang splitting).
void EnergyLeakExchange(const ChamberModel k[2], const double volume[2], double piston_leak, double area, double t,
                        GasState gas[2]);

// line_volume > 0: the pressures of the line and of its chamber at the end of a step of length h.
// The line (volume V_L, isothermal at the cylinder's temperature T: a thin tube's wall holds its gas
// near ambient) takes the valve ports' flows, and passes Q_r to the chamber through its restriction
// (ISO 6358, paper 002 eq. 4, b = 0.433):
//   dp_L/dt = (r T / V_L) (Q_valve(p_L) - Q_r(p_L, p))
//   dp/dt   = n r T (Q_r(p_L, p) + Q_leak(p)) / V - alpha n p (dV/dt) / V     (paper 000 eq. 4a)
// with Q_leak the chamber's leaks to the atmosphere (laminar and orifice); the leaks across the piston
// are not in it (Cylinder::Step exchanges them around it). Each substep is exponential Rosenbrock-Euler
// (the compression exact, p V^(alpha n); the flows linearised at the substep's start; phi1 of the 2 x 2
// Jacobian), kept between the lowest and the highest pressure the gas can come from. Step doubling with Richardson extrapolation makes it second
// order and adapts the substep to k.tolerance; the step splits at valve switching instants. (The
// project's own method.)
// *supply_mass (if not null) gets the mass that entered the line through the supply port (kg).
void LinePressureStep(const ChamberModel& k, const PortSchedule& ports, const VolumePath& volume, double line0,
                      double p0, double h, double* line1, double* p1, double* supply_mass);

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
