#include "diagnosis/candidates.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "model_loading.h"

namespace pneumatic::diagnosis {
namespace {

// a value as MJCF text (std::to_string's %f would write a dead volume of 4e-7 m^3 as 0.000000)
std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.6g", value);
  return text;
}

std::string KeyUnit(const std::string& key) {
  std::string base = key.size() > 2 && key[1] == '.' ? key.substr(2) : key;
  for (const ParameterDoc& doc : Parameters()) {
    if (doc.key == base) return doc.unit;
  }
  return "";
}

double Parameter(const mjModel* m, const std::string& cylinder, const std::string& key, double fallback) {
  std::string ignored;
  return GetParameter(m, cylinder, key, &ignored).value_or(fallback);
}

std::string Choice(const mjModel* m, const std::string& cylinder, const std::string& key) {
  std::string ignored;
  return GetChoice(m, cylinder, key, &ignored).value_or("");
}

// a key of the cylinder's "pneumatic:" text, fitted
EffectParameter KeyParameter(const std::string& cylinder, const std::string& key, double initial, double lower, double upper,
                             double scale, bool logarithmic = false) {
  EffectParameter p;
  p.logarithmic = logarithmic;
  p.name = cylinder + ":" + key;
  p.unit = KeyUnit(key);
  p.initial = initial, p.lower = lower, p.upper = upper, p.scale = scale;
  p.apply = [cylinder, key](mjModel* m, SignalModel*, double value) {
    std::string error;
    return SetParameter(m, cylinder, key, value, &error) ? std::string() : error;
  };
  return p;
}

// p, whose value also has the prediction estimate the model's unmeasured states over the log's
// history (SignalModel::history_estimate) instead of from each window's warm-up alone
void EstimatedOverTheHistory(EffectParameter* p) {
  p->apply = [set = p->apply](mjModel* model, SignalModel* signals, double value) {
    signals->history_estimate = true;
    return set(model, signals, value);
  };
}

// The laminar leak conductance (kg/(s Pa)) that passes an orifice's flow per m^2 of its area at a
// choked flow from the supply to the exhaust: G = C1 p_s / (sqrt(T) (p_s - p_e)), with paper 001 eq.
// 2's C1 = sqrt(gamma/r (2/(gamma+1))^((gamma+1)/(gamma-1))) for the cylinder's gas: the scale that
// puts leakage's laminar and orifice forms on the same range
double LaminarConductancePerArea(const mjModel* m, const CylinderSeries& cyl) {
  const std::string& n = cyl.info.name;
  const double gamma = Parameter(m, n, "heat_capacity_ratio", 1.4), r = Parameter(m, n, "gas_constant", 287);
  const double c1 = std::sqrt(gamma / r * std::pow(2 / (gamma + 1), (gamma + 1) / (gamma - 1)));
  return c1 * cyl.info.p_supply / (std::sqrt(Parameter(m, n, "temperature", 293.15)) * (cyl.info.p_supply - cyl.info.p_exhaust));
}

// leakage's orifice areas (m^2) across the piston and from each chamber to the atmosphere, from
// 1e-9 m^2 (a leak far below any valve's, about 0.03 mm across) on a log scale, or the model's own
std::vector<EffectParameter> OrificeLeakAreas(const mjModel* m, const CylinderSeries& cyl) {
  const std::string& n = cyl.info.name;
  std::vector<EffectParameter> areas;
  for (const char* key : {"piston_leak_area", "P.atmosphere_leak_area", "N.atmosphere_leak_area"}) {
    areas.push_back(KeyParameter(n, key, std::max(Parameter(m, n, key, 0), 1e-9), 1e-12, 1e-5, 1e-9, true));
  }
  return areas;
}

// leakage's laminar conductances (kg/(s Pa)) along the same paths, on the orifice areas' range
// converted (LaminarConductancePerArea)
std::vector<EffectParameter> LaminarLeakConductances(const mjModel* m, const CylinderSeries& cyl) {
  const std::string& n = cyl.info.name;
  const double per_area = LaminarConductancePerArea(m, cyl);
  std::vector<EffectParameter> conductances;
  for (const char* key : {"piston_leak_conductance", "P.atmosphere_leak_conductance", "N.atmosphere_leak_conductance"}) {
    conductances.push_back(KeyParameter(n, key, std::max(Parameter(m, n, key, 0), 1e-9 * per_area), 1e-12 * per_area,
                                        1e-5 * per_area, 1e-9 * per_area, true));
  }
  return conductances;
}

// the largest force (N or N m) the cylinder's chambers can apply: a scale for friction
double MaxForce(const mjModel* m, const CylinderSeries& c) {
  const double area = Parameter(m, c.info.name, "P.area", 1e-4);
  return area * (c.info.p_supply - c.info.p_atm);
}

// the largest volume of a cylinder's two chambers together (m^3): both dead volumes and both areas
// over the stroke, the volume a reservoir must exceed to feed it (plugin/README.md)
double ChamberVolumes(const mjModel* m, const CylinderSeries& c) {
  const std::string& n = c.info.name;
  return Parameter(m, n, "P.dead_volume", 0) + Parameter(m, n, "N.dead_volume", 0) +
         (Parameter(m, n, "P.area", 0) + Parameter(m, n, "N.area", 0)) * c.stroke;
}

// the reservoir of the supply_drop candidate's tank form
constexpr char kSupplyTank[] = "supply_tank";
// the reservoirs of its logged form, one per cylinder: "logged_supply_<cylinder>"
constexpr char kLoggedSupply[] = "logged_supply";

std::string Replace(const std::string& text, size_t at, size_t length, const std::string& with) {
  return text.substr(0, at) + with + text.substr(at + length);
}

// Adds to `edit` what gives the cylinder its command delay line (DelayLineStates) with `key`
// (spool_dead_time or line_delay) at `initial` seconds, unless the model has the line already: its
// delay spool_dead_time + line_delay is not 0. The valve must be a proportional one.
void AddDelayLine(const mjModel* m, const std::string& cylinder, const std::string& key, const std::string& initial,
                  ModelEdit* edit) {
  if (Parameter(m, cylinder, "spool_dead_time", 0) + Parameter(m, cylinder, "line_delay", 0) != 0) return;
  const std::vector<std::string> states = DelayLineStates(Choice(m, cylinder, "valve"));
  edit->state_actuators.insert(edit->state_actuators.end(), states.begin(), states.end());
  edit->keys.push_back({key, initial});
}

bool ProportionalValve(const mjModel* m, const std::string& cylinder) {
  return !DelayLineStates(Choice(m, cylinder, "valve")).empty();
}

}  // namespace

