#include "laib_smc.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pneumatic {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr const char* kName = "laib controller";

// numbers in messages
std::string Number(double v) { return NumberForMessage(v); }

std::string KeyError(const std::string& key, const std::string& message) {
  return ControllerKeyError(kName, key, message);
}

double Sign(double v) { return v > 0 ? 1 : v < 0 ? -1 : 0; }

// the chamber lengths L_P, L_N of the header, kept positive off the stroke
void Lengths(const LaibSmcParams& p, double x1, double* LP, double* LN) {
  const double floor = 1e-3 * p.stroke;
  *LP = std::max(p.stroke / 2 + x1, 0.0) + p.dead_volume / p.area_P;
  *LN = std::max(p.stroke / 2 - x1, 0.0) + p.dead_volume / p.area_N;
  *LP = std::max(*LP, floor), *LN = std::max(*LN, floor);
}

// F(X, u) of (15)
LaibState Derivative(const LaibSmcParams& p, const LaibState& X, double u) {
  const LaibModel f = LaibEvaluate(p, X, u);
  return {X[1], X[2], f.phi1 + f.g1 * u, f.phi2 + f.g2 * u};
}

}  // namespace

const std::vector<LaibSmcKey>& LaibSmcKeys() {
  using P = LaibSmcParams;
  static const std::vector<LaibSmcKey> keys = {
      {"mass", "kg", "moving mass m (Table 3)", 0, kInf, true, true, &P::mass},
      {"viscous", "N s/m", "viscous friction b_v (Table 3)", 0, kInf, false, true, &P::viscous},
      {"stroke", "m", "stroke l (Table 3 prints 0.01)", 0, kInf, true, true, &P::stroke},
      {"area_P", "m^2", "piston area A_P", 0, kInf, true, true, &P::area_P},
      {"area_N", "m^2", "piston area A_N", 0, kInf, true, true, &P::area_N},
      {"dead_volume", "m^3", "dead volume V0 of each chamber (0 in the paper)", 0, kInf, false, true, &P::dead_volume},
      {"polytropic_index", "", "k of (1)", 1, 2, false, false, &P::polytropic_index},
      {"gas_constant", "J/(kg K)", "r of (1)", 0, kInf, true, true, &P::gas_constant},
      {"temperature", "K", "T of (1)", 0, kInf, true, true, &P::temperature},
      {"p_supply", "Pa", "P_S, absolute", 0, kInf, true, true, &P::p_supply},
      {"p_exhaust", "Pa", "P_E, absolute", 0, kInf, true, true, &P::p_exhaust},
      {"critical_ratio", "", "b_crit of (3)", 0, 1, false, true, &P::critical_ratio},
      {"sonic_conductance", "kg/(s Pa)", "C_val of (3)", 0, kInf, true, true, &P::sonic_conductance},
      {"lambda", "1/s", "lambda of the sliding surface s_p", 0, kInf, true, true, &P::lambda},
      {"beta", "", "gain-uncertainty bound of (17), > 1", 1, kInf, true, true, &P::beta},
      {"gamma", "", "drift-uncertainty bound of (17)", 0, kInf, false, true, &P::gamma},
      {"eta", "m/s^3", "reaching gain of (20)", 0, kInf, true, true, &P::eta},
      {"observer", "", "0 (or high_gain): observer (22); 1 (or sliding): observer (23)", 0, 1, false, false, nullptr,
       nullptr, &P::observer},
      {"g11", "", "G_1 of (22)", 0, kInf, true, true, &P::g11},
      {"g12", "", "G_1 of (22)", 0, kInf, true, true, &P::g12},
      {"g13", "", "G_1 of (22)", 0, kInf, true, true, &P::g13},
      {"g2", "", "G_2 of (22)", 0, kInf, true, true, &P::g2},
      {"theta1", "", "theta_1 of (22): Theta_1 = diag(theta1, theta1^2, theta1^3)", 0, kInf, true, true, &P::theta1},
      {"theta2", "", "theta_2 of (22): Theta_2", 0, kInf, true, true, &P::theta2},
      {"k11", "1/s", "K_1 of (23)", 0, kInf, true, true, &P::k11},
      {"k12", "1/s^2", "K_1 of (23)", 0, kInf, true, true, &P::k12},
      {"k13", "1/s^3", "K_1 of (23)", 0, kInf, true, true, &P::k13},
      {"k2", "1/s", "K_2 of (23)", 0, kInf, true, true, &P::k2},
      {"l11", "m/s", "L_1 of (23), > max |e2| (24)", 0, kInf, false, true, &P::l11},
      {"l12", "m/s^2", "L_1 of (23)", 0, kInf, false, true, &P::l12},
      {"l13", "m/s^3", "L_1 of (23)", 0, kInf, false, true, &P::l13},
      {"l2", "Pa/s", "L_2 of (23), > max |delta2| (24)", 0, kInf, false, true, &P::l2},
      {"substeps", "", "observer Euler steps per control period", 1, 100000, false, false, nullptr, nullptr,
       &P::substeps},
  };
  return keys;
}

