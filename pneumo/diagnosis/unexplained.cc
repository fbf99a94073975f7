#include "diagnosis/unexplained.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace pneumatic::diagnosis {
namespace {

constexpr int kBins = 10;

std::string Fixed(const char* format, double a) {
  char text[128];
  std::snprintf(text, sizeof(text), format, a);
  return text;
}

// the states a residual of cylinder c is tested against, by name, per row
std::vector<std::pair<std::string, std::vector<double>>> States(const Measurements& meas, const CylinderSeries& c) {
  const std::string& n = c.info.name;
  const int half = VelocityHalfWindow(meas.period);
  std::vector<std::pair<std::string, std::vector<double>>> states = {
      {n + ".x", c.signal[kPosition]},
      {n + ".v", c.velocity},
      {n + ".a", EstimateVelocity(c.velocity, meas.period, half)},
      {n + ".p_P", c.signal[kPressureP]},
      {n + ".p_N", c.signal[kPressureN]}};
  for (size_t k = 0; k < c.commands.size(); ++k) states.push_back({n + "." + c.command_names[k], c.commands[k]});
  return states;
}

// eta^2 of r against q where r does not depend on q, with their own autocorrelations: the mean
// over q shifted circularly by 1/7 .. 6/7 of the rows (the header's eta^2_noise)
double ChanceLevel(const std::vector<double>& r, const std::vector<double>& q) {
  const size_t n = q.size();
  double sum = 0;
  for (int k = 1; k <= 6; ++k) {
    std::vector<double> shifted(n);
    for (size_t i = 0; i < n; ++i) shifted[i] = q[(i + n * k / 7) % n];
    sum += CorrelationRatio(r, shifted, kBins).eta2;
  }
  return sum / 6;
}

ResidualStructure Structure(const Measurements& meas, const GapOptions& g, const Evaluated& full, const NoiseFloor& floor, int s) {
  ResidualStructure out;
  out.signal = meas.SignalLabel(s);
  out.floor = floor.signal_floor[s];
  out.gap = full.signal_gap[s];
  out.rms = full.signal_rms[s];
  std::vector<double> r(meas.rows(), std::nan(""));
  std::vector<double> present;
  for (int row = 0; row < meas.rows(); ++row) {
    const double sim = full.prediction.simulated[s][row];
    if (std::isnan(sim)) continue;
    r[row] = sim - meas.Signal(s)[row];
    present.push_back(r[row]);
  }
  if (present.size() < 4 * kBins) return out;
  double mean = 0, var = 0;
  for (double e : present) mean += e;
  mean /= static_cast<double>(present.size());
  for (double e : present) var += (e - mean) * (e - mean);
  var /= static_cast<double>(present.size());
  out.mean = mean;
  out.effective_samples = static_cast<double>(present.size()) / std::max(1.0, IntegratedAutocorrelationTime(present, 200));
  // lags of 0, 20 and 100 ms: a state acting at once, through a valve's or a line's lag, through the motion
  std::vector<int> lags = {0};
  for (double lag_s : {0.02, 0.1}) {
    const int rows = static_cast<int>(std::lround(lag_s / meas.period));
    if (rows > lags.back() && rows < meas.rows() / 4) lags.push_back(rows);
  }
  double best_excess = 0;
  for (const auto& [name, q] : States(meas, meas.cylinders[s / kSignalsPerCylinder])) {
    StateDependence best;
    best.state = name, best.eta2 = -1;
    for (int lag : lags) {
      std::vector<double> shifted(meas.rows(), std::nan(""));
      for (int row = lag; row < meas.rows(); ++row) shifted[row] = q[row - lag];
      BinnedDependence b = CorrelationRatio(r, shifted, kBins);
      if (b.eta2 <= best.eta2) continue;
      best.eta2 = b.eta2, best.lag_s = lag * meas.period, best.bins = std::move(b);
      best.excess = std::max(0.0, best.eta2 - ChanceLevel(r, shifted));
    }
    if (best.eta2 < 0) continue;
    best_excess = std::max(best_excess, best.excess);
    out.dependences.push_back(std::move(best));
  }
  std::stable_sort(out.dependences.begin(), out.dependences.end(),
                   [](const StateDependence& a, const StateDependence& b) { return a.excess > b.excess; });
  out.systematic = std::sqrt(mean * mean + best_excess * var) / g.signal_scale[s];
  out.structured = out.systematic > out.floor;
  return out;
}

}  // namespace

std::string VerdictWithoutEffect(const Unexplained& u) { return u.above_floor ? "unexplained" : "none"; }

