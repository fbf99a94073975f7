#include "cli/rollout_command.h"

#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>

#include <mujoco/mujoco.h>
#include <nlohmann/json.hpp>

#include "simulation/closed_loop.h"
#include "simulation/controller_config.h"
#include "karpenko_pid.h"
#include "laib_smc.h"
#include "position_stiffness.h"
#include "sliding_mode.h"
#include "formats/log_csv.h"
#include "formats/model_loading.h"
#include "formats/output_file.h"
#include "simulation/parallel_for.h"
#include "pneumatic/pneumatic.h"
#include "rendering/frames.h"

namespace pneumatic {
namespace {

using nlohmann::json;

int Fail(const std::string& message) {
  std::fprintf(stderr, "pneumo rollout: %s\n", message.c_str());
  return 1;
}

// The papers' controllers take "key=value ..." configurations (their key tables name units and
// ranges); their JSON configuration gives them as a flat object of numbers.
std::string JsonToKeyValues(const json& config, const std::string& where, std::string* text) {
  if (!config.is_object()) return where + ": expected a JSON object of key: number";
  for (const auto& [key, value] : config.items()) {
    if (!value.is_number()) return where + ": key '" + key + "' must be a number";
    char number[64];
    std::snprintf(number, sizeof(number), "%.17g", value.get<double>());
    *text += key + "=" + number + " ";
  }
  return "";
}

// the factory of one of the papers' controllers, its configuration (`config` from `where`, if any)
// read now (errors name the key)
std::string PaperController(const std::string& name, const json* config, const std::string& where,
                            ClosedLoopOptions* out) {
  std::string text;
  if (config) {
    if (std::string e = JsonToKeyValues(*config, where, &text); !e.empty()) return e;
  }
  std::string error;
  out->controller = "custom";
  if (name == "sliding3" || name == "sliding7") {
    SlidingModeParams params;
    params.modes = name == "sliding3" ? 3 : 7;
    if (!text.empty() && !ParseSlidingModeConfig(text, &params, &error)) return where + ": " + error;
    out->make_controller = [params](const std::vector<ValveDrive>& drives, double period, std::string* e) {
      std::vector<ValveDrive> copy = drives;
      SlidingModeParams p = params;
      if (!drives.empty()) p.p_supply = drives[0].p_supply, p.p_exhaust = drives[0].p_exhaust;
      return std::unique_ptr<Controller>(SlidingModeController::Create(copy, p, period, e));
    };
  } else if (name == "karpenko") {
    KarpenkoPidParams params;
    if (!text.empty() && !ParseKarpenkoPidConfig(text, &params, &error)) return where + ": " + error;
    out->make_controller = [params](const std::vector<ValveDrive>& drives, double period, std::string* e) {
      return std::unique_ptr<Controller>(KarpenkoPid::Create(drives, params, period, e));
    };
  } else if (name == "laib") {
    LaibSmcParams params;
    if (!text.empty() && !ParseLaibSmcConfig(text, &params, &error)) return where + ": " + error;
    out->make_controller = [params](const std::vector<ValveDrive>& drives, double period, std::string* e) {
      return std::unique_ptr<Controller>(LaibSmcController::Create(drives, params, period, e));
    };
  } else if (name == "position_stiffness") {
    PositionStiffnessParams params;
    if (std::string e = ParsePositionStiffnessConfig(text, &params); !e.empty()) return where + ": " + e;
    out->make_controller = [params](const std::vector<ValveDrive>& drives, double period, std::string* e) {
      return std::unique_ptr<Controller>(PositionStiffness::Create(drives, params, period, e));
    };
  } else {
    return "unknown controller '" + name + "'";
  }
  return "";
}

struct Variation {
  std::string name;                                          // "" for the model as it is
  std::vector<std::pair<std::string, double>> parameters;    // "cyl:key" -> value
};

std::string ReadVariations(const std::string& path, std::vector<Variation>* out) {
  json list;
  if (std::string e = ReadJsonFile(path, &list); !e.empty()) return e;
  if (!list.is_array() || list.empty()) return path + ": expected a non-empty array of {\"name\", \"set\"}";
  for (const json& item : list) {
    if (!item.is_object() || !item.contains("name") || !item["name"].is_string() || !item.contains("set") ||
        !item["set"].is_object()) {
      return path + ": every variation needs \"name\" (text) and \"set\" ({\"cyl:key\": number})";
    }
    Variation v{item["name"].get<std::string>(), {}};
    // the name goes into the output file names ({run}): a plain, unique file name part
    if (v.name.empty() || v.name.find_first_of("/\\") != std::string::npos || v.name == "." || v.name == "..") {
      return path + ": variation name '" + v.name + "' must be a non-empty file name part, without '/'";
    }
    for (const Variation& earlier : *out) {
      if (earlier.name == v.name) return path + ": two variations are named '" + v.name + "' (their outputs would collide)";
    }
    for (const auto& [key, value] : item["set"].items()) {
      if (!value.is_number()) return path + ": variation '" + v.name + "': '" + key + "' must be a number";
      v.parameters.emplace_back(key, value.get<double>());
    }
    out->push_back(v);
  }
  return "";
}

// `controller`: its name and where its configuration came from (a file, the model, its defaults)
json SummaryJson(const ClosedLoopSummary& s, const std::string& run, const json& controller) {
  json cylinders = json::object();
  for (const CylinderSummary& c : s.cylinders) {
    cylinders[c.name] = {{"rms_tracking_error", c.rms_tracking_error},
                         {"max_tracking_error", c.max_tracking_error},
                         {"p_P_range_pa", {c.p_min[0], c.p_max[0]}},
                         {"p_N_range_pa", {c.p_min[1], c.p_max[1]}},
                         {"within_supply_range", c.within_supply_range}};
  }
  return {{"run", run},
          {"controller", controller},
          {"steps", s.steps},
          {"simulated_s", s.simulated_s},
          {"wall_s", s.wall_s},
          {"real_time_factor", s.real_time_factor},
          {"cylinders", cylinders},
          {"warnings", s.warnings}};
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

}  // namespace

int RunClosedLoopCommand(const ClosedLoopCommandOptions& options) {
  std::string error;
  ModelPtr model = LoadAttachedModel(options.model_path, &error);
  if (!model) return Fail(error);

  ClosedLoopOptions base;
  base.controller = options.controller;
  base.duration = options.duration;
  base.control_rate = options.control_rate;
  base.noise_pressure = options.noise_pressure;
  base.noise_position = options.noise_position;
  // the controller's configuration: --controller-config, else the one the model carries, else none
  // (the controller's defaults)
  json config;
  std::string config_source = options.controller_config_path;
  bool configured = !config_source.empty();
  if (configured) {
    if (std::string e = ReadJsonFile(config_source, &config); !e.empty()) return Fail(e);
  } else if (std::string e = ModelControllerConfig(model.get(), options.controller, &config, &config_source, &configured);
             !e.empty()) {
    return Fail(options.model_path + ": " + e);
  } else if (configured) {
    config_source = options.model_path + ": " + config_source;
    std::fprintf(stderr, "pneumo rollout: %s configuration from %s (--controller-config replaces it)\n",
                 options.controller.c_str(), config_source.c_str());
  }
  if (options.controller == "pid" || options.controller == "none") {
    if (configured) {
      if (std::string e = ReadControllerConfig(config, config_source, &base); !e.empty()) return Fail(e);
    }
  } else if (std::string e = PaperController(options.controller, configured ? &config : nullptr,
                                             configured ? config_source : options.controller, &base);
             !e.empty()) {
    return Fail(e);
  }
  const json controller = {{"name", options.controller},
                           {"configuration", configured ? config_source : "the controller's defaults"}};
  std::optional<log::Log> reference;
  if (!options.reference_path.empty()) {
    log::ReadOptions read;
    for (const CylinderInfo& c : Cylinders(model.get())) read.cylinders.insert(c.name);
    read.uniform_time = false;
    log::ReadResult r = log::ReadLog(options.reference_path, read);
    if (!r.log) return Fail(r.error);
    reference = std::move(r.log);
    base.reference = &*reference;
  }
  if (options.duration == 0) {
    // holding a pose has no length of its own
    if (!reference) return Fail("--controller needs --duration (or a --reference, whose span it then runs)");
    base.duration = reference->time.back();
    char span[32];
    std::snprintf(span, sizeof span, "%g", base.duration);
    if (!(base.duration > 0)) {
      return Fail(options.reference_path + ": its last row is at t = " + span + " s, not after the run's start at 0 s: give --duration");
    }
    std::fprintf(stderr, "pneumo rollout: running the reference's %s s (--duration sets another length)\n", span);
  }
  std::vector<Variation> variations;
  if (!options.variations_path.empty()) {
    if (std::string e = ReadVariations(options.variations_path, &variations); !e.empty()) return Fail(e);
  }

  std::vector<Run> runs;
  std::set<std::uint64_t> seeds;
  for (std::uint64_t seed : options.seeds) {
    if (!seeds.insert(seed).second) {
      return Fail("--seed " + std::to_string(seed) + " is given twice (the two runs would write the same files)");
    }
  }
  for (std::uint64_t seed : options.seeds) {
    if (variations.empty()) runs.push_back({"seed" + std::to_string(seed), seed, nullptr});
    for (const Variation& v : variations) runs.push_back({v.name + "-seed" + std::to_string(seed), seed, &v});
  }
  if (runs.size() > 1 && (options.out_path.find("{run}") == std::string::npos ||
                          (!options.summary_path.empty() && options.summary_path.find("{run}") == std::string::npos))) {
    return Fail(std::to_string(runs.size()) + " runs: --out and --summary must contain {run}, e.g. --out 'runs/{run}.csv'");
  }

  if (!options.frames_dir.empty() && runs.size() > 1) {
    return Fail("--frames renders one run: give one seed and no variations");
  }
  // every run's outputs, checked before any runs rather than after
  for (const Run& run : runs) {
    if (std::string e = CheckOutputPath(Substitute(options.out_path, run.name), "a log file"); !e.empty()) return Fail(e);
    if (!options.summary_path.empty()) {
      if (std::string e = CheckOutputPath(Substitute(options.summary_path, run.name), "a JSON file"); !e.empty()) return Fail(e);
    }
  }
  // each run on its own copy of the model; workers take runs in order, outputs are per run
  size_t done = 0;  // runs finished (counted under `report`)
  std::mutex report;
  std::vector<std::string> errors(runs.size());
  const bool single = runs.size() == 1;
  ProgressBar bar(base.duration);
  ParallelFor(runs.size(), options.jobs, [&](size_t i) {
    const Run& run = runs[i];
    std::unique_ptr<mjModel, void (*)(mjModel*)> copy(mj_copyModel(nullptr, model.get()), mj_deleteModel);
    std::string e;
    if (run.variation) {
      for (const auto& [name, value] : run.variation->parameters) {
        const size_t colon = name.find(':');
        if (colon == std::string::npos) {
          e = "variation '" + run.variation->name + "': '" + name + "' is not <cylinder>:<key>";
        } else if (!SetParameter(copy.get(), name.substr(0, colon), name.substr(colon + 1), value, &e)) {
          e = "variation '" + run.variation->name + "': " + e;
        }
        if (!e.empty()) break;
      }
    }
    if (e.empty()) {
      ClosedLoopOptions o = base;
      o.seed = run.seed;
      if (single) o.progress = [&](double f) { bar(f); };
      std::unique_ptr<FrameWriter> frames;
      if (!options.frames_dir.empty()) {
        FrameOptions frame_options;
        frame_options.dir = options.frames_dir;
        frame_options.fps = options.fps;
        frame_options.width = options.width, frame_options.height = options.height;
        frame_options.camera = options.camera;
        frames = FrameWriter::Create(copy.get(), frame_options, &e);
        if (frames) o.observer = [&](const mjData* d) { return frames->Offer(d); };
      }
      ClosedLoopResult result = e.empty() ? RunClosedLoop(copy.get(), o) : ClosedLoopResult{};
      if (e.empty() && result.log && frames) {
        e = frames->Finish();
        if (e.empty()) {
          std::lock_guard<std::mutex> lock(report);
          std::fprintf(stderr, "pneumo rollout: wrote %d frames to %s%s%s\n", frames->frames_written(),
                       options.frames_dir.c_str(), frames->video_path().empty() ? "" : " and ",
                       frames->video_path().c_str());
        }
      }
      if (!e.empty()) {
        // nothing more to do for this run
      } else if (!result.log) {
        e = result.error;
      } else {
        result.log->comments.insert(result.log->comments.begin(), "model: " + options.model_path);
        result.log->comments.push_back("run " + run.name);
        e = log::WriteLog(Substitute(options.out_path, run.name), *result.log);
        if (e.empty() && !options.summary_path.empty()) {
          e = WriteOutput(Substitute(options.summary_path, run.name), SummaryJson(result.summary, run.name, controller).dump(2) + "\n",
                          "a JSON file");
        }
        if (e.empty()) {
          std::lock_guard<std::mutex> lock(report);
          const std::vector<std::string>& warnings = result.summary.warnings;
          const std::string more = warnings.size() > 1 ? " (and " + std::to_string(warnings.size() - 1) +
                                                             " more warnings: --summary lists them)"
                                                       : "";
          std::fprintf(stderr, "pneumo rollout: %s: %.2f s simulated, real-time factor %.2f%s%s%s\n", run.name.c_str(),
                       result.summary.simulated_s, result.summary.real_time_factor, warnings.empty() ? "" : "; warning: ",
                       warnings.empty() ? "" : warnings.front().c_str(), more.c_str());
        }
      }
    }
    errors[i] = e.empty() ? "" : run.name + ": " + e;
    if (!single) {
      std::lock_guard<std::mutex> lock(report);
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
