// supply_drop (docs/effects.md): the valves fed below the model's supply pressure. Three forms: a
// lower constant supply, a supply tank that sags under flow, and the logged supply pressure.
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "diagnosis/effects/effect_form_helpers.h"
#include "pneumatic/pneumatic.h"

namespace pneumatic::diagnosis::effects {
namespace {

// the reservoir of the supply_drop candidate's tank form
constexpr char kSupplyTank[] = "supply_tank";
// the reservoirs of its logged form, one per cylinder: "logged_supply_<cylinder>"
constexpr char kLoggedSupply[] = "logged_supply";

// the largest volume of a cylinder's two chambers together (m^3): both dead volumes and both areas
// over the stroke, the volume a reservoir must exceed to feed it (docs/cylinder.md)
double ChamberVolumes(const mjModel* m, const CylinderSeries& c) {
  const std::string& n = c.info.name;
  return Parameter(m, n, "P.dead_volume", 0) + Parameter(m, n, "N.dead_volume", 0) +
         (Parameter(m, n, "P.area", 0) + Parameter(m, n, "N.area", 0)) * c.stroke;
}

// supply_drop: a supply pressure below the nominal one
void LowerSupply(FormLibrary* library) {
  library->PerCylinder("supply_drop", "a lower supply pressure", [&](const CylinderSeries& cyl, Candidate* c) {
    const std::string& n = cyl.info.name;
    const double nominal = cyl.info.p_supply;
    c->parameters.push_back(KeyParameter(n, "p_supply", nominal, std::max(cyl.info.p_exhaust * 1.05, 0.5 * nominal), nominal * 1.05,
                                         0.02 * (nominal - cyl.info.p_exhaust)));
    c->parameters.back().nominal = nominal;
  });
}

// a key of the tank form's reservoir, fitted on a log scale from `initial`
EffectParameter TankParameter(const std::string& key, const std::string& unit, double initial, double lower, double upper) {
  EffectParameter p;
  p.name = std::string(kSupplyTank) + ":" + key;
  p.unit = unit;
  p.initial = initial, p.lower = lower, p.upper = upper, p.scale = initial, p.logarithmic = true;
  p.apply = [key](mjModel* model, SignalModel*, double value) {
    std::string error;
    return SetReservoirParameter(model, kSupplyTank, key, value, &error) ? std::string() : error;
  };
  return p;
}

// supply_drop, second form: a supply that sags under flow. A tank behind a restrictive line from
// the compressor feeds every cylinder (a reservoir, docs/cylinder.md "Supply reservoirs"): a
// small tank is a restrictive supply line, whose pressure follows the flow drawn; a large one
// sags and refills slowly. Its pressure, which no sensor gives, is estimated over the log's
// history (prediction.h)
void SupplyTank(FormLibrary* library) {
  const mjModel* m = library->m;
  Candidate c{"supply_drop", "a supply tank behind a restrictive line, feeding every cylinder", {}, {}, true};
  double chambers = 0;  // the largest volume of the chambers the tank feeds together (its lower bound)
  for (const CylinderSeries& cyl : library->meas.cylinders) {
    if (cyl.info.supply_actuator >= 0) continue;  // a model with its own reservoir: the lower constant supply remains
    chambers += ChamberVolumes(m, cyl);
    c.edits.push_back({cyl.info.name, {}, {}, {}, {}, kSupplyTank, {}});
  }
  if (c.edits.empty() || !(chambers > 0)) return;
  // bounds: a tank from just above the chambers' volume (the reservoir step's stability
  // condition) to 1000 times it; a line from 1e-11 kg/(s Pa) (far below any valve's) to 1e-5
  // (a 75 mm orifice: no restriction); it starts mild, a tank of 100 chamber volumes behind a
  // line of 1e-7
  const double volume = 100 * chambers, conductance = 1e-7;
  c.edits.front().reservoir_keys = {{"volume", Number(volume)}, {"line_conductance", Number(conductance)}};
  c.parameters.push_back(TankParameter("volume", "m^3", volume, 1.05 * chambers, 1000 * chambers));
  c.parameters.push_back(TankParameter("line_conductance", "kg/(s Pa)", conductance, 1e-11, 1e-5));
  for (EffectParameter& p : c.parameters) p.absent = p.upper;  // an endless tank, an unrestricted line
  library->candidates.push_back(std::move(c));
}

// supply_drop, third form: the logged supply pressure. A log's p_S column is the supply pressure
// measured (docs/log_format.md); where it departs from the model's p_supply (it sags under
// flow, or sits lower), it gives the valves' supply directly, which the tank form can only
// estimate. The project's own form: each cylinder gets a reservoir of its own, sealed from the
// compressor, that the prediction sets to the logged p_S at every model step (prediction.h,
// SignalModel::logged_supply); one parameter, the p_S sensor's offset, up to 5 % of the supply's
// gauge range. Offered when every cylinder has p_S, the model feeds none from a reservoir, and
// some cylinder's p_S departs from its p_supply by more than 1 % of that range (the spread of its
// 5th to 95th percentile, or its median's distance): a sensor's noise alone spans less (500 Pa
// of noise, as on the rigs' pressure sensors, spans 1.6 kPa between those percentiles; 1 % of a
// 6.2e5 Pa supply's range is 5.2 kPa)
void LoggedSupply(FormLibrary* library) {
  const mjModel* m = library->m;
  const Measurements& meas = library->meas;
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
  if (!(every_cylinder_logged && departs && chambers > 0)) return;
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
  p.nuisance = true;  // the effect is the logged supply; an unbiased sensor's offset fits 0
  p.apply = [](mjModel*, SignalModel* signals, double value) {
    signals->logged_supply = true;
    signals->supply_offset = value;
    return std::string();
  };
  c.parameters.push_back(p);
  library->candidates.push_back(std::move(c));
}

}  // namespace

void SupplyDropForms(FormLibrary* library) {
  LowerSupply(library);
  SupplyTank(library);
  LoggedSupply(library);
}

}  // namespace pneumatic::diagnosis::effects
