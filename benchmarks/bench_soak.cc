// Soak (issue 54, item 7): the pneumatic humanoid under PID with the shipped gains, the wave
// (models_mjcf/humanoid_wave.csv, 7.5 s, starting and ending in the same pose) repeated for an hour
// of simulated time, as one closed-loop run resumed wave after wave (ClosedLoopOptions::resume: the
// same rows as one uninterrupted run, bit for bit). Prints Markdown:
//  * the resident set size after the first wave and after the last, and its peak (VmRSS, VmHWM of
//    /proc/self/status): a run that keeps nothing per step holds them flat;
//  * every chamber's mean pressure over each wave: the largest change of a chamber's mean between
//    the second wave and the last, and its least-squares trend over the run: once the start-up
//    transient has passed, a periodic motion under a periodic command has periodic pressures, so a
//    trend there is not physics (the closed loop is not exactly periodic: the wave-to-wave scatter
//    is printed beside it);
//  * the RMS tracking error of each wave (its first and last), and every warning the runs raised
//    (references beyond a stroke, pressures outside the supply range, MuJoCo's warnings).
// `bench_soak [SECONDS]` (default 3600 of simulated time, whole waves); exits 1 on a warning, a
// failed run or a non-finite pressure, so that a short run is a smoke test.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <mujoco/mujoco.h>

#include "formats/log_csv.h"
#include "formats/model_loading.h"
#include "machine.h"
#include "pneumatic/pneumatic.h"
#include "simulation/closed_loop.h"
#include "simulation/controller_config.h"

namespace {

constexpr double kWaveSeconds = 7.5;

// "VmRSS" or "VmHWM" of /proc/self/status, in MiB
double StatusMiB(const char* key) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind(key, 0) == 0) return std::atof(line.c_str() + line.find(':') + 1) / 1024.0;  // kB
  }
  return 0;
}

// the wave shifted to start at `start` seconds
pneumatic::log::Log Shifted(const pneumatic::log::Log& wave, double start) {
  pneumatic::log::Log shifted = wave;
  for (double& t : shifted.time) t += start;
  return shifted;
}

void Fail(const std::string& message) {
  std::fprintf(stderr, "bench_soak: %s\n", message.c_str());
  std::exit(1);
}

// what the waves leave: per wave, each chamber's mean pressure (Pa) and the RMS tracking error over
// the cylinders; the warnings, the steps, and the resident set after the first wave and every 40
struct SoakRecord {
  std::vector<std::vector<double>> mean_pressure;
  std::vector<double> rms_tracking;
  std::vector<std::string> warnings;
  double rss_first = 0;
  std::vector<std::pair<int, double>> rss_by_wave;  // (wave, MiB) every 40 waves
  double rss_last = 0, rss_peak = 0;                // MiB, after the last wave
  long steps = 0;
};

// each chamber's mean pressure over wave k's log
std::vector<double> MeanPressures(const pneumatic::log::Log& log, int k) {
  std::vector<double> means;
  for (size_t c = 0; c < log.columns.size(); ++c) {
    const std::string& signal = log.columns[c].signal;
    if (signal != "p_P" && signal != "p_N") continue;
    double sum = 0;
    for (double p : log.values[c]) {
      if (!std::isfinite(p)) Fail("a non-finite pressure in wave " + std::to_string(k + 1));
      sum += p;
    }
    means.push_back(sum / static_cast<double>(log.values[c].size()));
  }
  return means;
}

// the wave `waves` times, one closed-loop run resumed wave after wave
void RunWaves(const mjModel* m, pneumatic::ClosedLoopOptions options, const pneumatic::log::Log& wave, int waves,
              SoakRecord* record) {
  pneumatic::ClosedLoopState state;
  for (int k = 0; k < waves; ++k) {
    pneumatic::log::Log reference = Shifted(wave, k * kWaveSeconds);
    options.reference = &reference;
    options.duration = kWaveSeconds;
    options.resume = k == 0 ? nullptr : &state;
    pneumatic::ClosedLoopResult result = pneumatic::RunClosedLoop(m, options);
    if (!result.log) Fail("wave " + std::to_string(k + 1) + ": " + result.error);
    for (const std::string& w : result.summary.warnings) record->warnings.push_back("wave " + std::to_string(k + 1) + ": " + w);
    state = std::move(result.final_state);
    record->steps += result.summary.steps;
    record->mean_pressure.push_back(MeanPressures(*result.log, k));
    double squares = 0;
    for (const auto& c : result.summary.cylinders) squares += c.rms_tracking_error * c.rms_tracking_error;
    record->rms_tracking.push_back(std::sqrt(squares / static_cast<double>(result.summary.cylinders.size())));
    if (k == 0) record->rss_first = StatusMiB("VmRSS");
    if ((k + 1) % 40 == 0 || k + 1 == waves) {
      record->rss_by_wave.emplace_back(k + 1, StatusMiB("VmRSS"));
      std::fprintf(stderr, "soak: wave %d of %d, resident set %.1f MiB\n", k + 1, waves, record->rss_by_wave.back().second);
    }
  }
}

// how the chambers' mean pressures per wave move over the run
struct Drift {
  double drift = 0, late_step = 0;  // Pa
  size_t chamber_of_drift = 0;
  double trend = 0;                 // Pa over the run
  double first_mean = 0, last_mean = 0;  // Pa, over the chambers
};

