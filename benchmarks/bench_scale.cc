// Scaling benchmark of the pneumatic extension: many cylinders in one model, and threads. It
// prints Markdown to stdout (headings start at ###; progress goes to stderr).
//
// Model (ModelXml, generated here): N = 38 independent bodies (0.5 kg), each on its own slide
// joint (limited to +-0.05 m, damping 20 N s/m), gravity 0, Euler, timestep 1 ms, no contacts
// (every geom has contype=0 conaffinity=0). In the pneumatic model each joint is driven by a
// rig C cylinder exactly as in models_mjcf/rig_per_chamber.xml (actuators c<i>.uP, c<i>.uN,
// c<i>.P, c<i>.N and the same parameters): 2 x 38 = 76 chambers. The same model with
// commands=chambers has no c<i>.uP, c<i>.uN: the voltages are the ctrl of c<i>.P, c<i>.N (two
// actuators per cylinder; same physics, bit for bit: tests/command_place_test). The motor twin
// has the same bodies and joints with one <motor> (gear 1) per joint and no extension.
//
// Commands, set at the start of each 10 ms control period and held: s_i = sin(2 pi f_i t +
// phi_i) with f_i spread over 0.5..3 Hz. Motor i gets 1 N * s_i. Cylinder i gets uP = 5 + d_i,
// uN = 5 - d_i (V, clamped to 3..7 V) with d_i = 1 V * s_i - 40 V/m x_i - 0.3 V s/m v_i: the
// centring term of rig C's reference excitation (tests/reference), without which an open-loop
// valve pair integrates the piston into its limits at any amplitude. The state is reset every
// 4 s of simulated time. The s_i are tabulated before any timing, so the timed loop is
// mj_step plus the controls (38 cylinders every 10 steps) and the resets.
//
// Speed: each model is stepped for 0.2 s of wall time (warm-up, not counted), then for about
// 1 s; the time per mj_step is wall time / steps. Five runs, alternating the two models; the
// median is reported. The extension's cost per chamber step is
// (us per step, pneumatic - us per step, motor twin) / 76, for each actuator layout.
//
// Threads: 1 and 2 threads step their own mjData of the same mjModel at the same time, each
// for 0.2 s of warm-up then about 1 s; the total steps/s is the sum over the threads. Median of
// three runs.
//
// Check: one untimed reset period (4 s) of each model, checking every step for MuJoCo warnings
// (d->warning), non-finite state, chamber pressures outside [0.5 p_exhaust, 1.1 p_supply],
// and recording the piston positions reached. The timed runs also count MuJoCo warnings.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <mujoco/mujoco.h>

#include "formats/model_loading.h"
#include "machine.h"
#include "pneumatic/pneumatic.h"

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kDefaultCylinders = 38;
constexpr double kTimestep = 1e-3;         // s
constexpr double kControlPeriod = 10e-3;   // s: commands held 10 ms (100 Hz)
constexpr double kResetSeconds = 4;        // simulated s between resets
constexpr double kWarmupSeconds = 0.2;     // wall s
constexpr double kMeasureSeconds = 1;      // wall s
constexpr int kSpeedRepeats = 5;
constexpr int kThreadRepeats = 3;
constexpr double kValveAmplitude = 1;      // V: differential valve command around 5 V
constexpr double kCentringPosition = 40;   // V/m: rig C's centring term (tests/reference)
constexpr double kCentringVelocity = 0.3;  // V s/m
constexpr double kMotorAmplitude = 1;      // N
constexpr double kJointRange = 0.05;       // m
constexpr double kNearLimit = 1e-3;        // m: "at the limit" when closer than this

