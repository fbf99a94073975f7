#include "reproductions/reproduce_karpenko2006.h"

#include "formats/report_files.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <vector>

#include "formats/model_loading.h"
#include "pneumatic/pneumatic.h"
#include "reproductions/reproduction_support.h"

namespace pneumatic {
namespace {

using reproductions::CreateOutputDirectory;
using reproductions::Failed;
using reproductions::Finish;
using reproductions::Format;
using reproductions::Round;

constexpr double kPi = 3.14159265358979323846;
constexpr double kStepHold = 5;          // s after the step
constexpr double kSteadyWindow = 0.5;    // s: the end of a run or hold judged "steady"
constexpr double kSineWarmUp = 2;       // s before a sine is judged
// the slow sines: {amplitude m, frequency Hz}; peak speeds 16 and 63 mm/s
constexpr double kSines[2][2] = {{0.050, 0.05}, {0.100, 0.10}};

// paper 001's figures
constexpr double kPaperSimLinearOvershoot = 29;  // %, Fig. 5a ("approximately 29 %")
constexpr double kPaperSimResetOvershoot = 8;    // %, Fig. 5b ("less than 8 %"): an upper bound
constexpr double kPaperExpRiseTime = 0.68;       // s, Fig. 6 (90 % rise time, resetting PI)
constexpr double kPaperExpSteadyError = 1;       // mm, Fig. 6 ("less than 1 mm"): an upper bound
constexpr double kPaperExpPlainPeakError = 50;   // mm, Fig. 7 ("approximately 50 mm")
constexpr double kPaperExpPlainDeadtime = 0.75;  // s, Fig. 7 ("on the order of 0.75 seconds")
constexpr double kPaperExpTrackingSteady = 4;    // mm, VII: "maximum steady errors ... 4 mm" (Fig. 9)

// one piece of an S-curve reference: a move from `from` to `to` over `duration` s, or a hold (from == to)
struct Segment {
  double from, to, duration;
};

std::vector<Segment> SCurveSegments() {
  return {{0, 0, kKarpenko2006StepTime}, {0, -0.150, 3},   {-0.150, -0.150, 2}, {-0.150, 0.150, 6},
          {0.150, 0.150, 3},             {0.150, 0, 3},     {0, 0, 3},           {0, 0.020, 2},
          {0.020, 0.020, 2}};
}

double SegmentValue(const Segment& s, double t) {
  if (s.from == s.to || s.duration <= 0) return s.to;
  const double u = std::clamp(t / s.duration, 0.0, 1.0);
  return s.from + (s.to - s.from) * (u - std::sin(2 * kPi * u) / (2 * kPi));  // cycloidal S-curve
}

const std::vector<double>& Column(const log::Log& log, const char* signal) {
  static const std::vector<double> empty;
  const int c = log.FindColumn("cyl", signal);
  return c < 0 ? empty : log.values[static_cast<size_t>(c)];
}

}  // namespace

std::optional<KarpenkoPidParams> Karpenko2006Controller(const std::string& name) {
  KarpenkoPidParams p;  // the paper's values; reset on, eps = 1 mm, additions off
  if (name == "linear_pi") {
    p.reset = false;
  } else if (name == "reset_pi" || name == "plain") {
  } else if (name == "augmented") {
    p.augmentation = true;
  } else if (name == "augmented_braking") {
    p.augmentation = true, p.braking = true, p.epsilon = 0.004;  // Fig. 9: eps raised to 4 mm
  } else {
    return std::nullopt;
  }
  return p;
}

std::optional<log::Log> Karpenko2006Reference(const std::string& name, double step, double* duration,
                                              std::string* error) {
  const double T = 1 / kKarpenko2006ControlRate;
  std::vector<Segment> segments;
  if (name == "step") {
    segments = {{0, 0, kKarpenko2006StepTime}, {step, step, kStepHold}};
  } else if (name == "s_curve") {
    segments = SCurveSegments();
  } else {
    if (error) *error = "unknown reference '" + name + "' (step, s_curve)";
    return std::nullopt;
  }
  double total = 0;
  for (const Segment& s : segments) total += s.duration;
  log::Log ref;
  ref.comments.push_back("paper 001 reference '" + name + "'");
  ref.columns = {{"cyl", "ref"}};
  ref.values.assign(1, {});
  const long ticks = std::lround(total / T);
  for (long k = 0; k <= ticks; ++k) {
    const double t = static_cast<double>(k) * T;
    // the segment holding tick k, counted in whole ticks so that a hold is exactly constant
    long start = 0;
    double value = segments.back().to;
    for (const Segment& s : segments) {
      const long length = std::lround(s.duration / T);
      if (k < start + length) {
        value = SegmentValue(s, static_cast<double>(k - start) * T);
        break;
      }
      start += length;
    }
    ref.time.push_back(t);
    ref.values[0].push_back(value);
  }
  if (duration) *duration = total;
  return ref;
}

log::Log Karpenko2006SineReference(double amplitude, double frequency, double duration) {
  const double T = 1 / kKarpenko2006ControlRate;
  log::Log ref;
  ref.comments.push_back("sine " + Format(1e3 * amplitude) + " mm, " + Format(frequency) + " Hz");
  ref.columns = {{"cyl", "ref"}};
  ref.values.assign(1, {});
  const long ticks = std::lround(duration / T);
  for (long k = 0; k <= ticks; ++k) {
    const double t = static_cast<double>(k) * T;
    ref.time.push_back(t);
    ref.values[0].push_back(amplitude * std::sin(2 * kPi * frequency * t));
  }
  return ref;
}

ClosedLoopResult RunKarpenko2006(const mjModel* m, const log::Log& reference, double duration,
                                 const KarpenkoPidParams& params) {
  ClosedLoopOptions options;
  options.duration = duration;
  options.control_rate = kKarpenko2006ControlRate;
  options.controller = "custom";
  options.reference = &reference;
  options.make_controller = [&params](const std::vector<ValveDrive>& drives, double T, std::string* error) {
    std::unique_ptr<Controller> c = KarpenkoPid::Create(drives, params, T, error);
    return c;
  };
  return RunClosedLoop(m, options);
}

Karpenko2006StepMetrics Karpenko2006MeasureStep(const log::Log& log, double step_time, double step) {
  Karpenko2006StepMetrics out;
  const std::vector<double>& x = Column(log, "x");
  const std::vector<double>& ref = Column(log, "ref");
  if (x.empty() || ref.empty() || step == 0) return out;
  const double sign = step > 0 ? 1 : -1;
  const double end = log.time.back();
  double worst = 0;
  for (size_t k = 0; k < log.rows(); ++k) {
    if (log.time[k] < step_time - 1e-9) continue;
    const double travelled = sign * x[k];  // the run starts at x = 0
    worst = std::max(worst, travelled - std::fabs(step));
    if (out.rise_time_s < 0 && travelled >= 0.9 * std::fabs(step)) out.rise_time_s = log.time[k] - step_time;
    if (log.time[k] >= end - kSteadyWindow - 1e-9) {
      out.steady_error_mm = std::max(out.steady_error_mm, 1e3 * std::fabs(ref[k] - x[k]));
    }
  }
  out.overshoot_pct = 100 * worst / std::fabs(step);
  return out;
}

Karpenko2006TrackingMetrics Karpenko2006MeasureTracking(const log::Log& log) {
  Karpenko2006TrackingMetrics out;
  const std::vector<double>& x = Column(log, "x");
  const std::vector<double>& ref = Column(log, "ref");
  if (x.empty() || ref.empty() || log.rows() == 0) return out;
  const size_t n = log.rows();
  double squared = 0;
  bool moving = false;       // the reference has started to move
  double move_start = 0;
  double direction = 0;      // of the last move
  for (size_t k = 0; k < n; ++k) {
    const double e = ref[k] - x[k];
    squared += e * e;
    out.peak_error_mm = std::max(out.peak_error_mm, 1e3 * std::fabs(e));
    const bool still = k > 0 && ref[k] == ref[k - 1];
    if (k > 0 && !still) direction = ref[k] > ref[k - 1] ? 1 : -1;
    if (!moving && k > 0 && !still) moving = true, move_start = log.time[k - 1];
    if (moving && out.deadtime_s < 0 && std::fabs(x[k] - x[0]) >= 0.001) out.deadtime_s = log.time[k] - move_start;
    // a hold: past its target in the last move's direction; and its end (the next tick moves, or the log ends)
    if (still && direction != 0) {
      out.overshoot_mm = std::max(out.overshoot_mm, 1e3 * direction * (x[k] - ref[k]));
      const bool hold_ends = k + 1 == n || ref[k + 1] != ref[k];
      if (hold_ends) out.max_hold_error_mm = std::max(out.max_hold_error_mm, 1e3 * std::fabs(e));
    }
  }
  out.final_error_mm = 1e3 * std::fabs(ref[n - 1] - x[n - 1]);
  out.rms_error_mm = 1e3 * std::sqrt(squared / static_cast<double>(n));
  return out;
}

namespace {

double Number(const nlohmann::json& j) { return j.is_number() ? j.get<double>() : std::nan(""); }

nlohmann::json StepJson(const Karpenko2006StepMetrics& m) {
  return {{"overshoot_pct", Round(m.overshoot_pct, 2)},
          {"rise_time_s", m.rise_time_s < 0 ? nlohmann::json() : nlohmann::json(Round(m.rise_time_s))},
          {"steady_error_mm", Round(m.steady_error_mm)}};
}

// paper 001's figures, as the report quotes them
nlohmann::json PaperFigures() {
  return {
      {"source", "paper 001 (Karpenko, Sepehri), Section V: simulated unit step responses of the QFT plant set (Fig. 5); "
                 "Section VI: experiments on the Festo MPYE-5 / DNC rig (Figs. 6-9)"},
      {"simulation", {{"step", {{"linear_pi", {{"overshoot_pct", kPaperSimLinearOvershoot}}},
                                {"reset_pi", {{"overshoot_pct_below", kPaperSimResetOvershoot}}}}}}},
      {"experiment", {{"step", {{"reset_pi", {{"rise_time_s", kPaperExpRiseTime},
                                              {"steady_error_mm_below", kPaperExpSteadyError}}}}},
                      {"s_curve", {{"plain", {{"peak_error_mm", kPaperExpPlainPeakError},
                                              {"deadtime_s", kPaperExpPlainDeadtime},
                                              {"note", "stick-slip on the small slow ramps; overshoot when x_d' returns to 0"}}},
                                   {"augmented", {{"note", "Fig. 8: deadtime much reduced, overshoot remains"}}},
                                   {"augmented_braking", {{"max_steady_error_mm", kPaperExpTrackingSteady},
                                                          {"note", "Fig. 9: overshoot removed (VII: steady errors up to 4 mm)"}}}}}}}};
}

// ours against theirs, with the differences; a sentence where they disagree
struct Comparison {
  nlohmann::json comparison = nlohmann::json::array();
  nlohmann::json disagreement = nlohmann::json::array();

