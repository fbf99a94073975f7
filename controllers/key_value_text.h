// The text form of a controller's configuration: "key=value" pairs separated by spaces, tabs,
// newlines or commas (e.g. "omega=100 xi=0.5"), shared by the papers' controllers.
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

// Sets one parameter of a controller from its key table (rows with a `key` member): check(row, value)
// ("" or the error) then apply(row, value) on the row named `key`. False with *error set if the value
// is refused or no row has that name (key_error words that, listing the keys).
template <typename Row, typename Check, typename Apply, typename KeyError>
bool SetFromKeyTable(const std::vector<Row>& rows, const std::string& key, double value, std::string* error,
                     Check check, Apply apply, KeyError key_error) {
  for (const Row& row : rows) {
    if (key != row.key) continue;
    if (std::string e = check(row, value); !e.empty()) {
      if (error) *error = e;
      return false;
    }
    apply(row, value);
    return true;
  }
  std::string known;
  for (const Row& row : rows) known += std::string(known.empty() ? "" : " ") + row.key;
  if (error) *error = key_error(key, "unknown key (keys: " + known + ")");
  return false;
}

// Parses a controller's "key=value ..." text: each number goes through set(&copy, key, number, error)
// (false: an unknown or out-of-range key, *error set), then validate(copy) checks the whole ("" or
// the error); *params changes only when all of it is accepted. key_error(key, message) words the
// errors of the text itself (not key=value, not a number). A value that is a word, e.g.
// observer=sliding, may be turned into its number by `name_value` first.
template <typename Params, typename Set, typename Validate, typename KeyError>
bool ParseKeyValueConfig(const std::string& text, Params* params, std::string* error, Set set, Validate validate,
                         KeyError key_error,
                         std::string (*name_value)(const std::string& key, const std::string& value) = nullptr) {
  Params out = *params;
  std::vector<std::pair<std::string, std::string>> pairs;
  std::string bad;
  if (!SplitKeyValues(text, &pairs, &bad)) {
    if (error) *error = key_error(bad.substr(0, bad.find('=')), "expected key=value, got '" + bad + "'");
    return false;
  }
  for (auto& [key, value] : pairs) {
    if (name_value) value = name_value(key, value);
    double number = 0;
    if (!ParseNumber(value, &number)) {
      if (error) *error = key_error(key, "'" + value + "' is not a number");
      return false;
    }
    if (!set(&out, key, number, error)) return false;
  }
  if (std::string e = validate(out); !e.empty()) {
    if (error) *error = e;
    return false;
  }
  *params = out;
  return true;
}

}  // namespace pneumatic

#endif  // PNEUMATIC_CONTROLLERS_KEY_VALUE_TEXT_H_
