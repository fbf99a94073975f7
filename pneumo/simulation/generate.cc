#include "simulation/generate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <vector>

#include "pid.h"
#include "pneumatic/pneumatic.h"
#include "simulation/random_stream.h"
#include "simulation/rollout.h"

namespace pneumatic {
namespace {

constexpr double kPi = 3.14159265358979323846;

// the law of generate.h
constexpr int kReferenceSines = 4;
constexpr double kReferenceFreqMin = 0.1, kReferenceFreqMax = 0.8;  // Hz
constexpr double kReferenceFraction = 0.7;  // of the half stroke: PID overshoot stays off the limits
constexpr double kFadeIn = 1.0;             // s: the reference rises from 0 (the rest state) as sin^2
constexpr double kCoContractionFreqMin = 0.03, kCoContractionFreqMax = 0.15;  // Hz
constexpr double kCoContractionMean = 0.25, kCoContractionAmplitude = 0.75;  // V: c in [-0.5, 1]
constexpr double kValveCentre = 5, kValveMin = 3, kValveMax = 7;              // V
constexpr PidGains kGains{/*kp=*/60, /*ki=*/60, /*kd=*/1.5, /*u_offset=*/0, /*u_min=*/-4, /*u_max=*/4};

struct Sine {
  double amplitude, frequency, phase;
  double operator()(double t) const { return amplitude * std::sin(2 * kPi * frequency * t + phase); }
};

enum Purpose : std::uint64_t { kReference = 1, kCoContraction = 2, kNoise = 3 };

// what drives one cylinder
struct Channel {
  CylinderInfo info;
  int actuator_uP = -1, actuator_uN = -1;
  std::vector<double> reference;        // per row, m
  std::vector<Sine> co_contraction;     // C(t) of generate.h
  Stream noise;
  Pid pid;
};

// the rows and the model steps per row the options ask for, or an error
std::string PlanRows(const mjModel* m, const GenerateOptions& options, size_t* rows, long* steps) {
  if (!std::isfinite(options.duration) || !(options.duration > 0)) return "the duration must be a positive number of seconds";
  if (!(options.period > 0) || !std::isfinite(options.period)) return "the period must be positive";
  if (!(options.noise_pressure >= 0) || !std::isfinite(options.noise_pressure)) return "the pressure noise must be >= 0 Pa";
  if (!(options.noise_position >= 0) || !std::isfinite(options.noise_position)) return "the position noise must be >= 0 m";
  double rows_real = std::ceil(options.duration / options.period - 1e-9);
  if (rows_real < 2) return "the duration must cover at least two rows (" + std::to_string(2 * options.period) + " s)";
  if (rows_real > 1e8) return "the duration is too long (at most 1e8 rows)";
  *rows = static_cast<size_t>(rows_real);
  const double timestep = m->opt.timestep;
  const double steps_per_row = options.period / timestep;
  *steps = std::lround(steps_per_row);
  if (*steps < 1 || std::fabs(steps_per_row - static_cast<double>(*steps)) > 1e-6 * steps_per_row) {
    return "the control period " + std::to_string(options.period) + " s is not a whole number of model timesteps (" +
           std::to_string(timestep) + " s)";
  }
  return "";
}

// reference: a sum of sines scaled so that its largest row reaches kReferenceFraction of the half stroke
std::vector<double> ReferenceRows(const GenerateOptions& options, size_t i, size_t rows, double stroke) {
  Stream random(options.seed, i, kReference);
  std::vector<Sine> sines;
  for (int k = 0; k < kReferenceSines; ++k) {
    double f = random.Uniform(kReferenceFreqMin, kReferenceFreqMax);
    sines.push_back({1 / f, f, random.Uniform(0, 2 * kPi)});
  }
  std::vector<double> reference(rows);
  double peak = 0;
  for (size_t row = 0; row < rows; ++row) {
    double t = static_cast<double>(row) * options.period, s = 0;
    for (const Sine& sine : sines) s += sine(t);
    if (t < kFadeIn) s *= std::pow(std::sin(0.5 * kPi * t / kFadeIn), 2);
    reference[row] = s;
    peak = std::max(peak, std::fabs(s));
  }
  double scale = peak > 0 ? kReferenceFraction * 0.5 * stroke / peak : 0;
  for (double& r : reference) r *= scale;
  return reference;
}

// what drives cylinder i (c): one proportional valve per chamber, commanded by uP and uN
std::string MakeChannel(const mjModel* m, const GenerateOptions& options, const CylinderInfo& c, size_t i, size_t rows,
                        std::vector<Channel>* channels) {
  Channel ch{c, -1, -1, {}, {}, Stream(options.seed, i, kNoise), Pid(kGains, options.period)};
  ch.actuator_uP = c.CommandActuator("uP"), ch.actuator_uN = c.CommandActuator("uN");
  if (ch.actuator_uP < 0 || ch.actuator_uN < 0 || c.command_actuators.size() != 2) {
    return "cylinder '" + c.name + "' has valve=" + GetChoice(m, c.name, "valve", nullptr).value_or("?") +
           ": generate drives one proportional valve per chamber (valve=proportional_per_chamber, "
           "commands uP and uN, paper 000's set-up, rig C)";
  }
  std::string why;
  std::optional<double> stroke = GetParameter(m, c.name, "stroke", &why);
  if (!stroke) return "cylinder '" + c.name + "': " + why;
  ch.reference = ReferenceRows(options, i, rows, *stroke);
  Stream slow(options.seed, i, kCoContraction);
  for (int k = 0; k < 2; ++k) {
    double f = slow.Uniform(kCoContractionFreqMin, kCoContractionFreqMax);
    ch.co_contraction.push_back({0.5, f, slow.Uniform(0, 2 * kPi)});
  }
  channels->push_back(std::move(ch));
  return "";
}

// columns per cylinder: uP, uN, p_P, p_N, x, v, ref
constexpr int kColumns = 7;

// One generate run's simulation: the rows' sensors, the law's commands, and the range of each
// piston's noise-free position.
struct GenerateRun {
  const mjModel* m;
  const GenerateOptions& options;
  std::vector<Channel>& channels;
  log::Log& out;
  double noise_velocity;
  std::vector<double> x_min, x_max;