  void Compare(const std::string& what, const std::string& kind, double paper, double ours, const std::string& unit,
               bool is_bound, double tolerance) {
    nlohmann::json c = {{"quantity", what}, {"source", kind}, {"paper", paper}, {"simulated", Round(ours, 3)},
                        {"unit", unit}, {"difference", Round(ours - paper, 3)}};
    if (is_bound) c["paper_is_upper_bound"] = true;
    comparison.push_back(c);
    const bool off = is_bound ? ours > paper : std::fabs(ours - paper) > tolerance;
    if (off) {
      disagreement.push_back(what + ": " + Format(ours) + " " + unit + " simulated against the paper's " +
                             (is_bound ? "under " : "") + Format(paper) + " " + unit + " (" + kind + "), " +
                             (ours > paper ? "+" : "") + Format(ours - paper, 3) + " " +
                             (unit == "%" ? std::string("percentage points") : unit));
    }
  }

  // the figures of the paper's Figs. 5-9 against the runs'
  void CompareFigures(nlohmann::json& report) {
    const nlohmann::json& st = report["step"];
    const nlohmann::json& sc = report["s_curve"];
    Compare("step, linear PI overshoot", "simulation, Fig. 5a", kPaperSimLinearOvershoot,
            Number(st["linear_pi"]["overshoot_pct"]), "%", false, 5);
    Compare("step, resetting PI overshoot", "simulation, Fig. 5b", kPaperSimResetOvershoot,
            Number(st["reset_pi"]["overshoot_pct"]), "%", true, 0);
    const nlohmann::json& sn = report["step_nominal"];
    Compare("step on the nominal rig (no deadband, no friction), linear PI overshoot", "simulation, Fig. 5a",
            kPaperSimLinearOvershoot, Number(sn["linear_pi"]["overshoot_pct"]), "%", false, 5);
    Compare("step on the nominal rig (no deadband, no friction), resetting PI overshoot", "simulation, Fig. 5b",
            kPaperSimResetOvershoot, Number(sn["reset_pi"]["overshoot_pct"]), "%", true, 0);
    Compare("step, resetting PI 90 % rise time", "experiment, Fig. 6", kPaperExpRiseTime,
            Number(st["reset_pi"]["rise_time_s"]), "s", false, 0.2 * kPaperExpRiseTime);
    Compare("step, resetting PI steady error", "experiment, Fig. 6", kPaperExpSteadyError,
            Number(st["reset_pi"]["steady_error_mm"]), "mm", true, 0);
    Compare("S-curves, resetting PI peak error", "experiment, Fig. 7", kPaperExpPlainPeakError,
            Number(sc["plain"]["peak_error_mm"]), "mm", false, 0.3 * kPaperExpPlainPeakError);
    Compare("S-curves, resetting PI deadtime", "experiment, Fig. 7", kPaperExpPlainDeadtime,
            Number(sc["plain"]["deadtime_s"]), "s", false, 0.3 * kPaperExpPlainDeadtime);
    Compare("S-curves, full controller steady error at the holds", "experiment, Fig. 9 and VII", kPaperExpTrackingSteady,
            Number(sc["augmented_braking"]["max_hold_error_mm"]), "mm", true, 0);
  }

