#include "reservoir.h"

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <map>
#include <sstream>

#include "config.h"
#include "roles.h"

namespace pneumatic {

const char kReservoirStateRole[] = "pressure";

namespace {

// one row of the reservoir's parameter table: documentation and checks in one place
struct ReservoirParam {
  const char* key;
  const char* unit;
  const char* default_value;  // nullptr: required
  double min, max;
  bool min_open, max_open;
  const char* meaning;
  double ReservoirConfig::*field;
};

const ReservoirParam kReservoirParams[] = {
    {"volume", "m^3", nullptr, 0, 10, true, false,
     "gas volume of the reservoir (tank, manifold and the lines to the valves); must exceed the largest total volume of "
     "the chambers it feeds",
     &ReservoirConfig::volume},
    {"line_conductance", "kg/(s Pa)", nullptr, 0, 1e-4, false, false,
     "sonic conductance C rho0 of the supply line from the compressor (p_supply of the fed cylinders) into the "
     "reservoir, ISO 6358 as paper 002 eq. 4; 0 = sealed (no refill)",
     &ReservoirConfig::line_conductance},
    {"line_critical_ratio", "", "0.433", 0, 1, false, true,
     "critical pressure ratio b of the supply line's ISO 6358 law (default: paper 002's valve value)",
     &ReservoirConfig::line_critical_ratio},
};

std::string Bound(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

std::string Valid(const ReservoirParam& p) {
  return std::string(p.min_open ? "(" : "[") + Bound(p.min) + ", " + Bound(p.max) + (p.max_open ? ")" : "]");
}

}  // namespace

const std::vector<ParameterDoc>& ReservoirParameters() {
  static const std::vector<ParameterDoc> docs = [] {
    std::vector<ParameterDoc> out;
    for (const ReservoirParam& p : kReservoirParams) {
      ParameterDoc doc{p.key, p.unit, p.default_value ? p.default_value : "required", Valid(p), "reservoir", p.meaning};
      doc.min = p.min, doc.max = p.max, doc.min_open = p.min_open, doc.max_open = p.max_open;
      out.push_back(doc);
    }
    return out;
  }();
  return docs;
}

std::optional<ReservoirConfig> ParseReservoirConfig(const std::string& name, const std::string& text,
                                                    std::string* error) {
  auto fail = [&](const std::string& key, const std::string& message) -> std::optional<ReservoirConfig> {
    *error = "reservoir '" + name + "': " + (key.empty() ? "" : "key '" + key + "': ") + message;
    return std::nullopt;
  };
  if (name.empty() || name.find_first_of(". \t,=") != std::string::npos) {
    return fail("", "a reservoir name cannot be empty or contain '.', ',', '=' or spaces (its actuator is <name>." +
                        std::string(kReservoirStateRole) + ")");
  }
  std::map<std::string, std::string> given;
  std::istringstream in(text);
  std::string token;
  while (in >> token) {
    size_t eq = token.find('=');
    if (eq == std::string::npos || eq == 0) return fail(token, "expected key=value");
    std::string key = token.substr(0, eq), value = token.substr(eq + 1);
    if (value.empty()) return fail(key, "missing value");
    bool known = false;
    for (const ReservoirParam& p : kReservoirParams) known |= key == p.key;
    if (!known) return fail(key, "unknown key (see plugin/README.md, 'Supply reservoirs')");
    if (!given.emplace(key, value).second) return fail(key, "given twice");
  }
  ReservoirConfig c;
  c.name = name;
  for (const ReservoirParam& p : kReservoirParams) {
    auto it = given.find(p.key);
    std::string value;
    if (it != given.end()) {
      value = it->second;
    } else if (p.default_value) {
      value = p.default_value;
    } else {
      return fail(p.key, "required for every reservoir");
    }
    const char* begin = value.c_str();
    char* end = nullptr;
    double v = std::strtod(begin, &end);
    if (end == begin || *end != '\0') return fail(p.key, "value '" + value + "' is not a number");
    if (!std::isfinite(v)) return fail(p.key, "value '" + value + "' is not finite");
    bool below = p.min_open ? v <= p.min : v < p.min;
    bool above = p.max_open ? v >= p.max : v > p.max;
    if (below || above) {
      return fail(p.key, "value " + value + " is out of range " + Valid(p) + (p.unit[0] ? std::string(" ") + p.unit : ""));
    }
    c.*p.field = v;
  }
  return c;
}

std::string FormatReservoirConfig(const ReservoirConfig& c) {
  std::string text;
  for (const ReservoirParam& p : kReservoirParams) {
    text += (text.empty() ? "" : " ") + std::string(p.key) + "=" + FormatNumber(c.*p.field);
  }
  return text;
}

int PackedReservoirSize() { return static_cast<int>(std::size(kReservoirParams)); }

void PackReservoirConfig(const ReservoirConfig& c, double* out) {
  for (const ReservoirParam& p : kReservoirParams) *out++ = c.*p.field;
}

std::optional<ReservoirConfig> UnpackReservoirConfig(const std::string& name, const double* values,
                                                     std::string* error) {
  ReservoirConfig c;
  for (const ReservoirParam& p : kReservoirParams) c.*p.field = *values++;
  return ParseReservoirConfig(name, FormatReservoirConfig(c), error);
}

std::optional<BoundReservoir> BindReservoir(const mjModel* m, ReservoirConfig config, std::string* error) {
  const RoleSpec* role = FindRole(RoleOwner::kReservoir, kReservoirStateRole);
  std::string actuator = config.name + "." + role->suffix;
  auto fail = [&](const std::string& message) -> std::optional<BoundReservoir> {
    *error = "reservoir '" + config.name + "': actuator '" + actuator + "': " + message;
    return std::nullopt;
  };
  int id = mj_name2id(m, mjOBJ_ACTUATOR, actuator.c_str());
  if (id < 0) {
    return fail(std::string("missing: ") + role->missing + " (role '" + role->suffix + "', required by " +
                role->required_by + ")");
  }
  if (std::string problem = StateActuatorProblem(m, id, *role); !problem.empty()) return fail(problem);
  // every other "<name>.*" actuator is a typo
  std::string prefix = config.name + ".";
  for (int other = 0; other < m->nu; ++other) {
    const char* other_name = mj_id2name(m, mjOBJ_ACTUATOR, other);
    if (other == id || !other_name || std::string(other_name).rfind(prefix, 0) != 0) continue;
    actuator = other_name;
    return fail(std::string("has no role in a reservoir (its one actuator is '") + config.name + "." + role->suffix + "')");
  }
  BoundReservoir r;
  r.config = std::move(config);
  r.actuator = id;
  return r;
}

double ReservoirPressureStep(const ReservoirModel& r, double p0, double drawn, double h) {
  const double k = r.gas_rt / r.volume;
  // a sealed reservoir: the mass balance alone, exactly
  if (r.line_conductance <= 0) return p0 - k * drawn;
  double slope = 0;
  double inflow = MassFlowAndSlope(r.line, r.line_conductance, r.p_source, p0, &slope);
  double rate = k * (inflow - drawn / h);  // dp/dt at p0
  double conductance = -slope;             // G = -dQ/dp >= 0
  // near the source pressure the law goes as sqrt(p_source - p): the chord from p_source to where
  // the step would take the pressure stands in for the slope (as the chamber step does)
  double travel = h * rate;
  if (std::fabs(r.p_source - p0) <= std::fabs(travel) || !std::isfinite(conductance)) {
    double dp = r.p_source - (p0 + travel);
    double smallest = 1e-9 * r.p_source;
    if (std::fabs(dp) < smallest) dp = smallest;
    conductance = MassFlow(r.line, r.line_conductance, r.p_source, r.p_source - dp) / dp;
  }
  // p0 + h phi1(x) rate, x = -k G h: the linear ODE dp/dt = rate - k G (p - p0) solved exactly
  double x = -k * conductance * h;
  double phi1 = std::fabs(x) < 1e-8 ? 1 + x / 2 : std::expm1(x) / x;
  return std::max(p0 + h * phi1 * rate, 0.0);
}

}  // namespace pneumatic