double Seconds(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// MuJoCo prints warnings to stdout unless told otherwise: keep the output clean, count them
int mujoco_warnings = 0;
void CountWarning(const char*) { ++mujoco_warnings; }


//---------------------------------- models ---------------------------------------------------------

// the rig C cylinder of models_mjcf/rig_per_chamber.xml
constexpr const char* kRigC =
    "valve=proportional_per_chamber stroke=0.1 P.area=7.854e-5 N.area=6.597e-5 dead_volume=1.0e-6 "
    "p_supply=6.2e5 p_exhaust=1.0e5 temperature=293 gas_constant=286.55172413793103 "
    "heat_capacity_ratio=1.4 polytropic_index=1.4 compressibility=0.99 flow=thin_plate "
    "discharge_coefficient=0.72 area_gain=2e-6 u_supply_seal=5.3 u_exhaust_seal=4.7 "
    "leak_area_supply=5e-8 leak_area_exhaust=5e-8 area_smoothing=1e-6";

std::string Name(const char* prefix, int i, const char* suffix = "") {
  return prefix + std::to_string(i) + suffix;
}

// how each joint is driven
enum class Layout {
  kCommandActuators,  // a rig C cylinder: c<i>.uP, c<i>.uN (valve voltages), c<i>.P, c<i>.N
  kCommandsInChambers,  // the same with commands=chambers: c<i>.P, c<i>.N, whose ctrl are the voltages
  kMotors,            // the twin: one motor
};

// MJCF of `cylinders` sliding bodies, each driven as `layout` says
std::string ModelXml(int cylinders, Layout layout) {
  const bool pneumatic = layout != Layout::kMotors, in_chambers = layout == Layout::kCommandsInChambers;
  std::string xml = "<mujoco model=\"scale\">\n";
  xml += "  <option timestep=\"" + std::to_string(kTimestep) + "\" integrator=\"Euler\" gravity=\"0 0 0\"/>\n";
  if (pneumatic) xml += "  <size nuser_actuator=\"" + std::to_string(pneumatic::ActuatorUserSize()) + "\"/>\n";

  // bodies side by side along y, each on its own slide joint
  xml += "  <worldbody>\n";
  for (int i = 0; i < cylinders; ++i) {
    xml += "    <body name=\"" + Name("b", i) + "\" pos=\"0 " + std::to_string(0.03 * i) + " 0\">\n"
           "      <inertial pos=\"0 0 0\" mass=\"0.5\" diaginertia=\"1e-4 1e-4 1e-4\"/>\n"
           "      <joint name=\"" + Name("x", i) + "\" type=\"slide\" axis=\"1 0 0\" limited=\"true\" "
           "range=\"-0.05 0.05\" damping=\"20\"/>\n"
           "      <geom type=\"capsule\" fromto=\"0 0 0 0.12 0 0\" size=\"0.002\" contype=\"0\" conaffinity=\"0\"/>\n"
           "    </body>\n";
  }
  xml += "  </worldbody>\n  <actuator>\n";

  // MuJoCo 2.2 wants the stateless actuators (valve commands, motors) before the chambers
  for (int i = 0; i < cylinders; ++i) {
    std::string joint = "joint=\"" + Name("x", i) + "\"";
    if (!pneumatic) {
      xml += "    <motor name=\"" + Name("m", i) + "\" " + joint + " gear=\"1\"/>\n";
      continue;
    }
    for (const char* role : {".uP", ".uN"}) {
      if (in_chambers) break;
      xml += "    <general name=\"" + Name("c", i, role) + "\" " + joint +
             " gaintype=\"user\" ctrllimited=\"true\" ctrlrange=\"0 10\"/>\n";
    }
  }
  for (int i = 0; pneumatic && i < cylinders; ++i) {
    for (const char* role : {".P", ".N"}) {
      xml += "    <general name=\"" + Name("c", i, role) + "\" joint=\"" + Name("x", i) +
             "\" dyntype=\"user\" gaintype=\"user\"" + (in_chambers ? " ctrllimited=\"true\" ctrlrange=\"0 10\"" : "") +
             "/>\n";
    }
  }
  xml += "  </actuator>\n";

  // one configuration per cylinder
  if (pneumatic) {
    xml += "  <custom>\n";
    for (int i = 0; i < cylinders; ++i) {
      xml += "    <text name=\"" + Name("pneumatic:c", i) + "\" data=\"" + kRigC +
             (in_chambers ? " commands=chambers" : "") + "\"/>\n";
    }
    xml += "  </custom>\n";
  }
  return xml + "</mujoco>\n";
}

// compiles MJCF text; null and *error on failure
mjModel* LoadXml(const std::string& xml, std::string* error) {
  return pneumatic::LoadModelFromText(xml, "scale.xml", error).release();
}

//---------------------------------- commands -------------------------------------------------------

// excitation of cylinder i of n: sin(2 pi f_i t + phi_i), f_i in 0.5..3 Hz
double Excitation(int i, int n, double t) {
  double f = 0.5 + 2.5 * i / std::max(1, n - 1);
  double phi = 2.399963 * i;   // golden angle: phases spread evenly
  return std::sin(2 * M_PI * f * t + phi);
}

// a model, its commanded actuators and the excitation of one reset period
struct Drive {
  const char* label;
  mjModel* m;
  int chambers;                                 // 0 for the motor twin
  std::vector<int> actuators;                   // per cylinder: uP and uN, or its motor
  std::vector<int> qpos, dof;                   // per cylinder: its joint's qpos and qvel index
  std::vector<std::vector<double>> excitation;  // [period][cylinder]: s_i at the period's start
};

// the actuators, joints and excitation table of a model (an attached one, if pneumatic)
Drive MakeDrive(const char* label, mjModel* m, int cylinders, bool pneumatic) {
  Drive drive{label, m, pneumatic ? 2 * cylinders : 0, {}, {}, {}, {}};
  std::vector<pneumatic::CylinderInfo> infos;
  if (pneumatic) infos = pneumatic::Cylinders(m);
  for (int i = 0; i < cylinders; ++i) {
    if (pneumatic) {
      // uP and uN, wherever the layout keeps them
      auto info = std::find_if(infos.begin(), infos.end(), [&](const auto& c) { return c.name == Name("c", i); });
      for (const auto& [signal, id] : info->command_actuators) drive.actuators.push_back(id);
    } else {
      drive.actuators.push_back(mj_name2id(m, mjOBJ_ACTUATOR, Name("m", i).c_str()));
    }
    int joint = mj_name2id(m, mjOBJ_JOINT, Name("x", i).c_str());
    drive.qpos.push_back(m->jnt_qposadr[joint]);
    drive.dof.push_back(m->jnt_dofadr[joint]);
  }
  long periods = std::lround(kResetSeconds / kControlPeriod);
  for (long k = 0; k < periods; ++k) {
    std::vector<double> row;
    double t = static_cast<double>(k) * kControlPeriod;
    for (int i = 0; i < cylinders; ++i) row.push_back(Excitation(i, cylinders, t));
    drive.excitation.push_back(row);
  }
  return drive;
}

// the controls of one control period: valve voltages, or motor forces
void ApplyControls(const Drive& drive, size_t period, mjData* d) {
  const std::vector<double>& s = drive.excitation[period];
  for (size_t i = 0; i < s.size(); ++i) {
    if (drive.chambers == 0) {
      d->ctrl[drive.actuators[i]] = kMotorAmplitude * s[i];
      continue;
    }
    // differential command, centred on x = 0 as rig C's reference excitation is
    double diff = kValveAmplitude * s[i] - kCentringPosition * d->qpos[drive.qpos[i]] -
                  kCentringVelocity * d->qvel[drive.dof[i]];
    d->ctrl[drive.actuators[2 * i]] = std::clamp(5 + diff, 3.0, 7.0);
    d->ctrl[drive.actuators[2 * i + 1]] = std::clamp(5 - diff, 3.0, 7.0);
  }
}

//---------------------------------- stepping -------------------------------------------------------

// an mjData and where it is in the command table
struct Runner {
  const Drive& drive;
  mjData* d;
  size_t period = 0;
  long warnings = 0;   // MuJoCo warnings seen before the resets

  explicit Runner(const Drive& dr) : drive(dr), d(mj_makeData(dr.m)) {}
  ~Runner() { mj_deleteData(d); }
  Runner(const Runner&) = delete;
  Runner& operator=(const Runner&) = delete;

  long Warnings() const {
    long n = warnings;
    for (int w = 0; w < mjNWARNING; ++w) n += d->warning[w].number;
    return n;
  }

  // one control period: reset at the end of the table, set the controls, step
  long StepPeriod() {
    if (period == drive.excitation.size()) {
      warnings = Warnings();
      mj_resetData(drive.m, d);
      period = 0;
    }
    ApplyControls(drive, period++, d);
    long steps = std::lround(kControlPeriod / drive.m->opt.timestep);
    for (long s = 0; s < steps; ++s) mj_step(drive.m, d);
    return steps;
  }

  // steps whole control periods for about `seconds` of wall time; returns steps and *elapsed
  long StepFor(double seconds, double* elapsed) {
    long steps = 0;
    Clock::time_point start = Clock::now();
    do {
      for (int k = 0; k < 10; ++k) steps += StepPeriod();
      *elapsed = Seconds(start);
    } while (*elapsed < seconds);
    return steps;
  }
};

// us per mj_step after a warm-up; adds the run's MuJoCo warnings to *warnings
double MicrosecondsPerStep(const Drive& drive, long* warnings) {
  Runner runner(drive);
  double elapsed = 0;
  runner.StepFor(kWarmupSeconds, &elapsed);
  long steps = runner.StepFor(kMeasureSeconds, &elapsed);
  *warnings += runner.Warnings();
  return elapsed / static_cast<double>(steps) * 1e6;
}

// total steps/s of `threads` threads, each stepping its own mjData
double StepsPerSecond(const Drive& drive, int threads, long* warnings) {
  std::vector<double> rate(threads);
  std::vector<long> warned(threads);
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&, t]() {
      Runner runner(drive);
      double elapsed = 0;
      runner.StepFor(kWarmupSeconds, &elapsed);
      long steps = runner.StepFor(kMeasureSeconds, &elapsed);
      rate[t] = static_cast<double>(steps) / elapsed;
      warned[t] = runner.Warnings();
    });
  }
  for (std::thread& thread : pool) thread.join();
  for (long w : warned) *warnings += w;
  double total = 0;
  for (double r : rate) total += r;
  return total;
}

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

