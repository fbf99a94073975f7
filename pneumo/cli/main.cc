// pneumo: the command line of the pneumatic extension for MuJoCo 2.2.
//
//   pneumo rollout MODEL.xml --commands LOG.csv --out OUT.csv   replay a log open loop
//   pneumo rollout MODEL.xml --duration 2 --set cyl.u=2.5 --out OUT.csv
//   pneumo rollout MODEL.xml --controller pid --reference GESTURE.csv --duration 10 --out OUT.csv   closed loop
//   pneumo generate MODEL.xml --duration 100 --seed 1 --out LOG.csv   closed-loop identification log (rig C)
//   pneumo identify MODEL.xml LOG.csv --out PARAMS.json --heldout LOG2.csv   fit paper 000's model and physical parameters
//   pneumo render MODEL.xml --out frame.png [--log LOG.csv --time T]   a picture, off screen (OSMesa)
//   pneumo reproduce karpenko2006|hodgson2012|laib2021 [--out DIR]                  a paper's experiment rerun in simulation
//   pneumo info MODEL.xml                                       cylinders and their signals
//   pneumo params [--markdown]                                  the MJCF parameter table
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <set>
#include <string>

#include <CLI/CLI.hpp>
#include <mujoco/mujoco.h>

#include "simulation/controller_config.h"
#include "diagnosis/report.h"
#include "simulation/generate.h"
#include "identification/identify_log.h"
#include "formats/log_csv.h"
#include "formats/output_file.h"
#include "pneumatic/pneumatic.h"
#include "rendering/frames.h"
#include "reproductions/reproduce_hodgson2012.h"
#include "reproductions/reproduce_karpenko2006.h"
#include "reproductions/reproduce_laib2021.h"
#include "simulation/rollout.h"
#include "cli/rollout_command.h"