  // the S-curves' deadtime and overshoot against Figs. 8-9, and why the steps differ from Fig. 5
  void ExplainStepsAndSCurves(nlohmann::json& report) {
    const nlohmann::json& st = report["step"];
    const nlohmann::json& sc = report["s_curve"];
    const nlohmann::json& sn = report["step_nominal"];
    if (Number(sc["augmented"]["deadtime_s"]) >= Number(sc["plain"]["deadtime_s"])) {
      disagreement.push_back("S-curves: the augmentation (14-15) does not shorten the deadtime (" +
                             Format(Number(sc["augmented"]["deadtime_s"])) + " s against " +
                             Format(Number(sc["plain"]["deadtime_s"])) + " s without; Fig. 8: much shorter)");
    }
    if (Number(sc["augmented_braking"]["overshoot_mm"]) >= Number(sc["augmented"]["overshoot_mm"])) {
      disagreement.push_back("S-curves: the braking term (16-17) does not reduce the overshoot at the holds (" +
                             Format(Number(sc["augmented_braking"]["overshoot_mm"])) + " mm against " +
                             Format(Number(sc["augmented"]["overshoot_mm"])) + " mm without; Fig. 9: removed)");
    }
    {
      const double sl = Number(st["linear_pi"]["overshoot_pct"]), sr = Number(st["reset_pi"]["overshoot_pct"]);
      const double nl = Number(sn["linear_pi"]["overshoot_pct"]), nr = Number(sn["reset_pi"]["overshoot_pct"]);
      disagreement.push_back(
          "why the steps differ from Fig. 5: on rig B with deadband and friction the piston sticks short of the target "
          "(K_p e = 1 V at the step, barely past the 0.6 V deadband once e has fallen) and the integral breaks it loose "
          "into a stick-slip jump; the overshoot (" + Format(sl) + " % linear, " + Format(sr) + " % resetting) is that "
          "jump, and the resetting PI's advantage is " + Format(sl - sr, 2) + " percentage points, from zeroing the integral "
          "as the error passes through +-eps during the jump. On the nominal rig the overshoot (" + Format(nl) + " % / " +
          Format(nr) + " %) comes from the proportional loop's underdamped pneumatic spring, not from the integral "
          "(K_i / K_p = 2.6 1/s against a 0.12 s rise), so the reset, which acts on the integral only, removes " +
          Format(nl - nr, 2) + " percentage points, not the paper's 21");
    }
    if (Number(sc["augmented_braking"]["overshoot_mm"]) > kPaperExpTrackingSteady) {
      disagreement.push_back("S-curves: with braking (16-17) the overshoot at the holds is " +
                             Format(Number(sc["augmented_braking"]["overshoot_mm"])) + " mm (" +
                             Format(Number(sc["augmented"]["overshoot_mm"])) + " mm without; Fig. 9: removed). The "
                             "augmentation holds u at +-0.65 V while the piston lags, which moves it at several cm/s on "
                             "rig B; the piston then sticks past the target and the integral needs seconds (K_i e = "
                             "0.5 V/s at 20 mm) to cross the deadband back, longer than our 2-3 s holds");
    }
  }

