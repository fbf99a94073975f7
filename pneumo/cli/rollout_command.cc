#include "cli/rollout_command.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>

#include <mujoco/mujoco.h>
#include <nlohmann/json.hpp>

#include "formats/log_csv.h"
#include "formats/model_loading.h"
#include "formats/output_file.h"
#include "pneumatic/pneumatic.h"
#include "rendering/frames.h"
#include "simulation/closed_loop.h"
#include "simulation/controller_config.h"
#include "simulation/model_edits.h"
#include "simulation/parallel_for.h"
#include "simulation/rollout.h"
#include "simulation/rollout_summary.h"

namespace pneumatic {
namespace {

using nlohmann::json;

int Fail(const std::string& message) {
  std::fprintf(stderr, "pneumo rollout: %s\n", message.c_str());
  return 1;
}

std::string Substitute(std::string pattern, const std::string& run) {
  size_t at = pattern.find("{run}");
  if (at != std::string::npos) pattern.replace(at, 5, run);
  return pattern;
}

// one run: a seed, possibly with a variation of the model's parameters
struct Run {
  std::string name;
  std::uint64_t seed = 1;
  const Variation* variation = nullptr;
};

// a progress bar on stderr for one long run, redrawn at most every 0.2 s
class ProgressBar {
 public:
  explicit ProgressBar(double duration) : duration_(duration), terminal_(isatty(STDERR_FILENO)) {}
  void operator()(double fraction) {
    auto now = std::chrono::steady_clock::now();
    if (fraction < 1 && now - last_ < std::chrono::milliseconds(200)) return;
    last_ = now;
    const int width = 30, filled = static_cast<int>(fraction * width);
    std::fprintf(stderr, "%s[%.*s%*s] %3.0f %% of %g s%s", terminal_ ? "\r" : "", filled,
                 "==============================", width - filled, "", 100 * fraction, duration_,
                 terminal_ && fraction < 1 ? "" : "\n");
  }

