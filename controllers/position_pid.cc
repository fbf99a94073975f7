#include "position_pid.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pneumatic {
namespace {

// The controller carries its own copy of the model's equations, as a real rig's controller would (the
// extension's are private to it): each names the plugin function it follows.

// the command in the drive's range at which `rising`, a function that rises with the command, reaches
// `target`; the end of the range where the target lies beyond it. Brent's method (R. P. Brent,
// "Algorithms for Minimization without Derivatives", 1973, ch. 4, procedure zero, as netlib's zeroin):
// secant and inverse quadratic steps inside a bracket, bisection when they would not shrink it fast
// enough. It ends when the bracket is narrower than 1e-11 V, far below any valve's resolution (as 40
// halvings of 10 V would), after about ten evaluations of `rising` where bisection takes forty
template <typename Rising>
double CommandWhere(const ValveDrive& drive, Rising rising, double target) {
  constexpr double kResolution = 1e-11;  // V
  double a = drive.command_min, b = drive.command_max;
  double fa = rising(a) - target, fb = rising(b) - target;
  if (fa >= 0) return a;
  if (fb <= 0) return b;
  // [b, c] brackets the command, b the better end; d the last step, e the one before
  double c = a, fc = fa, d = b - a, e = d;
  for (int i = 0; i < 200; ++i) {  // (it converges well within: at worst a few times bisection's 40)
    if (std::fabs(fc) < std::fabs(fb)) {
      a = b, b = c, c = a;
      fa = fb, fb = fc, fc = fa;
    }
    const double tolerance = 2 * std::numeric_limits<double>::epsilon() * std::fabs(b) + kResolution / 2;
    const double half = (c - b) / 2;
    if (std::fabs(half) <= tolerance || fb == 0) return b;
    bool interpolated = false;
    if (std::fabs(e) >= tolerance && std::fabs(fa) > std::fabs(fb)) {
      const double s = fb / fa;
      double p, q;
      if (a == c) {  // secant
        p = 2 * half * s, q = 1 - s;
      } else {  // inverse quadratic
        const double qa = fa / fc, r = fb / fc;
        p = s * (2 * half * qa * (qa - r) - (b - a) * (r - 1));
        q = (qa - 1) * (r - 1) * (s - 1);
      }
      if (p > 0) q = -q;
      p = std::fabs(p);
      // accepted if it falls inside the bracket and shrinks faster than the step before last
      if (2 * p < 3 * half * q - std::fabs(tolerance * q) && p < std::fabs(e * q / 2)) {
        e = d, d = p / q;
        interpolated = true;
      }
    }
    if (!interpolated) d = e = half;  // bisection
    a = b, fa = fb;
    b += std::fabs(d) > tolerance ? d : std::copysign(tolerance, half);
    fb = rising(b) - target;
    if ((fb > 0 && fc > 0) || (fb < 0 && fc < 0)) {  // the command now lies between a and b
      c = a, fc = fa;
      d = e = b - a;
    }
  }
  return b;
}

// paper 000 eq. 1c (Appendix eqs. 11-13): the thin-plate mass flow per unit of port area
// (kg/(s m^2)) from p_from to p_to, p_from >= p_to >= 0 (plugin/src/flow.h, with the shape computed
// rather than tabulated)
double FlowPerArea(const ValveDrive::ChamberValve& v, double p_from, double p_to) {
  if (!(p_from > p_to)) return 0;
  if (p_to * v.flow_theta < p_from) return v.flow_beta * p_from;  // choked
  const double r = p_to / p_from;
  return v.flow_alpha * p_from * std::sqrt(std::max(0.0, std::pow(r, 2 / v.kappa) - std::pow(r, (v.kappa + 1) / v.kappa)));
}

// paper 000 eq. 3 (plugin/src/valves.h ProportionalValveAreas): the net mass flow (kg/s) into a chamber
// whose valve is at u (V), given each port's flow per unit area (supply to chamber, chamber to exhaust)
double NetFlow(const ValveDrive::ChamberValve& v, double u, double into, double out) {
  auto smax = [&](double y) { return (std::sqrt(y * y + v.area_smoothing * v.area_smoothing) + y) / 2; };
  const double supply = v.leak_supply + smax((u - v.u_supply_seal) * v.area_gain - v.leak_supply);
  const double exhaust = v.leak_exhaust + smax((v.u_exhaust_seal - u) * v.area_gain - v.leak_exhaust);
  return supply * into - exhaust * out;
}

// the command whose pressure, predicted by paper 000's identified model one period on from p with the
// volume sensor held at x (eq. 7, s and r of eqs. 8-10; plugin/src/chamber.cc IdentifiedModel and
// IdentifiedPressureStep), is `aim` (Pa abs)
double CommandForIdentifiedPressure(const ValveDrive& drive, const ValveDrive::ChamberValve& v, double aim, double p,
                                    double x, double period) {
  auto predicted = [&](double u) {
    const double u_hat = u - v.c[1];
    const double arg = v.c[2] * u_hat + v.c[3] * u_hat * u_hat * u_hat;
    const double g = arg / std::sqrt(arg * arg + 1);                                                     // eq. 8
    const double rate_k = std::sqrt(u_hat * u_hat + v.c_gamma * v.c_gamma) - v.c_gamma + v.c[9] + v.c[8] * u_hat;  // eq. 9
    const double s = v.c_b + v.c_s * g;                                           // eq. 10 with v' = 0
    const double r = std::max(v.c[7] * rate_k / (1 + v.c[6] * x), 0.0);
    return s + (p - s) * std::exp(-r * period);                                   // eq. 7
  };
  return CommandWhere(drive, predicted, aim);
}

// the command that moves chamber k (0 = P, 1 = N) from its measured pressure p toward p_target (Pa abs)
// by about `step_fraction` of the way in one period (position_pid.h)
double CommandForPressure(const ValveDrive& drive, int k, double p_target, double p, double x, double period,
                          double step_fraction) {
  const ValveDrive::ChamberValve& v = drive.chamber[k];
  if (v.identified) return CommandForIdentifiedPressure(drive, v, p + step_fraction * (p_target - p), p, x, period);
  const double swept = std::clamp(drive.half_stroke + (k == 0 ? x : -x), 0.0, 2 * drive.half_stroke);
  const double volume = v.dead_volume + v.area * swept;
  const double wanted = step_fraction * (p_target - p) * volume / (period * v.rate_per_mass);
  // each port's flow per area at this pressure; a port whose flow would run backwards (a chamber
  // above p_supply or below p_exhaust) is left out, so that the net flow rises with u
  const double into = FlowPerArea(v, drive.p_supply, p), out = FlowPerArea(v, p, drive.p_exhaust);
  return CommandWhere(drive, [&](double u) { return NetFlow(v, u, into, out); }, wanted);
}

}  // namespace

