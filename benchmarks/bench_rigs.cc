// Benchmark of the pneumatic extension on the three rigs of docs/rigs.md; it prints the
// Markdown of the README's "Benchmark" section to stdout (its headings start at ###; progress
// goes to stderr). It compares the three chamber steps of the MJCF key `step`:
//   linearized  the shipped model as is (the default): an exponential Rosenbrock step with
//               the flow linearised by its slope, a second-order correction and an adaptive fallback;
//   exact       `step=exact` inserted: adaptive implicit backward Euler with Richardson
//               extrapolation (the former default);
//   explicit    `step=explicit` inserted: MuJoCo's plain explicit Euler on the same equations
//               (comparison only).
//
// Speed: each shipped rig model (models_mjcf/, at its own timestep) is stepped with mj_step for
// about one second of wall time, its commands taken from the rig's reference excitation
// (Excitation(rig, 4 s, seed 1), zero-order hold at the control period, the state reset every
// 4 s), once per chamber step and once without the extension (no callbacks, ctrl 0), which is
// MuJoCo's own cost. Each of these four is run three times, interleaved, and the median is
// reported. The extension's cost per chamber step is (time per step with the extension - time
// per step without) / 2 chambers.
//
// Accuracy: the reference is the independent docs/rigs.md implementation of tests/reference,
// integrated with classical RK4 at 1 us over 4 s of the rig's excitation generated with every
// command held 10 ms (so that every dt below divides the command period). Its log is replayed
// through the model (pneumatic::Rollout) with the timestep set to dt = 0.5, 1, 2, 5, 10 ms, for
// each chamber step and in two modes: open loop (MuJoCo simulates the mechanics) and along the
// reference's motion (follow_motion: only the pressures are simulated, paper 000's multi-step
// prediction). The error is the max |p_sim - p_ref| over both chambers and all rows (the log
// samples once per command period), as % of supply - exhaust, and for open loop max |x error|.
// A dt that does not divide the command period cannot hold the commands and is skipped. A
// replay that Rollout rejects (MuJoCo warnings, non-finite state) or whose pressure leaves
// [0, 10 supply] is "diverged". After each accuracy table two checks are printed: whether
// linearized stays within kLinearizedTolerance (1.5x) of exact's pressure error at every dt
// (errors below kTieFraction, 0.001 %, for both count as a tie), and whether exact beats explicit.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <mujoco/mujoco.h>

#include "formats/model_loading.h"
#include "machine.h"
#include "pneumatic/pneumatic.h"
#include "reference_log.h"
#include "rig_reference.h"
#include "simulation/rollout.h"