 private:
  double duration_;
  bool terminal_;
  std::chrono::steady_clock::time_point last_{};
};

// the controller's configuration: --controller-config, else the one the model carries, else none
// (the controller's defaults), read into *base (the library's ConfigureController); *controller
// names it and its source for the summaries
std::string SetUpController(const mjModel* model, const ClosedLoopCommandOptions& options, ClosedLoopOptions* base,
                            json* controller) {
  json config;
  if (!options.controller_config_path.empty()) {
    if (std::string e = ReadJsonFile(options.controller_config_path, &config); !e.empty()) return e;
  }
  return ConfigureController(model, options.model_path, options.controller,
                             options.controller_config_path.empty() ? nullptr : &config,
                             options.controller_config_path, base, controller, [](const std::string& line) {
                               std::fprintf(stderr, "pneumo rollout: %s (--controller-config replaces it)\n",
                                            line.c_str());
                             });
}

// the --reference log into *reference (base->reference points to it), and without --duration the
// run's length from its span
std::string ReadReference(const mjModel* model, const ClosedLoopCommandOptions& options,
                          std::optional<log::Log>* reference, ClosedLoopOptions* base) {
  if (!options.reference_path.empty()) {
    log::ReadResult r = ReadModelLog(model, options.reference_path, false);
    if (!r.log) return r.error;
    *reference = std::move(r.log);
    base->reference = &**reference;
  }
  if (options.duration == 0) {
    // holding a pose has no length of its own
    if (!*reference) return "--controller needs --duration (or a --reference, whose span it then runs)";
    base->duration = (*reference)->time.back();
    char span[32];
    std::snprintf(span, sizeof span, "%g", base->duration);
    if (!(base->duration > 0)) {
      return options.reference_path + ": its last row is at t = " + span + " s, not after the run's start at 0 s: give --duration";
    }
    std::fprintf(stderr, "pneumo rollout: running the reference's %s s (--duration sets another length)\n", span);
  }
  return "";
}

// the runs: every seed, with every variation if there are any; their output paths checked before any
// runs rather than after
std::string PlanRuns(const ClosedLoopCommandOptions& options, const std::vector<Variation>& variations,
                     std::vector<Run>* runs) {
  std::set<std::uint64_t> seeds;
  for (std::uint64_t seed : options.seeds) {
    if (!seeds.insert(seed).second) {
      return "--seed " + std::to_string(seed) + " is given twice (the two runs would write the same files)";
    }
  }
  for (std::uint64_t seed : options.seeds) {
    if (variations.empty()) runs->push_back({"seed" + std::to_string(seed), seed, nullptr});
    for (const Variation& v : variations) runs->push_back({v.name + "-seed" + std::to_string(seed), seed, &v});
  }
  if (runs->size() > 1 && (options.out_path.find("{run}") == std::string::npos ||
                           (!options.summary_path.empty() && options.summary_path.find("{run}") == std::string::npos))) {
    return std::to_string(runs->size()) + " runs: --out and --summary must contain {run}, e.g. --out 'runs/{run}.csv'";
  }
  if (!options.frames_dir.empty() && runs->size() > 1) return "--frames renders one run: give one seed and no variations";
  for (const Run& run : *runs) {
    if (std::string e = CheckOutputPath(Substitute(options.out_path, run.name), "a log file"); !e.empty()) return e;
    if (!options.summary_path.empty()) {
      if (std::string e = CheckOutputPath(Substitute(options.summary_path, run.name), "a JSON file"); !e.empty()) return e;
    }
  }
  return "";
}

// what the runs of one `pneumo rollout --controller` share; `report` orders their lines on stderr
struct RunsContext {
  const ClosedLoopCommandOptions& options;
  const mjModel* model;
  const ClosedLoopOptions& base;
  const json& controller;
  bool single;  // one run: its progress bar shown
  ProgressBar bar;
  std::mutex report;
};

// the run on `copy` (its frames written with --frames) into *result; an error of the frames
std::string SimulateRun(RunsContext& context, const Run& run, const mjModel* copy, ClosedLoopResult* result) {
  const ClosedLoopCommandOptions& options = context.options;
  std::string e;
  ClosedLoopOptions o = context.base;
  o.seed = run.seed;
  if (context.single) o.progress = [&](double f) { context.bar(f); };
  std::unique_ptr<FrameWriter> frames;
  if (!options.frames_dir.empty()) {
    FrameOptions frame_options;
    frame_options.dir = options.frames_dir;
    frame_options.fps = options.fps;
    frame_options.width = options.width, frame_options.height = options.height;
    frame_options.camera = options.camera;
    frames = FrameWriter::Create(copy, frame_options, &e);
    if (frames) o.observer = [&](const mjData* d) { return frames->Offer(d); };
  }
  if (!e.empty()) return e;
  *result = RunClosedLoop(copy, o);
  if (result->log && frames) {
    e = frames->Finish();
    if (e.empty()) {
      std::lock_guard<std::mutex> lock(context.report);
      std::fprintf(stderr, "pneumo rollout: wrote %d frames to %s%s%s\n", frames->frames_written(),
                   options.frames_dir.c_str(), frames->video_path().empty() ? "" : " and ", frames->video_path().c_str());
    }
  }
  return e;
}

// the run's log and summary written, and its line on stderr
std::string WriteRunOutputs(RunsContext& context, const Run& run, ClosedLoopResult* result) {
  const ClosedLoopCommandOptions& options = context.options;
  result->log->comments.insert(result->log->comments.begin(), "model: " + options.model_path);
  result->log->comments.push_back("run " + run.name);
  std::string e = log::WriteLog(Substitute(options.out_path, run.name), *result->log);
  if (e.empty() && !options.summary_path.empty()) {
    e = WriteOutput(Substitute(options.summary_path, run.name),
                    SummaryJson(result->summary, run.name, context.controller).dump(2) + "\n", "a JSON file");
  }
  if (e.empty()) {
    std::lock_guard<std::mutex> lock(context.report);
    const std::vector<std::string>& warnings = result->summary.warnings;
    const std::string more = warnings.size() > 1 ? " (and " + std::to_string(warnings.size() - 1) +
                                                       " more warnings: --summary lists them)"
                                                 : "";
    std::fprintf(stderr, "pneumo rollout: %s: %.2f s simulated, real-time factor %.2f%s%s%s\n", run.name.c_str(),
                 result->summary.simulated_s, result->summary.real_time_factor, warnings.empty() ? "" : "; warning: ",
                 warnings.empty() ? "" : warnings.front().c_str(), more.c_str());
  }
  return e;
}

// one run on its own copy of the model: its error, or ""
std::string DoRun(RunsContext& context, const Run& run) {
  std::unique_ptr<mjModel, void (*)(mjModel*)> copy(mj_copyModel(nullptr, context.model), mj_deleteModel);
  if (run.variation) {
    if (std::string e = ApplyVariation(*run.variation, copy.get()); !e.empty()) return e;
  }
  ClosedLoopResult result;
  if (std::string e = SimulateRun(context, run, copy.get(), &result); !e.empty()) return e;
  if (!result.log) return result.error;
  return WriteRunOutputs(context, run, &result);
}

}  // namespace

int RunClosedLoopCommand(const ClosedLoopCommandOptions& options) {
  std::string error;
  ModelPtr model = LoadAttachedModel(options.model_path, &error);
  if (!model) return Fail(error);

  ClosedLoopOptions base;
  base.duration = options.duration;
  base.control_rate = options.control_rate;
  base.noise_pressure = options.noise_pressure;
  base.noise_position = options.noise_position;
  json controller;
  if (std::string e = SetUpController(model.get(), options, &base, &controller); !e.empty()) return Fail(e);
  std::optional<log::Log> reference;
  if (std::string e = ReadReference(model.get(), options, &reference, &base); !e.empty()) return Fail(e);
  std::vector<Variation> variations;
  if (!options.variations_path.empty()) {
    json list;
    if (std::string e = ReadJsonFile(options.variations_path, &list); !e.empty()) return Fail(e);
    if (std::string e = ReadVariations(list, options.variations_path, &variations); !e.empty()) return Fail(e);
  }
  std::vector<Run> runs;
  if (std::string e = PlanRuns(options, variations, &runs); !e.empty()) return Fail(e);

  // each run on its own copy of the model; workers take runs in order, outputs are per run
  size_t done = 0;  // runs finished (counted under `report`)
  std::vector<std::string> errors(runs.size());
  RunsContext context{options, model.get(), base, controller, runs.size() == 1, ProgressBar(base.duration), {}};
  ParallelFor(runs.size(), options.jobs, [&](size_t i) {
    const Run& run = runs[i];
    const std::string e = DoRun(context, run);
    errors[i] = e.empty() ? "" : run.name + ": " + e;
    if (!context.single) {
      std::lock_guard<std::mutex> lock(context.report);
      std::fprintf(stderr, "pneumo rollout: %zu of %zu runs done\n", ++done, runs.size());
    }
  });
  Detach(model.get());
  int status = 0;
  for (const std::string& e : errors) {
    if (!e.empty()) status = Fail(e);
  }
  return status;
}

}  // namespace pneumatic

