#include "karpenko_pid.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pneumatic {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr const char* kName = "karpenko PID controller";

std::string KeyError(const std::string& key, const std::string& message) {
  return ControllerKeyError(kName, key, message);
}

// the checks between keys: augmentation (15) divides by K_i
std::string KeysTogether(const KarpenkoPidParams& params) {
  if (params.augmentation && !(params.ki > 0)) {
    return KeyError("ki", "must be positive with augmentation=1, which divides by it (15) (got " +
                              NumberForMessage(params.ki) + ")");
  }
  return "";
}

const ControllerConfigTable<KarpenkoPidParams>& Table() {
  static const ControllerConfigTable<KarpenkoPidParams> table{kName, KarpenkoPidKeys(), KeysTogether};
  return table;
}

}  // namespace

const std::vector<KarpenkoPidKey>& KarpenkoPidKeys() {
  using P = KarpenkoPidParams;
  static const std::vector<KarpenkoPidKey> keys = {
      {"kp", "V/m", "proportional gain K_p (12)", 0, kInf, false, true, &P::kp, nullptr},
      {"ki", "V/(m s)", "integral gain K_i (12); must be positive with augmentation (15 divides by it)", 0, kInf,
       false, true, &P::ki, nullptr},
      {"reset", "", "1: Clegg-type reset of the integral when |e| <= eps (13); 0: the linear PI", 0, 1, false, false,
       nullptr, &P::reset},
      {"epsilon", "m", "reset threshold eps (13); paper: 1 mm, 4 mm for the S-curves of Fig. 9", 0, kInf, false, true,
       &P::epsilon, nullptr},
      {"reset_when_still", "", "1: reset only while the reference is still, x_d' = 0 (VI, 15 row 4); 0: (13) as printed",
       0, 1, false, false, nullptr, &P::reset_when_still},
      {"augmentation", "", "1: velocity-error-triggered integral augmentation (14-15)", 0, 1, false, false, nullptr,
       &P::augmentation},
      {"e_dot_min", "m/s", "threshold e_min' on e_db' (15)", 0, kInf, false, true, &P::e_dot_min, nullptr},
      {"beta", "", "beta of the velocity-error filter (14)", 0, kInf, false, true, &P::beta, nullptr},
      {"u_lower", "V", "command magnitude the augmentation brings u to, towards -x (15)", 0, kInf, false, true,
       &P::u_lower, nullptr},
      {"u_upper", "V", "command the augmentation brings u to, towards +x (15)", 0, kInf, false, true, &P::u_upper,
       nullptr},
      {"braking", "", "1: braking-acceleration term in the integral (16-17)", 0, 1, false, false, nullptr, &P::braking},
      {"ka", "s^2", "braking gain K_a (16)", 0, kInf, false, true, &P::ka, nullptr},
  };
  return keys;
}

std::string ValidateKarpenkoPidParams(const KarpenkoPidParams& params) {
  return ValidateControllerParams(Table(), params);
}

bool SetKarpenkoPidParameter(KarpenkoPidParams* params, const std::string& key, double value, std::string* error) {
  return SetControllerParameter(Table(), params, key, value, error);
}

bool ParseKarpenkoPidConfig(const std::string& text, KarpenkoPidParams* params, std::string* error) {
  return ParseControllerConfig(Table(), text, params, error);
}

double KarpenkoVelocityErrorEq14(double xp_dot, double xd_dot, double beta) {
  const double denominator = xd_dot * xd_dot + beta * xp_dot * xp_dot;
  if (!(denominator > 0)) return 0;  // x_d' = x_p' = 0: no velocity error
  return (xp_dot - xd_dot) * xd_dot * xd_dot / denominator;
}

double KarpenkoBrakingEq17(double xd_dot, double xd_ddot) { return xd_ddot * xd_dot < 0 ? xd_ddot : 0; }

std::unique_ptr<KarpenkoPid> KarpenkoPid::Create(std::vector<ValveDrive> drives, const KarpenkoPidParams& params,
                                                 double period, std::string* error) {
  auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return std::unique_ptr<KarpenkoPid>();
  };
  if (!(period > 0) || !std::isfinite(period)) return fail("karpenko PID controller: the period must be positive");
  if (std::string e = ValidateKarpenkoPidParams(params); !e.empty()) return fail(e);
  for (size_t i = 0; i < drives.size(); ++i) {
    if (drives[i].kind != ValveDrive::Kind::kFiveThree) {
      return fail("karpenko PID controller: cylinder " + std::to_string(i) +
                  " does not have one 5/3 proportional valve (u), which paper 001's controller drives");
    }
    if (!(drives[i].u_max > 0)) {
      return fail("karpenko PID controller: cylinder " + std::to_string(i) + " has no positive u_max");
    }
  }
  return std::unique_ptr<KarpenkoPid>(new KarpenkoPid(std::move(drives), params, period));
}

