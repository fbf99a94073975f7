#include "diagnosis/calibration.h"

#include <algorithm>
#include <cmath>

namespace pneumatic::diagnosis {
namespace {

constexpr double kAirHeatCapacityRatio = 1.4;  // diatomic ideal gas, cp / cv = 7 / 5

// one key of both chambers ("P.<key>" and "N.<key>") fitted as one value, from the P chamber's,
// within [1 - spread, 1 + spread] times it and the key's own range: the parameter added, or null
// if the key does not apply
EffectParameter* AddBothChambers(const mjModel* m, const std::string& cylinder, const std::string& key, double spread, Candidate* c) {
  std::string error;
  const std::optional<double> value = GetParameter(m, cylinder, "P." + key, &error);
  if (!value || !(*value > 0)) return nullptr;
  double lower = (1 - spread) * *value, upper = (1 + spread) * *value;
  for (const ParameterDoc& doc : Parameters()) {
    if (doc.key != key) continue;
    lower = std::max(lower, doc.min_open ? std::nextafter(doc.min, doc.max) : doc.min);
    upper = std::min(upper, doc.max_open ? std::nextafter(doc.max, doc.min) : doc.max);
    EffectParameter p;
    p.name = cylinder + ":" + key;
    p.unit = doc.unit.empty() ? "1" : doc.unit;
    p.initial = p.nominal = *value, p.lower = lower, p.upper = upper, p.scale = 0.05 * *value;
    p.apply = [cylinder, key](mjModel* model, SignalModel*, double v) {
      std::string why;
      return SetParameter(model, cylinder, "P." + key, v, &why) && SetParameter(model, cylinder, "N." + key, v, &why) ? std::string() : why;
    };
    c->parameters.push_back(p);
    return &c->parameters.back();
  }
  return nullptr;
}

// one chamber's key ("P.dead_volume"), within [1 - spread, 1 + spread] times the model's value
void AddChamber(const mjModel* m, const std::string& cylinder, const std::string& key, double spread, Candidate* c) {
  std::string error;
  const std::optional<double> value = GetParameter(m, cylinder, key, &error);
  if (!value || !(*value > 0)) return;
  EffectParameter p;
  p.name = cylinder + ":" + key;
  p.unit = "m^3";
  p.initial = p.nominal = *value, p.lower = (1 - spread) * *value, p.upper = (1 + spread) * *value, p.scale = 0.05 * *value;
  p.apply = [cylinder, key](mjModel* model, SignalModel*, double v) {
    std::string why;
    return SetParameter(model, cylinder, key, v, &why) ? std::string() : why;
  };
  c->parameters.push_back(p);
}

}  // namespace

Candidate CalibrationCandidate(const mjModel* m, const Measurements& meas) {
  Candidate c;
  c.effect = "calibration";
  c.form = "the model's nominal parameters re-fitted: flow coefficient, critical ratio, dead volumes, polytropic index, damping";
  constexpr double kNarrow = 0.30, kWide = 0.45;  // calibration.h
  for (const CylinderSeries& cyl : meas.cylinders) {
    const std::string& n = cyl.info.name;
    std::string error;
    const std::string flow = GetChoice(m, n, "P.flow", &error).value_or("");
    AddBothChambers(m, n, flow == "iso6358" ? "sonic_conductance" : "discharge_coefficient", kNarrow, &c);
    if (flow == "iso6358" || flow == "sanville") AddBothChambers(m, n, "critical_ratio", kNarrow, &c);
    AddChamber(m, n, "P.dead_volume", kWide, &c);
    AddChamber(m, n, "N.dead_volume", kWide, &c);
    // the polytropic index over its physical range: a polytropic process of a gas lies between
    // isothermal (n = 1) and adiabatic (n = gamma, the cylinder's heat_capacity_ratio; air's where
    // the model's flow law and thermal model have none of their own: an iso6358 valve,
    // thermal_model=polytropic). An index above gamma is no process of the gas and stands in for
    // some other effect (rig A's 1.2 went to 1.42-1.51 on the independent suite's friction, heat and
    // supply logs); one at either end is a value, kept (EffectParameter::ends_are_physical_limits)
    if (EffectParameter* p = AddBothChambers(m, n, "polytropic_index", kNarrow, &c)) {
      const double gamma = GetParameter(m, n, "heat_capacity_ratio", &error).value_or(kAirHeatCapacityRatio);
      p->lower = 1, p->upper = std::max(gamma, p->nominal), p->ends_are_physical_limits = true;
    }
    if (cyl.joint >= 0 && m->dof_damping[m->jnt_dofadr[cyl.joint]] > 0) {
      const int dof = m->jnt_dofadr[cyl.joint];
      const double b = m->dof_damping[dof];
      EffectParameter p;
      p.name = n + ":joint " + std::string(m->names + m->name_jntadr[cyl.joint]) + " damping";
      p.unit = m->jnt_type[cyl.joint] == mjJNT_HINGE ? "N m s/rad" : "N s/m";
      p.initial = p.nominal = b, p.lower = (1 - kWide) * b, p.upper = (1 + kWide) * b, p.scale = 0.05 * b;
      p.apply = [dof](mjModel* model, SignalModel*, double v) {
        model->dof_damping[dof] = v;
        return std::string();
      };
      c.parameters.push_back(p);
    }
  }
  return c;
}

}  // namespace pneumatic::diagnosis