namespace {

// the checks between keys: the supply above the exhaust, and observers whose error dynamics are stable
std::string KeysTogether(const LaibSmcParams& p) {
  if (!(p.p_supply > p.p_exhaust)) {
    return KeyError("p_supply", "must exceed p_exhaust = " + Number(p.p_exhaust) + " Pa (got " + Number(p.p_supply) + ")");
  }
  // A_1 - G_1 C_1 and A_1 - K_1 C_1 Hurwitz: s^3 + a s^2 + b s + c with a, b, c > 0 needs a b > c
  if (!(p.g11 * p.g12 > p.g13)) {
    return KeyError("g13", "must be below g11 g12 = " + Number(p.g11 * p.g12) +
                               " for A1 - G1 C1 to be Hurwitz (got " + Number(p.g13) + ")");
  }
  if (!(p.k11 * p.k12 > p.k13)) {
    return KeyError("k13", "must be below k11 k12 = " + Number(p.k11 * p.k12) +
                               " for A1 - K1 C1 to be Hurwitz (got " + Number(p.k13) + ")");
  }
  return "";
}

// observer=high_gain and observer=sliding, as the numbers 0 and 1
std::string ObserverNumber(const std::string& key, const std::string& value) {
  if (key == "observer" && value == "high_gain") return "0";
  if (key == "observer" && value == "sliding") return "1";
  return value;
}

const ControllerConfigTable<LaibSmcParams>& Table() {
  static const ControllerConfigTable<LaibSmcParams> table{kName, LaibSmcKeys(), KeysTogether, ObserverNumber};
  return table;
}

}  // namespace

std::string ValidateLaibSmcParams(const LaibSmcParams& p) { return ValidateControllerParams(Table(), p); }

bool SetLaibSmcParameter(LaibSmcParams* params, const std::string& key, double value, std::string* error) {
  return SetControllerParameter(Table(), params, key, value, error);
}

bool ParseLaibSmcConfig(const std::string& text, LaibSmcParams* params, std::string* error) {
  return ParseControllerConfig(Table(), text, params, error);
}

double LaibFlow(const LaibSmcParams& p, double pu, double pd) {
  // eq. (3), T_u = T
  if (!(pu > 0) || pd >= pu) return 0;
  const double ratio = pd / pu, b = p.critical_ratio;
  if (ratio <= b) return p.sonic_conductance * pu;
  const double q = (ratio - b) / (1 - b);
  return p.sonic_conductance * pu * std::sqrt(std::max(0.0, 1 - q * q));
}