  // row `row`: the sensors at its time t, before its command acts, and the law's commands for it
  void DriveRow(mjData* d, size_t row, double t) {
    for (size_t i = 0; i < channels.size(); ++i) {
      Channel& ch = channels[i];
      const double p_P = ChamberPressure(m, d, ch.info, Chamber::kP);
      const double p_N = ChamberPressure(m, d, ch.info, Chamber::kN);
      const double x = PistonPosition(m, d, ch.info);
      const double v = PistonVelocity(m, d, ch.info);
      x_min[i] = std::min(x_min[i], x), x_max[i] = std::max(x_max[i], x);

      const double r = ch.reference[row];
      const double diff = ch.pid.Update(r, x);
      double c = 0;
      for (const Sine& s : ch.co_contraction) c += s(t);
      c = kCoContractionMean + kCoContractionAmplitude * c;
      const double uP = std::clamp(kValveCentre + c + diff, kValveMin, kValveMax);
      const double uN = std::clamp(kValveCentre + c - diff, kValveMin, kValveMax);
      d->ctrl[ch.actuator_uP] = uP;
      d->ctrl[ch.actuator_uN] = uN;

      // noise drawn whatever its level, so that the noise-free run is the same run
      const double n_P = ch.noise.Gaussian(), n_N = ch.noise.Gaussian(), n_x = ch.noise.Gaussian(),
                   n_v = ch.noise.Gaussian();
      std::vector<std::vector<double>>::iterator col = out.values.begin() + static_cast<long>(i) * kColumns;
      col[0][row] = uP;
      col[1][row] = uN;
      col[2][row] = p_P + options.noise_pressure * n_P;
      col[3][row] = p_N + options.noise_pressure * n_N;
      col[4][row] = x + options.noise_position * n_x;
      col[5][row] = v + noise_velocity * n_v;
      col[6][row] = r;
    }
  }

  // every row, each held for `steps` model steps; an error if the simulation diverged
  std::string Simulate(size_t rows, long steps) {
    std::unique_ptr<mjData, void (*)(mjData*)> d(mj_makeData(m), mj_deleteData);
    if (!d) return "mj_makeData failed";
    x_min.assign(channels.size(), 1e300), x_max.assign(channels.size(), -1e300);
    for (size_t row = 0; row < rows; ++row) {
      const double t = static_cast<double>(row) * options.period;
      out.time[row] = t;
      mj_forward(m, d.get());  // sensors at the row's time, before its command acts
      DriveRow(d.get(), row, t);
      for (long k = 0; k < steps; ++k) mj_step(m, d.get());
      for (int w : {mjWARN_BADQACC, mjWARN_BADQVEL, mjWARN_BADQPOS, mjWARN_BADCTRL}) {
        if (d->warning[w].number > 0) {
          return "the simulation diverged near t = " + std::to_string(d->time) + " s (MuJoCo warning " +
                 std::to_string(w) + ")";
        }
      }
    }
    return "";
  }