  // the slow sines where the full controller tracks worse, and the set-up's differences
  void ExplainSinesAndSetUp(nlohmann::json& report) {
    for (const nlohmann::json& s : report["sines"]) {
      if (Number(s["augmented_braking"]["max_error_mm"]) > Number(s["reset_pi"]["max_error_mm"])) {
        disagreement.push_back(
            "sine " + Format(Number(s["amplitude_mm"])) + " mm at " + Format(Number(s["frequency_hz"])) +
            " Hz (peak " + Format(Number(s["peak_speed_mm_s"])) + " mm/s, not a paper experiment): the full controller's "
            "max error " + Format(Number(s["augmented_braking"]["max_error_mm"])) + " mm is worse than the resetting PI's " +
            Format(Number(s["reset_pi"]["max_error_mm"])) + " mm. On rig B, u_upper = u_lower = 0.65 V is 0.05 V past the "
            "0.6 V deadband and moves the piston faster than a slow reference; a piston that sticks ahead of the reference "
            "gives e_db' = -x_d' (14), and (15) pushes it on, away from the reference, whatever the position error");
      }
    }
    disagreement.push_back(
        "set-up, not a result: the paper's Fig. 5 is a simulation of unit steps through its linearised QFT plant set "
        "(transfer functions at three operating points, no deadband or friction); ours is the nonlinear rig B with the "
        "paper's deadband and friction, and a 100 mm step (the paper gives no size for Fig. 6). The paper's sample "
        "rate is not given; we run 1 kHz. The S-curve profile, speeds and timing are ours (the paper: 'a number of "
        "S-curve trajectories covering 60 % of the stroke', small peak speeds). Velocities and accelerations in "
        "(14-17) are backward differences of the measured position and of the reference; the paper does not say how "
        "it estimated them. Comparisons with the experiments are for reference only.");
  }
};

// the rig, the controller and the metrics' definitions, for the report
nlohmann::json Setup(const mjModel* model, const std::string& path) {
  auto parameter = [&](const char* key) {
    std::string e;
    std::optional<double> v = GetParameter(model, "cyl", key, &e);
    return v ? *v : std::nan("");
  };
  const double deadband = parameter("deadband"), coulomb = parameter("coulomb_friction");
  const double u_max = parameter("u_max"), spool_gain = parameter("spool_gain");
  const KarpenkoPidParams paper;
  return {
      {"rig", "rig B of docs/rigs.md with paper 001's deadband and friction: " + path},
      {"deadband", deadband},
      {"deadband_v", Round(deadband * u_max, 3)},
      {"coulomb_friction_n", coulomb},
      {"static_friction_n", 40},
      {"spool_gain_m_per_v", spool_gain},
      {"control_rate_hz", kKarpenko2006ControlRate},
      {"step", {{"time_s", kKarpenko2006StepTime}, {"size_m", kKarpenko2006Step}, {"hold_s", kStepHold}}},
      {"s_curve", "cycloidal moves 0 -> -150 mm (3 s), hold 2 s, -150 -> +150 mm (6 s), hold 3 s, +150 -> 0 (3 s), "
                  "hold 3 s, 0 -> +20 mm (2 s), hold 2 s, after 0.5 s at 0; peak speed 0.1 m/s"},
      {"controller", {{"kp_v_per_m", paper.kp}, {"ki_v_per_m_s", paper.ki}, {"epsilon_m", paper.epsilon},
                      {"epsilon_augmented_braking_m", 0.004}, {"e_dot_min_m_s", paper.e_dot_min},
                      {"beta", paper.beta}, {"u_lower_v", paper.u_lower}, {"u_upper_v", paper.u_upper},
                      {"ka_s2", paper.ka}, {"u_max_v", u_max}}},
      {"definitions",
       {{"overshoot_pct", "100 max(x - target, 0) / step after the step"},
        {"rise_time_s", "from the step to the first tick at 90 % of the step"},
        {"steady_error_mm", "max |x_d - x| over the last 0.5 s"},
        {"peak_error_mm", "max |x_d - x| over the run"},
        {"final_error_mm", "|x_d - x| at the last tick"},
        {"max_hold_error_mm", "max over the holds of |x_d - x| at the hold's last tick"},
        {"overshoot_mm", "max over the holds of how far x passes the target in the last move's direction"},
        {"deadtime_s", "from the first move of the reference until the piston has moved 1 mm"}}}};
}

// One run of ReproduceKarpenko2006: rig B with the paper's deadband and friction, where the logs go,
// and the report its experiments fill. Every experiment returns an error, or "".
struct Karpenko2006Reproduction {
  const std::string& models_dir;
  const std::string& out_dir;
  const mjModel* model;
  nlohmann::json report;