namespace pneumatic::cli {
namespace {

int RunRollout(const std::string& model_path, const std::string& commands_path, const std::string& out_path,
               bool duration_given, double duration, double period, const std::vector<std::string>& sets,
               bool follow_motion) {
  if (std::string e = pneumatic::CheckOutputPath(out_path, "a log file"); !e.empty()) return Fail(e);
  AttachedModel model;
  if (std::string e = Load(model_path, &model); !e.empty()) return Fail(e);
  const mjModel* m = model.model;

  pneumatic::RolloutOptions options;
  if (duration_given) options.duration = duration;
  options.period = period;
  options.follow_motion = follow_motion;
  for (const std::string& s : sets) {
    size_t eq = s.find('=');
    char* end = nullptr;
    double value = eq == std::string::npos ? 0 : std::strtod(s.c_str() + eq + 1, &end);
    if (eq == std::string::npos || end == s.c_str() + eq + 1 || *end != '\0' || !std::isfinite(value)) {
      return Fail("--set '" + s + "': expected <cylinder>.<signal>=<number>, e.g. cyl.u=2.5");
    }
    options.constant_commands[s.substr(0, eq)] = value;
  }

  std::optional<pneumatic::log::Log> commands;
  if (!commands_path.empty()) {
    pneumatic::log::ReadResult r = pneumatic::ReadModelLog(m, commands_path, true);
    if (!r.log) return Fail(r.error);
    commands = std::move(r.log);
  }

  auto start = std::chrono::steady_clock::now();
  pneumatic::RolloutResult result = pneumatic::Rollout(m, commands ? &*commands : nullptr, options);
  if (!result.log) return Fail(result.error);
  double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.log->comments.insert(result.log->comments.begin(), "model: " + model_path);
  if (!commands_path.empty()) result.log->comments.insert(result.log->comments.begin() + 1, "commands: " + commands_path);
  if (std::string e = pneumatic::log::WriteLog(out_path, *result.log); !e.empty()) return Fail(e);
  const auto& t = result.log->time;
  std::fprintf(stderr, "pneumo: wrote %s: %zu rows, %.3f s simulated in %.3f s\n", out_path.c_str(), t.size(),
               t.empty() ? 0.0 : t.back() - t.front() + result.log->Period(), wall);
  return 0;
}

// the options of `pneumo rollout`, open and closed loop
struct RolloutArguments {
  std::string model_path, commands_path, out_path;
  double duration = 0, period = 0;
  std::vector<std::string> sets;
  bool follow_motion = false;
  pneumatic::ClosedLoopCommandOptions closed;
};

// runs `pneumo rollout` once the command line is parsed: closed loop with --controller, else open loop
int RunRolloutCommand(const CLI::App* rollout, RolloutArguments& arguments) {
  const std::string &model_path = arguments.model_path, &commands_path = arguments.commands_path,
                    &out_path = arguments.out_path;
  const double duration = arguments.duration, period = arguments.period;
  const std::vector<std::string>& sets = arguments.sets;
  const bool follow_motion = arguments.follow_motion;
  pneumatic::ClosedLoopCommandOptions& closed = arguments.closed;
  if (rollout->count("--controller") > 0) {
    if (!commands_path.empty() || !sets.empty() || follow_motion) {
      return Fail("--controller runs closed loop: it does not take --commands, --set or --follow-motion");
    }
    // without --duration, the reference's span (RunClosedLoopCommand, which refuses a run with neither)
    if (rollout->count("--duration") > 0 && !(duration > 0)) return Fail("--duration must be positive");
    closed.model_path = model_path;
    closed.duration = rollout->count("--duration") > 0 ? duration : 0;
    closed.out_path = out_path;
    if (closed.seeds.empty()) closed.seeds = {1};
    return pneumatic::RunClosedLoopCommand(closed);
  }
  for (const char* closed_only : {"--controller-config", "--reference", "--control-rate", "--seed", "--noise-pressure",
                                  "--noise-position", "--variations", "--summary", "--jobs", "--frames", "--fps",
                                  "--width", "--height", "--camera"}) {
    if (rollout->count(closed_only) > 0) return Fail(std::string(closed_only) + " needs --controller");
  }
  bool duration_given = rollout->count("--duration") > 0;
  return RunRollout(model_path, commands_path, out_path, duration_given, duration, period, sets, follow_motion);
}

}  // namespace

Command AddRolloutCommand(CLI::App& app) {
  auto arguments = std::make_shared<RolloutArguments>();
  std::string &model_path = arguments->model_path, &commands_path = arguments->commands_path,
              &out_path = arguments->out_path;
  double &duration = arguments->duration, &period = arguments->period;
  std::vector<std::string>& sets = arguments->sets;
  CLI::App* rollout = app.add_subcommand("rollout", "replay a log's commands open loop from its first measured state");
  rollout->add_option("model", model_path, "MJCF model with pneumatic cylinders")->required();
  rollout->add_option("--commands", commands_path, "log (docs/log_format.md) whose command columns are replayed");
  rollout->add_option("--out", out_path, "simulated log to write")->required();
  rollout->add_option("--duration", duration,
                      "seconds to simulate (default: the whole --commands log; with --controller, the --reference's span)");
  rollout->add_option("--period", period, "row period without a command log, s (default 1 ms)");
  rollout->add_option("--set", sets, "constant command, e.g. --set cyl.u=2.5 (repeatable)");
  bool& follow_motion = arguments->follow_motion;
  rollout->add_flag("--follow-motion", follow_motion,
                    "reset pistons to the log's x and v at every row: simulate pressures only (paper 000 V.D)");
  pneumatic::ClosedLoopCommandOptions& closed = arguments->closed;
  rollout->add_option("--controller", closed.controller,
                      "closed loop: pid (a PID on every cylinder's position, any valve), none (valves at rest), "
                      "position_stiffness (per-chamber valves: position and co-contraction, paper 000's set-up), "
                      "sliding3 or sliding7 (paper 002, on/off valves), karpenko (paper 001's PI, a 5/3 valve), "
                      "laib (paper 003's sliding-mode controller with observers, on/off valves on PWM)")
      ->check(CLI::IsMember({"pid", "none", "position_stiffness", "sliding3", "sliding7", "karpenko", "laib"}));
  rollout->add_option("--controller-config", closed.controller_config_path,
                      "JSON of the controller's keys. pid: kp, ki, kd (on the error over the half stroke), "
                      "co_contraction and swing (V), onoff_band, bandwidth (rad/s: gains raised per cylinder to its load), "
                      "pressure_margin (Pa: per-chamber valves follow pressure targets inside "
                      "[p_exhaust + margin, p_supply - margin]), pressure_step (the fraction of a pressure error each "
                      "control period aims to close, default 0.25), "
                      "\"cylinders\": {NAME: {...}}; the others: a flat "
                      "object of numbers, keys and units in their headers (controllers/*.h); an unknown or "
                      "out-of-range key is refused, named. Default: the configuration the model carries, "
                      "<text name=\"pneumo:controller:NAME\" data='{...}'> in its <custom>, if it has one");
  rollout->add_option("--reference", closed.reference_path, "log with <cylinder>.ref columns: the targets (default: hold the initial pose)");
  rollout->add_option("--control-rate", closed.control_rate, "controller ticks per second (commands held between)")
      ->capture_default_str();
  rollout->add_option("--seed", closed.seeds, "seed of the sensor noise; several: one run each (repeatable)");
  rollout->add_option("--noise-pressure", closed.noise_pressure, "pressure sensor noise seen and logged, Pa (std)");
  rollout->add_option("--noise-position", closed.noise_position, "position sensor noise seen and logged, m or rad (std)");
  rollout->add_option("--variations", closed.variations_path,
                      "JSON [{\"name\": ..., \"set\": {\"cyl:key\": value}}]: one run per variation and seed; keys "
                      "<cylinder>:<key>, body:<name>:mass, joint:<name>:damping, joint:<name>:frictionloss");
  rollout->add_option("--summary", closed.summary_path,
                      "JSON summary: the controller and where its configuration came from, steps, real-time factor, "
                      "tracking errors, pressure ranges, warnings");
  rollout->add_option("--jobs", closed.jobs, "runs at once, each on its own copy of the model")->check(CLI::Range(1, 256));
  rollout->add_option("--frames", closed.frames_dir,
                      "closed loop: write rendered frames DIR/frame_00000.png... (and DIR/video.mp4 with ffmpeg)");
  rollout->add_option("--fps", closed.fps, "frames per second of simulated time")->capture_default_str();
  rollout->add_option("--width", closed.width, "frame width, pixels")->capture_default_str()->check(CLI::Range(1, 8192));
  rollout->add_option("--height", closed.height, "frame height, pixels")->capture_default_str()->check(CLI::Range(1, 8192));
  rollout->add_option("--camera", closed.camera, "a camera of the model (default: a free camera on the whole model)");
  return {rollout, [rollout, arguments] { return RunRolloutCommand(rollout, *arguments); }};
}

}  // namespace pneumatic::cli