//---------------------------------- check ----------------------------------------------------------

// what one untimed reset period of a model went through
struct Check {
  long warnings = 0;
  bool finite = true;
  double p_min = INFINITY, p_max = -INFINITY;   // Pa abs, over all chambers and steps
  double p_low = 0, p_high = 0;                 // the allowed band, Pa abs
  double x_min = INFINITY, x_max = -INFINITY;   // m, over all joints and steps
  double near_limit = 0;                        // share of joint-steps within kNearLimit of a limit
  int cylinders_at_limit = 0;                   // joints that came within kNearLimit of a limit
  double smallest_swing = INFINITY;             // m: the least max - min of any joint
};

bool Finite(const mjtNum* v, int n) {
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(v[i])) return false;
  }
  return true;
}

// records the pressures of every chamber into `c`
void CheckPressures(const Drive& drive, const mjData* d, const std::vector<pneumatic::CylinderInfo>& cyls, Check* c) {
  for (const pneumatic::CylinderInfo& cyl : cyls) {
    for (pneumatic::Chamber k : {pneumatic::Chamber::kP, pneumatic::Chamber::kN}) {
      double p = pneumatic::ChamberPressure(drive.m, d, cyl, k);
      c->p_min = std::min(c->p_min, p), c->p_max = std::max(c->p_max, p);
    }
    c->p_low = std::min(c->p_low == 0 ? INFINITY : c->p_low, 0.5 * cyl.p_exhaust);
    c->p_high = std::max(c->p_high, 1.1 * cyl.p_supply);
  }
}