std::vector<std::string> DelayLineStates(const std::string& valve) {
  if (valve == "proportional_5_3") return {"d1", "d2"};
  if (valve == "proportional_per_chamber") return {"dP1", "dP2", "dN1", "dN2"};
  return {};
}

std::string RefreshMassConstants(mjModel* m) {
  mjData* d = mj_makeData(m);
  if (!d) return "mj_makeData failed";
  mj_setConst(m, d);
  mj_deleteData(d);
  return "";
}

const std::vector<std::string>& EffectNames() {
  static const std::vector<std::string> names = {"valve_delay",  "valve_deadband", "friction", "leakage",
                                                 "heat_transfer", "supply_drop",   "line_dynamics", "payload",
                                                 "sensor_bias",  "none"};
  return names;
}

ModelPtr LoadEditedModel(const std::string& path, const std::vector<ModelEdit>& edits, std::string* error) {
  std::ifstream file(path, std::ios::binary);
  std::stringstream buffer;
  buffer << file.rdbuf();
  if (!file) {
    *error = path + ": cannot read the model";
    return ModelPtr(nullptr, mj_deleteModel);
  }
  std::string xml = buffer.str();
  for (const ModelEdit& e : edits) {
    // keys: appended to the data attribute of <text name="pneumatic:CYL" data="...">
    const std::string name = "\"pneumatic:" + e.cylinder + "\"";
    const size_t at = xml.find(name);
    const size_t open = at == std::string::npos ? at : xml.rfind('<', at);
    const size_t close = open == std::string::npos ? open : xml.find('>', at);
    const size_t data = close == std::string::npos ? close : xml.find("data=\"", open);
    if (data == std::string::npos || data > close) {
      *error = path + ": no <text name=\"pneumatic:" + e.cylinder + "\" data=\"...\"> element to edit (the diagnosis edits the model's own file, not its includes)";
      return ModelPtr(nullptr, mj_deleteModel);
    }
    const size_t end = xml.find('"', data + 6);
    // a reservoir that feeds several cylinders is added with the first edit that names it
    const bool new_reservoir =
        !e.reservoir.empty() && xml.find("\"pneumatic_reservoir:" + e.reservoir + "\"") == std::string::npos;
    std::string added;
    for (const auto& [key, value] : e.keys) added += " " + key + "=" + value;
    if (!e.reservoir.empty()) added += " supply=" + e.reservoir;
    xml = Replace(xml, end, 0, added);
    // state actuators: on the chamber P actuator's transmission, after every other actuator
    // (MuJoCo 2.2 wants stateless actuators first)
    for (const std::string& suffix : e.stateful_commands) {
      const size_t name_at = xml.find("\"" + e.cylinder + "." + suffix + "\"");
      const size_t element = name_at == std::string::npos ? name_at : xml.rfind('<', name_at);
      const size_t element_end = element == std::string::npos ? element : xml.find('>', name_at);
      if (element == std::string::npos || xml.substr(element, element_end - element).find("dyntype") != std::string::npos) {
        *error = path + ": cannot give actuator '" + e.cylinder + "." + suffix + "' a state (not found, or it has a dyntype)";
        return ModelPtr(nullptr, mj_deleteModel);
      }
      const size_t after_tag = xml.find_first_of(" \t\n", element);
      xml = Replace(xml, after_tag, 0, " dyntype=\"user\"");
    }
    if (new_reservoir) {
      const size_t custom = xml.find("<custom>");
      if (custom == std::string::npos) {
        *error = path + ": no <custom> element to add reservoir '" + e.reservoir + "' to";
        return ModelPtr(nullptr, mj_deleteModel);
      }
      std::string keys;
      for (const auto& [key, value] : e.reservoir_keys) keys += (keys.empty() ? "" : " ") + key + "=" + value;
      xml = Replace(xml, custom + 8, 0, "\n<text name=\"pneumatic_reservoir:" + e.reservoir + "\" data=\"" + keys + "\"/>");
    }
    if (!e.state_actuators.empty() || !e.force_actuators.empty() || new_reservoir) {
      const size_t chamber = xml.find("\"" + e.cylinder + ".P\"");
      const size_t element = chamber == std::string::npos ? chamber : xml.rfind('<', chamber);
      const size_t element_end = element == std::string::npos ? element : xml.find('>', chamber);
      std::string transmission;
      for (const char* attribute : {"joint=\"", "tendon=\"", "jointinparent=\""}) {
        size_t a = element == std::string::npos ? std::string::npos : xml.find(attribute, element);
        if (a != std::string::npos && a < element_end) {
          transmission = xml.substr(a, xml.find('"', a + std::string(attribute).size()) + 1 - a);
        }
      }
      const size_t last = xml.rfind("</actuator>");
      if (transmission.empty() || last == std::string::npos) {
        *error = path + ": cannot find the transmission of actuator '" + e.cylinder + ".P' to add the effect's states";
        return ModelPtr(nullptr, mj_deleteModel);
      }
      std::string actuators, forces;
      for (const std::string& suffix : e.state_actuators) {
        actuators += "<general name=\"" + e.cylinder + "." + suffix + "\" " + transmission + " dyntype=\"user\" gaintype=\"user\"/>\n";
      }
      if (new_reservoir) {
        actuators += "<general name=\"" + e.reservoir + ".pressure\" " + transmission + " dyntype=\"user\" gaintype=\"user\"/>\n";
      }
      for (const std::string& suffix : e.force_actuators) {
        forces += "\n<general name=\"" + e.cylinder + "." + suffix + "\" " + transmission + " gaintype=\"user\" biastype=\"user\"/>";
      }
      xml = Replace(xml, last, 0, actuators);
      const size_t first = xml.find('>', xml.find("<actuator"));
      xml = Replace(xml, first + 1, 0, forces);
    }
  }
  // a virtual file of the same name: MuJoCo looks it up first, and resolves includes and assets
  // relative to the original's directory
  const std::string virtual_name = path.substr(0, path.rfind('.')) + ".diagnosis.xml";
  std::string load_error;
  ModelPtr m = LoadModelFromText(xml, virtual_name, &load_error);
  if (!m) {
    *error = path + " with the effect's edits: " + load_error;
    return m;
  }
  std::string attach_error;
  if (!Attach(m.get(), &attach_error)) {
    *error = path + " with the effect's edits: " + attach_error;
    return ModelPtr(nullptr, mj_deleteModel);
  }
  return m;
}

