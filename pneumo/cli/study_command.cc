#include "cli/study_command.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "formats/report_files.h"
#include "studies/study.h"

namespace pneumatic::cli {
namespace {

struct StudyArguments {
  std::string plan_path, out_dir, scheduler;
  int jobs = 1;
  long point = -1;
  bool unfinished = false, collect = false, local = false, no_plots = false;
};

int StudyFail(const std::string& message) {
  std::fprintf(stderr, "pneumo study: %s\n", message.c_str());
  return 1;
}

// SIGINT, SIGTERM, SIGHUP: the first stops new points from starting (the points under way end
// whole or unrecorded), a second ends the process as the signal would
std::atomic<bool> stop_requested{false};

void OnSignal(int signal_number) {
  if (stop_requested.exchange(true)) {
    ::signal(signal_number, SIG_DFL);
    ::raise(signal_number);
    return;
  }
  static const char message[] = "\npneumo study: stopping: no new points (again to stop at once)\n";
  [[maybe_unused]] ssize_t written = ::write(STDERR_FILENO, message, sizeof message - 1);
}

void InstallStopHandler() {
  for (int signal_number : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction action {};
    action.sa_handler = OnSignal;
    sigemptyset(&action.sa_mask);
    ::sigaction(signal_number, &action, nullptr);
  }
}

// this program's path, for the Dask workers to run
std::string SelfPath() {
  char path[4096];
  const ssize_t n = ::readlink("/proc/self/exe", path, sizeof path - 1);
  return n > 0 ? std::string(path, static_cast<size_t>(n)) : std::string("pneumo");
}

int RunStudyCommand(const StudyArguments& a) {
  if ((a.point >= 0) + a.unfinished + a.collect > 1) return StudyFail("give one of --point, --unfinished and --collect");
  std::string error;
  std::unique_ptr<study::Study> s = study::Study::Open(a.plan_path, a.out_dir, &error);
  if (!s) return StudyFail(error);
  const size_t total = s->points().size();
  if (a.unfinished) {
    for (size_t k : s->Unfinished()) std::printf("%zu\n", k);
    return 0;
  }
  if (a.collect) {
    if (std::string e = s->Collect(!a.no_plots); !e.empty()) return StudyFail(e);
    std::fprintf(stderr, "pneumo study: wrote %s/results.csv (%zu points)\n", a.out_dir.c_str(), total);
    return 0;
  }
  InstallStopHandler();
  if (a.point >= 0) {
    if (static_cast<size_t>(a.point) >= total) {
      return StudyFail("--point " + std::to_string(a.point) + ": the plan has " + std::to_string(total) + " points (0 to " +
                       std::to_string(total - 1) + ")");
    }
    if (s->Finished(static_cast<size_t>(a.point))) {
      std::fprintf(stderr, "pneumo study: point %ld is already finished\n", a.point);
      return 0;
    }
    study::PointOutcome outcome = study::PointOutcome::kOk;
    if (std::string e = s->RunPoint(static_cast<size_t>(a.point), &stop_requested, &outcome); !e.empty()) return StudyFail(e);
    if (outcome == study::PointOutcome::kInterrupted) return 130;
    std::fprintf(stderr, "pneumo study: point %ld %s\n", a.point, outcome == study::PointOutcome::kOk ? "ok" : "failed (recorded)");
    return 0;
  }
  const std::string scheduler = !a.scheduler.empty() ? a.scheduler : a.local ? "" : s->plan().scheduler;
  if (!scheduler.empty()) {
    std::fprintf(stderr, "pneumo study: running the points through the Dask scheduler at %s (scripts/study_dask.py)\n",
                 scheduler.c_str());
    std::vector<std::string> arguments = {"--pneumo", SelfPath(), "--plan", a.plan_path, "--out", a.out_dir,
                                          "--scheduler", scheduler};
    if (a.no_plots) arguments.push_back("--no-plots");
    const int status = RunScript("study_dask.py", arguments);
    if (status != 0) std::fprintf(stderr, "pneumo study: the Dask driver ended with status %d\n", status);
    return status < 0 ? 1 : status;
  }
  const size_t before = total - s->Unfinished().size();
  if (before > 0) {
    std::fprintf(stderr, "pneumo study: %zu of %zu points already finished in %s; running the other %zu\n", before, total,
                 a.out_dir.c_str(), total - before);
  }
  const bool terminal = isatty(STDERR_FILENO);
  auto last = std::chrono::steady_clock::now() - std::chrono::seconds(1);
  const std::string e = s->Run(a.jobs, &stop_requested, [&](const study::Progress& p) {
    const auto now = std::chrono::steady_clock::now();
    if (p.finished < p.total && now - last < std::chrono::milliseconds(500)) return;
    last = now;
    const double rate = p.elapsed_s > 0 ? static_cast<double>(p.ran) / p.elapsed_s : 0;
    const double left = rate > 0 ? static_cast<double>(p.total - p.finished) / rate : 0;
    std::fprintf(stderr, "%spneumo study: %zu of %zu points done, %zu failed, %.2f points/s, about %.0f s left%s",
                 terminal ? "\r" : "", p.finished, p.total, p.failed, rate, left,
                 terminal && p.finished < p.total ? "" : "\n");
  });
  if (!e.empty()) return StudyFail(e);
  const size_t left = s->Unfinished().size();
  if (left > 0) {
    std::fprintf(stderr, "pneumo study: stopped with %zu of %zu points finished; the same command finishes the rest\n",
                 total - left, total);
    return 130;
  }
  if (std::string c = s->Collect(!a.no_plots); !c.empty()) return StudyFail(c);
  std::fprintf(stderr, "pneumo study: wrote %s/results.csv (%zu points)%s\n", a.out_dir.c_str(), total,
               a.no_plots ? "" : " and the plots in plots/");
  return 0;
}

}  // namespace

Command AddStudyCommand(CLI::App& app) {
  auto arguments = std::make_shared<StudyArguments>();
  StudyArguments& a = *arguments;
  CLI::App* study = app.add_subcommand(
      "study", "a parameter study: rollouts over a grid or random draws of parameters, or identify/diagnose a fleet's logs");
  study->add_option("plan", a.plan_path, "the plan, JSON (docs/study.md)")->required();
  study->add_option("--out", a.out_dir, "the study's folder: results.csv, plots/, points/<index>/; run again to resume")
      ->required();
  study->add_option("--jobs", a.jobs, "points at once, each on its own copy of the model")->check(CLI::Range(1, 256));
  study->add_option("--point", a.point, "run only this point (what a Dask worker runs)")->check(CLI::NonNegativeNumber);
  study->add_flag("--unfinished", a.unfinished, "prepare the folder and print the points not finished, one a line");
  study->add_flag("--collect", a.collect, "write results.csv and the plots from the finished points' records");
  study->add_option("--scheduler", a.scheduler, "run the points through this Dask scheduler (tcp://host:8786)");
  study->add_flag("--local", a.local, "run on this machine's threads even if the plan names a scheduler");
  study->add_flag("--no-plots", a.no_plots, "results.csv without the plots");
  study->footer(
      "Each point writes points/<index>/ (rollout.csv and summary.json, identify.json, or diagnose.json) and last\n"
      "record.json, its completion marker; results.csv and the plots are built from the records. Run again with the\n"
      "same --out to finish a study that stopped: finished points are not run again. A point that fails is recorded\n"
      "with its error. Ctrl-C stops starting new points.");
  return {study, [arguments] { return RunStudyCommand(*arguments); }};
}

}  // namespace pneumatic::cli