  // one controller on one reference: its log into *out (and out_dir), its warnings into the report
  std::string Run(const std::string& experiment, const std::string& name, const log::Log& reference, double duration,
                  log::Log* out) {
    const std::optional<KarpenkoPidParams> params = Karpenko2006Controller(name);
    ClosedLoopResult result = RunKarpenko2006(model, reference, duration, *params);
    if (!result.log) return experiment + ", " + name + ": " + result.error;
    result.log->comments.push_back("paper 001 " + experiment + " under the '" + name + "' controller");
    if (!out_dir.empty()) {
      const std::string file = out_dir + "/karpenko2006_" + experiment + "_" + name + ".csv";
      if (std::string e = log::WriteLog(file, *result.log); !e.empty()) return e;
    }
    for (const std::string& w : result.summary.warnings) report["warnings"].push_back(experiment + ", " + name + ": " + w);
    *out = std::move(*result.log);
    return "";
  }

  // the step (Figs. 5-6)
  std::string RunSteps() {
    double duration = 0;
    std::string error;
    std::optional<log::Log> ref = Karpenko2006Reference("step", kKarpenko2006Step, &duration, &error);
    if (!ref) return error;
    for (const std::string name : {"linear_pi", "reset_pi"}) {
      log::Log log;
      if (std::string e = Run("step", name, *ref, duration, &log); !e.empty()) return e;
      report["step"][name] = StepJson(Karpenko2006MeasureStep(log, kKarpenko2006StepTime, kKarpenko2006Step));
    }
    return "";
  }

