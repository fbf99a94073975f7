#include "sliding_mode.h"

#include <cmath>
#include <limits>

namespace pneumatic {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kPi = 3.14159265358979323846;
constexpr const char* kName = "sliding-mode controller";

// numbers in messages
std::string Number(double v) { return NumberForMessage(v); }

std::string KeyError(const std::string& key, const std::string& message) {
  return ControllerKeyError(kName, key, message);
}

// the checks between keys: E1 (15) needs the supply above the exhaust
std::string KeysTogether(const SlidingModeParams& params) {
  if (!(params.p_supply > params.p_exhaust)) {
    return KeyError("p_supply", "must exceed p_exhaust = " + Number(params.p_exhaust) + " Pa (got " +
                                    Number(params.p_supply) + ")");
  }
  return "";
}

const ControllerConfigTable<SlidingModeParams>& Table() {
  static const ControllerConfigTable<SlidingModeParams> table{kName, SlidingModeKeys(), KeysTogether};
  return table;
}

}  // namespace

const std::vector<SlidingModeKey>& SlidingModeKeys() {
  static const std::vector<SlidingModeKey> keys = {
      {"modes", "", "3: the 3-mode controller of ref. [17] (Fig. 6); 7: paper 002's Table II", 3, 7, false, false, nullptr,
       nullptr, &SlidingModeParams::modes, true},
      {"omega", "rad/s", "w of the switching function (7)", 0, kInf, true, true, &SlidingModeParams::omega},
      {"xi", "", "xi of the switching function (7)", 0, kInf, true, true, &SlidingModeParams::xi},
      {"tau", "s", "timeout: least time between M2<->M4 and M3<->M5 (IV.C.1)", 0, kInf, false, true,
       &SlidingModeParams::tau},
      {"beta", "m", "|s| above which M6/M7 drive (Table II, eq. 18)", 0, kInf, true, true, &SlidingModeParams::beta},
      {"e_min", "m", "the fixed eps: |s| below which all valves close (eq. 25, Fig. 6)", 0, kInf, false, true,
       &SlidingModeParams::e_min},
      {"kappa", "", "gain on s_stop in the variable eps (25)", 0, kInf, false, true, &SlidingModeParams::kappa},
      {"yd_dot_min", "m/s", "reference speed below which eps = kappa s_stop (25)", 0, kInf, false, true,
       &SlidingModeParams::yd_dot_min},
      {"variable_epsilon", "", "1: eps from (22-25) in the 7-mode controller; 0: eps = e_min", 0, 1, false, false,
       nullptr, &SlidingModeParams::variable_epsilon},
      {"filter_cutoff", "Hz", "cut-off of the 2nd-order Butterworth on the error (VI.A)", 0, kInf, true, true,
       &SlidingModeParams::filter_cutoff},
      {"p_supply", "Pa", "P_S in E1 (15), absolute", 0, kInf, true, true, &SlidingModeParams::p_supply},
      {"p_exhaust", "Pa", "P_E in E1 (15), absolute", 0, kInf, true, true, &SlidingModeParams::p_exhaust},
  };
  return keys;
}

std::string ValidateSlidingModeParams(const SlidingModeParams& params) {
  return ValidateControllerParams(Table(), params);
}

bool SetSlidingModeParameter(SlidingModeParams* params, const std::string& key, double value, std::string* error) {
  return SetControllerParameter(Table(), params, key, value, error);
}

bool ParseSlidingModeConfig(const std::string& text, SlidingModeParams* params, std::string* error) {
  return ParseControllerConfig(Table(), text, params, error);
}

double SlidingModeBetaEq18(double xi, double omega, double area, double p_supply, double p_exhaust, double viscous) {
  // eq. (18): beta = (3 xi / 4 w) max(y_dot), max(y_dot) = A (P_S - P_E) / b_m (17)
  return 3 * xi * area * (p_supply - p_exhaust) / (4 * viscous * omega);
}

const double* SlidingModeValves(int mode) {
  // Table I, modes M1..M7: {U1, U2, U3, U4}
  static const double table[7][4] = {{0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 0, 1},
                                     {0, 0, 1, 0}, {1, 0, 0, 1}, {0, 1, 1, 0}};
  return table[mode >= 1 && mode <= 7 ? mode - 1 : 0];
}

std::unique_ptr<SlidingModeController> SlidingModeController::Create(std::vector<ValveDrive> drives,
                                                                     const SlidingModeParams& params, double period,
                                                                     std::string* error) {
  auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return std::unique_ptr<SlidingModeController>();
  };
  if (!(period > 0) || !std::isfinite(period)) return fail("sliding-mode controller: the period must be positive");
  if (std::string e = ValidateSlidingModeParams(params); !e.empty()) return fail(e);
  if (!(params.filter_cutoff < 0.5 / period)) {
    return fail(KeyError("filter_cutoff", "must lie below the Nyquist frequency " + Number(0.5 / period) +
                                              " Hz of the control period (got " + Number(params.filter_cutoff) + ")"));
  }
  for (size_t i = 0; i < drives.size(); ++i) {
    if (drives[i].kind != ValveDrive::Kind::kOnOff) {
      return fail("sliding-mode controller: cylinder " + std::to_string(i) +
                  " does not have four on/off valves (u1..u4), which paper 002's controllers drive");
    }
    if (!(drives[i].half_stroke > 0)) {
      return fail("sliding-mode controller: cylinder " + std::to_string(i) + " has no positive stroke");
    }
  }
  return std::unique_ptr<SlidingModeController>(new SlidingModeController(std::move(drives), params, period));
}

