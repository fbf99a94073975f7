// The shared reader of the controllers' configuration text (controllers/config_parser.h), on a table of
// its own: every kind of key (a real number, a switch, a whole number, a two-valued whole number), a word
// turned into a number, the checks between keys, and the messages the papers' controllers give.
#include "config_parser.h"

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace pneumatic {
namespace {

using ::testing::HasSubstr;

constexpr double kInf = std::numeric_limits<double>::infinity();

struct Params {
  double gain = 2;      // (0, inf) 1/s
  double fraction = 0.5;  // [0, 1)
  bool on = true;
  int steps = 10;       // [1, 100]
  int modes = 3;        // 3 or 7
  double low = 1, high = 2;  // low < high
};

std::string LowBelowHigh(const Params& p) {
  if (p.low < p.high) return "";
  return ControllerKeyError("test controller", "low", "must be below high (got " + NumberForMessage(p.low) + ")");
}

std::string StepsWord(const std::string& key, const std::string& value) {
  return key == "steps" && value == "many" ? "100" : value;
}

const std::vector<ControllerKey<Params>>& Keys() {
  static const std::vector<ControllerKey<Params>> keys = {
      {"gain", "1/s", "a gain", 0, kInf, true, true, &Params::gain},
      {"fraction", "", "a fraction", 0, 1, false, true, &Params::fraction},
      {"on", "", "a switch", 0, 1, false, false, nullptr, &Params::on},
      {"steps", "", "a count", 1, 100, false, false, nullptr, nullptr, &Params::steps},
      {"modes", "", "3 or 7", 3, 7, false, false, nullptr, nullptr, &Params::modes, true},
      {"low", "m", "the lower end", -kInf, kInf, true, true, &Params::low},
      {"high", "m", "the upper end", -kInf, kInf, true, true, &Params::high},
  };
  return keys;
}

const ControllerConfigTable<Params>& Table() {
  static const ControllerConfigTable<Params> table{"test controller", Keys(), LowBelowHigh, StepsWord};
  return table;
}

TEST(ControllerConfigParser, ReadsEveryKindOfKey) {
  Params p;
  std::string error;
  ASSERT_TRUE(ParseControllerConfig(Table(), "gain=4, fraction=0.25\ton=0\nsteps=many modes=7 low=-1", &p, &error))
      << error;
  EXPECT_EQ(p.gain, 4);
  EXPECT_EQ(p.fraction, 0.25);
  EXPECT_FALSE(p.on);
  EXPECT_EQ(p.steps, 100);
  EXPECT_EQ(p.modes, 7);
  EXPECT_EQ(p.low, -1);
  EXPECT_EQ(p.high, 2);
  ASSERT_TRUE(ParseControllerConfig(Table(), "", &p, &error)) << error;  // nothing given: nothing changes
  EXPECT_EQ(p.gain, 4);
}

TEST(ControllerConfigParser, RefusesNamingTheControllerAndTheKey) {
  const std::pair<const char*, const char*> bad[] = {
      {"gain", "test controller: key 'gain': expected key=value, got 'gain'"},
      {"gain=", "test controller: key 'gain': expected key=value, got 'gain='"},
      {"gain=abc", "test controller: key 'gain': 'abc' is not a number"},
      {"gian=1", "test controller: key 'gian': unknown key (keys: gain fraction on steps modes low high)"},
      {"gain=inf", "test controller: key 'gain': must be a finite number (got inf)"},
      {"gain=0", "test controller: key 'gain': must be in (0, inf) 1/s (got 0)"},
      {"fraction=1", "test controller: key 'fraction': must be in [0, 1) (got 1)"},
      {"on=2", "test controller: key 'on': must be 0 or 1 (got 2)"},
      {"steps=2.5", "test controller: key 'steps': must be a whole number (got 2.5)"},
      {"steps=0", "test controller: key 'steps': must be in [1, 100] (got 0)"},
      {"modes=5", "test controller: key 'modes': must be 3 or 7 (got 5)"},
      {"low=3", "test controller: key 'low': must be below high (got 3)"},
  };
  for (const auto& [text, message] : bad) {
    Params p;
    p.gain = 5;
    std::string error;
    EXPECT_FALSE(ParseControllerConfig(Table(), std::string("fraction=0.75 ") + text, &p, &error)) << text;
    EXPECT_EQ(error, message) << text;
    EXPECT_EQ(p.gain, 5) << "unchanged on failure: " << text;
    EXPECT_EQ(p.fraction, 0.5) << "unchanged on failure, the keys before the error too: " << text;
  }
  // the first error in the text's order wins, and a null error pointer is allowed
  Params p;
  std::string error;
  EXPECT_FALSE(ParseControllerConfig(Table(), "gian=1 gain=abc", &p, &error));
  EXPECT_THAT(error, HasSubstr("'gian'"));
  EXPECT_FALSE(ParseControllerConfig(Table(), "gain=abc gian=1", &p, &error));
  EXPECT_THAT(error, HasSubstr("'gain'"));
  EXPECT_FALSE(ParseControllerConfig(Table(), "gain=-1", &p, nullptr));
}

TEST(ControllerConfigParser, SetAndValidateCheckAsTheTextDoes) {
  Params p;
  std::string error;
  EXPECT_TRUE(SetControllerParameter(Table(), &p, "steps", 42, &error)) << error;
  EXPECT_EQ(p.steps, 42);
  EXPECT_TRUE(SetControllerParameter(Table(), &p, "on", 0, &error)) << error;
  EXPECT_FALSE(p.on);
  EXPECT_FALSE(SetControllerParameter(Table(), &p, "modes", 4, &error));
  EXPECT_EQ(error, "test controller: key 'modes': must be 3 or 7 (got 4)");
  EXPECT_EQ(p.modes, 3);
  EXPECT_FALSE(SetControllerParameter(Table(), &p, "nope", 1, nullptr));
  // a single key's value does not see the checks between keys; Validate does
  EXPECT_TRUE(SetControllerParameter(Table(), &p, "low", 5, &error)) << error;
  EXPECT_EQ(ValidateControllerParams(Table(), p), "test controller: key 'low': must be below high (got 5)");
  p = Params();
  p.fraction = std::nan("");
  EXPECT_EQ(ValidateControllerParams(Table(), p), "test controller: key 'fraction': must be a finite number (got nan)");
  EXPECT_EQ(ValidateControllerParams(Table(), Params()), "");
  // every row reads back the value it sets
  for (const ControllerKey<Params>& k : Keys()) {
    Params q;
    const double v = ControllerKeyValue(k, Params());
    EXPECT_TRUE(SetControllerParameter(Table(), &q, k.key, v, &error)) << k.key << ": " << error;
    EXPECT_EQ(ControllerKeyValue(k, q), v) << k.key;
  }
}

}  // namespace
}  // namespace pneumatic