// each chamber's least-squares trend of its per-wave mean from the second wave on, as the change it
// makes over the run: what a drift would show and wave-to-wave scatter does not; the largest
double LargestTrend(const std::vector<std::vector<double>>& mean_pressure) {
  double trend = 0;
  const std::vector<double>& last = mean_pressure.back();
  const size_t n = mean_pressure.size() - 1;  // waves 2..N
  double t_mean = 0;
  for (size_t k = 1; k < mean_pressure.size(); ++k) t_mean += static_cast<double>(k) / static_cast<double>(n);
  for (size_t i = 0; i < last.size(); ++i) {
    double p_mean = 0;
    for (size_t k = 1; k < mean_pressure.size(); ++k) p_mean += mean_pressure[k][i] / static_cast<double>(n);
    double covariance = 0, variance = 0;
    for (size_t k = 1; k < mean_pressure.size(); ++k) {
      const double dt = static_cast<double>(k) - t_mean;
      covariance += dt * (mean_pressure[k][i] - p_mean), variance += dt * dt;
    }
    if (variance > 0) trend = std::max(trend, std::fabs(covariance / variance) * static_cast<double>(n));
  }
  return trend;
}

Drift MeasureDrift(const std::vector<std::vector<double>>& mean_pressure) {
  Drift d;
  // the largest change of a chamber's mean pressure per wave from the second wave to the last, and
  // the largest wave-to-wave change over the last ten waves
  const std::vector<double>& second = mean_pressure[1];
  const std::vector<double>& last = mean_pressure.back();
  for (size_t i = 0; i < last.size(); ++i) {
    if (std::fabs(last[i] - second[i]) > d.drift) d.drift = std::fabs(last[i] - second[i]), d.chamber_of_drift = i;
  }
  for (size_t k = std::max<size_t>(1, mean_pressure.size() - 10); k < mean_pressure.size(); ++k) {
    for (size_t i = 0; i < last.size(); ++i) {
      d.late_step = std::max(d.late_step, std::fabs(mean_pressure[k][i] - mean_pressure[k - 1][i]));
    }
  }
  d.trend = LargestTrend(mean_pressure);
  for (size_t i = 0; i < last.size(); ++i) d.first_mean += mean_pressure[0][i], d.last_mean += last[i];
  d.first_mean /= static_cast<double>(last.size()), d.last_mean /= static_cast<double>(last.size());
  return d;
}

void PrintFigures(const SoakRecord& r, const Drift& d, int waves, double wall) {
  std::printf("| figure | value |\n|---|---:|\n");
  std::printf("| simulated time | %.0f s (%ld steps) |\n", waves * kWaveSeconds, r.steps);
  std::printf("| wall time | %.0f s (real-time factor %.1f) |\n", wall, waves * kWaveSeconds / wall);
  std::printf("| resident set after the first wave | %.1f MiB |\n", r.rss_first);
  std::printf("| resident set after the last wave | %.1f MiB |\n", r.rss_last);
  std::printf("| peak resident set (VmHWM, as the kernel last counted it) | %.1f MiB |\n", r.rss_peak);
  std::printf("| resident set every 40 waves |");
  for (const auto& [k, mib] : r.rss_by_wave) std::printf(" %.1f", mib);
  std::printf(" MiB |\n");
  std::printf("| mean chamber pressure, first wave / last wave | %.1f / %.1f kPa |\n", d.first_mean / 1e3,
              d.last_mean / 1e3);
  std::printf("| largest change of a chamber's mean pressure per wave, wave 2 to wave %d | %.3g Pa (chamber %zu of %zu) |\n",
              waves, d.drift, d.chamber_of_drift + 1, r.mean_pressure.back().size());
  std::printf("| largest wave-to-wave change of a chamber's mean over the last 10 waves | %.3g Pa |\n", d.late_step);
  std::printf("| largest trend of a chamber's mean per wave, wave 2 to wave %d (least squares, over the run) | %.3g Pa |\n",
              waves, d.trend);
  std::printf("| RMS tracking error, first wave / last wave | %.3g / %.3g rad or m |\n", r.rms_tracking.front(),
              r.rms_tracking.back());
  std::printf("| warnings | %zu |\n", r.warnings.size());
  for (const std::string& w : r.warnings) std::printf("\n* %s", w.c_str());
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 3600;
  const int waves = std::max(2, static_cast<int>(std::lround(seconds / kWaveSeconds)));
  const std::string dir = std::string(PNEUMATIC_MODELS_DIR) + "/";
  std::string error;
  pneumatic::ModelPtr model = pneumatic::LoadAttachedModel(dir + "humanoid_pneumatic.xml", &error);
  if (!model) Fail(error);
  const mjModel* m = model.get();
  pneumatic::ClosedLoopOptions options;
  error = pneumatic::ReadControllerConfig(dir + "humanoid_pid.json", &options);
  if (!error.empty()) Fail(error);
  pneumatic::log::ReadOptions read;
  for (const auto& c : pneumatic::Cylinders(m)) read.cylinders.insert(c.name);
  read.uniform_time = false;
  pneumatic::log::ReadResult wave = pneumatic::log::ReadLog(dir + "humanoid_wave.csv", read);
  if (!wave.log) Fail(wave.error);

  pneumatic::benchmarks::PrintMachine(PNEUMATIC_BUILD_TYPE);
  std::printf("Soak: humanoid_pneumatic.xml (72 chambers, 1 ms Euler) under PID with humanoid_pid.json, the wave "
              "repeated %d times (%.0f s simulated), resumed wave after wave.\n\n",
              waves, waves * kWaveSeconds);
  SoakRecord record;
  const auto start = std::chrono::steady_clock::now();
  RunWaves(m, options, *wave.log, waves, &record);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  record.rss_last = StatusMiB("VmRSS"), record.rss_peak = StatusMiB("VmHWM");
  PrintFigures(record, MeasureDrift(record.mean_pressure), waves, wall);
  return record.warnings.empty() ? 0 : 1;
}