LaibModel LaibEvaluate(const LaibSmcParams& p, const LaibState& X, double u) {
  LaibModel f;
  double LP = 0, LN = 0;
  Lengths(p, X[0], &LP, &LN);
  const double krT = p.polytropic_index * p.gas_constant * p.temperature;
  f.psi = (p.area_P * X[3] - p.mass * X[2] - p.viscous * X[1]) / p.area_N;  // below (15)
  f.phi1 = -p.polytropic_index / p.mass * (p.area_P * X[3] / LP + p.area_N * f.psi / LN) * X[1] -
           p.viscous / p.mass * X[2];
  f.phi2 = -p.polytropic_index * X[3] / LP * X[1];
  if (u >= 0) {  // mode 6: P to supply, N to exhaust (13)
    f.g1 = krT / p.mass * (LaibFlow(p, p.p_supply, X[3]) / LP + LaibFlow(p, f.psi, p.p_exhaust) / LN);
    f.g2 = krT * LaibFlow(p, p.p_supply, X[3]) / (LP * p.area_P);
  } else {  // mode 7: P to exhaust, N to supply (12)
    f.g1 = krT / p.mass * (LaibFlow(p, X[3], p.p_exhaust) / LP + LaibFlow(p, p.p_supply, f.psi) / LN);
    f.g2 = krT * LaibFlow(p, X[3], p.p_exhaust) / (LP * p.area_P);
  }
  return f;
}

void LaibObserver::Advance(double dt, double u, double x0, double pP0, double x1, double pP1) {
  const LaibSmcParams& p = params_;
  const int n = std::max(1, p.substeps);
  const double h = dt / n;
  // the correction gains: Theta G (22) or K, L (23)
  double c1, c2, c3, c4, s1 = 0, s2 = 0, s3 = 0, s4 = 0;
  if (p.observer == 0) {
    c1 = p.theta1 * p.g11, c2 = p.theta1 * p.theta1 * p.g12, c3 = p.theta1 * p.theta1 * p.theta1 * p.g13;
    c4 = p.theta2 * p.g2;
  } else {
    c1 = p.k11, c2 = p.k12, c3 = p.k13, c4 = p.k2;
    s1 = p.l11, s2 = p.l12, s3 = p.l13, s4 = p.l2;
  }
  for (int i = 0; i < n; ++i) {
    const double a = static_cast<double>(i) / n;
    const double z1 = x0 + a * (x1 - x0), z4 = pP0 + a * (pP1 - pP0);
    const LaibState F = Derivative(p, X_, u);
    const double e1 = X_[0] - z1, e4 = X_[3] - z4;
    const double sg1 = Sign(e1), sg4 = Sign(e4);
    X_[0] += h * (F[0] - c1 * e1 - s1 * sg1);
    X_[1] += h * (F[1] - c2 * e1 - s2 * sg1);
    X_[2] += h * (F[2] - c3 * e1 - s3 * sg1);
    X_[3] += h * (F[3] - c4 * e4 - s4 * sg4);
  }
}

double LaibObserver::p_N() const { return LaibEvaluate(params_, X_, 0).psi; }

std::unique_ptr<LaibSmcController> LaibSmcController::Create(std::vector<ValveDrive> drives,
                                                             const LaibSmcParams& params, double period,
                                                             std::string* error) {
  auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return std::unique_ptr<LaibSmcController>();
  };
  if (!(period > 0) || !std::isfinite(period)) return fail("laib controller: the period must be positive");
  if (std::string e = ValidateLaibSmcParams(params); !e.empty()) return fail(e);
  for (size_t i = 0; i < drives.size(); ++i) {
    if (drives[i].kind != ValveDrive::Kind::kDuty) {
      return fail("laib controller: cylinder " + std::to_string(i) +
                  " does not have on/off valves on PWM (input=pwm, one duty), which paper 003's controller drives");
    }
  }
  return std::unique_ptr<LaibSmcController>(new LaibSmcController(std::move(drives), params, period));
}