  // the step on the nominal rig B (rig_proportional.xml: no deadband, no seal friction), the closer analogue
  // of Fig. 5's simulation, whose plants leave both out
  std::string RunStepsOnTheNominalRig() {
    const std::string nominal_path = models_dir + "/rig_proportional.xml";
    std::string why;
    ModelPtr nominal = LoadAttachedModel(nominal_path, &why);
    if (!nominal) return why;
    double duration = 0;
    std::string error;
    std::optional<log::Log> ref = Karpenko2006Reference("step", kKarpenko2006Step, &duration, &error);
    if (!ref) return error;
    for (const std::string name : {"linear_pi", "reset_pi"}) {
      ClosedLoopResult result = RunKarpenko2006(nominal.get(), *ref, duration, *Karpenko2006Controller(name));
      if (!result.log) return "step on the nominal rig, " + name + ": " + result.error;
      if (!out_dir.empty()) {
        const std::string file = out_dir + "/karpenko2006_step_nominal_" + name + ".csv";
        if (std::string e = log::WriteLog(file, *result.log); !e.empty()) return e;
      }
      report["step_nominal"][name] = StepJson(Karpenko2006MeasureStep(*result.log, kKarpenko2006StepTime, kKarpenko2006Step));
    }
    return "";
  }

  // the S-curves (Figs. 7-9)
  std::string RunSCurves() {
    double duration = 0;
    std::string error;
    std::optional<log::Log> ref = Karpenko2006Reference("s_curve", 0, &duration, &error);
    if (!ref) return error;
    for (const std::string name : {"plain", "augmented", "augmented_braking"}) {
      log::Log log;
      if (std::string e = Run("s_curve", name, *ref, duration, &log); !e.empty()) return e;
      const Karpenko2006TrackingMetrics m = Karpenko2006MeasureTracking(log);
      report["s_curve"][name] = {{"peak_error_mm", Round(m.peak_error_mm, 2)},
                                 {"final_error_mm", Round(m.final_error_mm)},
                                 {"max_hold_error_mm", Round(m.max_hold_error_mm)},
                                 {"overshoot_mm", Round(m.overshoot_mm)},
                                 {"rms_error_mm", Round(m.rms_error_mm)},
                                 {"deadtime_s", m.deadtime_s < 0 ? nlohmann::json() : nlohmann::json(Round(m.deadtime_s))}};
    }
    return "";
  }

