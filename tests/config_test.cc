// Every kind of bad cylinder configuration fails at Attach with a message that
// names the cylinder and the offending key or actuator, never crashes, and
// leaves the model unattached; valid models attach with the expected signals.
//
// Each case is a small rig built from a template (a slide joint "x" like rig A,
// plus a few spare joints, a site and a tendon to point actuators at), a
// configuration given as key=value pairs, and the actuator lines.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "pneumatic/pneumatic.h"
#include "test_util.h"

namespace pneumatic::testing {
namespace {

using ::testing::HasSubstr;

// ---------------------------------------------------------------------------------------------
// model template

constexpr char kTemplate[] = R"(
<mujoco model="config_test">
  <size nuser_actuator="128"/>
  <option timestep="0.00025" integrator="$INTEGRATOR" gravity="0 0 0"/>
  <worldbody>
    <body name="piston">
      <inertial pos="0 0 0" mass="0.9" diaginertia="1e-4 1e-4 1e-4"/>
      <joint name="x" type="slide" axis="1 0 0" limited="true" range="-0.05 0.05" damping="50"
             frictionloss="$FRICTIONLOSS"/>
      <site name="tip" pos="0.1 0 0"/>
    </body>
    <body name="other" pos="0 1 0">
      <inertial pos="0 0 0" mass="0.9" diaginertia="1e-4 1e-4 1e-4"/>
      <joint name="y" type="slide" axis="1 0 0" limited="true" range="-0.05 0.05"/>
    </body>
    <body name="ball_body" pos="0 2 0">
      <inertial pos="0 0 0" mass="0.9" diaginertia="1e-4 1e-4 1e-4"/>
      <joint name="ball" type="ball"/>
    </body>
    <body name="free_body" pos="0 3 0">
      <inertial pos="0 0 0" mass="0.9" diaginertia="1e-4 1e-4 1e-4"/>
      <freejoint name="free"/>
    </body>
  </worldbody>
  <tendon>
    <fixed name="tx"><joint joint="x" coef="1"/></fixed>
  </tendon>
  <actuator>$ACTUATORS
  </actuator>
  <custom>$CUSTOM
  </custom>
</mujoco>
)";

void ReplaceAll(std::string* s, const std::string& from, const std::string& to) {
  for (size_t at = s->find(from); at != std::string::npos; at = s->find(from, at + to.size())) {
    s->replace(at, from.size(), to);
  }
}

// a chamber: its act is the gauge pressure, its gain the piston area
const std::string kChamberAttrs = R"(dyntype="user" gaintype="user")";
// a valve command whose act holds the valve state (spool position, armature)
const std::string kStatefulValve = R"(dyntype="user" gaintype="user")";

// one <general> actuator "cyl.<role>"; attrs default to a stateless, forceless valve command
std::string Actuator(const std::string& role, const std::string& attrs = R"(gaintype="user")",
                     const std::string& target = R"(joint="x")") {
  return "\n    <general name=\"cyl." + role + "\" " + target + " " + attrs + "/>";
}
std::string Chamber(const std::string& role, const std::string& attrs = kChamberAttrs,
                    const std::string& target = R"(joint="x")") {
  return Actuator(role, attrs, target);
}
// both chambers last: MuJoCo 2.2 wants stateless actuators before stateful ones
std::string Chambers() { return Chamber("P") + Chamber("N"); }
const std::string kFriction = Actuator("friction", R"(gaintype="user" biastype="user")");

std::string OnOffValves(const std::string& attrs = R"(gaintype="user")") {
  return Actuator("u1", attrs) + Actuator("u2", attrs) + Actuator("u3", attrs) + Actuator("u4", attrs);
}

// a rig: configuration as ordered key=value pairs (plus raw text), actuators, model options
struct Rig {
  std::vector<std::pair<std::string, std::string>> config;
  std::string raw;  // appended verbatim after the pairs
  std::string actuators;
  std::string text_name = "pneumatic:cyl";
  std::string integrator = "Euler";
  std::string frictionloss = "0";

  // key=value replaced in place, or appended
  Rig Set(const std::string& key, const std::string& value) const {
    Rig r = *this;
    for (auto& [k, v] : r.config) {
      if (k == key) {
        v = value;
        return r;
      }
    }
    r.config.emplace_back(key, value);
    return r;
  }
  Rig Drop(const std::string& key) const {
    Rig r = *this;
    r.config.erase(std::remove_if(r.config.begin(), r.config.end(), [&](const auto& kv) { return kv.first == key; }),
                   r.config.end());
    return r;
  }
  Rig Raw(const std::string& text) const {
    Rig r = *this;
    r.raw += " " + text;
    return r;
  }
  Rig Actuators(const std::string& lines) const {
    Rig r = *this;
    r.actuators = lines;
    return r;
  }
  Rig Integrator(const std::string& name) const {
    Rig r = *this;
    r.integrator = name;
    return r;
  }
  Rig Frictionloss(const std::string& value) const {
    Rig r = *this;
    r.frictionloss = value;
    return r;
  }
  Rig TextName(const std::string& name) const {
    Rig r = *this;
    r.text_name = name;
    return r;
  }

