// The text form of a controller's configuration: "key=value" pairs separated by spaces, tabs,
// newlines or commas (e.g. "omega=100 xi=0.5"), shared by the papers' controllers.
#ifndef PNEUMATIC_CONTROLLERS_KEY_VALUE_TEXT_H_
#define PNEUMATIC_CONTROLLERS_KEY_VALUE_TEXT_H_

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

}  // namespace pneumatic

#endif  // PNEUMATIC_CONTROLLERS_KEY_VALUE_TEXT_H_
