// Room for effects (issue 12, item 5): the table of actuator roles (roles.h) that binding
// validates against, and a state shared by several cylinders, the supply reservoir
// (reservoir.h), stepped together with the chambers it feeds.
#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "reservoir.h"
#include "roles.h"
#include "test_util.h"

namespace pneumatic {
namespace {

using ::testing::HasSubstr;
using testing::LoadModelFromString;
using testing::MujocoTest;
using testing::PatternCommand;
using testing::ReadText;
using testing::SameBits;
using testing::ShippedModel;
using testing::State;

constexpr double kR = 287, kT = 296, kSupply = 6e5, kAtm = 1e5;
constexpr double kArea = 1.814e-4, kStroke = 0.1, kDead = 2e-6;

// N on/off cylinders like rig A (polytropic_index 1: isothermal chambers, as the reservoir), each
// on its own slide joint; `fed[i]`: cylinder i takes supply=tank; the reservoir's text is
// `reservoir` (none if empty). Pistons are held (1e12 kg) when `held`.
struct ModelSpec {
  int cylinders = 1;
  std::vector<bool> fed = {true};
  std::string reservoir = "volume=1e-4 line_conductance=0";
  std::string timestep = "0.0001";
  std::string step = "linearized";
  bool held = true;
  std::string extra_cylinder_keys;
  std::string extra_actuators;
};

std::string Xml(const ModelSpec& s) {
  std::string bodies, commands, chambers, texts;
  for (int i = 0; i < s.cylinders; ++i) {
    std::string c = "c" + std::to_string(i), x = "x" + std::to_string(i);
    bodies += "<body pos=\"0 " + std::to_string(i) + " 0\"><inertial pos=\"0 0 0\" mass=\"" +
              std::string(s.held ? "1e12" : "0.9") + "\" diaginertia=\"1e-4 1e-4 1e-4\"/><joint name=\"" + x +
              "\" type=\"slide\" axis=\"1 0 0\" limited=\"true\" range=\"-0.05 0.05\" damping=\"50\"/></body>\n";
    for (const char* u : {"u1", "u2", "u3", "u4"}) {
      commands += "<general name=\"" + c + "." + u + "\" joint=\"" + x + "\" gaintype=\"user\"/>\n";
    }
    chambers += "<general name=\"" + c + ".P\" joint=\"" + x + "\" dyntype=\"user\" gaintype=\"user\"/>\n";
    chambers += "<general name=\"" + c + ".N\" joint=\"" + x + "\" dyntype=\"user\" gaintype=\"user\"/>\n";
    texts += "<text name=\"pneumatic:" + c +
             "\" data=\"valve=onoff stroke=0.1 area=1.814e-4 dead_volume=2e-6 p_supply=6e5 p_exhaust=1e5 "
             "temperature=296 polytropic_index=1 sonic_conductance=3.4e-9 critical_ratio=0.433 step=" +
             s.step + (s.fed[static_cast<size_t>(i)] ? " supply=tank" : "") + " " + s.extra_cylinder_keys + "\"/>\n";
  }
  if (!s.reservoir.empty()) {
    chambers += "<general name=\"tank.pressure\" joint=\"x0\" dyntype=\"user\" gaintype=\"user\"/>\n";
    texts += "<text name=\"pneumatic_reservoir:tank\" data=\"" + s.reservoir + "\"/>\n";
  }
  return "<mujoco><size nuser_actuator=\"128\"/><option timestep=\"" + s.timestep +
         "\" integrator=\"Euler\" gravity=\"0 0 0\"/>\n<worldbody>\n" + bodies + "</worldbody>\n<actuator>\n" +
         commands + s.extra_actuators + chambers + "</actuator>\n<custom>\n" + texts + "</custom></mujoco>";
}

mjModel* Load(const std::string& xml, std::string* error) {
  mjModel* m = LoadModelFromString(xml, error);
  if (!m) return nullptr;
  if (!Attach(m, error)) {
    mj_deleteModel(m);
    return nullptr;
  }
  return m;
}

mjModel* LoadOrFail(const std::string& xml) {
  std::string error;
  mjModel* m = Load(xml, &error);
  EXPECT_NE(m, nullptr) << error;
  return m;
}

// the Attach error of a model that must not attach
std::string AttachError(const std::string& xml) {
  std::string error;
  mjModel* m = LoadModelFromString(xml, &error);
  if (!m) return "load failed: " + error;
  bool attached = Attach(m, &error);
  EXPECT_FALSE(IsAttached(m));
  mj_deleteModel(m);
  return attached ? "attached" : error;
}

// text without the <general .../> element of actuator `name`
std::string WithoutActuator(std::string xml, const std::string& name) {
  size_t at = xml.find("<general name=\"" + name + "\"");
  EXPECT_NE(at, std::string::npos) << name;
  if (at == std::string::npos) return xml;
  return xml.erase(at, xml.find("/>", at) + 2 - at);
}

double ChamberVolume(const mjModel* m, const mjData* d, const CylinderInfo& c, Chamber k) {
  double x = PistonPosition(m, d, c);
  return kDead + kArea * (kStroke / 2 + (k == Chamber::kP ? x : -x));
}

// ---------------------------------------------------------------------------------------------
// (a) the role table

TEST(RoleTable, EveryRowIsDocumented) {
  int count = 0;
  const RoleSpec* rows = RoleTable(&count);
  ASSERT_GT(count, 0);
  for (int i = 0; i < count; ++i) {
    const RoleSpec& r = rows[i];
    SCOPED_TRACE(r.suffix);
    EXPECT_GT(std::string(r.required_by).size(), 0u);
    EXPECT_GT(std::string(r.unit).size(), 0u);
    EXPECT_GT(std::string(r.meaning).size(), 0u);
    EXPECT_GT(std::string(r.missing).size(), 0u);
    EXPECT_EQ(FindRole(r.owner, r.suffix), &r) << "suffixes are unique per owner";
    // a state says what mj_resetData (act = 0) starts it at
    if (r.state != nullptr && (r.role == Role::kChamber || r.role == Role::kReservoir || r.role == Role::kState)) {
      EXPECT_GT(std::string(r.initial).size(), 0u);
    }
    EXPECT_FALSE(RoleKindText(r).empty());
  }
  EXPECT_NE(FindRole(RoleOwner::kReservoir, "pressure"), nullptr);
  EXPECT_EQ(FindRole(RoleOwner::kCylinder, "pressure"), nullptr);
}

// every actuator whose role a configuration requires, removed in turn: Attach names the actuator,
// its role and the keys that require it
TEST(RoleTable, MissingRequiredRoleIsNamedWithTheKeyThatRequiresIt) {
  struct Case {
    std::string name, xml, owner;
  };
  std::string friction = ReadText(ShippedModel("rig_onoff.xml"));
  friction = testing::ReplaceAll(friction, "damping=\"50\"", "damping=\"50\" frictionloss=\"20\"");
  friction = testing::ReplaceAll(friction, "critical_ratio=0.433\"", "critical_ratio=0.433 coulomb_friction=10\"");
  friction = testing::ReplaceAll(friction, "<general name=\"cyl.u1\"",
                                 "<general name=\"cyl.friction\" joint=\"x\" gaintype=\"user\" biastype=\"user\"/>\n"
                                 "    <general name=\"cyl.u1\"");
  std::vector<Case> cases;
  for (const char* file : testing::kShippedRigs) cases.push_back({file, ReadText(ShippedModel(file)), "cyl"});
  cases.push_back({"rig A with seal friction", friction, "cyl"});
  cases.push_back({"a reservoir", Xml(ModelSpec{}), ""});
  int checked = 0;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    mjModel* m = LoadOrFail(c.xml);
    ASSERT_NE(m, nullptr);
    std::vector<std::pair<std::string, const RoleSpec*>> required;  // actuator, row
    for (int id = 0; id < m->nu; ++id) {
      std::string actuator = mj_id2name(m, mjOBJ_ACTUATOR, id);
      std::string owner = actuator.substr(0, actuator.find('.')), suffix = actuator.substr(actuator.find('.') + 1);
      const RoleSpec* row = FindRole(owner == "tank" ? RoleOwner::kReservoir : RoleOwner::kCylinder, suffix);
      ASSERT_NE(row, nullptr) << actuator << " is in no row of the role table";
      required.push_back({actuator, row});
    }
    mj_deleteModel(m);
    for (const auto& [actuator, row] : required) {
      SCOPED_TRACE("without " + actuator);
      std::string error = AttachError(WithoutActuator(c.xml, actuator));
      EXPECT_THAT(error, HasSubstr("actuator '" + actuator + "'"));
      EXPECT_THAT(error, HasSubstr("missing"));
      EXPECT_THAT(error, HasSubstr("role '" + std::string(row->suffix) + "'"));
      EXPECT_THAT(error, HasSubstr(std::string("required by ") + row->required_by));
      EXPECT_THAT(error, HasSubstr(row->owner == RoleOwner::kReservoir ? "reservoir 'tank'" : "cylinder '"));
      ++checked;
    }
  }
  EXPECT_GE(checked, 20);
}

TEST(RoleTable, RoleNotUsedByTheConfigurationIsRefusedWithItsReason) {
  // rig C's valves are uP and uN: a "cyl.u" is the 5/3 valve's command
  std::string rig_c = ReadText(ShippedModel("rig_per_chamber.xml"));
  std::string with_u = testing::ReplaceAll(rig_c, "<general name=\"cyl.uP\"",
                                           "<general name=\"cyl.u\" joint=\"x\" gaintype=\"user\"/>\n"
                                           "    <general name=\"cyl.uP\"");
  std::string error = AttachError(with_u);
  EXPECT_THAT(error, HasSubstr("actuator 'cyl.u'"));
  EXPECT_THAT(error, HasSubstr("no role"));
  EXPECT_THAT(error, HasSubstr("valve=proportional_5_3"));
  // a reservoir state with no cylinder to feed
  ModelSpec unfed;
  unfed.fed = {false};
  error = AttachError(Xml(unfed));
  EXPECT_THAT(error, HasSubstr("reservoir 'tank'"));
  EXPECT_THAT(error, HasSubstr("feeds no cylinder"));
  EXPECT_THAT(error, HasSubstr("tank.pressure"));
  // a state actuator that could not hold a state
  ModelSpec plain;
  std::string xml = testing::ReplaceAll(Xml(plain), "name=\"tank.pressure\" joint=\"x0\" dyntype=\"user\"",
                                        "name=\"tank.pressure\" joint=\"x0\" dyntype=\"filter\"");
  error = AttachError(xml);
  EXPECT_THAT(error, HasSubstr("actuator 'tank.pressure'"));
  EXPECT_THAT(error, HasSubstr("dyntype=\"user\""));
}

TEST(Reservoir, ConfigurationErrorsNameReservoirCylinderAndKey) {
  struct Case {
    std::string name;
    ModelSpec spec;
    std::vector<std::string> says;
  };
  ModelSpec unknown;
  unknown.reservoir = "";
  ModelSpec small;
  small.reservoir = "volume=3e-5 line_conductance=0";  // the chambers hold 4.028e-5 m^3
  ModelSpec two_compressors;
  two_compressors.cylinders = 2;
  two_compressors.fed = {true, true};
  ModelSpec missing_key;
  missing_key.reservoir = "line_conductance=1e-8";
  ModelSpec bad_key;
  bad_key.reservoir = "volume=1e-3 line_conductance=1e-8 colume=2";
  const std::vector<Case> cases = {
      {"no such reservoir", unknown, {"cylinder 'c0'", "key 'supply'", "no reservoir 'tank'"}},
      {"too small", small, {"reservoir 'tank'", "key 'volume'", "must exceed", "4.028e-05"}},
      {"missing key", missing_key, {"reservoir 'tank'", "key 'volume'", "required"}},
      {"unknown key", bad_key, {"reservoir 'tank'", "key 'colume'", "unknown key"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    std::string error = AttachError(Xml(c.spec));
    for (const std::string& s : c.says) EXPECT_THAT(error, HasSubstr(s));
  }
  // cylinders sharing a reservoir share its compressor
  std::string xml = Xml(two_compressors);
  size_t second = xml.find("pneumatic:c1");
  xml.replace(xml.find("p_supply=6e5", second), 12, "p_supply=5e5");
  std::string error = AttachError(xml);
  EXPECT_THAT(error, HasSubstr("cylinder 'c1'"));
  EXPECT_THAT(error, HasSubstr("key 'p_supply'"));
  EXPECT_THAT(error, HasSubstr("reservoir 'tank'"));
  // every documented key, just outside its documented range
  int checked = 0;
  for (const ParameterDoc& doc : ReservoirParameters()) {
    EXPECT_EQ(doc.scope, "reservoir");
    for (double v : {doc.min_open ? doc.min : doc.min - 0.1 * std::max(1.0, std::fabs(doc.min)),
                     doc.max_open ? doc.max : doc.max + 0.1 * std::max(1.0, std::fabs(doc.max))}) {
      SCOPED_TRACE(doc.key + "=" + FormatNumber(v));
      ModelSpec s;
      s.reservoir = "volume=1e-3 line_conductance=1e-8 " + doc.key + "=" + FormatNumber(v);
      std::string text = s.reservoir;
      // the later value of a key given twice would be refused as such: give it once
      s.reservoir = doc.key == "volume"             ? "line_conductance=1e-8 volume=" + FormatNumber(v)
                    : doc.key == "line_conductance" ? "volume=1e-3 line_conductance=" + FormatNumber(v)
                                                    : text;
      error = AttachError(Xml(s));
      EXPECT_THAT(error, HasSubstr("reservoir 'tank': key '" + doc.key + "'"));
      EXPECT_THAT(error, HasSubstr("out of range " + doc.valid));
      ++checked;
    }
  }
  EXPECT_EQ(checked, 2 * static_cast<int>(ReservoirParameters().size()));
  // SetParameter checks the link as Attach does
  std::string rig_c = ReadText(ShippedModel("rig_per_chamber.xml"));
  mjModel* m = LoadOrFail(rig_c);
  ASSERT_NE(m, nullptr);
  EXPECT_FALSE(SetParameter(m, "cyl", "supply", std::string("tank"), &error));
  EXPECT_THAT(error, HasSubstr("no reservoir 'tank'"));
  mj_deleteModel(m);
}

// ---------------------------------------------------------------------------------------------
// (b) reservoir physics

struct StepCase {
  const char* step;
  const char* timestep;
};
void PrintTo(const StepCase& c, std::ostream* os) { *os << "step=" << c.step << " timestep=" << c.timestep; }
std::string StepName(const ::testing::TestParamInfo<StepCase>& info) {
  std::string h = info.param.timestep;
  return std::string(info.param.step) + "_" + (h == "0.0001" ? "100us" : h == "0.001" ? "1ms" : "20us");
}
class ReservoirSteps : public MujocoTest, public ::testing::WithParamInterface<StepCase> {};

// A sealed reservoir (line_conductance=0, V_r = 1e-4 m^3, at p_supply = 6 bar after reset) fills
// chamber P of each of `n` held cylinders (1 bar, V_P = 1.107e-5 m^3) through valve 1. With
// isothermal chambers (polytropic_index=1) and reservoir at one temperature, p V / (r T) is the
// gas mass: p_r V_r + sum p_P V_P must hold at every step, and the end state is the closed form
// p_f = (p_r0 V_r + n p_P0 V_P) / (V_r + n V_P).
TEST_P(ReservoirSteps, SealedReservoirFillingChambersConservesTheGas) {
  for (int n : {1, 2}) {
    SCOPED_TRACE(std::to_string(n) + " cylinders");
    ModelSpec spec;
    spec.cylinders = n;
    spec.fed.assign(n, true);
    spec.step = GetParam().step;
    spec.timestep = GetParam().timestep;
    mjModel* m = LoadOrFail(Xml(spec));
    ASSERT_NE(m, nullptr);
    mjData* d = mj_makeData(m);
    std::vector<CylinderInfo> cylinders = Cylinders(m);
    std::vector<ReservoirInfo> reservoirs = Reservoirs(m);
    ASSERT_EQ(reservoirs.size(), 1u);
    const ReservoirInfo& tank = reservoirs[0];
    EXPECT_EQ(tank.p_source, kSupply);
    EXPECT_EQ(tank.cylinders.size(), static_cast<size_t>(n));
    mj_forward(m, d);
    EXPECT_EQ(ReservoirPressure(m, d, tank), kSupply) << "mj_resetData starts a charged reservoir";
    auto gas = [&] {
      double sum = ReservoirPressure(m, d, tank) * 1e-4;
      for (const CylinderInfo& c : cylinders) {
        for (Chamber k : {Chamber::kP, Chamber::kN}) sum += ChamberPressure(m, d, c, k) * ChamberVolume(m, d, c, k);
      }
      return sum;
    };
    const double gas0 = gas();
    const double v_p = kDead + kArea * kStroke / 2;
    const double p_final = (kSupply * 1e-4 + n * kAtm * v_p) / (1e-4 + n * v_p);
    for (const CylinderInfo& c : cylinders) d->ctrl[c.command_actuators[0].second] = 1;  // u1: P to supply
    double worst = 0;
    while (d->time < 0.3) {
      mj_step(m, d);
      mj_forward(m, d);
      worst = std::max(worst, std::fabs(gas() / gas0 - 1));
    }
    EXPECT_LT(worst, 1e-10) << "p_r V_r + sum p V drifted";
    EXPECT_NEAR(ReservoirPressure(m, d, tank) / p_final, 1, 1e-6);
    for (const CylinderInfo& c : cylinders) {
      EXPECT_NEAR(ChamberPressure(m, d, c, Chamber::kP) / p_final, 1, 1e-6);
      EXPECT_NEAR(ChamberPressure(m, d, c, Chamber::kN), kAtm, 1e-3) << "chamber N is sealed";
    }
    mj_deleteData(d);
    mj_deleteModel(m);
  }
}

// ISO 6358 (as paper 002 eq. 4), written here independently: mass flow from p_u to p_d
double Iso6358(double c, double b, double p_u, double p_d) {
  double r = p_d / p_u;
  if (r <= b) return c * p_u;
  double s = (r - b) / (1 - b);
  return c * p_u * std::sqrt(std::max(0.0, 1 - s * s));
}

// A reservoir drawn down to 1.5 bar, valves closed, refills through its line (C = 1e-9 kg/(s Pa),
// b = 0.433, V = 1e-4 m^3): while choked (p < b p_supply = 2.598 bar) at exactly
// dp/dt = r T C p_supply / V = 5.097e5 Pa/s, then as a fine-step RK4 integration of
// dp/dt = (r T / V) Q_ISO6358(p_supply, p) says, never above p_supply.
TEST_P(ReservoirSteps, DrawnDownReservoirRefillsAtTheRateItsLineAllows) {
  ModelSpec spec;
  spec.reservoir = "volume=1e-4 line_conductance=1e-9 line_critical_ratio=0.433";
  spec.step = GetParam().step;
  spec.timestep = GetParam().timestep;
  mjModel* m = LoadOrFail(Xml(spec));
  ASSERT_NE(m, nullptr);
  mjData* d = mj_makeData(m);
  const ReservoirInfo tank = Reservoirs(m).at(0);
  const double p0 = 1.5e5, k = kR * kT / 1e-4, c = 1e-9, b = 0.433;
  // set through the cylinder it feeds (pneumatic.h SetSupplyPressure): the same state
  ASSERT_TRUE(SetSupplyPressure(m, d, Cylinders(m).at(0), p0));
  ASSERT_EQ(ReservoirPressure(m, d, tank), p0);
  const double choked_rate = k * c * kSupply;
  ASSERT_NEAR(choked_rate, 5.097e5, 1e2);
  // the choked phase
  while (d->time < 0.15 - 1e-9) mj_step(m, d);
  EXPECT_NEAR(ReservoirPressure(m, d, tank), p0 + choked_rate * d->time, 1e-9 * kSupply);
  // the subsonic phase, against the reference
  double p_ref = p0, t_ref = 0;
  auto rate = [&](double p) { return k * Iso6358(c, b, kSupply, p); };
  double worst = 0, highest = 0;
  for (double until : {0.3, 0.5, 0.8, 1.2}) {
    while (d->time < until - 1e-9) {
      mj_step(m, d);
      highest = std::max(highest, ReservoirPressure(m, d, tank));
    }
    const double dt = 1e-6;
    while (t_ref < d->time - 1e-12) {
      double s = std::min(dt, d->time - t_ref);
      double k1 = rate(p_ref), k2 = rate(p_ref + s / 2 * k1), k3 = rate(p_ref + s / 2 * k2), k4 = rate(p_ref + s * k3);
      p_ref += s / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
      t_ref += s;
    }
    worst = std::max(worst, std::fabs(ReservoirPressure(m, d, tank) - p_ref) / (kSupply - p0));
  }
  EXPECT_LT(worst, std::string(GetParam().timestep) == "0.001" ? 5e-3 : 1e-3);
  EXPECT_LE(highest, kSupply);
  EXPECT_GT(ReservoirPressure(m, d, tank), 5.9e5) << "refilled";
  mj_deleteData(d);
  mj_deleteModel(m);
}

// Two cylinders pushing at once from one reservoir make it sag more than one does (the other fed
// by the compressor directly)
TEST_P(ReservoirSteps, AReservoirSharedByTwoCylindersSagsMore) {
  double lowest[2] = {0, 0};
  for (int shared : {0, 1}) {
    ModelSpec spec;
    spec.cylinders = 2;
    spec.fed = {true, shared == 1};
    spec.held = false;
    spec.reservoir = "volume=2e-4 line_conductance=3e-9";
    spec.step = GetParam().step;
    spec.timestep = GetParam().timestep;
    mjModel* m = LoadOrFail(Xml(spec));
    ASSERT_NE(m, nullptr);
    mjData* d = mj_makeData(m);
    const ReservoirInfo tank = Reservoirs(m).at(0);
    EXPECT_EQ(tank.cylinders.size(), shared ? 2u : 1u);
    if (!shared) {
      const std::vector<mjtNum> act(d->act, d->act + m->na);
      EXPECT_FALSE(SetSupplyPressure(m, d, Cylinders(m).at(1), 5e5)) << "fed by the compressor: no state to set";
      EXPECT_EQ(std::vector<mjtNum>(d->act, d->act + m->na), act) << "nothing written";
      EXPECT_EQ(SupplyPressure(m, d, Cylinders(m).at(1)), kSupply);
    }
    lowest[shared] = kSupply;
    for (const CylinderInfo& c : Cylinders(m)) {
      d->ctrl[c.command_actuators[0].second] = 1;  // u1: P to supply
      d->ctrl[c.command_actuators[3].second] = 1;  // u4: N to exhaust
    }
    while (d->time < 0.2) {
      mj_step(m, d);
      lowest[shared] = std::min(lowest[shared], ReservoirPressure(m, d, tank));
    }
    mj_deleteData(d);
    mj_deleteModel(m);
  }
  EXPECT_LT(lowest[0], kSupply - 1e4) << "one cylinder draws the reservoir down";
  EXPECT_LT(lowest[1], lowest[0] - 1e4) << "two draw it down further";
}

INSTANTIATE_TEST_SUITE_P(Steps, ReservoirSteps,
                         ::testing::Values(StepCase{"linearized", "0.0001"}, StepCase{"linearized", "0.001"},
                                           StepCase{"exact", "0.0001"}, StepCase{"exact", "0.001"},
                                           StepCase{"explicit", "0.00002"}),
                         StepName);

// ---------------------------------------------------------------------------------------------
// (c) a model with a reservoir steps bit for bit alike across copies, reset and threads

ModelSpec Moving() {
  ModelSpec spec;
  spec.cylinders = 2;
  spec.fed = {true, true};
  spec.held = false;
  spec.reservoir = "volume=2e-4 line_conductance=3e-9";
  return spec;
}

void RunPatterns(const mjModel* m, mjData* d, int first, int steps) {
  std::vector<CylinderInfo> cylinders = Cylinders(m);
  for (int i = first; i < first + steps; ++i) {
    for (size_t c = 0; c < cylinders.size(); ++c) PatternCommand(cylinders[c], d, i + 37 * static_cast<int>(c));
    mj_step(m, d);
  }
}

std::vector<double> RunFromReset(const mjModel* m, int steps) {
  mjData* d = mj_makeData(m);
  RunPatterns(m, d, 0, steps);
  std::vector<double> s = State(m, d);
  mj_deleteData(d);
  return s;
}

// the same, on a thread of its own (a copied model decodes its parameters from its storage there)
std::vector<double> RunFromResetOnFreshThread(const mjModel* m, int steps) {
  std::vector<double> s;
  std::thread t([&] { s = RunFromReset(m, steps); });
  t.join();
  return s;
}

class ReservoirDeterminism : public MujocoTest {};

TEST_F(ReservoirDeterminism, CopiesResetAndThreadsStepAlike) {
  constexpr int kSteps = 3000;
  const std::string xml = Xml(Moving());
  mjModel* m = LoadOrFail(xml);
  ASSERT_NE(m, nullptr);
  const std::vector<double> reference = RunFromReset(m, kSteps);
  // the reservoir moved
  mjData* d = mj_makeData(m);
  RunPatterns(m, d, 0, kSteps / 2);
  const ReservoirInfo tank = Reservoirs(m).at(0);
  EXPECT_LT(ReservoirPressure(m, d, tank), kSupply - 1e3);
  // mj_copyData half way, both go on
  mjData* copy_data = mj_makeData(m);
  mj_copyData(copy_data, m, d);
  RunPatterns(m, d, kSteps / 2, kSteps / 2);
  RunPatterns(m, copy_data, kSteps / 2, kSteps / 2);
  EXPECT_TRUE(SameBits(State(m, d), reference));
  EXPECT_TRUE(SameBits(State(m, copy_data), reference));
  // reset, and again
  mj_resetData(m, d);
  EXPECT_EQ(ReservoirPressure(m, d, tank), kSupply);
  RunPatterns(m, d, 0, kSteps);
  EXPECT_TRUE(SameBits(State(m, d), reference));
  mj_deleteData(copy_data);
  mj_deleteData(d);
  // mj_copyModel: the copy steps alike, also once the original is freed, on a fresh thread
  mjModel* copy = mj_copyModel(nullptr, m);
  ASSERT_EQ(Reservoirs(copy).size(), 1u);
  EXPECT_EQ(Reservoirs(copy)[0].cylinders, (std::vector<std::string>{"c0", "c1"}));
  std::vector<double> on_threads[2];
  std::thread a([&] { on_threads[0] = RunFromReset(m, kSteps); });
  std::thread b([&] { on_threads[1] = RunFromReset(copy, kSteps); });
  a.join();
  b.join();
  EXPECT_TRUE(SameBits(on_threads[0], reference));
  EXPECT_TRUE(SameBits(on_threads[1], reference));
  mj_deleteModel(m);
  EXPECT_TRUE(SameBits(RunFromResetOnFreshThread(copy, kSteps), reference));
  // a freshly loaded model
  mjModel* again = LoadOrFail(xml);
  ASSERT_NE(again, nullptr);
  EXPECT_TRUE(SameBits(RunFromReset(again, kSteps), reference));
  mj_deleteModel(again);
  mj_deleteModel(copy);
}

TEST_F(ReservoirDeterminism, SetParameterKeepsTheSupplyLink) {
  constexpr int kSteps = 2000;
  mjModel* m = LoadOrFail(Xml(Moving()));
  ASSERT_NE(m, nullptr);
  std::string error;
  ASSERT_TRUE(SetParameter(m, "c1", "dead_volume", 3e-6, &error)) << error;
  std::optional<std::string> text = ConfigurationText(m, "c1", &error);
  ASSERT_TRUE(text) << error;
  EXPECT_THAT(*text, HasSubstr("supply=tank"));
  EXPECT_FALSE(GetParameter(m, "c1", "supply", &error));
  EXPECT_THAT(error, HasSubstr("'tank'"));
  ModelSpec written = Moving();
  std::string xml = Xml(written);
  size_t second = xml.find("pneumatic:c1");
  xml.replace(xml.find("dead_volume=2e-6", second), 16, "dead_volume=3e-6");
  mjModel* w = LoadOrFail(xml);
  ASSERT_NE(w, nullptr);
  EXPECT_TRUE(SameBits(RunFromReset(m, kSteps), RunFromReset(w, kSteps)));
  // and a copy of the changed model, decoded from its storage on a fresh thread
  mjModel* copy = mj_copyModel(nullptr, m);
  EXPECT_TRUE(SameBits(RunFromResetOnFreshThread(copy, kSteps), RunFromReset(w, kSteps)));
  // unlinking the last cylinder would leave the reservoir feeding nothing
  ASSERT_TRUE(SetParameter(m, "c1", "supply", std::string("none"), &error)) << error;
  EXPECT_EQ(Reservoirs(m).at(0).cylinders, std::vector<std::string>{"c0"});
  EXPECT_FALSE(SetParameter(m, "c0", "supply", std::string("none"), &error));
  EXPECT_THAT(error, HasSubstr("feeds no cylinder"));
  mj_deleteModel(copy);
  mj_deleteModel(w);
  mj_deleteModel(m);
}

// SetReservoirParameter: the model steps as one whose MJCF has the new values, a copy too; what it
// refuses names reservoir and key and leaves the model as it was.
TEST_F(ReservoirDeterminism, SetReservoirParameterStepsAsTheWrittenValue) {
  constexpr int kSteps = 2000;
  mjModel* m = LoadOrFail(Xml(Moving()));
  ASSERT_NE(m, nullptr);
  const std::vector<double> before = RunFromReset(m, kSteps);
  std::string error;
  ASSERT_TRUE(SetReservoirParameter(m, "tank", "volume", 3e-4, &error)) << error;
  ASSERT_TRUE(SetReservoirParameter(m, "tank", "line_conductance", 5e-9, &error)) << error;
  EXPECT_EQ(Reservoirs(m).at(0).volume, 3e-4);
  ModelSpec written = Moving();
  written.reservoir = "volume=3e-4 line_conductance=5e-9";
  mjModel* w = LoadOrFail(Xml(written));
  ASSERT_NE(w, nullptr);
  const std::vector<double> reference = RunFromReset(w, kSteps);
  EXPECT_TRUE(SameBits(RunFromReset(m, kSteps), reference));
  EXPECT_FALSE(SameBits(before, reference)) << "the new values change the motion";
  mjModel* copy = mj_copyModel(nullptr, m);
  EXPECT_TRUE(SameBits(RunFromResetOnFreshThread(copy, kSteps), reference));
  // refusals: the model keeps its values
  EXPECT_FALSE(SetReservoirParameter(m, "reservoir", "volume", 3e-4, &error));
  EXPECT_THAT(error, HasSubstr("no reservoir 'reservoir'"));
  EXPECT_FALSE(SetReservoirParameter(m, "tank", "colume", 3e-4, &error));
  EXPECT_THAT(error, HasSubstr("reservoir 'tank': unknown key 'colume'"));
  EXPECT_FALSE(SetReservoirParameter(m, "tank", "line_conductance", -1, &error));
  EXPECT_THAT(error, HasSubstr("reservoir 'tank': key 'line_conductance'"));
  EXPECT_FALSE(SetReservoirParameter(m, "tank", "volume", 1e-7, &error));
  EXPECT_THAT(error, HasSubstr("reservoir 'tank': key 'volume'"));
  EXPECT_THAT(error, HasSubstr("must exceed"));
  EXPECT_TRUE(SameBits(RunFromReset(m, kSteps), reference));
  mj_deleteModel(copy);
  mj_deleteModel(w);
  mj_deleteModel(m);
}

}  // namespace
}  // namespace pneumatic
