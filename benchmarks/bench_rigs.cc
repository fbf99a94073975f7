// Benchmark of the pneumatic extension on the three rigs of shared/spec/rigs.md; it prints the
// Markdown of the README's "Benchmark" section to stdout (its headings start at ###; progress
// goes to stderr).
//
// Speed: each shipped rig model (models_mjcf/, timestep 0.25 ms) is stepped with mj_step for
// about one second of wall time, its commands taken from the rig's reference excitation
// (Excitation(rig, 4 s, seed 1), zero-order hold at the control period, the state reset every
// 4 s). Three variants: the model with the chamber step `step=exact` (the default), the same
// model with `step=explicit` (MuJoCo's plain explicit Euler on the same equations), and the
// same model without the extension (no callbacks, ctrl 0), which is MuJoCo's own cost. Each is
// run three times, interleaved, and the median is reported. The extension's cost per chamber
// step is (time per step with the extension - time per step without) / 2 chambers.
//
// Accuracy: the reference is the independent rigs.md implementation of tests/reference,
// integrated with classical RK4 at 1 us over 4 s of the rig's excitation generated with every
// command held 10 ms (so that every dt below divides the command period). Its log is replayed
// through the model (pneumatic::Rollout) with the timestep set to dt = 0.5, 1, 2, 5, 10 ms, for
// both chamber steps and in two modes: open loop (MuJoCo simulates the mechanics) and along the
// reference's motion (follow_motion: only the pressures are simulated, paper 000's multi-step
// prediction). The error is the max |p_sim - p_ref| over both chambers and all rows (the log
// samples once per command period), as % of supply - exhaust, and for open loop max |x error|.
// A dt that does not divide the command period cannot hold the commands and is skipped. A
// replay that Rollout rejects (MuJoCo warnings, non-finite state) or whose pressure leaves
// [0, 10 supply] is "diverged".
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

#include "pneumatic/pneumatic.h"
#include "reference_log.h"
#include "rig_reference.h"
#include "rollout.h"

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

//---------------------------------- machine --------------------------------------------------------

std::string CpuModel() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line;
  while (std::getline(cpuinfo, line)) {
    if (line.rfind("model name", 0) == 0) {
      size_t colon = line.find(':');
      if (colon != std::string::npos) return line.substr(line.find_first_not_of(" \t", colon + 1));
    }
  }
  return "unknown CPU";
}

std::string Compiler() {
#if defined(__clang__)
  return std::string("Clang ") + __clang_version__;
#elif defined(__GNUC__)
  return std::string("GCC ") + __VERSION__;
#else
  return "unknown compiler";
#endif
}

//---------------------------------- models ---------------------------------------------------------

// how the model integrates its chamber pressures
enum class Step { kExact = 0, kExplicit = 1 };

const char* StepName(Step step) { return step == Step::kExact ? "exact" : "explicit"; }

// a loaded rig model, attached to the extension while `attached`
class RigModel {
 public:
  RigModel(const RigModel&) = delete;
  RigModel& operator=(const RigModel&) = delete;
  ~RigModel() {
    if (!m_) return;
    pneumatic::Detach(m_);
    mj_deleteModel(m_);
  }

  // loads the shipped model of `rig` with the chamber step `step`; null and *error on failure
  static std::unique_ptr<RigModel> Load(Rig rig, Step step, std::string* error);

  mjModel* m() const { return m_; }

  bool Attach(std::string* error) { return pneumatic::Attach(m_, error); }
  void Detach() { pneumatic::Detach(m_); }

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

  // step=explicit: prepend the key to the cylinder's configuration
  if (step == Step::kExplicit) {
    size_t element = xml.find("name=\"pneumatic:");
    size_t data = element == std::string::npos ? element : xml.find("data=\"", element);
    if (data == std::string::npos) {
      *error = file + ": no <text name=\"pneumatic:...\" data=\"...\">";
      return nullptr;
    }
    xml.insert(data + std::strlen("data=\""), "step=explicit ");
  }

