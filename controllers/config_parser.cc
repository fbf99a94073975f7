#include "config_parser.h"

#include <cmath>

namespace pneumatic {

std::string ControllerKeyError(const char* controller, const std::string& key, const std::string& message) {
  return std::string(controller) + ": key '" + key + "': " + message;
}

std::string ControllerKeyValueProblem(const char* controller, const char* key, const char* unit, double min,
                                      double max, bool min_open, bool max_open, bool two_valued, bool whole,
                                      double value) {
  auto problem = [&](const std::string& message) { return ControllerKeyError(controller, key, message); };
  const std::string got = " (got " + NumberForMessage(value) + ")";
  if (!std::isfinite(value)) return problem("must be a finite number" + got);
  if (two_valued) {
    if (value == min || value == max) return "";
    return problem("must be " + NumberForMessage(min) + " or " + NumberForMessage(max) + got);
  }
  if (whole && value != std::floor(value)) return problem("must be a whole number" + got);
  const std::string range = RangeProblem(value, min, max, min_open, max_open, unit);
  return range.empty() ? "" : problem(range);
}

bool ReadControllerKeyNumbers(const char* controller, const std::string& text,
                              std::string (*word_value)(const std::string& key, const std::string& value),
                              const std::function<bool(const std::string& key, double value, std::string* error)>& set,
                              std::string* error) {
  std::vector<std::pair<std::string, std::string>> pairs;
  std::string bad;
  if (!SplitKeyValues(text, &pairs, &bad)) {
    if (error) *error = ControllerKeyError(controller, bad.substr(0, bad.find('=')), "expected key=value, got '" + bad + "'");
    return false;
  }
  for (auto& [key, value] : pairs) {
    if (word_value) value = word_value(key, value);
    double number = 0;
    if (!ParseNumber(value, &number)) {
      if (error) *error = ControllerKeyError(controller, key, "'" + value + "' is not a number");
      return false;
    }
    if (!set(key, number, error)) return false;
  }
  return true;
}

}  // namespace pneumatic
