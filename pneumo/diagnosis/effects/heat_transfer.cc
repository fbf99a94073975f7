// heat_transfer (docs/effects.md): the gas exchanging heat with the cylinder's walls, where the
// model takes the chambers polytropic. One form: the energy equation, the gas temperatures
// estimated over the log's history.
#include <string>

#include "diagnosis/effects/effect_form_helpers.h"

namespace pneumatic::diagnosis::effects {
namespace {

// heat_transfer: the gas temperature as a state (the energy equation of an open chamber with wall
// heat, Richer and Hurmuzlu 2000; docs/cylinder.md, "heat_transfer") with one wall heat conductance
// for both chambers, started from a wall time constant m c_v / (h A) of 1 s for a chamber at
// mid-stroke at 3 bar, or from the model's own
void AddEnergyEquation(const mjModel* m, const CylinderSeries& cyl, Candidate* c) {
  const std::string& n = cyl.info.name;
  const double volume = Parameter(m, n, "P.dead_volume", 1e-6) + Parameter(m, n, "P.area", 1e-4) * cyl.stroke / 2;
  double conductance = 3e5 * volume / (Parameter(m, n, "temperature", 293) * 0.4) / 1.0;
  if (Choice(m, n, "thermal_model") == "energy") {
    conductance = Parameter(m, n, "P.wall_heat_conductance", conductance);  // refit the model's own
  } else {
    c->edits.push_back({n, {"TP", "TN"}, {}, {}, {{"thermal_model", "energy"}, {"wall_heat_conductance", Number(conductance)}}});
  }
  // Neither end of the range is heat transfer a polytropic model lacks: adiabatic walls (the lower
  // end, the model without the effect) are the polytropic index at the gas' ratio of specific heats,
  // isothermal walls (the upper end, rejected as a bound) the index at 1, and the calibration fits
  // the index between the two. Only walls whose time constant is that of the motion are the effect.
  // (Counting a fit at either end as present named an energy equation with adiabatic walls on the
  // independent suite's C25, a tight spot in the bore outside the library: -12 % of the held-out
  // gap, the test gap 2.8 % worse.)
  c->parameters.push_back(KeyParameter(n, "wall_heat_conductance", conductance, 1e-3 * conductance, 1e3 * conductance, conductance, true));
}

}  // namespace

void HeatTransferForms(FormLibrary* library) {
  const mjModel* m = library->m;
  // the gas temperatures estimated over the log's history (SignalModel::history_estimate), not
  // started at the wall's in each window's warm-up (prediction.h): a gas temperature relaxes to the
  // wall's over tenths of a second, longer than a window, so from the warm-up a window starts with
  // its gas too close to the wall's temperature after a filling or a venting and the walls' effect
  // hardly shows. With that start as its first form (the history a richer form fitted only where it
  // led), heat transfer near adiabatic walls (0.6 s, the independent suite's A18, B19, C19) was
  // missed: its conductance was not determined or ran to the adiabatic end, the effect never led,
  // and the verdicts were `unexplained` or a valve delay. Over the history, A18's energy equation
  // fitted with the calibration leaves the floor (-72.3 % of the gap) and B19's is named in its
  // second round. The history costs a simulation of the whole log per evaluation, so the
  // conductance is not scanned (EffectParameter::scanned): its start, a wall time constant of 1 s at
  // mid-stroke, lies in the one basin of a range whose ends are the adiabatic and the isothermal
  // gas, the more heat the closer to isothermal. On bench_diagnose --speed's rig A log at 1 kHz
  // the fit took 11 evaluations without the scan and 22 with it; A18 and B19 end the same without it
  library->PerCylinder("heat_transfer", "gas temperature as a state, one wall heat conductance, the temperatures estimated over the log's history",
                       [m](const CylinderSeries& cyl, Candidate* c) {
    AddEnergyEquation(m, cyl, c);
    EstimatedOverTheHistory(&c->parameters.back());
    c->parameters.back().scanned = false;
  });
}

}  // namespace pneumatic::diagnosis::effects
