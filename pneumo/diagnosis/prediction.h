// Short-horizon predictions of a measured closed-loop log (issue 14, "Where"). A closed-loop log
// cannot be replayed open loop for long: without the unknown controller's feedback, any model
// error makes the position drift away. So the log is cut into windows of a few tenths of a second;
// each window restarts the model from the measured state and predicts the window's rows from its
// commands, the project's own multi-step form of paper 000's pressure prediction (Section V.D):
//
//   full        pressures and motion simulated from the measured state at the window's start;
//   pneumatic   pressures simulated with the pistons following the measured motion (paper 000
//               Section II.5: given the volume and its rate, the pressure dynamics do not depend
//               on the mechanics);
//   mechanical  motion simulated with the chamber pressures held to the measured ones.
//
// The state at a window's start: measured p_P, p_N, x (through the inverse of the signal model's
// sensors) and, where the window simulates the motion, the velocity fitted over the warm-up's rows
// (the positions the model simulates from the fit's start match the measured ones best); states no
// sensor gives (spool, armature, gas temperature, bristle) are estimated by the warm-up: the model
// runs the rows before the window with its pressures reset to the measured ones at every row (and
// its motion, for the pneumatic side), so those states follow the logged commands; a line's
// pressure starts it at its chamber's measured one. A state far slower than the
// warm-up, a supply reservoir's pressure (it sags and refills over seconds), is estimated over the
// whole history instead: an observer runs the log that way from its first row and hands each
// window its states at the warm-up's first row (EstimatesOverTheHistory; a gas temperature, which
// relaxes over tenths of a second, when the signal model asks for it: SignalModel::history_estimate).
#ifndef PNEUMATIC_DIAGNOSIS_PREDICTION_H_
#define PNEUMATIC_DIAGNOSIS_PREDICTION_H_

#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "diagnosis/measurements.h"

namespace pneumatic::diagnosis {

// How the log's signals relate to the model's (the project's own measurement model): the identity
// unless a candidate changes it.
//   Sensors (sensor_bias): what a sensor reports for the true value y, reference + offset +
//   gain (y - reference), per signal (3 per cylinder), the reference being p_atm for a pressure (a
//   gauge sensor's gain acts on the gauge pressure; about 0 Pa offset and gain would be nearly
//   collinear) and 0 for x.
//   Commands (valve_delay's exact dead time): the valves of cylinder c act on the logged commands
//   command_delay[c] seconds late, held over their rows (zero-order hold) as the controller held
//   them. Each model step gets the delayed commands' mean over the step, so a proportional valve's
//   prediction is continuous in the delay (a fit can follow it between steps); an on/off valve,
//   open at 1/2 or more, switches at the model step nearest the delayed switch.
//   Supply (supply_drop's logged form, logged_supply): the valves of each cylinder see the logged
//   p_S, less the p_S sensor's supply_offset, on the straight line between its rows; the model
//   holds it in a reservoir that feeds the cylinder alone (the candidate adds it), set at every
//   model step.
struct SignalModel {
  std::vector<double> offset, gain, reference;
  std::vector<double> command_delay;  // s, per cylinder
  // the unmeasured states start each window from the history estimate (Predict) also in a model
  // without a reservoir: heat_transfer's form sets it for its gas temperatures
  bool history_estimate = false;
  bool logged_supply = false;
  double supply_offset = 0;  // Pa
  static SignalModel Identity(const Measurements& meas);
  double Measured(int signal, double truth) const { return reference[signal] + offset[signal] + gain[signal] * (truth - reference[signal]); }
  double Truth(int signal, double measured) const { return reference[signal] + (measured - reference[signal] - offset[signal]) / gain[signal]; }
};

enum class PredictionKind { kFull, kPneumatic, kMechanical };
const char* PredictionKindName(PredictionKind kind);  // "full", "pneumatic", "mechanical"

struct Windows {
  int horizon_rows = 0;  // rows predicted per window
  int warmup_rows = 0;   // rows before each window that estimate the unmeasured states
  std::vector<int> starts;  // the row each window starts from; it predicts rows start+1 .. start+horizon
};

// Windows of `horizon_rows` tiling rows [warmup, rows), back to back.
Windows MakeWindows(int rows, int horizon_rows, int warmup_rows);

// Every stride-th window of w from its first, the stride raised as far as needed to keep at most
// max_windows of them (0: no limit): windows spread over the whole log at a bounded cost.
Windows EveryNthWindow(const Windows& w, int stride, int max_windows);

// simulated[signal][row] as the sensors would report it; NaN in rows no window predicts (the
// warm-up of the first window, each window's start row, a last partial window)
struct Prediction {
  std::vector<std::vector<double>> simulated;
  std::string error;  // non-empty: the model diverged or refused the state; `simulated` is incomplete
};

// True if m has a state far slower than a warm-up, a supply reservoir (unless the log gives its
// pressure: SignalModel::logged_supply, whose candidate is offered only for a model without
// reservoirs of its own), or the signal model asks for it (SignalModel::history_estimate): Predict
// then estimates the unmeasured states over the log's whole history, at the cost of one more
// simulation of the log (on a thread of its own when there are two or more, on which the windows
// wait). A gas temperature (thermal_model=energy) relaxes over tenths of a second and gains from it
// too: heat_transfer's form asks for it (a 20 ms warm-up hardly shows a wall near adiabatic).
bool EstimatesOverTheHistory(const mjModel* m, const SignalModel& signals);

// Predicts `meas` with m (attached) on up to `threads` threads (windows are independent; each
// thread has its own mjData, and each window writes only its own rows: the result does not depend
// on the thread count).
Prediction Predict(const mjModel* m, const Measurements& meas, const SignalModel& sensors, const Windows& windows,
                   PredictionKind kind, int threads);

}  // namespace pneumatic::diagnosis

#endif  // PNEUMATIC_DIAGNOSIS_PREDICTION_H_