Unexplained DescribeResidual(const Measurements& meas, const GapOptions& g, const Evaluated& full, const std::vector<double>& pneumatic_gap,
                             const std::vector<double>& mechanical_gap, const std::vector<std::string>& regime_names,
                             const std::vector<double>& regime_gap, const NoiseFloor& floor, double floor_multiple) {
  Unexplained u;
  u.gap = full.gap, u.floor = floor.floor;
  bool structured = false;
  u.mechanical_ratio = u.pneumatic_ratio = u.full_ratio = std::nan("");
  auto worse = [](double* worst, double ratio) {
    if (std::isfinite(ratio) && !(*worst >= ratio)) *worst = ratio;
  };
  for (int s = 0; s < meas.signals(); ++s) {
    u.signals.push_back(Structure(meas, g, full, floor, s));
    structured |= u.signals.back().structured;
    const double f = floor.signal_floor[s];
    if (!(f > 0)) continue;
    worse(&u.full_ratio, full.signal_gap[s] / f);
    if (s % kSignalsPerCylinder == kPosition) {
      if (s < static_cast<int>(mechanical_gap.size())) worse(&u.mechanical_ratio, mechanical_gap[s] / f);
    } else if (s < static_cast<int>(pneumatic_gap.size())) {
      worse(&u.pneumatic_ratio, pneumatic_gap[s] / f);
    }
  }
  u.ratio = GapOverFloor(full.signal_gap, floor);
  if (!std::isfinite(u.ratio)) u.ratio = u.gap / u.floor;  // no floor per signal: the log's
  u.above_floor = u.ratio > floor_multiple;
  u.structured = structured;
  u.present = u.above_floor && structured;
  for (size_t k = 0; k < regime_names.size() && k < regime_gap.size(); ++k) {
    if (std::isfinite(regime_gap[k]) && regime_gap[k] > 1.25 * u.gap) u.regimes.push_back({regime_names[k], regime_gap[k] / u.gap});
  }
  std::stable_sort(u.regimes.begin(), u.regimes.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
  const bool mechanical = u.mechanical_ratio > floor_multiple, pneumatic = u.pneumatic_ratio > floor_multiple;
  u.side = mechanical && pneumatic ? "mechanical and pneumatic"
           : mechanical             ? "mechanical"
           : pneumatic              ? "pneumatic"
           : u.full_ratio > floor_multiple ? "sensors"
                                           : "";
  // in words
  std::string text = Fixed("The gap %.4f", u.gap) + Fixed(" (noise floor %.4f) is ", u.floor) +
                     Fixed("%.1f times the floor, each signal against its own", u.ratio);
  text += u.present       ? ", and structured."
          : structured    ? ", structured but within the floor's margin."
          : u.above_floor ? ", well above it, but its residuals do not depend on the states, the commands or their lags beyond noise: "
                            "what is missing varies with time or comes from outside them (a drift, a disturbance, noise the floor does not count)."
                          : ", and its residuals do not depend on the states beyond noise.";
  for (const ResidualStructure& r : u.signals) {
    if (!r.structured) continue;
    // in the signal's unit: Pa for a pressure, m (rad on a hinge) for x
    const std::string kind = r.signal.substr(r.signal.rfind('.') + 1);
    text += " " + r.signal + Fixed(": residual %.3g", r.rms) + (kind == "x" ? " m (rad on a hinge)" : " Pa") +
            Fixed(" RMS (systematic part %.1f times its floor)", r.systematic / std::max(r.floor, 1e-300));
    int listed = 0;
    for (const StateDependence& d : r.dependences) {
      if (d.excess <= 0 || listed == 3) break;
      text += (listed++ ? ", " : "; depends on ") + d.state + Fixed(" (eta^2 %.2f", d.eta2) + Fixed(" at lag %.0f ms)", 1e3 * d.lag_s);
    }
    text += ".";
  }
  if (!u.regimes.empty()) {
    text += " Largest in the regimes";
    for (size_t k = 0; k < u.regimes.size(); ++k) text += (k ? ", " : " ") + u.regimes[k].first + Fixed(" (%.1f x the mean)", u.regimes[k].second);
    text += ".";
  }
  if (!u.side.empty() && !structured) {
    text += Fixed(" Gaps over their floors: the motion from the measured pressures %.1f", u.mechanical_ratio) +
            Fixed(", the pressures along the measured motion %.1f", u.pneumatic_ratio) +
            "; with no structured residual, the split does not point at missing physics.";
  } else if (!u.side.empty()) {
    text += " It looks " + (u.side == "sensors" ? std::string("like the sensors' side") : u.side) +
            Fixed(": the motion from the measured pressures misses by %.1f times its floor", u.mechanical_ratio) +
            Fixed(", the pressures along the measured motion by %.1f", u.pneumatic_ratio) + Fixed(", the full prediction by %.1f.", u.full_ratio);
  }
  u.summary = text;
  return u;
}

}  // namespace pneumatic::diagnosis
