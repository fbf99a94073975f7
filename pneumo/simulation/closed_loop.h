// Closed-loop rollout: a model with pneumatic cylinders driven by a feedback controller at its
// own control rate, as on a real robot, recorded in the log format (`pneumo rollout --controller`).
//
// At every control tick t_k = k T (T = 1 / control_rate, a whole number of model steps) the
// controller reads each cylinder's measured p_P, p_N and x (with optional seeded sensor noise)
// and its reference, and writes the valve commands, held until the next tick (zero-order hold).
// The log has one row per tick: the commands of that tick, and the measured p_P, p_N, x, v, p_S
// and ref sampled at t_k before the tick's commands act (docs/log_format.md). The run
// starts from the model's first keyframe if it has one, else its reset state (chambers at
// atmospheric pressure, qpos0). Same options, same log, bit for bit, in any thread.
#ifndef PNEUMATIC_CLOSED_LOOP_H_
#define PNEUMATIC_CLOSED_LOOP_H_

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "controller.h"
#include "formats/log_csv.h"
#include "position_pid.h"

namespace pneumatic {

// Everything a closed-loop run needs to continue where it stopped: resuming from it (options.resume)
// gives the rows the uninterrupted run would have given, bit for bit.
struct ClosedLoopState {
  // mjData: time, qpos, qvel, act, ctrl, qacc_warmstart (the constraint solver's start),
  // qfrc_applied, xfrc_applied (a tick measures x and v from qpos and qvel at its own time)
  std::vector<double> mujoco;
  std::vector<double> controller;  // Controller::State()
  std::vector<double> hold;        // each cylinder's target when it has no reference
  std::vector<std::string> noise;  // each cylinder's sensor-noise stream
};

struct ClosedLoopOptions {
  double duration = 0;        // s, > 0
  double control_rate = 100;  // Hz: paper 000's loop
  // "pid": PositionPid on every cylinder; "none": every valve held at rest (per-chamber valves at
  // their centre, 5/3 at 0, on/off closed): the passive model; "custom": make_controller's
  std::string controller = "pid";
  // with controller "custom": builds the run's controller from the cylinders' valve drives (in
  // the order of pneumatic::Cylinders) and the control period; null and *error on failure
  std::function<std::unique_ptr<Controller>(const std::vector<ValveDrive>&, double period, std::string* error)>
      make_controller;
  PositionPidGains gains;                                  // every cylinder ...
  std::map<std::string, PositionPidGains> cylinder_gains;  // ... unless given here by name
  // targets "<cyl>.ref" (m or rad), linear between the rows; a cylinder without a column (or
  // without a reference log) holds its initial position; after the last row, the last value
  const log::Log* reference = nullptr;
  std::uint64_t seed = 1;
  double noise_pressure = 0;  // Pa: std of the Gaussian noise on the measured p_P, p_N
  double noise_position = 0;  // m or rad: on the measured x
  // the valves receive each tick's commands this many ticks late: a field bus' latency, an exact
  // dead time that no valve model has (bench_diagnose's valve_delay truth of another form). The
  // log holds the commands as the controller sent them; the valves stay at rest until the first
  // arrives. Not with `resume`
  int command_delay_ticks = 0;
  // called now and then with the fraction done (0..1), for a progress display
  std::function<void(double)> progress;
  // continue a run from its final_state instead of the model's initial state (same model and
  // options); `duration` is then the time to add
  const ClosedLoopState* resume = nullptr;
  // called with the state before the first step and after every step (e.g. to render frames);
  // a non-empty return ends the run with that error
  std::function<std::string(const mjData*)> observer;
};

// What a run did, for `--summary`.
struct CylinderSummary {
  std::string name;
  double rms_tracking_error = 0, max_tracking_error = 0;  // |ref - x| over the ticks, m or rad
  double p_min[2] = {0, 0}, p_max[2] = {0, 0};  // Pa abs, chambers P and N, over every step
  bool within_supply_range = true;  // every chamber pressure, at every step, in [p_exhaust, p_supply] (+-1 Pa)
};
struct ClosedLoopSummary {
  long steps = 0;
  double simulated_s = 0, wall_s = 0, real_time_factor = 0;
  std::vector<CylinderSummary> cylinders;
  std::vector<std::string> warnings;  // references beyond a stroke, chambers outside the supply range, MuJoCo warnings raised
};

struct ClosedLoopResult {
  std::optional<log::Log> log;
  ClosedLoopSummary summary;
  ClosedLoopState final_state;  // to resume from
  std::string error;
};

// Runs m (attached) closed loop. A diverging simulation (MuJoCo's bad qacc or qvel) ends the run
// with an error naming the time.
ClosedLoopResult RunClosedLoop(const mjModel* m, const ClosedLoopOptions& options);

}  // namespace pneumatic

#endif  // PNEUMATIC_CLOSED_LOOP_H_