  std::string Text() const {
    std::string text;
    for (const auto& [k, v] : config) text += (text.empty() ? "" : " ") + k + "=" + v;
    return text + raw;
  }
  std::string Xml() const {
    std::string xml = kTemplate;
    ReplaceAll(&xml, "$INTEGRATOR", integrator);
    ReplaceAll(&xml, "$FRICTIONLOSS", frictionloss);
    ReplaceAll(&xml, "$ACTUATORS", actuators);
    ReplaceAll(&xml, "$CUSTOM",
               text_name.empty() ? "" : "\n    <text name=\"" + text_name + "\" data=\"" + Text() + "\"/>");
    return xml;
  }
};

// rig A: four on/off valves, commanded one by one
Rig OnOff() {
  Rig r;
  r.config = {{"valve", "onoff"},          {"stroke", "0.1"},     {"area", "1.814e-4"},
              {"dead_volume", "2.0e-6"},   {"p_supply", "3.0e5"}, {"p_exhaust", "1.0e5"}};
  r.actuators = OnOffValves() + Chambers();
  return r;
}
// rig A commanded by one PWM duty, averaged model
Rig Pwm() { return OnOff().Set("input", "pwm").Actuators(Actuator("duty") + Chambers()); }
// rig A with thin-plate ports
Rig OnOffThinPlate() { return OnOff().Set("flow", "thin_plate").Set("port_area", "1e-6"); }
// rig B: one 5/3 proportional valve with a spool lag (the default spool_time_constant)
Rig Proportional() {
  Rig r;
  r.config = {{"valve", "proportional_5_3"}, {"stroke", "0.5"},     {"area", "10.6e-4"},
              {"dead_volume", "1.0e-5"},     {"p_supply", "5.0e5"}, {"p_exhaust", "1.0e5"}};
  r.actuators = Actuator("u", kStatefulValve) + Chambers();
  return r;
}
// rig C: one proportional valve per chamber
Rig PerChamber() {
  Rig r;
  r.config = {{"valve", "proportional_per_chamber"}, {"stroke", "0.1"},     {"area", "7.854e-5"},
              {"dead_volume", "1.0e-6"},             {"p_supply", "6.2e5"}, {"p_exhaust", "1.0e5"}};
  r.actuators = Actuator("uP") + Actuator("uN") + Chambers();
  return r;
}
// rig C with the identified chamber model of paper 000 eq. 10
Rig Identified() {
  return PerChamber()
      .Set("pressure_model", "identified")
      .Set("c1", "5")
      .Set("c2", "1")
      .Set("c3", "0")
      .Set("c4", "0")
      .Set("c5", "0")
      .Set("c6", "1")
      .Set("c7", "1")
      .Set("c8", "0")
      .Set("c9", "0.1");
}
// rig A with seal friction (Coulomb level 10 N under a 20 N frictionloss)
Rig WithFriction() {
  return OnOff().Set("coulomb_friction", "10").Frictionloss("20").Actuators(kFriction + OnOffValves() + Chambers());
}
// rig A with the energy equation in its chambers (gas temperature states "cyl.TP", "cyl.TN")
Rig WithEnergy() {
  return OnOff()
      .Set("thermal_model", "energy")
      .Set("wall_heat_conductance", "0.1")
      .Actuators(OnOffValves() + Chambers() + Actuator("TP", kStatefulValve) + Actuator("TN", kStatefulValve));
}
// rig A with a line between each valve and its chamber (line pressure states "cyl.LP", "cyl.LN")
Rig WithLine() {
  return OnOff()
      .Set("line_volume", "1e-6")
      .Set("line_conductance", "1e-9")
      .Actuators(OnOffValves() + Chambers() + Actuator("LP", kStatefulValve) + Actuator("LN", kStatefulValve));
}
// rig A with LuGre seal friction (its bristle state "cyl.z" after the chambers)
Rig WithLuGre() {
  return OnOff()
      .Set("coulomb_friction", "10")
      .Set("friction_model", "lugre")
      .Set("static_friction", "20")
      .Actuators(kFriction + OnOffValves() + Chambers() + Actuator("z", kStatefulValve));
}

// ---------------------------------------------------------------------------------------------
// expectations

class ConfigTest : public MujocoTest {
 protected:
  // compiles rig (the compiler must accept it: it is the plugin under test, not MuJoCo), attaches,
  // expects failure with every substring in the error and nothing attached
  void ExpectRejected(const Rig& rig, const std::vector<std::string>& substrings) {
    SCOPED_TRACE("config: " + rig.Text() + "\nactuators:" + rig.actuators);
    std::string error;
    mjModel* m = LoadModelFromString(rig.Xml(), &error);
    ASSERT_NE(m, nullptr) << "MuJoCo rejected the test model: " << error << "\n" << rig.Xml();
    error.clear();
    bool attached = Attach(m, &error);
    EXPECT_FALSE(attached) << "accepted a bad configuration";
    EXPECT_FALSE(IsAttached(m));
    for (const std::string& s : substrings) EXPECT_THAT(error, HasSubstr(s));
    Detach(m);
    mj_deleteModel(m);
  }
  // a configuration error: "cylinder 'cyl': key '<key>': ...<what>..."
  void ExpectKeyRejected(const Rig& rig, const std::string& key, const std::string& what) {
    ExpectRejected(rig, {"cylinder 'cyl'", "key '" + key + "'", what});
  }
  // an actuator error: "cylinder 'cyl': actuator '<actuator>': ...<what>..."
  void ExpectActuatorRejected(const Rig& rig, const std::string& actuator, const std::string& what) {
    ExpectRejected(rig, {"cylinder 'cyl'", "actuator '" + actuator + "'", what});
  }
  void ExpectAttaches(const Rig& rig) {
    SCOPED_TRACE("config: " + rig.Text());
    AttachedModel model;
    ASSERT_TRUE(model.Load(rig.Xml())) << model.error();
    EXPECT_TRUE(IsAttached(model.m()));
    ASSERT_EQ(Cylinders(model.m()).size(), 1u);
    EXPECT_EQ(model.cylinder().name, "cyl");
  }
};

// ---------------------------------------------------------------------------------------------
// the base rigs themselves are valid (every rejection below changes one thing)

TEST_F(ConfigTest, BaseRigsAttach) {
  for (const Rig& rig : {OnOff(), Pwm(), OnOffThinPlate(), Proportional(), PerChamber(), Identified(), WithFriction()}) {
    ExpectAttaches(rig);
  }
}

TEST_F(ConfigTest, AcceptsValveWithZeroFixedGainAndStatelessSpool) {
  ExpectAttaches(OnOff().Actuators(OnOffValves(R"(gainprm="0")") + Chambers()));
  ExpectAttaches(Proportional().Set("spool_time_constant", "0").Actuators(Actuator("u") + Chambers()));
}

TEST_F(ConfigTest, AcceptsTendonTransmissionAndImplicitIntegrator) {
  const std::string tendon = R"(tendon="tx")";
  ExpectAttaches(OnOff().Actuators(OnOffValves() + Chamber("P", kChamberAttrs, tendon) +
                                   Chamber("N", kChamberAttrs, tendon)));
  ExpectAttaches(OnOff().Integrator("implicit"));
}

// ---------------------------------------------------------------------------------------------
// configuration text

TEST_F(ConfigTest, RejectsUnknownKey) {
  ExpectKeyRejected(OnOff().Set("bogus", "1"), "bogus", "unknown key");
  ExpectKeyRejected(OnOff().Set("P.bogus", "1"), "P.bogus", "unknown key");
  ExpectKeyRejected(OnOff().Set("Stroke", "1"), "Stroke", "unknown key");  // keys are case sensitive
}

TEST_F(ConfigTest, RejectsKeyGivenTwice) {
  ExpectKeyRejected(OnOff().Raw("stroke=0.2"), "stroke", "given twice");
  ExpectKeyRejected(OnOff().Raw("area=2e-4"), "area", "given twice");
  ExpectKeyRejected(OnOff().Raw("P.area=1e-4 P.area=2e-4"), "P.area", "given twice");
  ExpectKeyRejected(OnOff().Raw("valve=onoff"), "valve", "given twice");
}

TEST_F(ConfigTest, RejectsTokenWithoutEquals) {
  ExpectKeyRejected(OnOff().Drop("stroke").Raw("stroke"), "stroke", "expected key=value");
  ExpectKeyRejected(OnOff().Raw("=0.1"), "=0.1", "expected key=value");
}

TEST_F(ConfigTest, RejectsKeyWithEmptyValue) {
  ExpectKeyRejected(OnOff().Set("stroke", ""), "stroke", "missing value");
  ExpectKeyRejected(OnOff().Set("valve", ""), "valve", "missing value");
}

TEST_F(ConfigTest, RejectsNonNumericValue) {
  for (const char* value : {"1.2.3", "abc", "1e", "0.1m", "0,1"}) {
    ExpectKeyRejected(OnOff().Set("stroke", value), "stroke", "not a number");
  }
}

TEST_F(ConfigTest, RejectsNonFiniteValue) {
  for (const char* value : {"nan", "inf", "-inf", "NaN", "infinity", "1e999"}) {
    ExpectKeyRejected(OnOff().Set("x_mid", value), "x_mid", "not finite");
  }
}

TEST_F(ConfigTest, RejectsMissingRequiredKey) {
  ExpectKeyRejected(OnOff().Drop("stroke"), "stroke", "required");
  ExpectKeyRejected(OnOff().Drop("area"), "P.area", "required");
  ExpectKeyRejected(OnOff().Drop("dead_volume"), "P.dead_volume", "required");
  ExpectKeyRejected(OnOff().Drop("area").Set("P.area", "1e-4"), "N.area", "required");
}

TEST_F(ConfigTest, RejectsValueJustOutsideRange) {
  struct Case {
    Rig rig;
    std::string key;
  };
  const std::vector<Case> cases = {
      {OnOff().Set("stroke", "0"), "stroke"},
      {OnOff().Set("stroke", "-1"), "stroke"},
      {OnOff().Set("area", "0"), "P.area"},
      {OnOff().Set("N.area", "-1e-4"), "N.area"},
      {OnOff().Set("dead_volume", "-1e-6"), "P.dead_volume"},
      {OnOff().Set("polytropic_index", "0.9"), "P.polytropic_index"},
      {OnOff().Set("polytropic_index", "2.1"), "P.polytropic_index"},
      {OnOff().Set("work_factor", "0"), "P.work_factor"},
      {OnOff().Set("critical_ratio", "1"), "P.critical_ratio"},
      {OnOff().Set("critical_ratio", "-0.1"), "P.critical_ratio"},
      {OnOff().Set("sonic_conductance", "0"), "P.sonic_conductance"},
      {OnOff().Set("delay_open", "-1"), "delay_open"},
      {OnOff().Set("delay_close", "2"), "delay_close"},
      {OnOff().Set("step_tolerance", "0"), "step_tolerance"},
      {OnOff().Set("step_tolerance", "0.2"), "step_tolerance"},
      {OnOff().Set("temperature", "0"), "temperature"},
      {OnOff().Set("p_exhaust", "0"), "p_exhaust"},
      {OnOff().Set("p_atm", "-1"), "p_atm"},
      // no cylinder has these: 1e-300 m^3 of dead volume, a 1000 bar supply, a 1e-5 mm stroke, a 1 m^2 piston
      {OnOff().Set("dead_volume", "1e-300"), "P.dead_volume"},
      {OnOff().Set("p_supply", "1e8"), "p_supply"},
      {OnOff().Set("stroke", "1e-8"), "stroke"},
      {OnOff().Set("area", "1"), "P.area"},
      {Proportional().Set("deadband", "1"), "deadband"},
      {Proportional().Set("spool_time_constant", "-0.001"), "spool_time_constant"},
      {Proportional().Set("discharge_coefficient", "1.1"), "P.discharge_coefficient"},
      {Proportional().Set("heat_capacity_ratio", "1"), "heat_capacity_ratio"},
      {PerChamber().Set("compressibility", "0"), "compressibility"},
      {Identified().Set("c3", "-1"), "P.c3"},
      {Identified().Set("c8", "1"), "P.c8"},
      {Identified().Set("N.c8", "-1"), "N.c8"},
      {Identified().Set("c7", "0"), "P.c7"},
      {Identified().Set("c9", "0"), "P.c9"},
  };
  for (const Case& c : cases) ExpectKeyRejected(c.rig, c.key, "out of range");
}

// numeric bound of a documented range "[a, b)" etc.: (value, open)
struct Bound {
  double value;
  bool open;
};
bool ParseRange(const std::string& valid, Bound* low, Bound* high) {
  if (valid.empty() || (valid.front() != '[' && valid.front() != '(')) return false;
  size_t comma = valid.find(',');
  if (comma == std::string::npos) return false;
  low->open = valid.front() == '(';
  high->open = valid.back() == ')';
  low->value = std::strtod(valid.substr(1, comma - 1).c_str(), nullptr);
  high->value = std::strtod(valid.substr(comma + 1, valid.size() - comma - 2).c_str(), nullptr);
  return true;
}

// a rig where a key of the given scope ("cylinder, valve=onoff", ...) applies
bool RigFor(const std::string& scope, Rig* rig) {
  size_t comma = scope.find(", ");
  std::string applies = comma == std::string::npos ? "" : scope.substr(comma + 2);
  if (applies.empty() || applies == "valve=onoff" || applies == "flow=iso6358" ||
      applies == "flow=iso6358 or flow=sanville") *rig = OnOff();
  else if (applies == "valve=onoff with input=pwm") *rig = Pwm();
  else if (applies == "valve=proportional_5_3" || applies == "flow=sanville or flow=thin_plate") *rig = Proportional();
  else if (applies == "valve=proportional_per_chamber" || applies == "flow=thin_plate") *rig = PerChamber();
  else if (applies == "valve=proportional_5_3 or valve=proportional_per_chamber") *rig = Proportional();
  else if (applies == "valve=onoff with flow=sanville or thin_plate") *rig = OnOffThinPlate();
  else if (applies == "pressure_model=identified") *rig = Identified();
  else if (applies == "cylinders with coulomb_friction") *rig = WithFriction();
  else if (applies == "friction_model=lugre") *rig = WithLuGre();
  else if (applies == "thermal_model=energy") *rig = WithEnergy();
  else if (applies == "line_volume > 0") *rig = WithLine();
  else if (applies == "flow=sanville or flow=thin_plate, or thermal_model=energy") *rig = Proportional();
  else return false;
  return true;
}

std::string Format(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.6g", v);
  return buffer;
}

TEST_F(ConfigTest, RejectsEveryNumericKeyJustOutsideItsDocumentedRange) {
  int checked = 0;
  for (const ParameterDoc& p : Parameters()) {
    Bound low{}, high{};
    if (!ParseRange(p.valid, &low, &high)) continue;  // a choice
    Rig base;
    if (!RigFor(p.scope, &base)) {
      ADD_FAILURE() << "no rig for scope '" << p.scope << "' of key " << p.key;
      continue;
    }
    bool chamber = p.scope.rfind("chamber", 0) == 0;
    std::vector<double> outside;
    double margin_low = 0.1 * std::max(1.0, std::fabs(low.value));
    double margin_high = 0.1 * std::max(1.0, std::fabs(high.value));
    if (std::isfinite(low.value)) outside.push_back(low.open ? low.value : low.value - margin_low);
    if (std::isfinite(high.value)) outside.push_back(high.open ? high.value : high.value + margin_high);
    for (double v : outside) {
      // a plain chamber key is reported for chamber P; a prefixed one for its own chamber
      ExpectKeyRejected(base.Set(p.key, Format(v)), chamber ? "P." + p.key : p.key, "out of range " + p.valid);
      if (chamber) ExpectKeyRejected(base.Set("N." + p.key, Format(v)), "N." + p.key, "out of range");
      ++checked;
    }
  }
  EXPECT_GT(checked, 40);
}

TEST_F(ConfigTest, RejectsSupplyNotAboveExhaust) {
  ExpectKeyRejected(OnOff().Set("p_supply", "1.0e5"), "p_supply", "p_exhaust");
  ExpectKeyRejected(OnOff().Set("p_supply", "0.9e5"), "p_supply", "must exceed p_exhaust");
  ExpectKeyRejected(OnOff().Drop("p_supply").Drop("p_exhaust").Set("p_exhaust", "7e5"), "p_supply", "p_exhaust");
}

TEST_F(ConfigTest, RejectsIdentifiedVolumeScaleThatVanishesWithinTheStroke) {
  // stroke 0.1: 1 + c6 x must stay > 0 for |x| <= 0.05, i.e. |c6| < 20
  for (const char* c6 : {"20", "-20", "30"}) ExpectKeyRejected(Identified().Set("c6", c6), "P.c6", "1 + c6 x");
  ExpectKeyRejected(Identified().Set("N.c6", "-25"), "N.c6", "1 + c6 x");
  ExpectAttaches(Identified().Set("c6", "19.9"));
}

TEST_F(ConfigTest, RejectsCriticalRatioWithThinPlateFlow) {
  // critical_ratio is b of iso6358 and P_cr of sanville; the thin-plate law has none to set
  ExpectKeyRejected(OnOffThinPlate().Set("critical_ratio", "0.3"), "P.critical_ratio",
                    "applies only to flow=iso6358 or flow=sanville");
  ExpectKeyRejected(OnOffThinPlate().Set("N.critical_ratio", "0.3"), "N.critical_ratio", "applies only to");
  ExpectKeyRejected(PerChamber().Set("critical_ratio", "0.2"), "P.critical_ratio", "applies only to");
  // per chamber: P on thin_plate refuses it, N on iso6358 takes it
  Rig mixed = OnOff().Set("P.flow", "thin_plate").Set("P.port_area", "1e-6");
  ExpectKeyRejected(mixed.Set("P.critical_ratio", "0.3"), "P.critical_ratio", "applies only to");
  ExpectAttaches(mixed.Set("N.critical_ratio", "0.3"));
  // the laws it applies to take it
  ExpectAttaches(OnOff().Set("critical_ratio", "0.3"));
  ExpectAttaches(Proportional().Set("critical_ratio", "0.3"));
}

TEST_F(ConfigTest, RejectsHugeGasConstant) {
  // finite, but far outside [50, 5000] J/(kg K) (r T would overflow the flow laws' constants)
  ExpectKeyRejected(OnOff().Set("gas_constant", "1e308"), "gas_constant", "out of range [50, 5000]");
}

TEST_F(ConfigTest, RejectsPwmFrequencyTooHighForTheTimestep) {
  // the template's step is 0.25 ms: 36 kHz puts 9 carrier periods in a step (more than 8), 30 kHz 7.5
  ExpectKeyRejected(Pwm().Set("pwm_frequency", "36000"), "pwm_frequency", "carrier periods");
  ExpectAttaches(Pwm().Set("pwm_frequency", "30000"));
}

// ---------------------------------------------------------------------------------------------
// enumerations

TEST_F(ConfigTest, RejectsBadEnumerationValue) {
  ExpectKeyRejected(OnOff().Set("valve", "solenoid"), "valve", "not one of: onoff proportional_5_3");
  ExpectKeyRejected(OnOff().Set("valve", "ONOFF"), "valve", "not one of");
  ExpectKeyRejected(OnOff().Set("flow", "laminar"), "P.flow", "not one of: iso6358 sanville thin_plate");
  ExpectKeyRejected(OnOff().Set("N.flow", "laminar"), "N.flow", "not one of");
  ExpectKeyRejected(OnOff().Set("input", "duty"), "input", "not one of: valves pwm");
  ExpectKeyRejected(OnOff().Set("pressure_model", "ideal"), "P.pressure_model", "not one of: physical identified");
  ExpectKeyRejected(OnOff().Set("step", "rk4"), "step", "not one of: linearized exact explicit");
}

TEST_F(ConfigTest, RejectsMissingValve) {
  ExpectKeyRejected(OnOff().Drop("valve"), "valve", "required");
  Rig empty = OnOff();
  empty.config.clear();
  ExpectKeyRejected(empty.Raw(" "), "valve", "required");
}

// ---------------------------------------------------------------------------------------------
// keys in the wrong place or for another configuration

TEST_F(ConfigTest, RejectsChamberPrefixOnCylinderKey) {
  ExpectKeyRejected(OnOff().Drop("stroke").Set("P.stroke", "0.1"), "P.stroke", "cylinder parameter");
  ExpectKeyRejected(OnOff().Set("N.valve", "onoff"), "N.valve", "takes no P./N. prefix");
}

TEST_F(ConfigTest, RejectsKeyThatDoesNotApplyToTheConfiguration) {
  struct Case {
    Rig rig;
    std::string key;
    std::string applies;
  };
  const std::vector<Case> cases = {
      {OnOff().Set("spool_gain", "2.5e-4"), "spool_gain", "valve=proportional_5_3"},
      {OnOff().Set("deadband", "0.1"), "deadband", "valve=proportional_5_3"},
      {OnOff().Set("area_gain", "2e-6"), "P.area_gain", "valve=proportional_per_chamber"},
      {OnOff().Set("pwm_frequency", "100"), "pwm_frequency", "valve=onoff with input=pwm"},
      {OnOff().Set("heat_capacity_ratio", "1.4"), "heat_capacity_ratio", "flow=sanville or flow=thin_plate"},
      {OnOff().Set("stribeck_velocity", "0.01"), "stribeck_velocity", "cylinders with coulomb_friction"},
      {OnOff().Set("c1", "5"), "P.c1", "pressure_model=identified"},
      {OnOffThinPlate().Set("sonic_conductance", "3.4e-9"), "P.sonic_conductance", "flow=iso6358"},
      {OnOff().Set("flow", "sanville").Set("port_area", "1e-6").Set("sonic_conductance", "3.4e-9"),
       "P.sonic_conductance", "flow=iso6358"},
      {OnOff().Set("port_area", "1e-6"), "P.port_area", "valve=onoff with flow=sanville or thin_plate"},
      {OnOff().Set("compressibility", "0.99"), "compressibility", "flow=thin_plate"},
      {Proportional().Set("delay_open", "1e-3"), "delay_open", "valve=onoff"},
      {Proportional().Set("port_area", "1e-6"), "P.port_area", "valve=onoff"},
      {PerChamber().Set("spool_gain", "2.5e-4"), "spool_gain", "valve=proportional_5_3"},
      {PerChamber().Set("c1", "5"), "P.c1", "pressure_model=identified"},
  };
  for (const Case& c : cases) ExpectKeyRejected(c.rig, c.key, "applies only to " + c.applies);
}

TEST_F(ConfigTest, RejectsMissingPortAreaForOnOffAreaLaw) {
  ExpectKeyRejected(OnOff().Set("flow", "thin_plate"), "P.port_area", "required");
  ExpectKeyRejected(OnOff().Set("N.flow", "sanville"), "N.port_area", "required");
}

TEST_F(ConfigTest, RejectsIso6358WithProportionalValve) {
  ExpectKeyRejected(Proportional().Set("flow", "iso6358"), "P.flow", "iso6358");
  ExpectKeyRejected(PerChamber().Set("N.flow", "iso6358"), "N.flow", "proportional valves take");
}

TEST_F(ConfigTest, RejectsIdentifiedModelWithOnOffValves) {
  Rig rig = Identified();
  rig.config[0] = {"valve", "onoff"};
  rig.actuators = OnOff().actuators;
  ExpectKeyRejected(rig, "P.pressure_model", "proportional valve");
}

// Without the c's the user is told to add c1..c9, then (after adding them) that the identified
// model cannot be used at all: the message should name the real conflict first.
TEST_F(ConfigTest, RejectsIdentifiedModelWithOnOffValvesBeforeAskingForItsParameters) {
  ExpectKeyRejected(OnOff().Set("pressure_model", "identified"), "P.pressure_model", "proportional valve");
}

TEST_F(ConfigTest, RejectsInputForProportionalValve) {
  // input (valves/pwm) applies to valve=onoff only; the table says giving it elsewhere is an error
  ExpectKeyRejected(Proportional().Set("input", "pwm"), "input", "valve=onoff");
  ExpectKeyRejected(PerChamber().Set("input", "valves"), "input", "valve=onoff");
}

TEST_F(ConfigTest, RejectsValveDelaysWithAveragedPwm) {
  ExpectKeyRejected(Pwm().Set("delay_open", "1.3e-3"), "delay_open", "pwm_frequency > 0");
  // only delay_close is given: the message must name it, not delay_open
  ExpectKeyRejected(Pwm().Set("delay_close", "2e-4"), "delay_close", "pwm_frequency > 0");
}

// ---------------------------------------------------------------------------------------------
// chamber actuators

TEST_F(ConfigTest, RejectsMissingChamberActuator) {
  ExpectActuatorRejected(OnOff().Actuators(OnOffValves() + Chamber("N")), "cyl.P", "missing");
  ExpectActuatorRejected(OnOff().Actuators(OnOffValves() + Chamber("P")), "cyl.N", "missing");
}

TEST_F(ConfigTest, RejectsChamberWithoutUserDynamics) {
  ExpectActuatorRejected(OnOff().Actuators(OnOffValves() + Chamber("P", R"(gaintype="user")") + Chamber("N")),
                         "cyl.P", "dyntype=\"user\"");
  ExpectActuatorRejected(
      OnOff().Actuators(OnOffValves() + Chamber("P") + Chamber("N", R"(dyntype="filter" gaintype="user")")),
      "cyl.N", "dyntype=\"user\"");
}

TEST_F(ConfigTest, RejectsChamberWithoutUserGain) {
  ExpectActuatorRejected(OnOff().Actuators(OnOffValves() + Chamber("P", R"(dyntype="user")") + Chamber("N")),
                         "cyl.P", "gaintype=\"user\"");
}

TEST_F(ConfigTest, RejectsChamberWithBias) {
  ExpectActuatorRejected(
      OnOff().Actuators(OnOffValves() + Chamber("P") +
                        Chamber("N", R"(dyntype="user" gaintype="user" biastype="affine" biasprm="0 1 0")")),
      "cyl.N", "biastype=\"none\"");
  ExpectActuatorRejected(
      OnOff().Actuators(OnOffValves() + Chamber("P", R"(dyntype="user" gaintype="user" biastype="user")") +
                        Chamber("N")),
      "cyl.P", "biastype");
}

// MuJoCo clamps a limited act after every step: with actrange="0 1" chamber P's gauge pressure
// could never exceed 1 Pa (an open supply valve leaves it at 1 Pa and the piston without force)
TEST_F(ConfigTest, RejectsChamberWithActivationLimits) {
  ExpectActuatorRejected(
      OnOff().Actuators(OnOffValves() + Chamber("P", R"(dyntype="user" gaintype="user" actlimited="true" actrange="0 1")") +
                        Chamber("N")),
      "cyl.P", "act");
}

TEST_F(ConfigTest, RejectsChambersOnDifferentJoints) {
  ExpectActuatorRejected(
      OnOff().Actuators(OnOffValves() + Chamber("P") + Chamber("N", kChamberAttrs, R"(joint="y")")), "cyl.N",
      "same transmission");
  ExpectActuatorRejected(
      OnOff().Actuators(OnOffValves() + Chamber("P") + Chamber("N", kChamberAttrs, R"(tendon="tx")")), "cyl.N",
      "same transmission");
}

TEST_F(ConfigTest, RejectsChambersWithDifferentGear) {
  ExpectActuatorRejected(
      OnOff().Actuators(OnOffValves() + Chamber("P") + Chamber("N", R"(dyntype="user" gaintype="user" gear="2")")),
      "cyl.N", "gear");
}

TEST_F(ConfigTest, RejectsBallOrFreeJointTransmission) {
  for (const char* joint : {"ball", "free"}) {
    std::string target = std::string("joint=\"") + joint + "\"";
    ExpectActuatorRejected(
        OnOff().Actuators(OnOffValves() + Chamber("P", kChamberAttrs, target) + Chamber("N", kChamberAttrs, target)),
        "cyl.P", std::string("joint '") + joint + "' is a ball or free joint");
  }
}

TEST_F(ConfigTest, RejectsSiteTransmission) {
  const std::string site = R"(site="tip")";
  ExpectActuatorRejected(
      OnOff().Actuators(OnOffValves() + Chamber("P", kChamberAttrs, site) + Chamber("N", kChamberAttrs, site)),
      "cyl.P", "site transmissions have no stroke");
}

TEST_F(ConfigTest, RejectsBodyTransmission) {
  const std::string body = R"(body="piston")";
  ExpectActuatorRejected(
      OnOff().Actuators(OnOffValves() + Chamber("P", kChamberAttrs, body) + Chamber("N", kChamberAttrs, body)),
      "cyl.P", "slide or hinge joint");
}

// a zero gear makes the chambers' force and the piston position identically zero: the cylinder
// neither moves nor pushes, whatever its pressures
TEST_F(ConfigTest, RejectsZeroGear) {
  const std::string zero = R"(dyntype="user" gaintype="user" gear="0")";
  ExpectActuatorRejected(OnOff().Actuators(OnOffValves() + Chamber("P", zero) + Chamber("N", zero)), "cyl.P", "gear");
}

// ---------------------------------------------------------------------------------------------
// valve command actuators

TEST_F(ConfigTest, RejectsMissingCommandActuator) {
  ExpectActuatorRejected(
      OnOff().Actuators(Actuator("u1") + Actuator("u2") + Actuator("u4") + Chambers()), "cyl.u3", "missing");
  ExpectActuatorRejected(Pwm().Actuators(Chambers()), "cyl.duty", "missing");
  ExpectActuatorRejected(Proportional().Actuators(Chambers()), "cyl.u", "missing");
  ExpectActuatorRejected(PerChamber().Actuators(Actuator("uP") + Chambers()), "cyl.uN", "missing");
}

TEST_F(ConfigTest, RejectsValveActuatorWithForce) {
  // MJCF <general> defaults to gaintype fixed with gainprm 1: ctrl would push the piston
  ExpectActuatorRejected(
      OnOff().Actuators(Actuator("u1", "") + Actuator("u2") + Actuator("u3") + Actuator("u4") + Chambers()),
      "cyl.u1", "applies no force");
  ExpectActuatorRejected(
      OnOff().Actuators(Actuator("u1") + Actuator("u2", R"(gainprm="0.5")") + Actuator("u3") + Actuator("u4") +
                        Chambers()),
      "cyl.u2", "applies no force");
  ExpectActuatorRejected(Proportional().Actuators(Actuator("u", R"(dyntype="user" gaintype="affine")") + Chambers()),
                         "cyl.u", "applies no force");
}

TEST_F(ConfigTest, RejectsValveActuatorWithBias) {
  ExpectActuatorRejected(
      OnOff().Actuators(Actuator("u1") + Actuator("u2") + Actuator("u3", R"(gaintype="user" biastype="user")") +
                        Actuator("u4") + Chambers()),
      "cyl.u3", "biastype=\"none\"");
  ExpectActuatorRejected(
      PerChamber().Actuators(Actuator("uP", R"(gainprm="0" biastype="affine" biasprm="1 0 0")") + Actuator("uN") +
                             Chambers()),
      "cyl.uP", "applies no force");
}

TEST_F(ConfigTest, RejectsStatefulValveWithoutUserDynamics) {
  // the default spool_time_constant 4.2 ms gives the spool a state
  ExpectActuatorRejected(Proportional().Actuators(Actuator("u") + Chambers()), "cyl.u", "spool position");
  ExpectActuatorRejected(Proportional().Actuators(Actuator("u", R"(dyntype="filter" gaintype="user")") + Chambers()),
                         "cyl.u", "dyntype=\"user\"");
  ExpectActuatorRejected(OnOff().Set("delay_open", "1.3e-3"), "cyl.u1", "delay_open/delay_close > 0");
  ExpectActuatorRejected(OnOff().Set("delay_close", "2e-4"), "cyl.u1", "valve armature");
}

TEST_F(ConfigTest, RejectsStatelessValveWithUserDynamics) {
  ExpectActuatorRejected(Proportional().Set("spool_time_constant", "0"), "cyl.u", "dyntype=\"none\"");
  ExpectActuatorRejected(OnOff().Actuators(Actuator("u2") + Actuator("u3") + Actuator("u4") +
                                           Actuator("u1", kStatefulValve) + Chambers()),
                         "cyl.u1", "no state");
  ExpectActuatorRejected(PerChamber().Actuators(Actuator("uP") + Actuator("uN", kStatefulValve) + Chambers()),
                         "cyl.uN", "dyntype=\"none\"");
}

TEST_F(ConfigTest, RejectsDelayedPwmWithoutValveStates) {
  // switched PWM with delays keeps each valve's armature in u1..u4
  Rig rig = Pwm().Set("pwm_frequency", "100").Set("delay_open", "1.3e-3");
  ExpectAttaches(rig.Actuators(Actuator("duty") + OnOffValves(kStatefulValve) + Chambers()));
  ExpectActuatorRejected(rig, "cyl.u1", "missing");
  ExpectActuatorRejected(rig.Actuators(Actuator("duty") + OnOffValves() + Chambers()), "cyl.u1", "dyntype=\"user\"");
}

TEST_F(ConfigTest, RejectsActuatorWithNoRole) {
  ExpectActuatorRejected(OnOff().Actuators(OnOffValves() + Actuator("u5") + Chambers()), "cyl.u5", "no role");
  ExpectActuatorRejected(Proportional().Actuators(Actuator("spool") + Actuator("u", kStatefulValve) + Chambers()),
                         "cyl.spool", "no role");
  // the commands of another valve arrangement
  ExpectActuatorRejected(Pwm().Actuators(Actuator("duty") + Actuator("u1") + Chambers()), "cyl.u1", "no role");
  ExpectActuatorRejected(OnOff().Actuators(OnOffValves() + Actuator("u") + Chambers()), "cyl.u", "no role");
}

// ---------------------------------------------------------------------------------------------
// seal friction

TEST_F(ConfigTest, RejectsCoulombFrictionWithoutFrictionActuator) {
  ExpectActuatorRejected(WithFriction().Actuators(OnOffValves() + Chambers()), "cyl.friction", "missing");
}

TEST_F(ConfigTest, RejectsFrictionActuatorWithoutCoulombFriction) {
  ExpectActuatorRejected(OnOff().Actuators(kFriction + OnOffValves() + Chambers()), "cyl.friction",
                         "coulomb_friction is not set");
}

TEST_F(ConfigTest, RejectsCoulombFrictionAboveFrictionloss) {
  ExpectKeyRejected(WithFriction().Set("coulomb_friction", "30"), "coulomb_friction", "exceeds the static friction");
  ExpectKeyRejected(WithFriction().Frictionloss("0"), "coulomb_friction", "frictionloss");
}

TEST_F(ConfigTest, RejectsFrictionActuatorOfWrongType) {
  ExpectActuatorRejected(WithFriction().Actuators(Actuator("friction") + OnOffValves() + Chambers()),
                         "cyl.friction", "biastype=\"user\"");
  ExpectActuatorRejected(
      WithFriction().Actuators(Actuator("friction", R"(biastype="user")") + OnOffValves() + Chambers()),
      "cyl.friction", "gaintype=\"user\"");
  ExpectActuatorRejected(
      WithFriction().Actuators(Actuator("friction", R"(gaintype="user" biastype="user")", R"(joint="y")") +
                               OnOffValves() + Chambers()),
      "cyl.friction", "same transmission");
}

// ---------------------------------------------------------------------------------------------
// model level

TEST_F(ConfigTest, RejectsRk4Integrator) {
  ExpectRejected(OnOff().Integrator("RK4"), {"RK4"});
}

TEST_F(ConfigTest, RejectsEmptyCylinderName) {
  ExpectRejected(OnOff().TextName("pneumatic:"), {"'pneumatic:'", "missing the cylinder name"});
}

TEST_F(ConfigTest, RejectsNullModel) {
  std::string error;
  EXPECT_FALSE(Attach(nullptr, &error));
  EXPECT_THAT(error, HasSubstr("null"));
  EXPECT_FALSE(IsAttached(nullptr));
}

TEST_F(ConfigTest, AttachesModelWithoutPneumaticText) {
  // neither the cylinder-looking actuators nor RK4 matter without a "pneumatic:" element: Attach
  // succeeds and stores nothing, so the model stays an ordinary one
  for (const Rig& rig : {OnOff().TextName(""), OnOff().TextName("other:cyl"), OnOff().TextName("").Integrator("RK4")}) {
    AttachedModel model;
    ASSERT_TRUE(model.Load(rig.Xml())) << model.error();
    EXPECT_FALSE(IsAttached(model.m()));
    EXPECT_TRUE(Cylinders(model.m()).empty());
  }
}

TEST_F(ConfigTest, FailedAttachLeavesOtherModelsAttached) {
  AttachedModel good;
  ASSERT_TRUE(good.Load(OnOff().Xml())) << good.error();
  mjfAct gain = mjcb_act_gain;
  ExpectRejected(OnOff().Set("bogus", "1"), {"bogus"});
  EXPECT_TRUE(IsAttached(good.m()));
  EXPECT_EQ(Cylinders(good.m()).size(), 1u);
  EXPECT_EQ(mjcb_act_gain, gain);
}

TEST_F(ConfigTest, AttachesTwoCylinders) {
  std::string xml = OnOff().Xml();
  // a second cylinder "left" on joint y next to "cyl" on joint x
  std::string left = R"(
    <general name="left.u1" joint="y" gaintype="user"/>
    <general name="left.u2" joint="y" gaintype="user"/>
    <general name="left.u3" joint="y" gaintype="user"/>
    <general name="left.u4" joint="y" gaintype="user"/>)";
  ReplaceAll(&xml, "<actuator>", "<actuator>" + left);
  ReplaceAll(&xml, R"(<general name="cyl.N" joint="x" dyntype="user" gaintype="user"/>)",
             R"(<general name="cyl.N" joint="x" dyntype="user" gaintype="user"/>
    <general name="left.P" joint="y" dyntype="user" gaintype="user"/>
    <general name="left.N" joint="y" dyntype="user" gaintype="user"/>)");
  ReplaceAll(&xml, "<custom>", "<custom>\n    <text name=\"pneumatic:left\" data=\"" + OnOff().Text() + "\"/>");
  AttachedModel model;
  ASSERT_TRUE(model.Load(xml)) << model.error();
  std::vector<CylinderInfo> cylinders = Cylinders(model.m());
  ASSERT_EQ(cylinders.size(), 2u);
  EXPECT_NE(cylinders[0].name, cylinders[1].name);
  for (const CylinderInfo& c : cylinders) EXPECT_TRUE(c.name == "cyl" || c.name == "left") << c.name;
}

