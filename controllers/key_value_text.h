// The text form of a controller's configuration: "key=value" pairs separated by spaces, tabs,
// newlines or commas (e.g. "omega=100 xi=0.5"), and the pieces of its messages. config_parser.h reads
// such text against a controller's table of keys.
#ifndef PNEUMATIC_CONTROLLERS_KEY_VALUE_TEXT_H_
#define PNEUMATIC_CONTROLLERS_KEY_VALUE_TEXT_H_

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace pneumatic {

// Splits `text` into (key, value) pairs. False, with the offending piece in *bad, if a piece is
// not key=value with a non-empty value.
inline bool SplitKeyValues(const std::string& text, std::vector<std::pair<std::string, std::string>>* pairs,
                           std::string* bad) {
  std::string piece;
  auto flush = [&]() {
    if (piece.empty()) return true;
    const size_t eq = piece.find('=');
    if (eq == std::string::npos || eq + 1 == piece.size()) {
      *bad = piece;
      return false;
    }
    pairs->emplace_back(piece.substr(0, eq), piece.substr(eq + 1));
    piece.clear();
    return true;
  };
  for (char c : text) {
    if (c == ' ' || c == ',' || c == '\t' || c == '\n' || c == '\r') {
      if (!flush()) return false;
    } else {
      piece += c;
    }
  }
  return flush();
}

// A number for a message: six significant digits ("0.001", "1e+06").
inline std::string NumberForMessage(double v) {
  std::ostringstream out;
  out.precision(6);
  out << v;
  return out.str();
}

// The whole of `value` as a number; false if any of it is not part of one.
inline bool ParseNumber(const std::string& value, double* number) {
  char* end = nullptr;
  *number = std::strtod(value.c_str(), &end);
  return !value.empty() && end == value.c_str() + value.size();
}

// "" if `value` lies in the range from min to max (each end excluded where flagged open), else the
// message "must be in [min, max) UNIT (got VALUE)" for a controller's key error.
inline std::string RangeProblem(double value, double min, double max, bool min_open, bool max_open,
                                const std::string& unit) {
  const bool low = min_open ? value > min : value >= min;
  const bool high = max_open ? value < max : value <= max;
  if (low && high) return "";
  const std::string range = std::string(min_open ? "(" : "[") + NumberForMessage(min) + ", " +
                            (std::isinf(max) ? std::string("inf") : NumberForMessage(max)) + (max_open ? ")" : "]");
  return "must be in " + range + (unit.empty() ? "" : " " + unit) + " (got " + NumberForMessage(value) + ")";
}

}  // namespace pneumatic

#endif  // PNEUMATIC_CONTROLLERS_KEY_VALUE_TEXT_H_