// one reset period, checked after every step
Check RunCheck(const Drive& drive) {
  Check c;
  Runner runner(drive);
  const mjModel* m = drive.m;
  mjData* d = runner.d;
  std::vector<pneumatic::CylinderInfo> cyls = pneumatic::Cylinders(m);
  std::vector<bool> touched(m->njnt, false);
  std::vector<double> lo(m->njnt, INFINITY), hi(m->njnt, -INFINITY);
  long joint_steps = 0, near = 0;
  for (size_t period = 0; period < drive.excitation.size(); ++period) {
    ApplyControls(drive, period, d);
    for (long s = 0; s < std::lround(kControlPeriod / m->opt.timestep); ++s) {
      mj_step(m, d);
      c.finite = c.finite && Finite(d->qpos, m->nq) && Finite(d->qvel, m->nv) && Finite(d->act, m->na);
      CheckPressures(drive, d, cyls, &c);
      // piston positions: each slide joint's qpos
      for (int j = 0; j < m->njnt; ++j) {
        double x = d->qpos[m->jnt_qposadr[j]];
        c.x_min = std::min(c.x_min, x), c.x_max = std::max(c.x_max, x);
        lo[j] = std::min(lo[j], x), hi[j] = std::max(hi[j], x);
        bool at_limit = kJointRange - std::fabs(x) < kNearLimit;
        near += at_limit, touched[j] = touched[j] || at_limit;
        ++joint_steps;
      }
    }
  }
  c.warnings = runner.Warnings();
  c.near_limit = static_cast<double>(near) / static_cast<double>(joint_steps);
  c.cylinders_at_limit = static_cast<int>(std::count(touched.begin(), touched.end(), true));
  for (int j = 0; j < m->njnt; ++j) c.smallest_swing = std::min(c.smallest_swing, hi[j] - lo[j]);
  return c;
}