SlidingModeController::SlidingModeController(std::vector<ValveDrive> drives, const SlidingModeParams& params,
                                             double period)
    : drives_(std::move(drives)), params_(params), period_(period), cylinders_(drives_.size()) {
  // 2nd-order Butterworth low-pass (VI.A) by the bilinear transform, pre-warped at the cut-off
  const double k = std::tan(kPi * params_.filter_cutoff * period_), q = std::sqrt(2.0);
  const double norm = 1 / (1 + q * k + k * k);
  b0_ = k * k * norm, b1_ = 2 * b0_, b2_ = b0_;
  a1_ = 2 * (k * k - 1) * norm, a2_ = (1 - q * k + k * k) * norm;
}

int SlidingModeController::ChooseMode(const ValveDrive& drive, const CylinderMeasurement& y, Cylinder* c) {
  const SlidingModeParams& p = params_;
  const double T = period_;
  // the error (7) and its filtered derivatives (29-31); the filter starts at rest on the first error
  const double e = y.x - y.reference;
  if (c->started == 0) {
    c->started = 1, c->e1 = c->e2 = c->f1 = c->f2 = e, c->yd1 = y.reference, c->mode = 1, c->held = 0;
  }
  const double f = b0_ * e + b1_ * c->e1 + b2_ * c->e2 - a1_ * c->f1 - a2_ * c->f2;
  const double e_dot = (f - c->f1) / T;                      // (29)
  const double e_ddot = (f - 2 * c->f1 + c->f2) / (T * T);   // (30)
  const double s = e_ddot / (p.omega * p.omega) + 2 * p.xi * e_dot / p.omega + f;  // (31)
  const double yd_dot = (y.reference - c->yd1) / T;          // (29) on y_d
  c->e2 = c->e1, c->e1 = e, c->f2 = c->f1, c->f1 = f, c->yd1 = y.reference;
  c->s = s;

  const int current = static_cast<int>(c->mode);
  c->held += 1;  // ticks since the current mode was entered
  if (p.modes == 3) {
    // ref. [17] as paper 002's Fig. 6: push hardest (M6), pull hardest (M7) or all closed (M1)
    c->eps = p.e_min;
    return s > p.e_min ? 7 : s < -p.e_min ? 6 : 1;
  }

  // the variable eps (22-25): where closing every valve lets the gas springs settle the piston on y_d
  double eps = p.e_min;
  if (p.variable_epsilon && s * e_dot < 0 && std::fabs(yd_dot) < p.yd_dot_min) {
    const double l = 2 * drive.half_stroke;
    const double yd = y.reference + l / 2;                  // y'_d (23)
    const double s_stop = std::fabs(y.p_N * yd * l / (y.p_N * yd + y.p_P * (l - yd)) - yd);  // (24)
    if (std::isfinite(s_stop)) eps = p.kappa * s_stop;      // (25)
  }
  c->eps = eps;
  // Table II
  if (std::fabs(s) <= eps) return 1;
  if (s > p.beta) return 7;
  if (s < -p.beta) return 6;
  const double e1 = (p.p_supply + p.p_exhaust) - (y.p_P + y.p_N);  // E1 (15) = E2 (16)
  int mode = s > 0 ? (e1 > 0 ? 5 : 3) : (e1 > 0 ? 2 : 4);
  // the timeout tau (IV.C.1): M2 <-> M4 and M3 <-> M5 only after tau in the current mode
  const bool sibling = (current == 2 && mode == 4) || (current == 4 && mode == 2) || (current == 3 && mode == 5) ||
                       (current == 5 && mode == 3);
  if (sibling && c->held * T < p.tau - 1e-9 * T) mode = current;
  return mode;
}

void SlidingModeController::Update(double /*time*/, const std::vector<CylinderMeasurement>& measured,
                                   std::vector<CylinderCommands>* commands) {
  commands->resize(drives_.size());
  for (size_t i = 0; i < drives_.size() && i < measured.size(); ++i) {
    Cylinder& c = cylinders_[i];
    const int mode = ChooseMode(drives_[i], measured[i], &c);
    if (mode != static_cast<int>(c.mode)) c.mode = mode, c.held = 0;
    const double* u = SlidingModeValves(mode);
    (*commands)[i] = {{"u1", u[0]}, {"u2", u[1]}, {"u3", u[2]}, {"u4", u[3]}};
  }
}

std::vector<double> SlidingModeController::State() const {
  std::vector<double> state;
  state.reserve(cylinders_.size() * kStateSize);
  for (const Cylinder& c : cylinders_) {
    for (double v : {c.started, c.e1, c.e2, c.f1, c.f2, c.yd1, c.mode, c.held, c.s, c.eps}) state.push_back(v);
  }
  return state;
}

bool SlidingModeController::SetState(const std::vector<double>& state) {
  if (state.size() != cylinders_.size() * kStateSize) return false;
  for (size_t i = 0; i < cylinders_.size(); ++i) {
    const double* v = &state[i * kStateSize];
    for (int j = 0; j < kStateSize; ++j) {
      if (!std::isfinite(v[j])) return false;
    }
    if (v[6] < 1 || v[6] > 7 || v[6] != std::floor(v[6]) || (v[0] != 0 && v[0] != 1) || v[7] < 0) return false;
  }
  for (size_t i = 0; i < cylinders_.size(); ++i) {
    const double* v = &state[i * kStateSize];
    cylinders_[i] = {v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9]};
  }
  return true;
}

}  // namespace pneumatic
