#include "position_pid.h"

#include <algorithm>
#include <cmath>

namespace pneumatic {

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
  const double authority = drives_[i].force_span * measured.mobility / drives_[i].half_stroke;
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