  // slow sines (not in the paper): where the augmentation's fixed +-0.65 V drives the piston faster than the reference
  std::string RunSlowSines() {
    for (const auto& sine : kSines) {  // NOLINT
      const double a = sine[0], f = sine[1], duration = kSineWarmUp + 1.5 / f;
      const log::Log ref = Karpenko2006SineReference(a, f, duration);
      nlohmann::json out = {{"amplitude_mm", 1e3 * a}, {"frequency_hz", f}, {"peak_speed_mm_s", Round(2e3 * kPi * a * f, 1)}};
      for (const std::string name : {"reset_pi", "augmented_braking"}) {
        ClosedLoopResult result = RunKarpenko2006(model, ref, duration, *Karpenko2006Controller(name));
        if (!result.log) return "sine, " + name + ": " + result.error;
        const std::vector<double>& x = Column(*result.log, "x");
        double worst = 0, squared = 0;
        long n = 0;
        for (size_t k = 0; k < result.log->rows(); ++k) {
          if (result.log->time[k] < kSineWarmUp - 1e-9) continue;
          const double e = ref.values[0][k] - x[k];
          worst = std::max(worst, std::fabs(e)), squared += e * e, ++n;
        }
        out[name] = {{"max_error_mm", Round(1e3 * worst, 2)},
                     {"rms_error_mm", Round(n ? 1e3 * std::sqrt(squared / static_cast<double>(n)) : 0, 2)}};
      }
      report["sines"].push_back(out);
    }
    return "";
  }
};

}  // namespace

nlohmann::json ReproduceKarpenko2006(const std::string& models_dir, const std::string& out_dir, std::string* error) {
  const std::string path = models_dir + "/rig_proportional_full.xml";
  std::string why;
  ModelPtr model = LoadAttachedModel(path, &why);
  if (!model) return Failed(why, error);
  if (Cylinders(model.get()).size() != 1) return Failed(path + ": expected one cylinder (rig B)", error);
  if (std::string e = CreateOutputDirectory(out_dir); !e.empty()) return Failed(e, error);

  Karpenko2006Reproduction run{models_dir, out_dir, model.get(), {}};
  for (auto experiment : {&Karpenko2006Reproduction::RunSteps, &Karpenko2006Reproduction::RunStepsOnTheNominalRig,
                          &Karpenko2006Reproduction::RunSCurves, &Karpenko2006Reproduction::RunSlowSines}) {
    if (std::string e = (run.*experiment)(); !e.empty()) return Failed(e, error);
  }
  nlohmann::json& report = run.report;
  report["paper"] = PaperFigures();
  Comparison c;
  c.CompareFigures(report);
  c.ExplainStepsAndSCurves(report);
  c.ExplainSinesAndSetUp(report);
  report["comparison"] = c.comparison;
  report["disagreement"] = c.disagreement;

  const nlohmann::json& st = report["step"];
  const double linear = Number(st["linear_pi"]["overshoot_pct"]), reset = Number(st["reset_pi"]["overshoot_pct"]);
  report["done_when"] = {{"criterion", "the resetting PI overshoots less than the linear PI on the step"},
                         {"linear_pi_overshoot_pct", linear},
                         {"reset_pi_overshoot_pct", reset},
                         {"pass", reset < linear}};
  report["setup"] = Setup(model.get(), path);
  return Finish(out_dir, "karpenko2006", std::move(report), error);
}

}  // namespace pneumatic
