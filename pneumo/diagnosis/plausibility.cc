#include "diagnosis/plausibility.h"

#include <cmath>
#include <cstdio>

namespace pneumatic::diagnosis {
namespace {

std::string Fixed(const char* format, double a) {
  char text[128];
  std::snprintf(text, sizeof(text), format, a);
  return text;
}

}  // namespace

std::string BoundReached(const EffectParameter& p, double value) {
  const bool log_scale = p.logarithmic && p.lower > 0 && value > 0;
  const double margin = log_scale ? 0.01 * std::log(p.upper / p.lower) : 0.01 * (p.upper - p.lower);
  const double below = log_scale ? std::log(value / p.lower) : value - p.lower;
  const double above = log_scale ? std::log(p.upper / value) : p.upper - value;
  if (below <= margin) return "at its lower bound";
  if (above <= margin) return "at its upper bound";
  return "";
}

double AbsentValue(const EffectParameter& p) {
  if (!std::isnan(p.absent)) return p.absent;
  const bool deviation = !p.logarithmic && (p.nominal != 0 || p.lower < 0);
  return deviation ? p.nominal : p.lower;
}

namespace {

// whether `value` of p is the model without the effect: its AbsentValue, or the bound it lies at
// where that bound is the absent end of the range
bool IsAbsent(const EffectParameter& p, double value) {
  const double absent = AbsentValue(p);
  const std::string bound = BoundReached(p, value);
  return value == absent || (bound == "at its lower bound" && absent <= p.lower) || (bound == "at its upper bound" && absent >= p.upper);
}

}  // namespace

std::string ValueAtAFarBound(const Candidate& c, const std::vector<double>& values) {
  for (size_t i = 0; i < c.parameters.size() && i < values.size(); ++i) {
    const EffectParameter& p = c.parameters[i];
    const std::string bound = BoundReached(p, values[i]);
    if (!bound.empty() && !IsAbsent(p, values[i])) return p.name + " " + bound + Fixed(" (%.3g ", values[i]) + p.unit + ")";
  }
  return "";
}

std::string Implausible(const Candidate& c, const std::vector<double>& values, const std::vector<double>& standard_errors) {
  if (std::string far = ValueAtAFarBound(c, values); !far.empty()) return far;
  bool any_present = false, any_magnitude = false;
  std::string undetermined;  // the first parameter off the model without the effect by less than its standard error
  for (size_t i = 0; i < c.parameters.size() && i < values.size() && i < standard_errors.size(); ++i) {
    const EffectParameter& p = c.parameters[i];
    if (p.nuisance) continue;
    any_magnitude = true;
    const double value = values[i], absent = AbsentValue(p);
    if (IsAbsent(p, value)) continue;
    if (!(standard_errors[i] <= std::fabs(value - absent))) {
      if (undetermined.empty()) {
        undetermined = p.name + " not determined by the data" + Fixed(" (%.3g", value) + Fixed(" +- %.2g ", standard_errors[i]) + p.unit + ")";
      }
      continue;
    }
    any_present = true;
  }
  if (any_present || !any_magnitude) return "";
  return undetermined.empty() ? "every parameter at the value of the model without the effect" : undetermined;
}

}  // namespace pneumatic::diagnosis