PositionPid::PositionPid(std::vector<ValveDrive> drives, std::vector<PositionPidGains> gains, double period)
    : drives_(std::move(drives)), gains_(std::move(gains)), period_(period) {
  for (size_t i = 0; i < gains_.size(); ++i) pids_.emplace_back(GainsAt(i, CylinderMeasurement()), period);
}

PidGains PositionPid::GainsAt(size_t i, const CylinderMeasurement& measured) const {
  const PositionPidGains& g = gains_[i];
  PidGains pid;
  pid.kp = g.kp, pid.ki = g.ki, pid.kd = g.kd, pid.u_min = -1, pid.u_max = 1;
  // the authority of the double integrator; the gains of the triple pole at -bandwidth, where larger
  // (position_pid.h)
  double force_span = drives_[i].force_span;
  if (g.pressure_margin > 0) {  // pressure targets span the supply range less twice the margin
    force_span *= 1 - 2 * g.pressure_margin / (drives_[i].p_supply - drives_[i].p_exhaust);
  }
  const double authority = force_span * measured.mobility / drives_[i].half_stroke;
  const double w = g.bandwidth;
  if (w > 0 && authority > 0 && std::isfinite(authority)) {
    pid.kp = std::max(pid.kp, 3 * w * w / authority);
    pid.kd = std::max(pid.kd, 3 * w / authority);
    pid.ki = std::max(pid.ki, w * w * w / authority);
  }
  return pid;
}

void PositionPid::Update(double /*time*/, const std::vector<CylinderMeasurement>& measured,
                         std::vector<CylinderCommands>* commands) {
  commands->resize(drives_.size());
  for (size_t i = 0; i < drives_.size(); ++i) {
    const ValveDrive& drive = drives_[i];
    const PositionPidGains& g = gains_[i];
    if (g.bandwidth > 0) pids_[i].SetGains(GainsAt(i, measured[i]));
    // normalised by the half stroke: one set of gains for every size of cylinder
    const double d = pids_[i].Update(measured[i].reference / drive.half_stroke, measured[i].x / drive.half_stroke);
    CylinderCommands& out = (*commands)[i];
    out.clear();
    switch (drive.kind) {
      case ValveDrive::Kind::kPerChamber: {
        if (g.pressure_margin > 0) {
          const double mid = (drive.p_supply + drive.p_exhaust) / 2;
          const double half = (drive.p_supply - drive.p_exhaust) / 2 - g.pressure_margin;
          const CylinderMeasurement& y = measured[i];
          out.emplace_back("uP", CommandForPressure(drive, 0, mid + half * d, y.p_P, y.x, period_, g.pressure_step));
          out.emplace_back("uN", CommandForPressure(drive, 1, mid - half * d, y.p_N, y.x, period_, g.pressure_step));
          break;
        }
        auto clip = [&](double u) { return std::clamp(u, drive.command_min, drive.command_max); };
        out.emplace_back("uP", clip(drive.centre + g.co_contraction + g.swing * d));
        out.emplace_back("uN", clip(drive.centre + g.co_contraction - g.swing * d));
        break;
      }
      case ValveDrive::Kind::kFiveThree:
        out.emplace_back("u", drive.u_max * d);
        break;
      case ValveDrive::Kind::kOnOff: {
        const double push = d > g.onoff_band ? 1 : 0, pull = d < -g.onoff_band ? 1 : 0;
        out = {{"u1", push}, {"u2", pull}, {"u3", pull}, {"u4", push}};
        break;
      }
      case ValveDrive::Kind::kDuty:
        out.emplace_back("duty", d);
        break;
    }
  }
}

bool PositionPid::UsesMobility() const {
  return std::any_of(gains_.begin(), gains_.end(), [](const PositionPidGains& g) { return g.bandwidth > 0; });
}

std::vector<double> PositionPid::State() const {
  std::vector<double> state(pids_.size() * Pid::kStateSize);
  for (size_t i = 0; i < pids_.size(); ++i) pids_[i].GetState(&state[i * Pid::kStateSize]);
  return state;
}

bool PositionPid::SetState(const std::vector<double>& state) {
  if (state.size() != pids_.size() * Pid::kStateSize) return false;
  for (size_t i = 0; i < pids_.size(); ++i) pids_[i].SetState(&state[i * Pid::kStateSize]);
  return true;
}

}  // namespace pneumatic