namespace {

using pneumatic::reference::Rig;
using Clock = std::chrono::steady_clock;

constexpr Rig kRigs[] = {Rig::kOnOff, Rig::kProportional, Rig::kPerChamber};
constexpr double kReferenceSeconds = 4;     // length of the excitation and of each replay, s
constexpr unsigned kReferenceSeed = 1;
constexpr double kReferenceStep = 1e-6;     // RK4 step of the reference, s
constexpr double kAccuracyPeriod = 10e-3;   // command period of the accuracy references, s
constexpr double kSpeedSeconds = 1;         // wall time of one speed measurement, s
constexpr int kSpeedRepeats = 3;
constexpr double kTimesteps[] = {0.5e-3, 1e-3, 2e-3, 5e-3, 10e-3};
constexpr int kChambers = 2;
constexpr double kLinearizedTolerance = 1.5;  // linearized's pressure error may be this many times exact's
constexpr double kTieFraction = 1e-5;         // errors below this fraction of supply - exhaust for both: a tie

double Seconds(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

const char* RigName(Rig rig) {
  switch (rig) {
    case Rig::kOnOff: return "A (on/off)";
    case Rig::kProportional: return "B (proportional 5/3)";
    case Rig::kPerChamber: return "C (3/3 per chamber)";
  }
  return "";
}

// supply - exhaust of a rig, Pa: the scale of the pressure errors
double PressureRange(Rig rig) {
  pneumatic::reference::RigParams p = pneumatic::reference::DefaultParams(rig);
  return p.supply_pressure - p.exhaust_pressure;
}

// printf into a std::string
template <typename... Args>
std::string Format(const char* format, Args... args) {
  char buffer[256];
  std::snprintf(buffer, sizeof(buffer), format, args...);
  return buffer;
}

// MuJoCo prints warnings to stdout unless told otherwise: keep the tables clean, count them
int mujoco_warnings = 0;
void CountWarning(const char*) { ++mujoco_warnings; }


//---------------------------------- models ---------------------------------------------------------

// how the model integrates its chamber pressures; the values index kSteps
enum class Step { kLinearized = 0, kExact = 1, kExplicit = 2 };

struct StepVariant {
  Step step;
  const char* name;
  const char* key;  // text inserted at the start of the cylinder's configuration ("": the shipped model)
};
constexpr StepVariant kSteps[] = {
    {Step::kLinearized, "linearized", ""},
    {Step::kExact, "exact", "step=exact "},
    {Step::kExplicit, "explicit", "step=explicit "},
};
constexpr size_t kStepCount = std::size(kSteps);
static_assert(kSteps[0].step == Step::kLinearized && kSteps[1].step == Step::kExact &&
              kSteps[2].step == Step::kExplicit, "kSteps is indexed by Step");

constexpr size_t Index(Step step) { return static_cast<size_t>(step); }
const StepVariant& Variant(Step step) { return kSteps[Index(step)]; }

// a loaded rig model; once attached it stays attached (the extension needs no detaching)
class RigModel {
 public:
  RigModel(const RigModel&) = delete;
  RigModel& operator=(const RigModel&) = delete;
  ~RigModel() { mj_deleteModel(m_); }

  // loads the shipped model of `rig` with the chamber step `step`; null and *error on failure
  static std::unique_ptr<RigModel> Load(Rig rig, Step step, std::string* error);

  mjModel* m() const { return m_; }

  bool Attach(std::string* error) { return pneumatic::Attach(m_, error); }

 private:
  explicit RigModel(mjModel* m) : m_(m) {}
  mjModel* m_;
};

std::unique_ptr<RigModel> RigModel::Load(Rig rig, Step step, std::string* error) {
  // the shipped MJCF text
  std::string file = pneumatic::reference::RigModelFile(rig);
  std::ifstream in(std::string(PNEUMATIC_MODELS_DIR) + "/" + file, std::ios::binary);
  if (!in) {
    *error = "cannot read " + std::string(PNEUMATIC_MODELS_DIR) + "/" + file;
    return nullptr;
  }
  std::stringstream text;
  text << in.rdbuf();
  std::string xml = text.str();

  // the variant's key, prepended to the cylinder's configuration
  const char* key = Variant(step).key;
  if (*key) {
    size_t element = xml.find("name=\"pneumatic:");
    size_t data = element == std::string::npos ? element : xml.find("data=\"", element);
    if (data == std::string::npos) {
      *error = file + ": no <text name=\"pneumatic:...\" data=\"...\">";
      return nullptr;
    }
    xml.insert(data + std::strlen("data=\""), key);
  }

  std::string load_error;
  mjModel* m = pneumatic::LoadModelFromText(xml, file, &load_error).release();
  if (!m) {
    *error = file + ": " + load_error;
    return nullptr;
  }
  return std::unique_ptr<RigModel>(new RigModel(m));
}

// the rig's commands as actuator controls: actuator "cyl.<signal>" and its value
struct Control {
  int actuator;
  double value;
};
std::vector<Control> Controls(const mjModel* m, Rig rig, const pneumatic::reference::RigCommand& c) {
  std::vector<Control> controls;
  for (const auto& [signal, value] : pneumatic::reference::NamedCommands(rig, c)) {
    controls.push_back({mj_name2id(m, mjOBJ_ACTUATOR, ("cyl." + signal).c_str()), value});
  }
  return controls;
}

//---------------------------------- speed ----------------------------------------------------------

// one speed measurement
struct SpeedSample {
  double steps_per_second = 0;
  bool diverged = false;
};

// steps `model` for about kSpeedSeconds of wall time. With `apply_commands` the controls
// follow `commands` (zero-order hold at `period`), otherwise they stay 0; the state is reset
// whenever the commands start over
SpeedSample MeasureSpeed(const RigModel& model, Rig rig, const std::vector<pneumatic::reference::RigCommand>& commands,
                         double period, bool apply_commands) {
  const mjModel* m = model.m();
  std::unique_ptr<mjData, void (*)(mjData*)> d(mj_makeData(m), mj_deleteData);

  // controls of each command, resolved before timing
  std::vector<std::vector<Control>> controls;
  for (const auto& c : commands) controls.push_back(Controls(m, rig, c));
  long steps_per_command = std::lround(period / m->opt.timestep);

  // MuJoCo's divergence warnings (mj_resetData clears them)
  SpeedSample sample;
  auto check_divergence = [&]() {
    for (int w : {mjWARN_BADQACC, mjWARN_BADQVEL, mjWARN_BADQPOS}) sample.diverged |= d->warning[w].number > 0;
  };

  // step in whole commands until the time is up; look at the clock every 1000 steps
  long steps = 0;
  size_t command = 0;
  Clock::time_point start = Clock::now();
  double elapsed = 0;
  while (elapsed < kSpeedSeconds) {
    for (int block = 0; block < 1000; block += static_cast<int>(steps_per_command)) {
      if (command == controls.size()) {
        check_divergence();
        command = 0;
        mj_resetData(m, d.get());
      }
      if (apply_commands) {
        for (const Control& c : controls[command]) d->ctrl[c.actuator] = c.value;
      }
      for (long k = 0; k < steps_per_command; ++k) mj_step(m, d.get());
      steps += steps_per_command;
      ++command;
    }
    elapsed = Seconds(start);
  }
  sample.steps_per_second = static_cast<double>(steps) / elapsed;
  check_divergence();
  return sample;
}

// MuJoCo's actuator callbacks removed while it lives: the extension installs them globally on
// the first Attach and keeps them, so "MuJoCo alone" takes them out to measure MuJoCo's own cost
class WithoutActuatorCallbacks {
 public:
  WithoutActuatorCallbacks() { mjcb_act_dyn = mjcb_act_gain = mjcb_act_bias = nullptr; }
  ~WithoutActuatorCallbacks() { mjcb_act_dyn = dyn_, mjcb_act_gain = gain_, mjcb_act_bias = bias_; }
  WithoutActuatorCallbacks(const WithoutActuatorCallbacks&) = delete;
  WithoutActuatorCallbacks& operator=(const WithoutActuatorCallbacks&) = delete;

 private:
  mjfAct dyn_ = mjcb_act_dyn, gain_ = mjcb_act_gain, bias_ = mjcb_act_bias;
};

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

// the speed table: MuJoCo alone and each chamber step for each rig
bool PrintSpeed(const std::vector<std::vector<pneumatic::reference::RigCommand>>& excitations) {
  std::printf("### Speed\n\n");
  std::printf("Shipped models (each at its own timestep dt, Euler), one cylinder each, driven by the reference excitation. "
              "Median of %d runs of about %.0f s each. \"MuJoCo alone\" is the same model without the extension "
              "(no callbacks, ctrl 0); the cost per chamber step is the extra time per mj_step over MuJoCo alone, "
              "divided by the %d chambers (rig B's spool lag included).\n\n",
              kSpeedRepeats, kSpeedSeconds, kChambers);
  std::string header = "| rig | dt | MuJoCo alone (steps/s) |", rule = "|---|---:|---:|";
  for (const StepVariant& v : kSteps) header += Format(" %s (steps/s) |", v.name), rule += "---:|";
  for (const StepVariant& v : kSteps) header += Format(" %s: µs per chamber step |", v.name), rule += "---:|";
  std::printf("%s\n%s\n", header.c_str(), rule.c_str());
  for (size_t r = 0; r < std::size(kRigs); ++r) {
    Rig rig = kRigs[r];
    double period = pneumatic::reference::ControlPeriod(rig);
    // MuJoCo alone: the shipped model, never attached; each chamber step: its model, attached
    std::string error;
    std::unique_ptr<RigModel> plain = RigModel::Load(rig, Step::kLinearized, &error);
    std::array<std::unique_ptr<RigModel>, kStepCount> models;
    for (size_t s = 0; s < kStepCount && plain; ++s) {
      models[s] = RigModel::Load(rig, kSteps[s].step, &error);
      if (!models[s] || !models[s]->Attach(&error)) {
        models[s] = nullptr;
        break;
      }
    }
    if (!plain || !models[kStepCount - 1]) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return false;
    }

    // interleave the variants so that a slow phase of the machine hits all of them alike
    std::vector<double> alone;
    std::array<std::vector<double>, kStepCount> with_step;
    std::array<bool, kStepCount> diverged{};
    for (int repeat = 0; repeat < kSpeedRepeats; ++repeat) {
      std::fprintf(stderr, "speed: rig %s, run %d/%d\n", RigName(rig), repeat + 1, kSpeedRepeats);
      {
        WithoutActuatorCallbacks no_callbacks;
        alone.push_back(MeasureSpeed(*plain, rig, excitations[r], period, false).steps_per_second);
      }
      for (size_t s = 0; s < kStepCount; ++s) {
        SpeedSample sample = MeasureSpeed(*models[s], rig, excitations[r], period, true);
        with_step[s].push_back(sample.steps_per_second);
        diverged[s] = diverged[s] || sample.diverged;
      }
    }

    // medians, and the extension's share of a step
    double sps_alone = Median(alone);
    std::string row = Format("| %s | %g ms | %.0f |", RigName(rig), plain->m()->opt.timestep * 1e3, sps_alone), costs;
    for (size_t s = 0; s < kStepCount; ++s) {
      double sps = Median(with_step[s]);
      row += Format(" %.0f%s |", sps, diverged[s] ? " (diverged)" : "");
      costs += Format(" %.3f |", (1 / sps - 1 / sps_alone) / kChambers * 1e6);
    }
    std::printf("%s%s\n", row.c_str(), costs.c_str());
  }
  std::printf("\n");
  return true;
}

//---------------------------------- accuracy -------------------------------------------------------

// the outcome of one replay against the reference
struct ReplayError {
  bool skipped = false;     // dt does not divide the command period
  bool diverged = false;
  std::string reason;       // why it diverged
  double pressure = 0;      // max |p_sim - p_ref| over both chambers and all rows, Pa
  double position = 0;      // max |x_sim - x_ref|, m
};

// replays `reference` through the model of `rig` at timestep dt
ReplayError Replay(Rig rig, Step step, double dt, bool follow_motion, const pneumatic::log::Log& reference) {
  ReplayError e;
  double steps = (reference.time[1] - reference.time[0]) / dt;
  if (std::fabs(steps - std::round(steps)) > 1e-9 * steps) {
    e.skipped = true;
    return e;
  }

  // the model at timestep dt
  std::string error;
  std::unique_ptr<RigModel> model = RigModel::Load(rig, step, &error);
  if (!model || !model->Attach(&error)) {
    e.diverged = true, e.reason = "load: " + error;
    return e;
  }
  model->m()->opt.timestep = dt;

  // replay
  pneumatic::RolloutOptions options;
  options.follow_motion = follow_motion;
  pneumatic::RolloutResult result = pneumatic::Rollout(model->m(), &reference, options);
  if (!result.log) {
    e.diverged = true, e.reason = result.error;
    return e;
  }

  // worst errors; a non-finite or absurd pressure is a divergence, not a number
  const pneumatic::log::Log& sim = *result.log;
  double supply = pneumatic::reference::DefaultParams(rig).supply_pressure;
  for (const char* signal : {"p_P", "p_N", "x"}) {
    const std::vector<double>& a = sim.values[sim.FindColumn("cyl", signal)];
    const std::vector<double>& b = reference.values[reference.FindColumn("cyl", signal)];
    bool pressure = signal[0] == 'p';
    double& worst = pressure ? e.pressure : e.position;
    for (size_t i = 0; i < a.size(); ++i) {
      if (!std::isfinite(a[i]) || (pressure && (a[i] < 0 || a[i] > 10 * supply))) {
        e.diverged = true;
        e.reason = Format("%s = %g at t = %g s", signal, a[i], sim.time[i]);
        return e;
      }
      worst = std::max(worst, std::fabs(a[i] - b[i]));
    }
  }
  return e;
}

// errors[rig][dt][step] of one mode, step indexed as kSteps
using StepErrors = std::array<ReplayError, kStepCount>;
using ModeErrors = std::vector<std::vector<StepErrors>>;

std::string PressureCell(Rig rig, const ReplayError& e) {
  if (e.skipped) return "n/a (control period)";
  if (e.diverged) return "diverged";
  return Format("%.3g %%", 100 * e.pressure / PressureRange(rig));
}

std::string PositionCell(const ReplayError& e) {
  if (e.skipped) return "n/a (control period)";
  if (e.diverged) return "diverged";
  return Format("%.3g", 1e3 * e.position);
}

std::string Milliseconds(double dt) { return Format("%g ms", 1e3 * dt); }

// the outcome of a check at one rig and dt; `note` is printed after the dt where it fails
struct Verdict {
  bool holds;
  std::string note;
};

// linearized's pressure error is within kLinearizedTolerance of exact's (a tie if both are tiny)
Verdict LinearizedNearExact(Rig rig, const StepErrors& e) {
  const ReplayError& linearized = e[Index(Step::kLinearized)];
  const ReplayError& exact = e[Index(Step::kExact)];
  if (linearized.diverged) return {false, exact.diverged ? "both diverged" : "linearized diverged"};
  if (exact.diverged) return {true, ""};
  double tie = kTieFraction * PressureRange(rig);
  if (linearized.pressure < tie && exact.pressure < tie) return {true, ""};
  double ratio = linearized.pressure / exact.pressure;
  return {ratio <= kLinearizedTolerance, Format("%.2fx", ratio)};
}

// the exact step's pressure error beats explicit Euler's
Verdict ExactBeatsExplicit(Rig, const StepErrors& e) {
  const ReplayError& exact = e[Index(Step::kExact)];
  const ReplayError& explicit_step = e[Index(Step::kExplicit)];
  if (exact.diverged) return {false, "exact diverged"};
  return {explicit_step.diverged || exact.pressure < explicit_step.pressure, ""};
}

// prints, as Markdown list items, where `check` holds and, plainly, where it does not:
// "<claim> at every dt tested: ..." or "<claim> at: ..." followed by "**<negation>** at: ..."
void PrintCheck(const ModeErrors& errors, Verdict (*check)(Rig, const StepErrors&), const char* claim,
                const char* negation) {
  std::string holds, fails;
  for (size_t r = 0; r < std::size(kRigs); ++r) {
    std::string rig_holds, rig_fails;
    for (size_t t = 0; t < std::size(kTimesteps); ++t) {
      const StepErrors& e = errors[r][t];
      if (e[0].skipped) continue;
      Verdict v = check(kRigs[r], e);
      std::string& list = v.holds ? rig_holds : rig_fails;
      list += (list.empty() ? "" : ", ") + Milliseconds(kTimesteps[t]);
      if (!v.holds && !v.note.empty()) list += " (" + v.note + ")";
    }
    std::string rig = std::string("rig ") + RigName(kRigs[r])[0];
    if (!rig_holds.empty()) holds += (holds.empty() ? "" : "; ") + rig + " at " + rig_holds;
    if (!rig_fails.empty()) fails += (fails.empty() ? "" : "; ") + rig + " at " + rig_fails;
  }
  if (fails.empty()) {
    std::printf("- %s at every dt tested: %s.\n", claim, holds.c_str());
  } else {
    std::printf("- %s at: %s.\n", claim, holds.empty() ? "no dt" : holds.c_str());
    std::printf("- **%s** at: %s.\n", negation, fails.c_str());
  }
}

// one accuracy table (the chamber steps side by side) and the checks that compare them
void PrintAccuracy(const char* title, const char* protocol, bool open_loop, const ModeErrors& errors) {
  std::printf("#### %s\n\n%s\n\n", title, protocol);
  std::string header = "| rig | dt |", rule = "|---|---:|";
  for (const StepVariant& v : kSteps) header += Format(" pressure error, %s |", v.name), rule += "---:|";
  if (open_loop) {
    for (const StepVariant& v : kSteps) header += Format(" x error (mm), %s |", v.name), rule += "---:|";
  }
  std::printf("%s\n%s\n", header.c_str(), rule.c_str());
  for (size_t r = 0; r < std::size(kRigs); ++r) {
    for (size_t t = 0; t < std::size(kTimesteps); ++t) {
      const StepErrors& e = errors[r][t];
      std::string row = "| " + std::string(RigName(kRigs[r])) + " | " + Milliseconds(kTimesteps[t]) + " |";
      for (const ReplayError& step : e) row += " " + PressureCell(kRigs[r], step) + " |";
      if (open_loop) {
        for (const ReplayError& step : e) row += " " + PositionCell(step) + " |";
      }
      std::printf("%s\n", row.c_str());
    }
  }

  std::printf("\n");
  std::string claim = Format("Linearized within %gx of exact in pressure", kLinearizedTolerance);
  std::string negation = Format("Linearized NOT within %gx of exact", kLinearizedTolerance);
  PrintCheck(errors, LinearizedNearExact, claim.c_str(), negation.c_str());
  PrintCheck(errors, ExactBeatsExplicit, "Exact beats explicit Euler in pressure",
             "Exact does NOT beat explicit Euler in pressure");
  std::printf("\n");
}

}  // namespace

