// `pneumo rollout`: open loop, a log's commands replayed or constant commands (simulation/rollout.h);
// with a controller, closed-loop runs (simulation/closed_loop.h), several at once on copies of the
// model (--jobs), with a JSON summary per run and a progress display.
#ifndef PNEUMATIC_CLI_ROLLOUT_COMMAND_H_
#define PNEUMATIC_CLI_ROLLOUT_COMMAND_H_

#include <cstdint>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "cli/command_support.h"

namespace pneumatic {

struct ClosedLoopCommandOptions {
  std::string model_path;
  std::string controller = "pid";       // pid or none
  std::string controller_config_path;   // optional JSON of PositionPidGains (see ReadControllerConfig)
  std::string reference_path;           // optional log with <cyl>.ref columns
  double duration = 0;                  // s; 0: the reference's span, from t = 0 to its last row
  double control_rate = 100;            // Hz
  std::vector<std::uint64_t> seeds = {1};
  double noise_pressure = 0, noise_position = 0;
  std::string variations_path;          // optional JSON: [{"name": ..., "set": {"cyl:key": value}}, ...]
  std::string out_path;                 // log; with several runs it must contain "{run}"
  std::string summary_path;             // optional JSON; with several runs it must contain "{run}"
  int jobs = 1;                         // runs at once, each on its own copy of the model
  std::string frames_dir;               // optional: rendered frames of the run (one run only)
  double fps = 30;
  int width = 640, height = 480;
  std::string camera;                   // "" = a free camera looking at the whole model
};

// Runs the command; returns the exit code (0, or 1 with a message on stderr).
int RunClosedLoopCommand(const ClosedLoopCommandOptions& options);

}  // namespace pneumatic

namespace pneumatic::cli {

// Adds `pneumo rollout` to app: open loop (a log's commands replayed, constant commands), or closed
// loop with --controller (RunClosedLoopCommand).
Command AddRolloutCommand(CLI::App& app);

}  // namespace pneumatic::cli

#endif  // PNEUMATIC_CLI_ROLLOUT_COMMAND_H_
