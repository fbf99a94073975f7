// Open-loop rollout: replay the command columns of a log through a model with
// the pneumatic extension attached, and record the simulated log.
#ifndef PNEUMATIC_ROLLOUT_H_
#define PNEUMATIC_ROLLOUT_H_

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "pneumatic/pneumatic.h"

#include "formats/log_csv.h"

namespace pneumatic {

struct RolloutOptions {
  // simulate only rows with time - time[0] < duration (s); unset: the whole log.
  // Without a command log: the length of the run (required). Must be positive.
  std::optional<double> duration;
  // constant commands "<cylinder>.<signal>" -> value, overriding (or, without a
  // log, setting) that command column for every row; unset commands are 0
  std::map<std::string, double> constant_commands;
  // sample period of the output without a command log (s); 0: 1 ms rounded to whole steps
  double period = 0;
  // move each piston along the log's measured x and v (a cubic Hermite curve between rows: its
  // joint, or with mount=hinge_sites its hinge at the angle that gives that x) instead of
  // simulating the mechanics, so only the pressures are simulated: paper 000's multi-step
  // pressure prediction (Section V.D), which separates the pressure model from the mechanics
  // (Section II.5)
  bool follow_motion = false;
};

struct RolloutResult {
  std::optional<log::Log> log;  // the simulated log, or nullopt and `error`
  std::string error;
};

// Replays `commands` (may be null) through m, which must be attached.
// The state starts from the log's first row: chamber pressures p_P, p_N and
// the position x and velocity v of joint-driven and mount=hinge_sites cylinders; what the log does
// not give starts from the model's reset state (atmospheric chambers, qpos0).
// Each row's commands are held for one row period (zero-order hold), which
// must be a whole number of model timesteps. The result has the command
// columns as given and, for every cylinder, the measured columns p_P, p_N, x,
// v, p_S sampled at each row's time before that row's command acts.
RolloutResult Rollout(const mjModel* m, const log::Log* commands, const RolloutOptions& options);

// The first value of `log` that no sensor or valve of m can give, as "FILE:LINE:COLUMN: message"
// (log::Log::Where), or "": an absolute pressure (p_P, p_N, p_S) <= 0 Pa or above 10 p_supply, a
// position x beyond its cylinder's stroke by more than 10 % of the stroke (the margin a sensor's
// noise and calibration may take), a command outside its actuator's ctrlrange. Every tool that
// reads a log of m checks it, every row (the replay itself reads only the first row's state).
std::string CheckMeasurements(const mjModel* m, const log::Log& log);

// Reads the log file at `path` for m: every column must name a cylinder of m; `uniform_time` as in
// log::ReadOptions (a command log's rows are evenly spaced, a reference's need not be).
log::ReadResult ReadModelLog(const mjModel* m, const std::string& path, bool uniform_time);

// The cylinders of an attached model; "" or why there are none to drive: the model has no
// "pneumatic:" text, or has some but was not attached.
std::string AttachedCylinders(const mjModel* m, std::vector<CylinderInfo>* cylinders);

}  // namespace pneumatic

#endif  // PNEUMATIC_ROLLOUT_H_