double LaibSmcController::Control(const CylinderMeasurement& y, Cylinder* c) {
  const LaibSmcParams& p = params_;
  const double T = period_;
  if (c->started == 0) {
    c->started = 1;
    c->X = {y.x, 0, 0, y.p_P};
    c->yd1 = c->yd2 = c->yd3 = y.reference;
    c->integral = 0, c->u1 = 0;
  } else {
    LaibObserver observer(p);
    observer.set_estimate(c->X);
    observer.Advance(T, c->u1, c->x1, c->pP1, y.x, y.p_P);
    c->X = observer.estimate();
  }
  c->x1 = y.x, c->pP1 = y.p_P;
  // the reference's derivatives, backward differences over the ticks
  const double yd = y.reference;
  const double yd_d1 = (yd - c->yd1) / T;
  const double yd_d2 = (yd - 2 * c->yd1 + c->yd2) / (T * T);
  const double yd_d3 = (yd - 3 * c->yd1 + 3 * c->yd2 - c->yd3) / (T * T * T);
  c->yd3 = c->yd2, c->yd2 = c->yd1, c->yd1 = yd;
  const LaibState& X = c->X;
  const double e = X[0] - yd, e_d1 = X[1] - yd_d1, e_d2 = X[2] - yd_d2;
  c->integral += e * T;
  const double L = p.lambda;
  c->s = e_d2 + 3 * L * e_d1 + 3 * L * L * e + L * L * L * c->integral;          // s_p
  const LaibModel fpos = LaibEvaluate(p, X, 1), fneg = LaibEvaluate(p, X, -1);  // phi1 does not depend on u
  const double u_eq = yd_d3 - fpos.phi1 - 3 * L * e_d2 - 3 * L * L * e_d1 - L * L * L * e;  // (19)
  const double Kc = p.beta * (p.gamma * std::fabs(fpos.phi1) + p.eta) + (p.beta - 1) * std::fabs(u_eq);  // (20)
  const double numerator = u_eq - Kc * Sign(c->s);
  const double g1 = numerator >= 0 ? fpos.g1 : fneg.g1;
  double u = g1 > 0 ? numerator / g1 : Sign(numerator);  // (18)
  if (!std::isfinite(u)) u = 0;
  u = std::clamp(u, -1.0, 1.0);
  c->u1 = u;
  return u;
}

void LaibSmcController::Update(double /*time*/, const std::vector<CylinderMeasurement>& measured,
                               std::vector<CylinderCommands>* commands) {
  commands->resize(drives_.size());
  for (size_t i = 0; i < drives_.size() && i < measured.size(); ++i) {
    (*commands)[i] = {{"duty", Control(measured[i], &cylinders_[i])}};
  }
}

std::vector<double> LaibSmcController::State() const {
  std::vector<double> state;
  state.reserve(cylinders_.size() * kStateSize);
  for (const Cylinder& c : cylinders_) {
    for (double v : {c.started, c.X[0], c.X[1], c.X[2], c.X[3], c.x1, c.pP1, c.u1, c.integral, c.yd1, c.yd2, c.yd3,
                     c.s}) {
      state.push_back(v);
    }
  }
  return state;
}

bool LaibSmcController::SetState(const std::vector<double>& state) {
  if (state.size() != cylinders_.size() * kStateSize) return false;
  for (size_t i = 0; i < cylinders_.size(); ++i) {
    const double* v = &state[i * kStateSize];
    for (int j = 0; j < kStateSize; ++j) {
      if (!std::isfinite(v[j])) return false;
    }
    if ((v[0] != 0 && v[0] != 1) || v[7] < -1 || v[7] > 1) return false;
  }
  for (size_t i = 0; i < cylinders_.size(); ++i) {
    const double* v = &state[i * kStateSize];
    Cylinder& c = cylinders_[i];
    c.started = v[0], c.X = {v[1], v[2], v[3], v[4]}, c.x1 = v[5], c.pP1 = v[6], c.u1 = v[7];
    c.integral = v[8], c.yd1 = v[9], c.yd2 = v[10], c.yd3 = v[11], c.s = v[12];
  }
  return true;
}

LaibState LaibSmcController::Estimate(size_t i) const { return cylinders_[i].X; }
double LaibSmcController::EstimatedPN(size_t i) const { return LaibEvaluate(params_, cylinders_[i].X, 0).psi; }
void LaibSmcController::SetEstimate(size_t i, const LaibState& X) { cylinders_[i].X = X; }

}  // namespace pneumatic