std::vector<Candidate> CandidateLibrary(const mjModel* m, const Measurements& meas) {
  std::vector<Candidate> out;
  auto per_cylinder = [&](const std::string& effect, const std::string& form,
                          const std::function<void(const CylinderSeries&, Candidate*)>& add, bool refinement = false) {
    Candidate c{effect, form, {}, {}, refinement};
    for (const CylinderSeries& cyl : meas.cylinders) add(cyl, &c);
    if (!c.parameters.empty()) out.push_back(std::move(c));
  };

  // valve_delay: what delays the valve's response beyond the nominal valve
  per_cylinder("valve_delay", "", [&](const CylinderSeries& cyl, Candidate* c) {
    const std::string& n = cyl.info.name;
    const std::string valve = Choice(m, n, "valve");
    if (valve == "onoff") {
      c->form = "on/off valve opening and closing delays (armature model)";
      // the armature is a state of each valve's command actuator: a model without delays gets it
      const double open = Parameter(m, n, "delay_open", 0), close = Parameter(m, n, "delay_close", 0);
      if (open == 0 && close == 0) {
        c->edits.push_back({n, {}, {}, {"u1", "u2", "u3", "u4"}, {{"delay_open", "0.001"}, {"delay_close", "0.001"}}});
      }
      c->parameters.push_back(KeyParameter(n, "delay_open", open > 0 ? open : 1e-3, 1e-5, 0.02, 1e-3, true));
      c->parameters.push_back(KeyParameter(n, "delay_close", close > 0 ? close : 1e-3, 1e-5, 0.02, 1e-3, true));
    } else if (valve == "proportional_5_3") {
      c->form = "a slower spool: first-order spool lag";
      c->parameters.push_back(
          KeyParameter(n, "spool_time_constant", Parameter(m, n, "spool_time_constant", 0), 0, 0.1, 2e-3));
    } else if (valve == "proportional_per_chamber") {
      // each chamber's valve voltage behind a first-order lag (its act: the lagged voltage)
      const double tau = Parameter(m, n, "spool_time_constant", 0);
      c->form = "a slower valve: first-order lag of each chamber's valve voltage";
      if (tau == 0) c->edits.push_back({n, {}, {}, {"uP", "uN"}, {{"spool_time_constant", "0.002"}}});
      c->parameters.push_back(KeyParameter(n, "spool_time_constant", tau > 0 ? tau : 0.002, 1e-4, 0.1, 2e-3, true));
    }
  });
  // valve_delay, second form: a dead time before the spool's lag (a valve driver's or a field bus'
  // latency, a slow solenoid that moves only after a while): the command reaches the valve through the
  // (1,2) Pade delay line of spool_dead_time (plugin/src/valves.h, ValveSignal), then the lag of the
  // first form. A refinement (candidates.h): a lag alone is its limit of a vanishing dead time
  per_cylinder("valve_delay", "a valve dead time (Pade delay line) before a first-order lag", [&](const CylinderSeries& cyl, Candidate* c) {
    const std::string& n = cyl.info.name;
    if (!ProportionalValve(m, n)) return;
    const bool per_chamber = Choice(m, n, "valve") == "proportional_per_chamber";
    ModelEdit edit{n, {}, {}, {}, {}};
    AddDelayLine(m, n, "spool_dead_time", "0.002", &edit);
    const double tau = Parameter(m, n, "spool_time_constant", 0);
    if (per_chamber && tau == 0) {
      edit.stateful_commands = {"uP", "uN"};
      edit.keys.push_back({"spool_time_constant", "0.002"});
    }
    if (!edit.state_actuators.empty() || !edit.stateful_commands.empty()) c->edits.push_back(edit);
    // the dead time on a log scale, scanned (a tenth of a millisecond to 50 ms); the lag from the
    // model's (or 2 ms), on a linear scale, so that the scan moves the dead time alone
    const double dead_time = Parameter(m, n, "spool_dead_time", 0);
    c->parameters.push_back(KeyParameter(n, "spool_dead_time", dead_time > 0 ? dead_time : 0.002, 1e-4, 0.05, 2e-3, true));
    // the delay line's states estimated over the log's history (SignalModel::history_estimate): from
    // a window's warm-up alone they would start each window off by what the line's error keeps after
    // it, exp(-2 t / T) (valves.h), 0.7 % after 20 ms for T = 8 ms, less for a shorter dead time,
    // which the fit then prefers: on a 500 Hz rig C log of an 8 ms dead time and no lag
    // (bench_diagnose) it stopped at 6.5 ms and a 1.1 ms lag, held-out gap 0.0216 (with a 60 ms
    // warm-up: 8.0 ms and no lag, 0.0176)
    EstimatedOverTheHistory(&c->parameters.back());
    if (per_chamber) {
      c->parameters.push_back(KeyParameter(n, "spool_time_constant", tau > 0 ? tau : 0.002, 1e-4, 0.1, 2e-3));
    } else {
      c->parameters.push_back(KeyParameter(n, "spool_time_constant", tau, 0, 0.1, 2e-3));
    }
  }, true);
  // valve_delay, third form: an exact dead time of the commands (a field bus', a valve driver's or a
  // controller's latency): the valves act on the logged commands that much later (SignalModel,
  // prediction.h), the nominal valve behind it. The project's own form, for every valve: an on/off
  // valve opens at a command of 1/2 or more (plugin/src/valves.cc), so the delayed command's mean over
  // a step switches it at the model step nearest the delayed switch (rig A: to 50 us), where the
  // armature delays of the first form lose pulses shorter than their opening delay. A refinement
  // (candidates.h) as the Pade form is: fitted in the rounds valve_delay leads or explains. Up to 50 ms, scanned
  // in half rows: the prediction error has a local minimum wherever the delayed commands line up with
  // the log's own oscillations (on a 500 Hz rig C log of an 8 ms latency, at 3.5, 5.5, 8 and 11 ms;
  // the true one's basin about a row wide)
  per_cylinder("valve_delay", "an exact dead time of the valve commands (a latency), the nominal valve behind it",
               [&](const CylinderSeries& cyl, Candidate* c) {
    const size_t index = &cyl - meas.cylinders.data();
    EffectParameter p;
    p.name = cyl.info.name + ":command_delay";
    p.unit = "s";
    p.initial = 0.002, p.lower = 0, p.upper = 0.05, p.scale = 0.002, p.scan_step = meas.period / 2;
    p.apply = [index](mjModel*, SignalModel* signals, double value) {
      signals->command_delay[index] = value;
      return std::string();
    };
    c->parameters.push_back(p);
  }, true);
  // valve_deadband: no flow for small spool displacements; the band is cut out of the opening, as
  // an overlapped spool's lands do, and the opening beyond it grows with the model's slope
  auto deadband = [&](const CylinderSeries& cyl, Candidate* c) {
    const std::string& n = cyl.info.name;
    const std::string valve = Choice(m, n, "valve");
    if (valve == "proportional_5_3") {
      c->form = "spool deadband (fraction of the spool range)";
      c->parameters.push_back(KeyParameter(n, "deadband", Parameter(m, n, "deadband", 0), 0, 0.5, 0.05));
    } else if (valve == "proportional_per_chamber") {
      c->form = "a voltage band added to each port's sealed band";
      c->parameters.push_back(KeyParameter(n, "deadband_voltage", Parameter(m, n, "deadband_voltage", 0), 0, 3, 0.1));
    }
  };
  per_cylinder("valve_deadband", "", deadband);
  // valve_deadband, second form, a refinement (candidates.h): the band and the valve's slope beyond
  // it. A valve modelled from its rated flow reaches that flow at full command; if the real valve has
  // a band, its opening grows more steeply beyond it (for a band b of a command range U, by
  // U / (U - b)), which the first form, keeping the model's slope, leaves as a flow error at every
  // large command. The project's own form: the first form's band, and a factor on the model's
  // spool_gain (5/3; the band, a fraction of the spool range, keeps its width in volts) or on each
  // chamber's area_gain (per chamber; paper 000 eq. 3's B), from 1
  per_cylinder("valve_deadband", "", [&](const CylinderSeries& cyl, Candidate* c) {
    const std::string& n = cyl.info.name;
    const std::string valve = Choice(m, n, "valve");
    std::vector<std::string> keys;
    if (valve == "proportional_5_3") keys = {"spool_gain"};
    if (valve == "proportional_per_chamber") keys = {"P.area_gain", "N.area_gain"};
    if (keys.empty()) return;
    deadband(cyl, c);  // the band, and the first form's text, which this form extends
    c->form += keys.size() == 1 ? ", and the valve's slope beyond it (a factor on spool_gain)"
                                : ", and the valve's slope beyond it (a factor on area_gain)";
    std::vector<std::pair<std::string, double>> gains;
    for (const std::string& key : keys) gains.push_back({key, Parameter(m, n, key, 0)});
    EffectParameter p;
    p.name = n + ":valve_gain_factor";
    p.unit = "1";
    p.initial = p.nominal = 1, p.lower = 0.5, p.upper = 2, p.scale = 0.02;
    p.apply = [n, gains](mjModel* model, SignalModel*, double factor) {
      std::string error;
      for (const auto& [key, gain] : gains) {
        if (!SetParameter(model, n, key, factor * gain, &error)) return error;
      }
      return std::string();
    };
    c->parameters.push_back(p);
  }, true);
  // a parameter of the driven joint's degree of freedom: the mjModel array `field` (dof_frictionloss,
  // dof_damping), named "CYLINDER:joint JOINT KEY", its unit by the joint's type; bounds by the caller
  auto joint_parameter = [&](const CylinderSeries& cyl, mjtNum* mjModel::*field, const char* key, const char* hinge_unit,
                             const char* slide_unit) {
    const int dof = m->jnt_dofadr[cyl.joint];
    EffectParameter p;
    p.name = cyl.info.name + ":joint " + std::string(m->names + m->name_jntadr[cyl.joint]) + " " + key;
    p.unit = m->jnt_type[cyl.joint] == mjJNT_HINGE ? hinge_unit : slide_unit;
    p.initial = p.nominal = (m->*field)[dof];
    p.apply = [dof, field](mjModel* model, SignalModel*, double value) {
      (model->*field)[dof] = value;
      return std::string();
    };
    return p;
  };
  // friction: Coulomb friction of the seals as MuJoCo's frictionloss on the driven joint (an
  // implicit constraint: it holds below the level and opposes sliding at it). In the joint's units:
  // x = gear q, so a force F on the piston is gear F on the joint
  auto coulomb_friction = [&](const CylinderSeries& cyl, Candidate* c) {
    EffectParameter p = joint_parameter(cyl, &mjModel::dof_frictionloss, "frictionloss", "N m", "N");
    p.lower = 0, p.upper = 0.5 * MaxForce(m, cyl) * cyl.gear;
    p.scale = 0.02 * MaxForce(m, cyl) * cyl.gear;
    c->parameters.push_back(p);
  };
  per_cylinder("friction", "Coulomb friction (the joint's frictionloss)", coulomb_friction);
  // friction, second form, a refinement: Coulomb and viscous friction, a lubricated seal's force
  // growing with the speed (F = F_c sign(v) + b v; the viscous term of LuGre, Canudas de Wit et al.
  // 1995 eq. 4's sigma2), as the joint's frictionloss and damping (MuJoCo's passive force -b qdot).
  // The damping in the joint's units is gear^2 b; its range is up to the largest force at a tenth of
  // a stroke per second, its unit 2 % of it at one stroke per second
  per_cylinder("friction", "Coulomb and viscous friction (the joint's frictionloss and damping)", [&](const CylinderSeries& cyl, Candidate* c) {
    coulomb_friction(cyl, c);
    const double per_stroke_speed = cyl.gear * cyl.gear / std::max(cyl.stroke, 1e-9);  // joint damping of 1 N at one stroke per second
    EffectParameter p = joint_parameter(cyl, &mjModel::dof_damping, "damping", "N m s/rad", "N s/m");
    p.lower = 0, p.upper = std::max(10 * MaxForce(m, cyl) * per_stroke_speed, 2 * p.initial);
    p.scale = 0.02 * MaxForce(m, cyl) * per_stroke_speed;
    c->parameters.push_back(p);
  }, true);
  // friction, third form, a refinement: static friction above the Coulomb level, the stick-slip of
  // effects.md's friction (paper 001: 40 N static, 20 N Coulomb), which neither form above has: the
  // LuGre model of Canudas de Wit et al. 1995 (plugin friction_model=lugre: its bristle state z, the
  // Stribeck curve g(v) = F_c + (F_s - F_c) exp(-(v/v_s)^2) of its eq. 3, the viscous sigma2 v of its
  // eq. 4; bristle stiffness and damping at the plugin's defaults). Fitted: F_c, the static excess
  // F_s - F_c (so that F_s >= F_c whatever the order the fit sets them in) and sigma2 on the second
  // form's scale. v_s is fixed, the project's own choice of a twentieth of a stroke per second (5
  // mm/s on rigs A and C): a log hardly tells it from the excess, and fitted too it ran to its upper
  // bound on a rig C log of a 0.01 m/s curve (0.2 m/s, with F_c 0.8 +- 2.4 N for 1.2 N). In a model
  // whose cylinder has seal friction already (coulomb_friction, or a frictionloss on its joint,
  // which LuGre would double) the form is not offered
  per_cylinder("friction", "static and Coulomb friction with a Stribeck curve, and viscous friction (LuGre)",
               [&](const CylinderSeries& cyl, Candidate* c) {
    const std::string& n = cyl.info.name;
    std::string ignored;
    if (GetParameter(m, n, "coulomb_friction", &ignored) || cyl.joint < 0 || m->dof_frictionloss[m->jnt_dofadr[cyl.joint]] > 0) return;
    const double force = MaxForce(m, cyl), stroke = std::max(cyl.stroke, 1e-9);
    c->edits.push_back({n, {"z"}, {"friction"}, {}, {{"friction_model", "lugre"}, {"coulomb_friction", Number(0.02 * force)},
                        {"static_friction", Number(0.04 * force)}, {"stribeck_velocity", Number(0.05 * stroke)}}});
    // sets F_c and F_s = F_c + excess; F_s >= F_c holds after each call (the plugin checks it): a
    // static level that rises is set first, one that falls last
    auto set_levels = [n](mjModel* model, double coulomb, double excess) {
      std::string error;
      const double stat = coulomb + excess;
      const bool ok = stat >= Parameter(model, n, "static_friction", 0)
                          ? SetParameter(model, n, "static_friction", stat, &error) && SetParameter(model, n, "coulomb_friction", coulomb, &error)
                          : SetParameter(model, n, "coulomb_friction", coulomb, &error) && SetParameter(model, n, "static_friction", stat, &error);
      return ok ? std::string() : error;
    };
    EffectParameter coulomb;
    coulomb.name = n + ":coulomb_friction";
    coulomb.unit = KeyUnit("coulomb_friction");
    coulomb.initial = 0.02 * force, coulomb.lower = 0, coulomb.upper = 0.5 * force, coulomb.scale = 0.02 * force;
    coulomb.apply = [n, set_levels](mjModel* model, SignalModel*, double value) {
      const double excess = Parameter(model, n, "static_friction", 0) - Parameter(model, n, "coulomb_friction", 0);
      return set_levels(model, value, excess);
    };
    EffectParameter excess = coulomb;
    excess.name = n + ":static_friction_excess";
    excess.apply = [n, set_levels](mjModel* model, SignalModel*, double value) {
      return set_levels(model, Parameter(model, n, "coulomb_friction", 0), value);
    };
    c->parameters.push_back(coulomb);
    c->parameters.push_back(excess);
    const double per_stroke_speed = 1 / stroke;  // sigma2 of 1 N at one stroke per second
    c->parameters.push_back(KeyParameter(n, "viscous_friction", 0, 0, 10 * force * per_stroke_speed, 0.02 * force * per_stroke_speed));
  }, true);
  // leakage: orifices across the piston and from each chamber to the atmosphere (the turbulent form;
  // a real leak may be laminar, or anything between)
  per_cylinder("leakage", "orifice leaks across the piston and to the atmosphere", [&](const CylinderSeries& cyl, Candidate* c) {
    c->parameters = OrificeLeakAreas(m, cyl);
  });
  // leakage, second form, a refinement (candidates.h): laminar leaks along the same paths, the mass
  // flow G dp proportional to the pressure difference (the plugin's *_leak_conductance, the
  // project's own form: the viscous flow of a seal's clearance gap, where the orifice form is a
  // hole's). The two forms are the ends of a real leak's range; where the first leads a round or is its runner-up, the
  // held-out gap tells which end is nearer. Its range is the orifice form's, converted
  // (LaminarConductancePerArea)
  // The fit starts from the orifice form's fit, each area converted at the same rate as the range: the
  // scan's coarse points (a decade and more apart) bracket a laminar leak poorly, since at the small
  // pressure differences near equalisation a laminar path passes far less than an orifice of the
  // converted area, and from them the fit could stall with a leak in its dead zone at the bottom of
  // the range: bench_diagnose --speed at 1 kHz (a laminar leak across the piston and to the
  // atmosphere) left 0.0382 of held-out gap with the piston's conductance at its lower bound, against
  // the orifice form's 0.0279
  per_cylinder("leakage", "laminar leaks across the piston and to the atmosphere (flow proportional to the pressure difference)",
               [&](const CylinderSeries& cyl, Candidate* c) {
    c->parameters = LaminarLeakConductances(m, cyl);
    const std::vector<EffectParameter> areas = OrificeLeakAreas(m, cyl);
    const double per_area = LaminarConductancePerArea(m, cyl);
    for (size_t i = 0; i < c->parameters.size(); ++i) {
      c->parameters[i].seed_from = areas[i].name;
      c->parameters[i].seed_factor = per_area;
    }
  }, true);
  // leakage, third form, a refinement: both laws on each path, a laminar conductance and an orifice
  // side by side (the project's own form). A real leak lies between the two ends, and a seal may
  // leak through its clearance gap and through a nick at once; each end alone leaves such a leak's
  // shape unexplained: rig B driven open loop, a piston leak half laminar and half an orifice, the
  // laminar form left 0.0235 against the clean log's 0.0119, and a spurious payload took part of it.
  // Six parameters would cost the scans a grid of 36 points and more, so the fit starts from the two
  // forms above instead, each law at half its own fit (seed_factor): the sum starts as the mean of
  // two fits of the same leak
  per_cylinder("leakage", "laminar and orifice leaks side by side, across the piston and to the atmosphere",
               [&](const CylinderSeries& cyl, Candidate* c) {
    c->parameters = OrificeLeakAreas(m, cyl);
    for (EffectParameter& p : LaminarLeakConductances(m, cyl)) c->parameters.push_back(p);
    for (EffectParameter& p : c->parameters) p.seed_factor = 0.5;
  }, true);
  // heat_transfer: the gas temperature as a state (the energy equation of an open chamber with wall
  // heat, Richer and Hurmuzlu 2000; plugin/README.md, "heat_transfer") with one wall heat conductance
  // for both chambers, started from a wall time constant m c_v / (h A) of 1 s for a chamber at
  // mid-stroke at 3 bar, or from the model's own
  auto energy_equation = [&](const CylinderSeries& cyl, Candidate* c) {
    const std::string& n = cyl.info.name;
    const double volume = Parameter(m, n, "P.dead_volume", 1e-6) + Parameter(m, n, "P.area", 1e-4) * cyl.stroke / 2;
    double conductance = 3e5 * volume / (Parameter(m, n, "temperature", 293) * 0.4) / 1.0;
    if (Choice(m, n, "thermal_model") == "energy") {
      conductance = Parameter(m, n, "P.wall_heat_conductance", conductance);  // refit the model's own
    } else {
      c->edits.push_back({n, {"TP", "TN"}, {}, {}, {{"thermal_model", "energy"}, {"wall_heat_conductance", Number(conductance)}}});
    }
    c->parameters.push_back(KeyParameter(n, "wall_heat_conductance", conductance, 1e-3 * conductance, 1e3 * conductance, conductance, true));
  };
  // first form: the gas temperatures start each window from the warm-up (prediction.h), which
  // starts them at the wall's
  per_cylinder("heat_transfer", "gas temperature as a state, one wall heat conductance for both chambers", energy_equation);
  // second form, a refinement (candidates.h): the same equation with the gas temperatures estimated
  // over the log's history (SignalModel::history_estimate). A gas temperature relaxes to the wall's
  // over tenths of a second, longer than a 20 ms warm-up, so the first form starts each window with
  // its gas too close to the wall's temperature after a filling or a venting. The history costs a
  // simulation of the whole log per evaluation, so only the rounds the first form leads or is the runner-up of pay it
  per_cylinder("heat_transfer", "gas temperature as a state, one wall heat conductance, the temperatures estimated over the log's history",
               [&](const CylinderSeries& cyl, Candidate* c) {
    energy_equation(cyl, c);
    EstimatedOverTheHistory(&c->parameters.back());
  }, true);
  // supply_drop: a supply pressure below the nominal one
  per_cylinder("supply_drop", "a lower supply pressure", [&](const CylinderSeries& cyl, Candidate* c) {
    const std::string& n = cyl.info.name;
    const double nominal = cyl.info.p_supply;
    c->parameters.push_back(KeyParameter(n, "p_supply", nominal, std::max(cyl.info.p_exhaust * 1.05, 0.5 * nominal), nominal * 1.05,
                                         0.02 * (nominal - cyl.info.p_exhaust)));
    c->parameters.back().nominal = nominal;
  });
  // supply_drop, second form: a supply that sags under flow. A tank behind a restrictive line from
  // the compressor feeds every cylinder (a reservoir, plugin/README.md "Supply reservoirs"): a
  // small tank is a restrictive supply line, whose pressure follows the flow drawn; a large one
  // sags and refills slowly. Its pressure, which no sensor gives, is estimated over the log's
  // history (prediction.h)
  {
    Candidate c{"supply_drop", "a supply tank behind a restrictive line, feeding every cylinder", {}, {}, true};
    double chambers = 0;  // the largest volume of the chambers the tank feeds together (its lower bound)
    for (const CylinderSeries& cyl : meas.cylinders) {
      if (cyl.info.supply_actuator >= 0) continue;  // a model with its own reservoir: the lower constant supply remains
      chambers += ChamberVolumes(m, cyl);
      c.edits.push_back({cyl.info.name, {}, {}, {}, {}, kSupplyTank, {}});
    }
    if (!c.edits.empty() && chambers > 0) {
      // bounds: a tank from just above the chambers' volume (the reservoir step's stability
      // condition) to 1000 times it; a line from 1e-11 kg/(s Pa) (far below any valve's) to 1e-5
      // (a 75 mm orifice: no restriction); it starts mild, a tank of 100 chamber volumes behind a
      // line of 1e-7
      const double volume = 100 * chambers, conductance = 1e-7;
      c.edits.front().reservoir_keys = {{"volume", Number(volume)}, {"line_conductance", Number(conductance)}};
      auto tank = [&](const std::string& key, const std::string& unit, double initial, double lower, double upper) {
        EffectParameter p;
        p.name = std::string(kSupplyTank) + ":" + key;
        p.unit = unit;
        p.initial = initial, p.lower = lower, p.upper = upper, p.scale = initial, p.logarithmic = true;
        p.apply = [key](mjModel* model, SignalModel*, double value) {
          std::string error;
          return SetReservoirParameter(model, kSupplyTank, key, value, &error) ? std::string() : error;
        };
        return p;
      };
      c.parameters.push_back(tank("volume", "m^3", volume, 1.05 * chambers, 1000 * chambers));
      c.parameters.push_back(tank("line_conductance", "kg/(s Pa)", conductance, 1e-11, 1e-5));
      for (EffectParameter& p : c.parameters) p.absent = p.upper;  // an endless tank, an unrestricted line
      out.push_back(std::move(c));
    }
  }
  // supply_drop, third form: the logged supply pressure. A log's p_S column is the supply pressure
  // measured (shared/spec/log_format.md); where it departs from the model's p_supply (it sags under
  // flow, or sits lower), it gives the valves' supply directly, which the tank form can only
  // estimate. The project's own form: each cylinder gets a reservoir of its own, sealed from the
  // compressor, that the prediction sets to the logged p_S at every model step (prediction.h,
  // SignalModel::logged_supply); one parameter, the p_S sensor's offset, up to 5 % of the supply's
  // gauge range. Offered when every cylinder has p_S, the model feeds none from a reservoir, and
  // some cylinder's p_S departs from its p_supply by more than 1 % of that range (the spread of its
  // 5th to 95th percentile, or its median's distance): a sensor's noise alone spans less (500 Pa
  // of noise, as on the rigs' pressure sensors, spans 1.6 kPa between those percentiles; 1 % of a
  // 6.2e5 Pa supply's range is 5.2 kPa)
  {
    const std::vector<ReservoirInfo> reservoirs = Reservoirs(m);
    bool every_cylinder_logged = reservoirs.empty(), departs = false;
    double chambers = 0, gauge_range = 0;
    for (const CylinderSeries& cyl : meas.cylinders) {
      if (cyl.supply.empty()) every_cylinder_logged = false;
      if (!every_cylinder_logged) break;
      std::vector<double> sorted = cyl.supply;
      std::sort(sorted.begin(), sorted.end());
      auto percentile = [&](double q) { return sorted[static_cast<size_t>(q * static_cast<double>(sorted.size() - 1))]; };
      const double range = cyl.info.p_supply - cyl.info.p_exhaust;
      departs |= percentile(0.95) - percentile(0.05) > 0.01 * range ||
                 std::fabs(percentile(0.5) - cyl.info.p_supply) > 0.01 * range;
      gauge_range = std::max(gauge_range, range);
      chambers = std::max(chambers, ChamberVolumes(m, cyl));
    }
    if (every_cylinder_logged && departs && chambers > 0) {
      Candidate c{"supply_drop", "the logged supply pressure (p_S) at the valves", {}, {}, false};
      // a reservoir far larger than the chambers (the step's stability condition), sealed: the
      // prediction sets its pressure at every step, so neither key shapes what the valves see
      const std::string volume = Number(std::min(1000 * chambers, 10.0));
      for (const CylinderSeries& cyl : meas.cylinders) {
        c.edits.push_back({cyl.info.name, {}, {}, {}, {}, std::string(kLoggedSupply) + "_" + cyl.info.name,
                           {{"volume", volume}, {"line_conductance", "0"}}});
      }
      EffectParameter p;
      p.name = "p_S:offset";
      p.unit = "Pa";
      p.initial = 0, p.lower = -0.05 * gauge_range, p.upper = 0.05 * gauge_range, p.scale = 0.01 * gauge_range;
      p.apply = [](mjModel*, SignalModel* signals, double value) {
        signals->logged_supply = true;
        signals->supply_offset = value;
        return std::string();
      };
      c.parameters.push_back(p);
      out.push_back(std::move(c));
    }
  }
  // line_dynamics: a tube volume and its restriction between the valve and each chamber, each
  // chamber's own (a valve seldom sits as near one chamber as the other: on a rig C log of tubes of
  // unequal length, one tube for both left half the gap and lost to a heat transfer). Volumes and
  // conductances are two kinds for the scan: alike on its grid, then each chamber's alone
  auto add_line = [&](const std::string& n, ModelEdit* edit, Candidate* c) {
    if (Parameter(m, n, "P.line_volume", 0) == 0) {
      edit->state_actuators.insert(edit->state_actuators.end(), {"LP", "LN"});
      edit->keys.push_back({"line_volume", Number(Parameter(m, n, "P.dead_volume", 1e-6))});
      edit->keys.push_back({"line_conductance", "1e-8"});
    }
    // bounds: a line of 0.1 to 100 dead volumes; a restriction from 1e-10 kg/(s Pa) (a hair-thin
    // tube) to 1e-7 (an orifice of about 9 mm): wider restrictions make the line stiff beyond what a
    // diagnosis can afford to simulate, and act as no restriction at all
    for (const std::string chamber : {"P.", "N."}) {
      const double v0 = Parameter(m, n, chamber + "dead_volume", 1e-6);
      c->parameters.push_back(KeyParameter(n, chamber + "line_volume", v0, 0.1 * v0, 100 * v0, v0, true));
    }
    for (const std::string chamber : {"P.", "N."}) {
      c->parameters.push_back(KeyParameter(n, chamber + "line_conductance", 1e-8, 1e-10, 1e-7, 1e-8, true));
      c->parameters.back().absent = c->parameters.back().upper;  // an unrestricted line
    }
  };
  per_cylinder("line_dynamics", "a tube volume between the valve and each chamber, with its restriction",
               [&](const CylinderSeries& cyl, Candidate* c) {
    ModelEdit edit{cyl.info.name, {}, {}, {}, {}};
    add_line(cyl.info.name, &edit, c);
    if (!edit.state_actuators.empty()) c->edits.push_back(edit);
  });
  // line_dynamics, second form: the same tube with its transport delay L/c (effects.md: "extra volume
  // and transport delay"; about 3 ms per metre), through line_delay's Pade delay line (proportional
  // valves: plugin/src/config.cc). A refinement (candidates.h): the first form is its limit of a
  // vanishing delay. The delay on a linear scale, not scanned: the scan keeps its grid of two kinds
  per_cylinder("line_dynamics", "a tube volume between the valve and each chamber, with its restriction, and the tubes' transport delay",
               [&](const CylinderSeries& cyl, Candidate* c) {
    const std::string& n = cyl.info.name;
    if (!ProportionalValve(m, n)) return;
    ModelEdit edit{n, {}, {}, {}, {}};
    add_line(n, &edit, c);
    AddDelayLine(m, n, "line_delay", "0.001", &edit);
    if (!edit.state_actuators.empty()) c->edits.push_back(edit);
    const double delay = Parameter(m, n, "line_delay", 0);
    c->parameters.push_back(KeyParameter(n, "line_delay", delay > 0 ? delay : 0.001, 1e-4, 0.02, 1e-3));
  }, true);
  // payload: a moving mass different from the model's, on the body the cylinder's joint moves. Fitted
  // as the body's mass on a log scale: a payload may be several times the body's own mass, which a
  // linear step from the nominal mass would crawl towards
  per_cylinder("payload", "a different moving mass on the driven body", [&](const CylinderSeries& cyl, Candidate* c) {
    const int body = m->jnt_bodyid[cyl.joint];
    const double mass = m->body_mass[body];
    EffectParameter p;
    p.name = cyl.info.name + ":body " + std::string(m->names + m->name_bodyadr[body]) + " mass";
    p.unit = "kg";
    p.initial = mass, p.lower = 0.2 * mass, p.upper = 20 * mass, p.scale = mass, p.logarithmic = true;
    const double inertia[3] = {m->body_inertia[3 * body], m->body_inertia[3 * body + 1], m->body_inertia[3 * body + 2]};
    p.apply = [body, mass, inertia](mjModel* model, SignalModel*, double value) {
      // the inertia scales with the mass: the added mass is spread like the body's own
      model->body_mass[body] = value;
      for (int i = 0; i < 3; ++i) model->body_inertia[3 * body + i] = inertia[i] * value / mass;
      return RefreshMassConstants(model);
    };
    c->parameters.push_back(p);
  });
  // sensor_bias: offset and gain of one measured signal (a measurement model, not physics; a
  // pressure sensor's gain acts about the atmosphere, SignalModel)
  for (int s = 0; s < meas.signals(); ++s) {
    const std::vector<double>& y = meas.Signal(s);
    const auto [lo, hi] = std::minmax_element(y.begin(), y.end());
    const double span = std::max(*hi - *lo, 1e-12);
    Candidate c{"sensor_bias", "offset and gain of " + meas.SignalLabel(s), {}, {}};
    EffectParameter offset;
    offset.name = meas.SignalLabel(s) + ":offset";
    offset.unit = s % 3 == kPosition ? "m" : "Pa";
    offset.initial = 0, offset.lower = -span, offset.upper = span, offset.scale = 0.01 * span;
    offset.apply = [s](mjModel*, SignalModel* sensors, double value) {
      sensors->offset[s] = value;
      return std::string();
    };
    EffectParameter gain;
    gain.name = meas.SignalLabel(s) + ":gain";
    gain.unit = "1";
    gain.initial = gain.nominal = 1, gain.lower = 0.5, gain.upper = 1.5, gain.scale = 0.01;
    gain.apply = [s](mjModel*, SignalModel* sensors, double value) {
      sensors->gain[s] = value;
      return std::string();
    };
    c.parameters = {offset, gain};
    out.push_back(std::move(c));
  }
  return out;
}

}  // namespace pneumatic::diagnosis