//---------------------------------- output ---------------------------------------------------------

// the speed table of the pneumatic models against the twin; fills *warnings
void PrintSpeed(const std::vector<const Drive*>& pneumatic, const Drive& motor, int cylinders, long* warnings) {
  // alternate the models so that a slow phase of the machine hits all alike
  std::vector<std::vector<double>> us_pneu(pneumatic.size());
  std::vector<double> us_motor;
  for (int r = 0; r < kSpeedRepeats; ++r) {
    std::fprintf(stderr, "speed: run %d/%d\n", r + 1, kSpeedRepeats);
    for (size_t i = 0; i < pneumatic.size(); ++i) us_pneu[i].push_back(MicrosecondsPerStep(*pneumatic[i], warnings));
    us_motor.push_back(MicrosecondsPerStep(motor, warnings));
  }
  const int chambers = pneumatic[0]->chambers;
  double q = Median(us_motor);
  std::printf("### %d chambers vs the motor twin\n\n", chambers);
  std::printf("%d bodies on slide joints (timestep 1 ms, Euler, no contacts), each driven by a rig C cylinder "
              "(%d chambers) or, in the twin, by a motor. The cylinders' valve voltages are their own actuators "
              "(uP, uN: four actuators per cylinder) or, with commands=chambers, the ctrl of the chamber "
              "actuators (two per cylinder; the same physics bit for bit). Commands held 10 ms: s_i = sin(2 pi "
              "f_i t + phi_i), f_i = 0.5..3 Hz; valves uP,N = 5 +- (%g V s_i - %g V/m x_i - %g V s/m v_i), motors "
              "%g N s_i; reset every %g s. Median of %d alternating runs of about %.0f s after a %.1f s warm-up.\n\n",
              cylinders, chambers, kValveAmplitude, kCentringPosition, kCentringVelocity, kMotorAmplitude,
              kResetSeconds, kSpeedRepeats, kMeasureSeconds, kWarmupSeconds);
  std::printf("| model | us per step | steps/s | ratio to the twin | extension cost per chamber step (us) |\n"
              "|---|---:|---:|---:|---:|\n");
  for (size_t i = 0; i < pneumatic.size(); ++i) {
    double p = Median(us_pneu[i]);
    std::printf("| %s | %.2f | %.0f | %.2f | (%.2f - %.2f) / %d = **%.3f** |\n", pneumatic[i]->label, p, 1e6 / p,
                p / q, p, q, chambers, (p - q) / chambers);
  }
  std::printf("| %s | %.2f | %.0f | 1 | |\n\n", motor.label, q, 1e6 / q);
}

// the threads table; fills *warnings
void PrintThreads(const std::vector<const Drive*>& drives, long* warnings) {
  std::printf("### Threads\n\n");
  std::printf("Each thread steps its own mjData of the same mjModel for about %.0f s after a %.1f s warm-up; "
              "steps/s is the total over the threads, median of %d runs.\n\n",
              kMeasureSeconds, kWarmupSeconds, kThreadRepeats);
  std::printf("| model | 1 thread (steps/s) | 2 threads (steps/s) | speed-up |\n|---|---:|---:|---:|\n");
  for (const Drive* drive : drives) {
    double rate[2];
    for (int threads = 1; threads <= 2; ++threads) {
      std::vector<double> runs;
      for (int r = 0; r < kThreadRepeats; ++r) {
        std::fprintf(stderr, "threads: %s, %d thread(s), run %d/%d\n", drive->label, threads, r + 1, kThreadRepeats);
        runs.push_back(StepsPerSecond(*drive, threads, warnings));
      }
      rate[threads - 1] = Median(runs);
    }
    std::printf("| %s | %.0f | %.0f | %.2f |\n", drive->label, rate[0], rate[1], rate[1] / rate[0]);
  }
  std::printf("\n");
}