// a gain callback installed before Attach keeps serving the user actuators that are not pneumatic
std::vector<int> gain_calls;
mjtNum TestGain(const mjModel*, const mjData*, int id) {
  gain_calls.push_back(id);
  return 3.0;
}

TEST_F(ConfigTest, LeavesTheGainCallbackToNonPneumaticActuators) {
  // chamber gains are fixed in the model (+A_P, -A_N), so the extension never takes mjcb_act_gain:
  // a callback installed before serves the model's other user-gain actuators, and only them
  const mjfAct original = mjcb_act_gain;
  mjcb_act_gain = TestGain;
  gain_calls.clear();
  {
    // "motor" belongs to no cylinder
    Rig rig = OnOff().Actuators(R"(
    <general name="motor" joint="y" gaintype="user"/>)" + OnOffValves() + Chambers());
    AttachedModel model;
    ASSERT_TRUE(model.Load(rig.Xml())) << model.error();
    EXPECT_EQ(mjcb_act_gain, TestGain);
    gain_calls.clear();  // the compiler's own forward pass ran before Attach
    int motor = model.actuator("motor");
    ASSERT_GE(motor, 0);
    model.d()->ctrl[motor] = 2.0;
    mj_forward(model.m(), model.d());
    EXPECT_DOUBLE_EQ(model.d()->actuator_force[motor], 6.0);  // gain 3 from TestGain times ctrl 2
    ASSERT_FALSE(gain_calls.empty());
    for (int id : gain_calls) EXPECT_EQ(id, motor) << "a pneumatic actuator was forwarded to the previous callback";
    // the chambers' fixed gains are their areas (rig A: 1.814e-4 m^2 on both sides)
    EXPECT_EQ(model.m()->actuator_gaintype[model.actuator("cyl.P")], mjGAIN_FIXED);
    EXPECT_DOUBLE_EQ(model.m()->actuator_gainprm[mjNGAIN * model.actuator("cyl.P")], 1.814e-4);
    EXPECT_DOUBLE_EQ(model.m()->actuator_gainprm[mjNGAIN * model.actuator("cyl.N")], -1.814e-4);
  }
  EXPECT_EQ(mjcb_act_gain, TestGain);
  mjcb_act_gain = original;
}

