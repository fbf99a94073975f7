// A controller's configuration read against its own table of keys. The papers' controllers (karpenko_pid,
// laib_smc, sliding_mode) each give a ControllerConfigTable: a row per key (its unit, meaning, kind and
// valid range), the checks between keys, and the controller's name, which starts every message
// ("karpenko PID controller: key 'ki': must be in [0, inf) V/(m s) (got -1)"). From it they get their
// Validate, Set and Parse, which check every key alike:
//   - the text is "key=value" pairs (key_value_text.h); a value must be a number (or a word the table
//     turns into one, e.g. observer=sliding);
//   - a key not in the table is refused, listing the table's keys;
//   - a value must be finite; a switch 0 or 1, a two-valued key one of its two ends (sliding mode's
//     modes: 3 or 7), a whole-number key whole; then within the row's range;
//   - the checks between keys run last, on the whole configuration;
// and a configuration changes only when all of its text is accepted.
#ifndef PNEUMATIC_CONTROLLERS_CONFIG_PARSER_H_
#define PNEUMATIC_CONTROLLERS_CONFIG_PARSER_H_

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "key_value_text.h"

namespace pneumatic {

// One key of a controller's parameters `Params`: its name, unit, meaning and valid range, and the member
// it sets, which says its kind: a real number, a switch (0 or 1) or a whole number.
template <typename Params>
struct ControllerKey {
  const char* key;
  const char* unit;
  const char* meaning;
  double min, max;          // valid range
  bool min_open, max_open;  // true: the bound itself is excluded
  double Params::*number = nullptr;  // a real number ...
  bool Params::*flag = nullptr;      // ... or a switch: 0 or 1 (min and max) ...
  int Params::*whole = nullptr;      // ... or a whole number
  bool ends_only = false;            // a whole number that is min or max, nothing between (e.g. 3 or 7)
};

// What a controller gives the shared parser: its name for the messages, its keys, and the checks
// between keys ("" or the error, worded with ControllerKeyError), which run after every key's own.
template <typename Params>
struct ControllerConfigTable {
  const char* controller;  // "karpenko PID controller": the start of every message
  const std::vector<ControllerKey<Params>>& keys;
  std::string (*relations)(const Params& params) = nullptr;
  // a value that is a word, turned into its number before it is read (observer=sliding: "1"); null: none
  std::string (*word_value)(const std::string& key, const std::string& value) = nullptr;
};

// "<controller>: key '<key>': <message>"
std::string ControllerKeyError(const char* controller, const std::string& key, const std::string& message);

// "" if `value` suits a key of the given kind and range, else the error naming the key (the checks of
// the header, in their order)
std::string ControllerKeyValueProblem(const char* controller, const char* key, const char* unit, double min,
                                      double max, bool min_open, bool max_open, bool two_valued, bool whole,
                                      double value);

// Reads "key=value ..." text: each value (after word_value, if given) as a number, handed to
// set(key, number, error) in the text's order; false with *error (if not null) at the first piece that is
// not key=value, not a number, or that set refuses.
bool ReadControllerKeyNumbers(const char* controller, const std::string& text,
                              std::string (*word_value)(const std::string& key, const std::string& value),
                              const std::function<bool(const std::string& key, double value, std::string* error)>& set,
                              std::string* error);

// the value of row k in params, as a number (a switch: 0 or 1)
template <typename Params>
double ControllerKeyValue(const ControllerKey<Params>& k, const Params& params) {
  if (k.number) return params.*(k.number);
  if (k.flag) return params.*(k.flag) ? 1 : 0;
  return params.*(k.whole);
}

// "" if `value` may be row k's, else the error naming the key
template <typename Params>
std::string CheckControllerKey(const ControllerConfigTable<Params>& table, const ControllerKey<Params>& k,
                               double value) {
  return ControllerKeyValueProblem(table.controller, k.key, k.unit, k.min, k.max, k.min_open, k.max_open,
                                   k.flag != nullptr || k.ends_only, k.whole != nullptr, value);
}

// "" if every key of params is valid and the keys agree with each other, else the first error
template <typename Params>
std::string ValidateControllerParams(const ControllerConfigTable<Params>& table, const Params& params) {
  for (const ControllerKey<Params>& k : table.keys) {
    if (std::string e = CheckControllerKey(table, k, ControllerKeyValue(k, params)); !e.empty()) return e;
  }
  return table.relations ? table.relations(params) : "";
}

// Sets the key named `key` to value (a switch: value != 0; a whole number: its int). False, with *error
// (if not null) naming the key, if no row has that name or the value is refused; params unchanged then.
template <typename Params>
bool SetControllerParameter(const ControllerConfigTable<Params>& table, Params* params, const std::string& key,
                            double value, std::string* error) {
  for (const ControllerKey<Params>& k : table.keys) {
    if (key != k.key) continue;
    if (std::string e = CheckControllerKey(table, k, value); !e.empty()) {
      if (error) *error = e;
      return false;
    }
    if (k.number) {
      params->*(k.number) = value;
    } else if (k.flag) {
      params->*(k.flag) = value != 0;
    } else {
      params->*(k.whole) = static_cast<int>(value);
    }
    return true;
  }
  std::string known;
  for (const ControllerKey<Params>& k : table.keys) known += std::string(known.empty() ? "" : " ") + k.key;
  if (error) *error = ControllerKeyError(table.controller, key, "unknown key (keys: " + known + ")");
  return false;
}

// Parses "key=value ..." over params' current values: every key set in the text's order, then the
// whole validated. False with *error (if not null) at the first error; params changes only when all of
// the text is accepted.
template <typename Params>
bool ParseControllerConfig(const ControllerConfigTable<Params>& table, const std::string& text, Params* params,
                           std::string* error) {
  Params out = *params;
  auto set = [&](const std::string& key, double value, std::string* e) {
    return SetControllerParameter(table, &out, key, value, e);
  };
  if (!ReadControllerKeyNumbers(table.controller, text, table.word_value, set, error)) return false;
  if (std::string e = ValidateControllerParams(table, out); !e.empty()) {
    if (error) *error = e;
    return false;
  }
  *params = out;
  return true;
}

}  // namespace pneumatic

#endif  // PNEUMATIC_CONTROLLERS_CONFIG_PARSER_H_