namespace {

// a model loaded from MJCF and attached to the extension, released in order
struct AttachedModel {
  mjModel* model = nullptr;
  ~AttachedModel() {
    if (model) {
      pneumatic::Detach(model);
      mj_deleteModel(model);
    }
  }
};

int Fail(const std::string& message) {
  std::fprintf(stderr, "pneumo: %s\n", message.c_str());
  return 1;
}

// loads and attaches; an empty string on success
std::string Load(const std::string& path, AttachedModel* out) {
  char error[1000] = "";
  out->model = mj_loadXML(path.c_str(), nullptr, error, sizeof(error));
  if (!out->model) return path + ": " + error;
  std::string attach_error;
  if (!pneumatic::Attach(out->model, &attach_error)) return path + ": " + attach_error;
  return "";
}

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
    pneumatic::log::ReadOptions read;
    for (const auto& c : pneumatic::Cylinders(m)) read.cylinders.insert(c.name);
    pneumatic::log::ReadResult r = pneumatic::log::ReadLog(commands_path, read);
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

int RunGenerate(const std::string& model_path, const std::string& out_path, const pneumatic::GenerateOptions& options) {
  if (std::string e = pneumatic::CheckOutputPath(out_path, "a log file"); !e.empty()) return Fail(e);
  AttachedModel model;
  if (std::string e = Load(model_path, &model); !e.empty()) return Fail(e);
  auto start = std::chrono::steady_clock::now();
  pneumatic::GenerateResult result = pneumatic::Generate(model.model, options);
  if (!result.log) return Fail(model_path + ": " + result.error);
  double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.log->comments.insert(result.log->comments.begin(), "model: " + model_path);
  if (std::string e = pneumatic::log::WriteLog(out_path, *result.log); !e.empty()) return Fail(e);
  std::fprintf(stderr, "pneumo: wrote %s: %zu rows, %.3f s simulated in %.3f s\n", out_path.c_str(),
               result.log->rows(), static_cast<double>(result.log->rows()) * options.period, wall);
  return 0;
}

int RunInfo(const std::string& model_path) {
  AttachedModel model;
  if (std::string e = Load(model_path, &model); !e.empty()) return Fail(e);
  const mjModel* m = model.model;
  std::printf("%s: timestep %g s, %d actuators, %zu pneumatic cylinders\n", model_path.c_str(), m->opt.timestep,
              m->nu, pneumatic::Cylinders(m).size());
  for (const auto& c : pneumatic::Cylinders(m)) {
    std::printf("cylinder %s: p_supply %g Pa, p_exhaust %g Pa, p_atm %g Pa\n  commands:", c.name.c_str(), c.p_supply,
                c.p_exhaust, c.p_atm);
    for (const auto& [signal, id] : c.command_actuators) std::printf(" %s.%s", c.name.c_str(), signal.c_str());
    std::printf("\n  measured: %s.p_P %s.p_N %s.x %s.v %s.p_S\n", c.name.c_str(), c.name.c_str(), c.name.c_str(),
                c.name.c_str(), c.name.c_str());
  }
  // the controllers' configurations the model carries (pneumo rollout --controller NAME uses them)
  const std::string prefix = pneumatic::kModelControllerConfigPrefix;
  for (int i = 0; i < m->ntext; ++i) {
    const std::string name = m->names + m->name_textadr[i];
    if (name.rfind(prefix, 0) != 0) continue;
    std::printf("controller %s: configuration carried in <text name=\"%s\">: %s\n", name.substr(prefix.size()).c_str(),
                name.c_str(), m->text_data + m->text_adr[i]);
  }
  return 0;
}

// text for a Markdown table cell: a '|' would end the cell, and '<' '>' would read as HTML tags
std::string MarkdownCell(const std::string& text) {
  std::string out;
  for (const char c : text) {
    if (c == '|') {
      out += "\\|";
    } else if (c == '<') {
      out += "&lt;";
    } else if (c == '>') {
      out += "&gt;";
    } else {
      out += c;
    }
  }
  return out;
}

int RunParams(bool markdown) {
  // the cylinder keys ("pneumatic:<cylinder>"), then those of a shared supply reservoir
  // ("pneumatic_reservoir:<name>"): a title and the MJCF element that holds them
  struct Table {
    const char* title;
    const char* element;
    const std::vector<pneumatic::ParameterDoc>* params;
  };
  const Table tables[] = {
      {"cylinder keys", "<text name=\"pneumatic:<cylinder>\" data=\"...\">", &pneumatic::Parameters()},
      {"reservoir keys", "<text name=\"pneumatic_reservoir:<name>\" data=\"...\">", &pneumatic::ReservoirParameters()}};
  if (markdown) {
    // docs/parameters.md is this output, checked by the docs_parameters_match test
    std::printf("<!-- generated by pneumo params --markdown from the key tables of plugin/src/config.cc and "
                "plugin/src/reservoir.cc; do not edit, regenerate: build/bin/pneumo params --markdown > docs/parameters.md "
                "-->\n# MJCF parameters\n\n");
  }
  for (const Table& table : tables) {
    const bool first = &table == &tables[0];
    if (markdown) {
      std::printf("%s%s: `%s`\n\n| key | unit | default | valid | scope | meaning |\n|---|---|---|---|---|---|\n",
                  first ? "" : "\n", table.title, table.element);
      for (const auto& p : *table.params) {
        std::printf("| `%s` | %s | %s | %s | %s | %s |\n", p.key.c_str(), MarkdownCell(p.unit).c_str(),
                    MarkdownCell(p.default_value).c_str(), MarkdownCell(p.valid).c_str(), MarkdownCell(p.scope).c_str(),
                    MarkdownCell(p.meaning).c_str());
      }
      continue;
    }
    std::printf("%s%s: %s\n", first ? "" : "\n", table.title, table.element);
    for (const auto& p : *table.params) {
      std::printf("%-22s %-14s default %-24s valid %s\n  %s; %s\n", p.key.c_str(), p.unit.c_str(),
                  p.default_value.c_str(), p.valid.c_str(), p.scope.c_str(), p.meaning.c_str());
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"pneumo: pneumatic actuators for MuJoCo 2.2"};
  app.require_subcommand(1);
  app.failure_message(CLI::FailureMessage::help);

  std::string model_path, commands_path, out_path;
  double duration = 0, period = 0;
  std::vector<std::string> sets;
  CLI::App* rollout = app.add_subcommand("rollout", "replay a log's commands open loop from its first measured state");
  rollout->add_option("model", model_path, "MJCF model with pneumatic cylinders")->required();
  rollout->add_option("--commands", commands_path, "log (docs/log_format.md) whose command columns are replayed");
  rollout->add_option("--out", out_path, "simulated log to write")->required();
  rollout->add_option("--duration", duration,
                      "seconds to simulate (default: the whole --commands log; with --controller, the --reference's span)");
  rollout->add_option("--period", period, "row period without a command log, s (default 1 ms)");
  rollout->add_option("--set", sets, "constant command, e.g. --set cyl.u=2.5 (repeatable)");
  bool follow_motion = false;
  rollout->add_flag("--follow-motion", follow_motion,
                    "reset pistons to the log's x and v at every row: simulate pressures only (paper 000 V.D)");
  pneumatic::ClosedLoopCommandOptions closed;
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
                      "JSON [{\"name\": ..., \"set\": {\"cyl:key\": value}}]: one run per variation and seed");
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

  pneumatic::GenerateOptions generate_options;
  std::string generate_model, generate_out;
  CLI::App* generate = app.add_subcommand(
      "generate",
      "closed-loop identification log of a rig with one proportional valve per chamber (rig C), as paper 000 V.C "
      "recorded its data");
  generate->footer(
      "Every 10 ms (100 Hz, commands held: zero-order hold), for each cylinder:\n"
      "  ref = 4 sines, f uniform in 0.1..0.8 Hz, amplitude 1/f, random phases, faded in over 1 s, scaled so its peak "
      "is 70 % of the half stroke\n"
      "  d   = PID(ref, x): kp 60 V/m, ki 60 V/(m s), kd 1.5 V s/m on x, |d| <= 4 V (controllers/pid.h)\n"
      "  c   = 0.25 V + 0.75 V (sin + sin)/2, f uniform in 0.03..0.15 Hz: the slowly varying co-contraction, "
      "-0.5..1 V\n"
      "  uP  = clamp(5 + c + d, 3, 7) V,  uN = clamp(5 + c - d, 3, 7) V (paper 000 uses 3 < u < 7 V)\n"
      "Logged: uP, uN, p_P, p_N, x, v, ref. Measured columns are INSTANTANEOUS samples at the row's time, before the "
      "row's command acts (docs/log_format.md), not paper 000's averages of 200 samples over each 10 ms period. Gaussian "
      "noise is added to the logged p_P, p_N, x and v (sqrt(2) x-noise / 10 ms, a finite difference's); the controller "
      "sees the noise-free x. Defaults (paper 000 gives no figures): 500 Pa (0.1 % of supply - exhaust on rig C) and "
      "0.1 mm (0.1 % of its stroke). Same arguments, same file bit for bit; use different seeds for training and "
      "held-out logs.");
  generate->add_option("model", generate_model, "MJCF model whose cylinders are all valve=proportional_per_chamber")
      ->required();
  generate->add_option("--duration", generate_options.duration, "seconds to record (paper 000: 100 s)")->required();
  generate->add_option("--seed", generate_options.seed, "seed of the reference, the co-contraction and the noise")
      ->required();
  generate->add_option("--out", generate_out, "log to write (docs/log_format.md)")->required();
  generate->add_option("--noise-pressure", generate_options.noise_pressure, "pressure sensor noise, Pa (std)")->capture_default_str();
  generate->add_option("--noise-position", generate_options.noise_position, "position sensor noise, m (std)")->capture_default_str();

  pneumatic::IdentifyOptions identify_options;
  CLI::App* identify = app.add_subcommand(
      "identify", "fit paper 000's parametric pressure model and the physical parameters of the model to a log");
  identify->add_option("model", identify_options.model_path, "MJCF model with pneumatic cylinders")->required();
  identify->add_option("log", identify_options.log_path, "training log (docs/log_format.md)")->required();
  identify->add_option("--out", identify_options.out_path, "PARAMS.json to write")->required();
  identify->add_option("--heldout", identify_options.heldout_path,
                       "held-out log: one-step fit % and the 2 s drift of paper 000 Fig. 13 (JSON and PNG)");
  identify->add_option("--plot", identify_options.plot_path, "drift PNG (default: PARAMS.json's name + .drift.png)");
  identify->add_option("--write-model", identify_options.write_model_path,
                       "write a copy of the MJCF with the fitted physical parameters");
  identify->add_option("--write-identified-model", identify_options.write_identified_model_path,
                       "write a copy of the MJCF with pressure_model=identified and the fitted c1..c9");
  identify->add_option("--fit", identify_options.fit_keys,
                       "physical parameter to fit, <cylinder>:<key> (repeatable; default: each cylinder's usual set)");
  bool skip_parametric = false, skip_physical = false;
  identify->add_option("--refine-horizon", identify_options.refine_horizon_s,
                       "refine each chamber's c1..c9 on the model's own predictions over sequences this long, s "
                       "(output error; 0: paper 000's one-step fit alone)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 10.0));
  identify->add_flag("--skip-parametric", skip_parametric, "do not fit paper 000's c1..c9");
  identify->add_flag("--skip-physical", skip_physical, "do not fit the physical parameters");
  identify->add_option("--threads", identify_options.threads, "threads for the fits")->capture_default_str()
      ->check(CLI::Range(1, 64));
  identify->footer(
      "Parametric model (paper 000 eqs. 7-10): per chamber, c1..c9 by bounded least squares (Ceres) on the next-step\n"
      "prediction of the pressure, Table I's bounds, c_gamma = 0.1 V, c_b and c_s from p_supply and p_exhaust; v is the\n"
      "logged x, its rate the forward difference (x[t+1] - x[t]) / h. Needs valve=proportional_per_chamber.\n"
      "--refine-horizon S then refines each chamber's c1..c9 on the model's own predictions (eq. 7 run from the measured\n"
      "p for S seconds, from starts every S/2), the quantity paper 000's drift measures (the project's own addition).\n"
      "Physical parameters: the model's pressures simulated along the measured motion (pneumo rollout --follow-motion)\n"
      "fitted to the measured ones; standard errors from the covariance at the optimum (Newey-West for residuals\n"
      "correlated in time), with a flag on each poorly determined parameter naming the reason.");

  pneumatic::RenderOptions render_options;
  CLI::App* render = app.add_subcommand(
      "render", "draw a model off screen (OSMesa) to a PNG, each cylinder coloured by its pressure difference");
  render->add_option("model", render_options.model_path, "MJCF model")->required();
  render->add_option("--out", render_options.out_path, "PNG to write")->required();
  std::string render_log;
  double render_time = 0;
  render->add_option("--log", render_log, "draw the state of a row of this log (p_P, p_N, x, v)");
  render->add_option("--time", render_time, "the row: the last at or before this time, s (default: the first)");
  render->add_option("--width", render_options.width, "pixels")->capture_default_str()->check(CLI::Range(1, 8192));
  render->add_option("--height", render_options.height, "pixels")->capture_default_str()->check(CLI::Range(1, 8192));
  render->add_option("--camera", render_options.camera, "a camera of the model (default: a free camera on the whole model)");
  render->footer("Colours: grey where p_P = p_N, red as chamber P's pressure exceeds N's (P pushes), blue the reverse, "
                 "full at a difference of p_supply - p_exhaust.");

  std::string reproduce_name, reproduce_out;
  CLI::App* reproduce = app.add_subcommand(
      "reproduce", "rerun a paper's experiment on its rig and print its headline figures next to the paper's (JSON)");
  reproduce->add_option("name", reproduce_name,
                        "the paper: karpenko2006 (paper 001's nonlinear PI on rig B), hodgson2012 (paper 002's sliding "
                        "controllers on rig A) or laib2021 (paper 003's averaged PWM model and sliding-mode controller "
                        "with observers on rig A)")
      ->required()
      ->check(CLI::IsMember({"karpenko2006", "hodgson2012", "laib2021"}));
  reproduce->add_option("--out", reproduce_out, "directory for the JSON, the logs and the comparison plots (PNG)");

  pneumatic::DiagnoseCommandOptions diagnose_options;
  CLI::App* diagnose = app.add_subcommand(
      "diagnose", "find where a model and a measured log part, which unmodelled effect explains it, and how far the gap shrinks");
  diagnose->add_option("model", diagnose_options.model_path, "MJCF model with pneumatic cylinders")->required();
  diagnose->add_option("log", diagnose_options.train_path, "training log (docs/log_format.md), closed loop, no v needed; a p_S column, if any, is used as the supply pressure measured")
      ->required();
  diagnose->add_option("--heldout", diagnose_options.heldout_path,
                       "held-out log (default: the last 30 % of the training log is held out)");
  diagnose->add_option("--test", diagnose_options.test_path,
                       "a third log the diagnosis does not see: the verdict's model is graded on it (JSON \"test\")");
  diagnose->add_option("--report", diagnose_options.report_dir, "directory for the HTML report and its PNG plots");
  diagnose->add_option("--calibration-iterations", diagnose_options.diagnose.calibration_iterations,
                       "iterations of the calibration of the model's nominal parameters before the effects (0: none)")
      ->capture_default_str()->check(CLI::Range(0, 200));
  diagnose->add_option("--horizon", diagnose_options.diagnose.horizon_s, "prediction window, s")->capture_default_str()
      ->check(CLI::Range(0.005, 10.0));
  diagnose->add_option("--max-effects", diagnose_options.diagnose.max_effects, "effects searched one after the other")
      ->capture_default_str()->check(CLI::Range(1, 5));
  diagnose->add_option("--threads", diagnose_options.diagnose.threads, "threads for the predictions")->capture_default_str()
      ->check(CLI::Range(1, 64));
  diagnose->add_flag("--quiet", diagnose_options.quiet, "no progress on stderr");
  diagnose->footer(
      "Prints JSON: verdict.{effect (an effect, none or unexplained), effects, params, calibration, noise_floor,\n"
      "unexplained, alternatives, heldout_gap_before, heldout_gap_after}, the ranking of every\n"
      "candidate (score = the information criterion dIC), where the gap lies (per signal, regime, over time).\n"
      "README, \"Diagnosis\", defines the gap and the verdict rule.");

  CLI::App* info = app.add_subcommand("info", "list a model's cylinders and their log signals");
  info->add_option("model", model_path, "MJCF model")->required();

  bool markdown = false;
  CLI::App* params = app.add_subcommand("params", "print the MJCF parameter table");
  params->add_flag("--markdown", markdown, "as a Markdown table");

  CLI11_PARSE(app, argc, argv);
  if (*rollout && rollout->count("--controller") > 0) {
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
  if (*rollout) {
    bool duration_given = rollout->count("--duration") > 0;
    return RunRollout(model_path, commands_path, out_path, duration_given, duration, period, sets, follow_motion);
  }
  if (*generate) return RunGenerate(generate_model, generate_out, generate_options);
  if (*diagnose) return pneumatic::RunDiagnose(diagnose_options);
  if (*identify) {
    identify_options.parametric = !skip_parametric;
    identify_options.physical = !skip_physical;
    return pneumatic::RunIdentify(identify_options);
  }
  if (*render) {
    if (render->count("--log")) render_options.log_path = render_log;
    if (render->count("--time")) render_options.time = render_time;
    return pneumatic::RunRender(render_options);
  }
  if (*reproduce) {
    std::string error;
    nlohmann::json result =
        reproduce_name == "laib2021"       ? pneumatic::ReproduceLaib2021(PNEUMATIC_MODELS_DIR, reproduce_out, &error)
        : reproduce_name == "karpenko2006" ? pneumatic::ReproduceKarpenko2006(PNEUMATIC_MODELS_DIR, reproduce_out, &error)
                                           : pneumatic::ReproduceHodgson2012(PNEUMATIC_MODELS_DIR, reproduce_out, &error);
    if (result.is_null()) return Fail("reproduce " + reproduce_name + ": " + error);
    std::printf("%s\n", result.dump(2).c_str());
    return 0;
  }
  if (*info) return RunInfo(model_path);
  if (*params) return RunParams(markdown);
  return 2;
}