// the check lines of one model
void PrintCheck(const Drive& drive, const Check& c) {
  std::printf("* %s: %ld MuJoCo warnings, state %s", drive.label, c.warnings, c.finite ? "finite" : "NOT finite");
  if (drive.chambers > 0) {
    bool inside = c.p_min >= c.p_low && c.p_max <= c.p_high;
    std::printf(", chamber pressures %.1f..%.1f kPa abs (%s [%.1f, %.1f] kPa)", c.p_min / 1e3, c.p_max / 1e3,
                inside ? "within" : "**OUTSIDE**", c.p_low / 1e3, c.p_high / 1e3);
  }
  std::printf(", pistons %.1f..%.1f mm (limits +-%.0f mm), every joint swept at least %.1f mm; "
              "%d joints came within %.0f mm of a limit, %.1f %% of joint-steps.\n",
              c.x_min * 1e3, c.x_max * 1e3, kJointRange * 1e3, c.smallest_swing * 1e3, c.cylinders_at_limit,
              kNearLimit * 1e3, 100 * c.near_limit);
}

}  // namespace

int main(int argc, char** argv) {
  mju_user_warning = CountWarning;
  int cylinders = argc > 1 ? std::atoi(argv[1]) : kDefaultCylinders;
  if (cylinders < 1) {
    std::fprintf(stderr, "usage: bench_scale [cylinders]\n");
    return 1;
  }

  // the models, the pneumatic ones attached to the extension
  std::string error;
  mjModel* m_pneu = LoadXml(ModelXml(cylinders, Layout::kCommandActuators), &error);
  mjModel* m_compact = m_pneu ? LoadXml(ModelXml(cylinders, Layout::kCommandsInChambers), &error) : nullptr;
  mjModel* m_motor = m_compact ? LoadXml(ModelXml(cylinders, Layout::kMotors), &error) : nullptr;
  if (!m_motor || !pneumatic::Attach(m_pneu, &error) || !pneumatic::Attach(m_compact, &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 1;
  }
  std::string n = std::to_string(cylinders);
  std::string pneu_label = "pneumatic (" + n + " rig C cylinders, " + std::to_string(m_pneu->nu) + " actuators)";
  std::string compact_label = "pneumatic, commands=chambers (" + n + " rig C cylinders, " +
                              std::to_string(m_compact->nu) + " actuators)";
  std::string motor_label = "motor twin (" + n + " motors)";
  Drive pneu = MakeDrive(pneu_label.c_str(), m_pneu, cylinders, true);
  Drive compact = MakeDrive(compact_label.c_str(), m_compact, cylinders, true);
  Drive motor = MakeDrive(motor_label.c_str(), m_motor, cylinders, false);

  // figures
  pneumatic::benchmarks::PrintMachine(PNEUMATIC_BUILD_TYPE);
  long warnings = 0;
  PrintSpeed({&pneu, &compact}, motor, cylinders, &warnings);
  PrintThreads({&pneu, &compact, &motor}, &warnings);

  // the simulation stayed sane and moved the pistons
  std::fprintf(stderr, "check\n");
  Check check_pneu = RunCheck(pneu), check_compact = RunCheck(compact), check_motor = RunCheck(motor);
  std::printf("### Check\n\n");
  std::printf("One untimed reset period (%.0f s) of each model, checked after every step.\n\n", kResetSeconds);
  PrintCheck(pneu, check_pneu);
  PrintCheck(compact, check_compact);
  PrintCheck(motor, check_motor);
  std::printf("* timed runs: %ld MuJoCo warnings (d->warning), %d reported through mju_user_warning.\n",
              warnings, mujoco_warnings);

  for (mjModel* m : {m_pneu, m_compact}) pneumatic::Detach(m);
  for (mjModel* m : {m_pneu, m_compact, m_motor}) mj_deleteModel(m);
  bool ok = warnings == 0;
  for (const Check* c : {&check_pneu, &check_compact, &check_motor}) ok = ok && c->finite && c->warnings == 0;
  for (const Check* c : {&check_pneu, &check_compact}) ok = ok && c->p_min >= c->p_low && c->p_max <= c->p_high;
  return ok ? 0 : 1;
}
