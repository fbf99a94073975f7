#include "position_stiffness.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "config_parser.h"

namespace pneumatic {
namespace {

// the keys, each with its closed range [min, max] (config_parser.h's table; the unit is part of the
// message). This controller reads its text on its own: pairs between spaces only, and its own messages,
// which `pneumo rollout --controller position_stiffness` has always given
const std::vector<ControllerKey<PositionStiffnessParams>>& Keys() {
  using P = PositionStiffnessParams;
  static const std::vector<ControllerKey<P>> keys = {
      {"kp", "1", "position loop's proportional gain on the error over the half stroke", 0, 1e3, false, false, &P::kp},
      {"ki", "1/s", "position loop's integral gain", 0, 1e3, false, false, &P::ki},
      {"kd", "s", "position loop's derivative gain (on the measurement)", 0, 10, false, false, &P::kd},
      {"swing", "V", "differential valve command per unit of position demand", 0, 10, false, false, &P::swing},
      {"mean_pressure", "1 (of p_supply - p_exhaust above p_exhaust)",
       "target mean chamber pressure, as a fraction of the way from p_exhaust to p_supply", 0, 1, false, false,
       &P::mean_pressure},
      {"stiffness_kp", "V", "stiffness loop's proportional gain on the normalised mean-pressure error", 0, 1e3, false,
       false, &P::stiffness_kp},
      {"stiffness_ki", "V/s", "stiffness loop's integral gain", 0, 1e4, false, false, &P::stiffness_ki},
      {"max_common", "V", "largest common valve command |c|", 0, 10, false, false, &P::max_common},
  };
  return keys;
}

}  // namespace

std::string ParsePositionStiffnessConfig(const std::string& text, PositionStiffnessParams* params) {
  PositionStiffnessParams out = *params;
  std::istringstream words(text);
  std::string word;
  while (words >> word) {
    const size_t eq = word.find('=');
    const std::string key = word.substr(0, eq);
    const ControllerKey<PositionStiffnessParams>* k = nullptr;
    for (const auto& candidate : Keys()) k = key == candidate.key ? &candidate : k;
    if (!k) return "position-stiffness controller: unknown key '" + key + "'";
    char* end = nullptr;
    const double value = eq == std::string::npos ? NAN : std::strtod(word.c_str() + eq + 1, &end);
    if (eq == std::string::npos || end == word.c_str() + eq + 1 || *end != '\0' || !std::isfinite(value) ||
        value < k->min || value > k->max) {
      return "position-stiffness controller: key '" + key + "': expected a number in [" + std::to_string(k->min) +
             ", " + std::to_string(k->max) + "] " + k->unit;
    }
    out.*(k->number) = value;
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