  // the log's comments: the run, the law, the sampling, the noise and the range each piston reached
  void WriteComments(size_t rows) {
    char line[400];
    out.comments.push_back("generated by pneumo generate: closed-loop identification run (paper 000 Section V.C)");
    std::snprintf(line, sizeof(line), "seed %llu, %zu rows at %g Hz, commands held %g ms (zero-order hold)",
                  static_cast<unsigned long long>(options.seed), rows, 1 / options.period, 1e3 * options.period);
    out.comments.push_back(line);
    std::snprintf(line, sizeof(line),
                  "law: uP = clamp(%g + c + d, %g, %g) V, uN = clamp(%g + c - d, %g, %g) V; d = PID(ref, x) with kp %g V/m, "
                  "ki %g V/(m s), kd %g V s/m, |d| <= %g V; c = %g + %g (sin + sin)/2 V at %g-%g Hz; ref = %d sines at %g-%g "
                  "Hz (amplitude 1/f), peak %g %% of the half stroke, faded in over %g s",
                  kValveCentre, kValveMin, kValveMax, kValveCentre, kValveMin, kValveMax, kGains.kp, kGains.ki, kGains.kd,
                  kGains.u_max, kCoContractionMean, kCoContractionAmplitude, kCoContractionFreqMin, kCoContractionFreqMax,
                  kReferenceSines, kReferenceFreqMin, kReferenceFreqMax, 100 * kReferenceFraction, kFadeIn);
    out.comments.push_back(line);
    out.comments.push_back(
        "measured columns are instantaneous samples at the row's time, before the row's command acts (docs/log_format.md), not "
        "paper 000's 10 ms averages");
    std::snprintf(line, sizeof(line),
                  "sensor noise (Gaussian, seeded): p_P, p_N %g Pa; x %g m; v %g m/s (sqrt(2) x noise / period); uP, uN, "
                  "ref exact; the controller sees the noise-free x",
                  options.noise_pressure, options.noise_position, noise_velocity);
    out.comments.push_back(line);
    for (size_t i = 0; i < channels.size(); ++i) {
      std::snprintf(line, sizeof(line), "%s: noise-free x reached %.4f .. %.4f m", channels[i].info.name.c_str(), x_min[i],
                    x_max[i]);
      out.comments.push_back(line);
    }
  }
};

}  // namespace

GenerateResult Generate(const mjModel* m, const GenerateOptions& options) {
  GenerateResult result;
  auto fail = [&](const std::string& message) {
    result.error = message;
    return result;
  };
  std::vector<CylinderInfo> cylinders;
  if (std::string problem = AttachedCylinders(m, &cylinders); !problem.empty()) return fail(problem);
  size_t rows = 0;
  long steps = 0;
  if (std::string problem = PlanRows(m, options, &rows, &steps); !problem.empty()) return fail(problem);
  std::vector<Channel> channels;
  for (size_t i = 0; i < cylinders.size(); ++i) {
    if (std::string problem = MakeChannel(m, options, cylinders[i], i, rows, &channels); !problem.empty()) {
      return fail(problem);
    }
  }
  log::Log out;
  for (const Channel& ch : channels) {
    for (const char* signal : {"uP", "uN", "p_P", "p_N", "x", "v", "ref"}) out.columns.push_back({ch.info.name, signal});
  }
  out.values.assign(out.columns.size(), std::vector<double>(rows));
  out.time.resize(rows);
  const double noise_velocity = std::sqrt(2.0) * options.noise_position / options.period;
  GenerateRun run{m, options, channels, out, noise_velocity, {}, {}};
  if (std::string problem = run.Simulate(rows, steps); !problem.empty()) return fail(problem);
  run.WriteComments(rows);
  if (std::string problem = log::ValidateLog(out, /*uniform_time=*/true); !problem.empty()) return fail(problem);
  result.log = std::move(out);
  return result;
}

}  // namespace pneumatic