int main() {
  Clock::time_point program_start = Clock::now();
  mju_user_warning = CountWarning;

  // machine
  pneumatic::benchmarks::PrintMachine(PNEUMATIC_BUILD_TYPE);

  // speed runs use each rig's own excitation; the accuracy references hold every command for
  // kAccuracyPeriod, which every dt divides, so each rig is measured at every dt
  std::vector<std::vector<pneumatic::reference::RigCommand>> excitations;
  std::vector<pneumatic::log::Log> references;
  std::vector<double> reference_seconds, stroke_used;
  for (Rig rig : kRigs) {
    std::fprintf(stderr, "reference: rig %s\n", RigName(rig));
    excitations.push_back(pneumatic::reference::Excitation(rig, kReferenceSeconds, kReferenceSeed));
    Clock::time_point start = Clock::now();
    pneumatic::reference::RigParams params = pneumatic::reference::DefaultParams(rig);
    std::vector<pneumatic::reference::Sample> samples = pneumatic::reference::Simulate(
        params, pneumatic::reference::RigState{},
        pneumatic::reference::Excitation(rig, kReferenceSeconds, kReferenceSeed, kAccuracyPeriod), kAccuracyPeriod,
        kReferenceStep);
    reference_seconds.push_back(Seconds(start));
    double x_max = 0;
    for (const auto& sample : samples) x_max = std::max(x_max, std::fabs(sample.state.x));
    stroke_used.push_back(x_max / (params.stroke / 2));
    references.push_back(pneumatic::reference::ToLog(rig, samples));
  }

  // speed
  if (!PrintSpeed(excitations)) return 1;

  // accuracy: every rig, dt, chamber step and mode
  ModeErrors open_loop(std::size(kRigs)), follow(std::size(kRigs));
  for (size_t r = 0; r < std::size(kRigs); ++r) {
    Rig rig = kRigs[r];
    std::fprintf(stderr, "accuracy: rig %s\n", RigName(rig));
    for (double dt : kTimesteps) {
      StepErrors loop, along;
      for (size_t s = 0; s < kStepCount; ++s) {
        loop[s] = Replay(rig, kSteps[s].step, dt, false, references[r]);
        along[s] = Replay(rig, kSteps[s].step, dt, true, references[r]);
        for (const ReplayError* e : {&loop[s], &along[s]}) {
          if (e->diverged) {
            std::fprintf(stderr, "  %s at %s, %s: diverged: %s\n", kSteps[s].name, Milliseconds(dt).c_str(),
                         e == &loop[s] ? "open loop" : "along the motion", e->reason.c_str());
          }
        }
      }
      open_loop[r].push_back(loop);
      follow[r].push_back(along);
    }
  }
  std::printf("### Accuracy\n\n");
  std::printf("Reference: the docs/rigs.md equations integrated independently (tests/reference) with classical RK4 "
              "at %g us over %g s of the rig's excitation (seed %u) with every command held %g ms, so that every "
              "dt divides the command period; it took %.2f s (A), %.2f s (B), %.2f s (C), and the piston used "
              "%.0f %%, %.0f %%, %.0f %% of its half stroke. "
              "Errors are the max |p_sim - p_ref| over both chambers and every command period, in %% of "
              "supply - exhaust (A %g, B %g, C %g Pa), and the max |x_sim - x_ref|. \"linearized\" is the extension's "
              "default chamber step (an exponential Rosenbrock step with the flow linearised by its slope, a second-order "
              "correction and an adaptive fallback), \"exact\" its former default (step=exact: adaptive implicit backward Euler with Richardson "
              "extrapolation), \"explicit\" MuJoCo's plain explicit Euler on the same equations (step=explicit). "
              "Linearized counts as within %gx of exact where its pressure error is at most %g times exact's or both "
              "are below %g %%.\n\n",
              kReferenceStep * 1e6, kReferenceSeconds, kReferenceSeed, kAccuracyPeriod * 1e3, reference_seconds[0],
              reference_seconds[1], reference_seconds[2], 100 * stroke_used[0], 100 * stroke_used[1],
              100 * stroke_used[2], PressureRange(Rig::kOnOff), PressureRange(Rig::kProportional),
              PressureRange(Rig::kPerChamber), kLinearizedTolerance, kLinearizedTolerance, 100 * kTieFraction);
  PrintAccuracy("Open loop", "The whole rig is simulated: MuJoCo's semi-implicit Euler mechanics and the chamber step.",
                true, open_loop);
  PrintAccuracy("Along the reference's motion",
                "follow_motion: the piston is moved along the reference's x, so only the pressure model is "
                "measured (paper 000's multi-step prediction protocol).",
                false, follow);

  std::printf("Benchmark run time: %.0f s.\n", Seconds(program_start));
  if (mujoco_warnings > 0) std::fprintf(stderr, "%d MuJoCo warnings (in diverged replays)\n", mujoco_warnings);
  return 0;
}