// "cyl.a" is a legal cylinder name next to "cyl": the actuators "cyl.a.*" belong to cylinder
// "cyl.a", not to "cyl" (which today rejects them as "has no role in this cylinder")
TEST_F(ConfigTest, RejectsCylinderNameWithADot) {
  std::string xml = OnOff().Xml();
  ReplaceAll(&xml, "<actuator>", R"(<actuator>
    <general name="cyl.a.u1" joint="y" gaintype="user"/>
    <general name="cyl.a.u2" joint="y" gaintype="user"/>
    <general name="cyl.a.u3" joint="y" gaintype="user"/>
    <general name="cyl.a.u4" joint="y" gaintype="user"/>)");
  ReplaceAll(&xml, "</actuator>", R"(
    <general name="cyl.a.P" joint="y" dyntype="user" gaintype="user"/>
    <general name="cyl.a.N" joint="y" dyntype="user" gaintype="user"/>
  </actuator>)");
  ReplaceAll(&xml, "<custom>", "<custom>\n    <text name=\"pneumatic:cyl.a\" data=\"" + OnOff().Text() + "\"/>");
  // "cyl.a.u1" would be both cylinder cyl's role "a.u1" and cylinder cyl.a's "u1": dots are refused
  AttachedModel model;
  EXPECT_FALSE(model.Load(xml));
  EXPECT_THAT(model.error(), HasSubstr("cylinder 'cyl.a': a cylinder name cannot contain '.'"));
}