  // compile through a virtual file system (mjVFS is large: heap)
  auto vfs = std::make_unique<mjVFS>();
  mj_defaultVFS(vfs.get());
  if (mj_makeEmptyFileVFS(vfs.get(), file.c_str(), static_cast<int>(xml.size())) != 0) {
    *error = "mj_makeEmptyFileVFS failed for " + file;
    return nullptr;
  }
  std::memcpy(vfs->filedata[vfs->nfile - 1], xml.data(), xml.size());
  char buffer[1000] = "";
  mjModel* m = mj_loadXML(file.c_str(), vfs.get(), buffer, sizeof(buffer));
  mj_deleteVFS(vfs.get());
  if (!m) {
    *error = file + ": " + buffer;
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
  std::vector<std::pair<const char*, double>> named;
  switch (rig) {
    case Rig::kOnOff: named = {{"cyl.u1", c.u1}, {"cyl.u2", c.u2}, {"cyl.u3", c.u3}, {"cyl.u4", c.u4}}; break;
    case Rig::kProportional: named = {{"cyl.u", c.u}}; break;
    case Rig::kPerChamber: named = {{"cyl.uP", c.uP}, {"cyl.uN", c.uN}}; break;
  }
  std::vector<Control> controls;
  for (const auto& [name, value] : named) controls.push_back({mj_name2id(m, mjOBJ_ACTUATOR, name), value});
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

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

// the speed table: MuJoCo alone, exact and explicit for each rig
bool PrintSpeed(const std::vector<std::vector<pneumatic::reference::RigCommand>>& excitations) {
  std::printf("### Speed\n\n");
  std::printf("Shipped models (timestep 0.25 ms, Euler), one cylinder each, driven by the reference excitation. "
              "Median of %d runs of about %.0f s each. \"MuJoCo alone\" is the same model without the extension "
              "(no callbacks, ctrl 0); the cost per chamber step is the extra time per mj_step over MuJoCo alone, "
              "divided by the %d chambers (rig B's spool lag included).\n\n",
              kSpeedRepeats, kSpeedSeconds, kChambers);
  std::printf("| rig | MuJoCo alone (steps/s) | exact (steps/s) | explicit (steps/s) | exact / explicit (steps/s) "
              "| exact: us per chamber step | explicit: us per chamber step |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|\n");
  for (size_t r = 0; r < std::size(kRigs); ++r) {
    Rig rig = kRigs[r];
    double period = pneumatic::reference::ControlPeriod(rig);
    std::string error;
    std::unique_ptr<RigModel> exact = RigModel::Load(rig, Step::kExact, &error);
    std::unique_ptr<RigModel> explicit_step = exact ? RigModel::Load(rig, Step::kExplicit, &error) : nullptr;
    if (!explicit_step) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return false;
    }

    // interleave the variants so that a slow phase of the machine hits all of them alike;
    // the extension is attached only while its variant runs, so MuJoCo alone has no callbacks
    std::vector<double> alone, with_exact, with_explicit;
    bool diverged[2] = {false, false};
    for (int repeat = 0; repeat < kSpeedRepeats; ++repeat) {
      std::fprintf(stderr, "speed: rig %s, run %d/%d\n", RigName(rig), repeat + 1, kSpeedRepeats);
      alone.push_back(MeasureSpeed(*exact, rig, excitations[r], period, false).steps_per_second);
      RigModel* variants[2] = {exact.get(), explicit_step.get()};
      for (int v = 0; v < 2; ++v) {
        if (!variants[v]->Attach(&error)) {
          std::fprintf(stderr, "error: %s\n", error.c_str());
          return false;
        }
        SpeedSample s = MeasureSpeed(*variants[v], rig, excitations[r], period, true);
        variants[v]->Detach();
        (v == 0 ? with_exact : with_explicit).push_back(s.steps_per_second);
        diverged[v] |= s.diverged;
      }
    }

    // medians, and the extension's share of a step
    double sps_alone = Median(alone), sps_exact = Median(with_exact), sps_explicit = Median(with_explicit);
    auto per_chamber_us = [&](double sps) { return (1 / sps - 1 / sps_alone) / kChambers * 1e6; };
    auto speed_cell = [](double sps, bool bad) { return Format("%.0f", sps) + (bad ? " (diverged)" : ""); };
    std::printf("| %s | %.0f | %s | %s | %.2f | %.3f | %.3f |\n", RigName(rig), sps_alone,
                speed_cell(sps_exact, diverged[0]).c_str(), speed_cell(sps_explicit, diverged[1]).c_str(),
                sps_exact / sps_explicit, per_chamber_us(sps_exact), per_chamber_us(sps_explicit));
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

// errors[rig][dt][step] of one mode
using ModeErrors = std::vector<std::vector<std::array<ReplayError, 2>>>;

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

// true if the exact step's pressure error beats explicit Euler's
bool ExactBeatsExplicit(const std::array<ReplayError, 2>& e) {
  if (e[0].diverged) return false;
  return e[1].diverged || e[0].pressure < e[1].pressure;
}

// one accuracy table (exact and explicit side by side) and the line that compares them
void PrintAccuracy(const char* title, const char* protocol, bool open_loop, const ModeErrors& errors) {
  std::printf("#### %s\n\n%s\n\n", title, protocol);
  std::printf("| rig | dt | pressure error, exact | pressure error, explicit |");
  if (open_loop) std::printf(" x error (mm), exact | x error (mm), explicit |");
  std::printf("\n|---|---:|---:|---:|%s\n", open_loop ? "---:|---:|" : "");
  for (size_t r = 0; r < std::size(kRigs); ++r) {
    for (size_t t = 0; t < std::size(kTimesteps); ++t) {
      const auto& e = errors[r][t];
      std::printf("| %s | %s | %s | %s |", RigName(kRigs[r]), Milliseconds(kTimesteps[t]).c_str(),
                  PressureCell(kRigs[r], e[0]).c_str(), PressureCell(kRigs[r], e[1]).c_str());
      if (open_loop) std::printf(" %s | %s |", PositionCell(e[0]).c_str(), PositionCell(e[1]).c_str());
      std::printf("\n");
    }
  }

  // where exact beats explicit, and plainly where it does not
  std::string wins, losses;
  for (size_t r = 0; r < std::size(kRigs); ++r) {
    std::string rig_wins, rig_losses;
    for (size_t t = 0; t < std::size(kTimesteps); ++t) {
      const auto& e = errors[r][t];
      if (e[0].skipped) continue;
      std::string& list = ExactBeatsExplicit(e) ? rig_wins : rig_losses;
      list += (list.empty() ? "" : ", ") + Milliseconds(kTimesteps[t]);
    }
    std::string rig = std::string("rig ") + RigName(kRigs[r])[0];
    if (!rig_wins.empty()) wins += (wins.empty() ? "" : "; ") + rig + " at " + rig_wins;
    if (!rig_losses.empty()) losses += (losses.empty() ? "" : "; ") + rig + " at " + rig_losses;
  }
  if (losses.empty()) {
    std::printf("\nExact beats explicit Euler in pressure at every dt tested: %s.\n\n", wins.c_str());
  } else {
    std::printf("\nExact beats explicit Euler in pressure at: %s.\n", wins.empty() ? "no dt" : wins.c_str());
    std::printf("**Exact does NOT beat explicit Euler** in pressure at: %s.\n\n", losses.c_str());
  }
}

}  // namespace

int main() {
  Clock::time_point program_start = Clock::now();
  mju_user_warning = CountWarning;

  // machine
  std::printf("Machine: %s, %u cores, MuJoCo %s, %s, %s build.\n\n", CpuModel().c_str(),
              std::thread::hardware_concurrency(), mj_versionString(), Compiler().c_str(),
              std::strlen(PNEUMATIC_BUILD_TYPE) ? PNEUMATIC_BUILD_TYPE : "unspecified");

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
      std::array<ReplayError, 2> loop, along;
      for (Step step : {Step::kExact, Step::kExplicit}) {
        int s = static_cast<int>(step);
        loop[s] = Replay(rig, step, dt, false, references[r]);
        along[s] = Replay(rig, step, dt, true, references[r]);
        for (const ReplayError* e : {&loop[s], &along[s]}) {
          if (e->diverged) {
            std::fprintf(stderr, "  %s at %s, %s: diverged: %s\n", StepName(step), Milliseconds(dt).c_str(),
                         e == &loop[s] ? "open loop" : "along the motion", e->reason.c_str());
          }
        }
      }
      open_loop[r].push_back(loop);
      follow[r].push_back(along);
    }
  }
  std::printf("### Accuracy\n\n");
  std::printf("Reference: the rigs.md equations integrated independently (tests/reference) with classical RK4 "
              "at %g us over %g s of the rig's excitation (seed %u) with every command held %g ms, so that every "
              "dt divides the command period; it took %.2f s (A), %.2f s (B), %.2f s (C), and the piston used "
              "%.0f %%, %.0f %%, %.0f %% of its half stroke. "
              "Errors are the max |p_sim - p_ref| over both chambers and every command period, in %% of "
              "supply - exhaust (A %g, B %g, C %g Pa), and the max |x_sim - x_ref|. \"exact\" is the extension's "
              "semi-analytic chamber step (step=exact, the default), \"explicit\" MuJoCo's plain explicit Euler on the "
              "same equations (step=explicit).\n\n",
              kReferenceStep * 1e6, kReferenceSeconds, kReferenceSeed, kAccuracyPeriod * 1e3, reference_seconds[0],
              reference_seconds[1], reference_seconds[2], 100 * stroke_used[0], 100 * stroke_used[1],
              100 * stroke_used[2], PressureRange(Rig::kOnOff), PressureRange(Rig::kProportional),
              PressureRange(Rig::kPerChamber));
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
