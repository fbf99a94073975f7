#include "position_stiffness.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace pneumatic {
namespace {

struct Key {
  const char* name;
  double PositionStiffnessParams::*field;
  double min, max;
  const char* unit;
};

const Key kKeys[] = {
    {"kp", &PositionStiffnessParams::kp, 0, 1e3, "1"},
    {"ki", &PositionStiffnessParams::ki, 0, 1e3, "1/s"},
    {"kd", &PositionStiffnessParams::kd, 0, 10, "s"},
    {"swing", &PositionStiffnessParams::swing, 0, 10, "V"},
    {"mean_pressure", &PositionStiffnessParams::mean_pressure, 0, 1, "1 (of p_supply - p_exhaust above p_exhaust)"},
    {"stiffness_kp", &PositionStiffnessParams::stiffness_kp, 0, 1e3, "V"},
    {"stiffness_ki", &PositionStiffnessParams::stiffness_ki, 0, 1e4, "V/s"},
    {"max_common", &PositionStiffnessParams::max_common, 0, 10, "V"},
};

}  // namespace

std::string ParsePositionStiffnessConfig(const std::string& text, PositionStiffnessParams* params) {
  PositionStiffnessParams out = *params;
  std::istringstream words(text);
  std::string word;
  while (words >> word) {
    const size_t eq = word.find('=');
    const std::string key = word.substr(0, eq);
    const Key* k = nullptr;
    for (const Key& candidate : kKeys) k = key == candidate.name ? &candidate : k;
    if (!k) return "position-stiffness controller: unknown key '" + key + "'";
    char* end = nullptr;
    const double value = eq == std::string::npos ? NAN : std::strtod(word.c_str() + eq + 1, &end);
    if (eq == std::string::npos || end == word.c_str() + eq + 1 || *end != '\0' || !std::isfinite(value) ||
        value < k->min || value > k->max) {
      return "position-stiffness controller: key '" + key + "': expected a number in [" + std::to_string(k->min) +
             ", " + std::to_string(k->max) + "] " + k->unit;
    }
    out.*(k->field) = value;
  }
  *params = out;
  return "";
}

PositionStiffness::PositionStiffness(std::vector<ValveDrive> drives, const PositionStiffnessParams& params,
                                     double period)
    : drives_(std::move(drives)), params_(params), period_(period) {
  PidGains position{params.kp, params.ki, params.kd, 0, -1, 1};
  PidGains stiffness{params.stiffness_kp, params.stiffness_ki, 0, 0, -params.max_common, params.max_common};
  for (size_t i = 0; i < drives_.size(); ++i) {
    position_.emplace_back(position, period);
    stiffness_.emplace_back(stiffness, period);
  }
}

std::unique_ptr<PositionStiffness> PositionStiffness::Create(const std::vector<ValveDrive>& drives,
                                                             const PositionStiffnessParams& params, double period,
                                                             std::string* error) {
  for (const ValveDrive& d : drives) {
    if (d.kind != ValveDrive::Kind::kPerChamber || !(d.p_supply > d.p_exhaust)) {
      *error = "the position-stiffness controller needs one proportional valve per chamber on every cylinder "
               "(valve=proportional_per_chamber, paper 000's set-up)";
      return nullptr;
    }
  }
  return std::unique_ptr<PositionStiffness>(new PositionStiffness(drives, params, period));
}

void PositionStiffness::Update(double /*time*/, const std::vector<CylinderMeasurement>& measured,
                               std::vector<CylinderCommands>* commands) {
  commands->resize(drives_.size());
  for (size_t i = 0; i < drives_.size(); ++i) {
    const ValveDrive& drive = drives_[i];
    const CylinderMeasurement& y = measured[i];
    const double d = position_[i].Update(y.reference / drive.half_stroke, y.x / drive.half_stroke);
    // the stiffness loop's "position" is the normalised mean pressure; its derivative gain is 0
    const double span = drive.p_supply - drive.p_exhaust;
    const double mean = ((y.p_P + y.p_N) / 2 - drive.p_exhaust) / span;
    const double c = stiffness_[i].Update(params_.mean_pressure, mean);
    auto clip = [&](double u) { return std::clamp(u, drive.command_min, drive.command_max); };
    (*commands)[i] = {{"uP", clip(drive.centre + c + params_.swing * d)},
                      {"uN", clip(drive.centre + c - params_.swing * d)}};
  }
}

std::vector<double> PositionStiffness::State() const {
  std::vector<double> state(drives_.size() * 2 * Pid::kStateSize);
  for (size_t i = 0; i < drives_.size(); ++i) {
    position_[i].GetState(&state[(2 * i) * Pid::kStateSize]);
    stiffness_[i].GetState(&state[(2 * i + 1) * Pid::kStateSize]);
  }
  return state;
}

bool PositionStiffness::SetState(const std::vector<double>& state) {
  if (state.size() != drives_.size() * 2 * Pid::kStateSize) return false;
  for (size_t i = 0; i < drives_.size(); ++i) {
    position_[i].SetState(&state[(2 * i) * Pid::kStateSize]);
    stiffness_[i].SetState(&state[(2 * i + 1) * Pid::kStateSize]);
  }
  return true;
}

}  // namespace pneumatic