// ---------------------------------------------------------------------------------------------
// shipped models

TEST_F(ConfigTest, ShippedModelsAttachWithTheirCommandSignals) {
  const std::vector<std::pair<std::string, std::vector<std::string>>> models = {
      {"rig_onoff.xml", {"u1", "u2", "u3", "u4"}},
      {"rig_proportional.xml", {"u"}},
      {"rig_proportional_full.xml", {"u"}},
      {"rig_per_chamber.xml", {"uP", "uN"}},
  };
  for (const auto& [file, signals] : models) {
    SCOPED_TRACE(file);
    AttachedModel model;
    ASSERT_TRUE(model.Load(ShippedModel(file), true)) << model.error();
    ASSERT_EQ(Cylinders(model.m()).size(), 1u);
    CylinderInfo c = model.cylinder();
    EXPECT_EQ(c.name, "cyl");
    EXPECT_EQ(c.chamber_actuator[0], model.actuator("cyl.P"));
    EXPECT_EQ(c.chamber_actuator[1], model.actuator("cyl.N"));
    std::vector<std::string> names;
    for (const auto& [signal, id] : c.command_actuators) {
      names.push_back(signal);
      EXPECT_EQ(id, model.actuator("cyl." + signal)) << signal;
    }
    EXPECT_EQ(names, signals);
  }
}

}  // namespace
}  // namespace pneumatic::testing
