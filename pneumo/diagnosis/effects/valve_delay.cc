// valve_delay (docs/effects.md): what delays the valve's response beyond the nominal valve. Three
// forms: the valve's own lag (an on/off valve's armature delays), a dead time before that lag, and
// an exact dead time of the commands.
#include <string>

#include "diagnosis/effects/effect_form_helpers.h"

namespace pneumatic::diagnosis::effects {
namespace {

// valve_delay: what delays the valve's response beyond the nominal valve
void ValveLag(FormLibrary* library) {
  const mjModel* m = library->m;
  library->PerCylinder("valve_delay", "", [&](const CylinderSeries& cyl, Candidate* c) {
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
}

// valve_delay, second form: a dead time before the spool's lag (a valve driver's or a field bus'
// latency, a slow solenoid that moves only after a while): the command reaches the valve through the
// (1,2) Pade delay line of spool_dead_time (plugin/src/valves.h, ValveSignal), then the lag of the
// first form. A refinement (candidates.h): a lag alone is its limit of a vanishing dead time
void DeadTimeBeforeLag(FormLibrary* library) {
  const mjModel* m = library->m;
  library->PerCylinder("valve_delay", "a valve dead time (Pade delay line) before a first-order lag", [&](const CylinderSeries& cyl, Candidate* c) {
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
}

// valve_delay, third form: an exact dead time of the commands (a field bus', a valve driver's or a
// controller's latency): the valves act on the logged commands that much later (SignalModel,
// prediction.h), the nominal valve behind it. The project's own form, for every valve: an on/off
// valve opens at a command of 1/2 or more (plugin/src/valves.cc), so the delayed command's mean over
// a step switches it at the model step nearest the delayed switch (rig A: to 50 us), where the
// armature delays of the first form lose pulses shorter than their opening delay. A refinement
// (candidates.h) as the Pade form is: fitted in the rounds where valve_delay is one of the two refined effects (diagnose.cc). Up to 50 ms, scanned
// in half rows: the prediction error has a local minimum wherever the delayed commands line up with
// the log's own oscillations (on a 500 Hz rig C log of an 8 ms latency, at 3.5, 5.5, 8 and 11 ms;
// the true one's basin about a row wide)
void CommandLatency(FormLibrary* library) {
  const Measurements& meas = library->meas;
  library->PerCylinder("valve_delay", "an exact dead time of the valve commands (a latency), the nominal valve behind it",
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
}

}  // namespace

void ValveDelayForms(FormLibrary* library) {
  ValveLag(library);
  DeadTimeBeforeLag(library);
  CommandLatency(library);
}

}  // namespace pneumatic::diagnosis::effects
