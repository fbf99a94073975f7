// Identification at humanoid scale (issue 13): paper 000's parametric model fitted to 76
// valve-chamber systems (its humanoid's 76 = 2 x 38 chambers, Section V) of 10^5 samples each
// (a 1000 s log at 100 Hz), with 1 and with 2 threads. It prints Markdown to stdout.
//
// Data: two 1000 s closed-loop logs of rig C (pneumatic::Generate, seeds 1 and 2, generated on
// two threads, not timed) give 4 distinct chambers of 99999 samples each; the 76 datasets are
// these 4 reused 19 times each. Every chamber is fitted from the default initial guess
// (ParametricFitOptions{}: coarse-to-fine, every 16th pair then all of them), standard errors
// included. Timed: FitChambers over the 76 datasets, wall time, once with 1 thread and once with
// 2; the two results must be bit-identical.
// Options for quick runs: --seconds S (log length), --chambers N.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <mujoco/mujoco.h>

#include "identification/chamber_series.h"
#include "identification/parametric_fit.h"
#include "machine.h"
#include "pneumatic/pneumatic.h"
#include "simulation/generate.h"

namespace {

using Clock = std::chrono::steady_clock;
using pneumatic::identification::ChamberSeries;
using pneumatic::identification::ParametricFit;

double g_log_seconds = 1000;  // 10^5 rows at 100 Hz; `--seconds S` changes it (quick runs)
int g_chambers = 76;         // `--chambers N` changes it

// the chambers of one generated rig C log; "" or why not
std::string RigCChambers(std::uint64_t seed, std::vector<ChamberSeries>* out) {
  const std::string path = std::string(PNEUMATIC_MODELS_DIR) + "/rig_per_chamber.xml";
  char error[1000] = "";
  mjModel* m = mj_loadXML(path.c_str(), nullptr, error, sizeof(error));
  if (!m) return path + ": " + error;
  std::string why;
  if (!pneumatic::Attach(m, &why)) {
    mj_deleteModel(m);
    return why;
  }
  pneumatic::GenerateOptions options;
  options.duration = g_log_seconds;
  options.seed = seed;
  pneumatic::GenerateResult generated = pneumatic::Generate(m, options);
  if (generated.log) why = pneumatic::identification::ExtractChambers(m, *generated.log, out);
  else why = generated.error;
  pneumatic::Detach(m);
  mj_deleteModel(m);
  return why;
}

double Seconds(Clock::time_point since) { return std::chrono::duration<double>(Clock::now() - since).count(); }

bool SameFits(const std::vector<ParametricFit>& a, const std::vector<ParametricFit>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::memcmp(a[i].model.c.data(), b[i].model.c.data(), sizeof(double) * 9) != 0) return false;
    if (std::memcmp(&a[i].rms_residual, &b[i].rms_residual, sizeof(double)) != 0) return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--seconds") == 0) g_log_seconds = std::atof(argv[i + 1]);
    if (std::strcmp(argv[i], "--chambers") == 0) g_chambers = std::atoi(argv[i + 1]);
  }
  if (!(g_log_seconds >= 2) || g_chambers < 1) {
    std::fprintf(stderr, "usage: bench_identify [--seconds S (>= 2)] [--chambers N (>= 1)]\n");
    return 2;
  }
  pneumatic::benchmarks::PrintMachine(PNEUMATIC_BUILD_TYPE);
  std::fprintf(stderr, "generating two %.0f s logs of rig C ...\n", g_log_seconds);
  std::vector<ChamberSeries> logs[2];
  std::string errors[2];
  {
    std::thread second([&] { errors[1] = RigCChambers(2, &logs[1]); });
    errors[0] = RigCChambers(1, &logs[0]);
    second.join();
  }
  for (const std::string& e : errors) {
    if (!e.empty()) {
      std::fprintf(stderr, "bench_identify: %s\n", e.c_str());
      return 1;
    }
  }
  std::vector<ChamberSeries> distinct = logs[0];
  distinct.insert(distinct.end(), logs[1].begin(), logs[1].end());
  std::vector<ChamberSeries> series;
  for (int i = 0; i < g_chambers; ++i) series.push_back(distinct[static_cast<size_t>(i) % distinct.size()]);

  std::printf("### Parametric identification (paper 000 eqs. 7-10), %d chambers x %zu samples\n\n", g_chambers,
              series[0].p.size());
  std::printf("| threads | wall time (s) | speed-up |\n|---|---|---|\n");
  double one_thread = 0;
  std::vector<ParametricFit> reference;
  for (int threads : {1, 2}) {
    std::fprintf(stderr, "fitting with %d thread(s) ...\n", threads);
    const Clock::time_point start = Clock::now();
    std::vector<ParametricFit> fits = pneumatic::identification::FitChambers(series, {}, threads);
    const double seconds = Seconds(start);
    if (threads == 1) one_thread = seconds, reference = fits;
    std::printf("| %d | %.2f | %.2f |\n", threads, seconds, one_thread / seconds);
    if (threads != 1 && !SameFits(fits, reference)) {
      std::printf("\nERROR: the fits with %d threads differ from those with 1 thread\n", threads);
      return 1;
    }
  }
  std::printf("\nPer distinct chamber (fits identical with 1 and 2 threads):\n\n");
  std::printf("| chamber | iterations (full data) | coarse iterations | converged | rms residual (Pa) | one-step fit (%%) | "
              "warnings |\n|---|---|---|---|---|---|---|\n");
  for (size_t i = 0; i < distinct.size(); ++i) {
    const ParametricFit& f = reference[i];
    std::printf("| %s (seed %zu) | %d | %d | %s | %.0f | %.2f | %zu%s%s |\n", f.name.c_str(), i / 2 + 1, f.iterations,
                f.coarse_iterations, f.converged ? "yes" : "no", f.rms_residual, f.one_step_fit_pct, f.warnings.size(),
                f.error.empty() ? "" : ", error: ", f.error.c_str());
  }
  return 0;
}