KarpenkoPid::KarpenkoPid(std::vector<ValveDrive> drives, const KarpenkoPidParams& params, double period)
    : drives_(std::move(drives)), params_(params), period_(period), cylinders_(drives_.size()) {}

void KarpenkoPid::Update(double /*time*/, const std::vector<CylinderMeasurement>& measured,
                         std::vector<CylinderCommands>* commands) {
  const KarpenkoPidParams& p = params_;
  const double dt = period_;
  commands->resize(drives_.size());
  for (size_t i = 0; i < drives_.size() && i < measured.size(); ++i) {
    Cylinder& c = cylinders_[i];
    const double x = measured[i].x, r = measured[i].reference;
    // backward differences; none before the samples exist
    const double xp_dot = c.ticks >= 1 ? (x - c.x1) / dt : 0;
    const double xd_dot = c.ticks >= 1 ? (r - c.r1) / dt : 0;
    const double xd_ddot = c.ticks >= 2 ? (r - 2 * c.r1 + c.r2) / (dt * dt) : 0;
    const double e = r - x;  // (12)
    const double e_db = KarpenkoVelocityErrorEq14(xp_dot, xd_dot, p.beta);  // (14)
    const double u_before = p.kp * e + p.ki * c.integral;  // u* of (15): this tick's error, last integral

    Branch branch = kIntegrate;
    double integral = c.integral;
    if (p.reset && std::fabs(e) <= p.epsilon && (!p.reset_when_still || xd_dot == 0)) {
      branch = kReset, integral = 0;  // (13), (15) row 4
    } else if (p.augmentation && e_db > p.e_dot_min && u_before > -p.u_lower) {
      branch = kAugmentLower, integral = (-p.u_lower - p.kp * e) / p.ki;  // (15) row 1
    } else if (p.augmentation && e_db < -p.e_dot_min && u_before < p.u_upper) {
      branch = kAugmentUpper, integral = (p.u_upper - p.kp * e) / p.ki;  // (15) row 3, read with -e_min'
    } else {
      integral += e * dt;  // (13), (15) row 2
      if (p.braking && std::fabs(e_db) <= p.e_dot_min) {
        integral += p.ka * KarpenkoBrakingEq17(xd_dot, xd_ddot) * dt;  // (16), for |e_db'| <= e_min' as printed
      }
    }
    const double u_max = drives_[i].u_max;
    const double u = std::clamp(p.kp * e + p.ki * integral, -u_max, u_max);  // (12), the valve's saturation

    c.ticks = std::min(c.ticks + 1, 2.0);
    c.integral = integral, c.x1 = x, c.r2 = c.r1, c.r1 = r;
    c.e_db = e_db, c.branch = branch, c.u = u;
    (*commands)[i] = {{"u", u}};
  }
}

std::vector<double> KarpenkoPid::State() const {
  std::vector<double> state;
  state.reserve(cylinders_.size() * kStateSize);
  for (const Cylinder& c : cylinders_) {
    for (double v : {c.ticks, c.integral, c.x1, c.r1, c.r2, c.e_db, c.branch, c.u}) state.push_back(v);
  }
  return state;
}

bool KarpenkoPid::SetState(const std::vector<double>& state) {
  if (state.size() != cylinders_.size() * kStateSize) return false;
  for (size_t i = 0; i < cylinders_.size(); ++i) {
    const double* v = &state[i * kStateSize];
    for (int j = 0; j < kStateSize; ++j) {
      if (!std::isfinite(v[j])) return false;
    }
    if ((v[0] != 0 && v[0] != 1 && v[0] != 2) || v[6] < 0 || v[6] > 3 || v[6] != std::floor(v[6])) return false;
  }
  for (size_t i = 0; i < cylinders_.size(); ++i) {
    const double* v = &state[i * kStateSize];
    cylinders_[i] = {v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]};
  }
  return true;
}

}  // namespace pneumatic
