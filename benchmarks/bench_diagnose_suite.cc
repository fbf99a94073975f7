// The diagnosis graded on logs it was not tuned on (issue 55, item 3).
//
// Every case of tests/reference/suite_cases.h is a "real" rig simulated by tests/reference/real_rig.h,
// a simulator independent of the extension: rigs A, B and C of docs/rigs.md with their
// parameters drawn around the nominal ones, at most one effect in a form of the suite's own (or one
// outside the library, whose right verdict is `unexplained`), sensor noise, lag and quantisation,
// logged at 100 Hz to 1 kHz. For each case the three logs are simulated (training, selection and
// test, each with an excitation of its own), the nominal model (models_mjcf/<rig file>) is diagnosed
// on the training log with the selection log held out, and the verdict is graded on the test log,
// which the diagnosis never saw (diagnosis::GradeOnLog: the gap of the model as given and of the
// verdict's model).
//
// A case is right when its verdict is its truth: an effect's name of docs/effects.md, `none`,
// or `unexplained` (then no library effect may be named). A case whose simulation, diagnosis or
// grading fails, or that runs longer than --timeout, is WRONG (verdict "failed" or "timeout"), never
// left out: each case runs in a child process of its own, which the runner ends (by its id) at the
// time limit.
//
// Prints one line per case (id, rig, rate, noise, truth, verdict, the test log's gap before and
// after, its shrink, seconds), then the confusion matrix (rows: truth; columns: verdict, with
// timeouts under "failed"), the share right, the library effects named on parameters-only logs
// (target 0), the median test-log shrink of the in-library cases named right, and the total time.
// Progress on stderr.
//
// usage: bench_diagnose_suite [--case TEXT] [--rig A|B|C] [--limit N] [--timeout S]
//                             [--durations TRAIN SELECTION TEST] [--verbose]
// (--case: the cases whose id contains TEXT; --limit: the first N cases selected; --timeout: seconds
// per case, 300 by default; --durations: the logs' lengths, 10 6 6 s by default; --verbose: the
// diagnosis' own progress on stderr)
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "diagnosis/diagnose.h"
#include "machine.h"
#include "reference_log.h"
#include "suite_cases.h"

namespace {

namespace dg = pneumatic::diagnosis;
namespace ref = pneumatic::reference;

// what a case's child process reports
struct Outcome {
  std::string verdict = "failed";  // "none", "unexplained", an effect, "failed" or "timeout"
  std::string effects;             // the established effects, joined by '+'
  double gap_before = NAN, gap_after = NAN, gap_calibrated = NAN;
  std::string error;
};

// one line, tab-separated: verdict, effects, the three gaps, error (tabs and newlines blanked)
std::string Encode(const Outcome& o) {
  std::string error = o.error;
  std::replace(error.begin(), error.end(), '\t', ' ');
  std::replace(error.begin(), error.end(), '\n', ' ');
  char gaps[96];
  std::snprintf(gaps, sizeof(gaps), "%.17g\t%.17g\t%.17g", o.gap_before, o.gap_after, o.gap_calibrated);
  return o.verdict + "\t" + (o.effects.empty() ? "-" : o.effects) + "\t" + gaps + "\t" + error + "\n";
}

Outcome Decode(const std::string& line) {
  Outcome o;
  std::vector<std::string> fields;
  std::stringstream in(line);
  for (std::string field; std::getline(in, field, '\t');) fields.push_back(field);
  if (fields.size() < 5) {
    o.error = "the case's process reported nothing";
    return o;
  }
  o.verdict = fields[0];
  o.effects = fields[1] == "-" ? "" : fields[1];
  o.gap_before = std::strtod(fields[2].c_str(), nullptr);
  o.gap_after = std::strtod(fields[3].c_str(), nullptr);
  o.gap_calibrated = std::strtod(fields[4].c_str(), nullptr);
  if (fields.size() > 5) o.error = fields[5];
  if (!o.error.empty() && o.error.back() == '\n') o.error.pop_back();
  return o;
}

// the case, in this process: simulate, diagnose on train with selection held out, grade on test
Outcome RunCase(const ref::SuiteCase& c, const double durations[3], bool verbose) {
  Outcome o;
  const std::string model = std::string(PNEUMATIC_MODELS_DIR) + "/" + ref::RigModelFile(c.rig);
  try {
    const pneumatic::log::Log train = ref::SimulateCase(c, ref::kTrainLog, durations[0]);
    const pneumatic::log::Log selection = ref::SimulateCase(c, ref::kSelectionLog, durations[1]);
    const pneumatic::log::Log test = ref::SimulateCase(c, ref::kTestLog, durations[2]);
    dg::DiagnoseOptions options;
    options.threads = 2;
    if (verbose) options.progress = [](const std::string& line) { std::fprintf(stderr, "    %s\n", line.c_str()); };
    const dg::Diagnosis d = dg::Diagnose(model, train, &selection, options);
    if (!d.error.empty()) {
      o.error = "diagnosis: " + d.error;
      return o;
    }
    for (const std::string& e : d.effects) o.effects += (o.effects.empty() ? "" : "+") + e;
    const dg::Graded g = dg::GradeOnLog(model, d, test, options);
    if (!g.error.empty()) {
      o.error = "grading: " + g.error;
      return o;
    }
    o.verdict = d.verdict;
    o.gap_before = g.gap_before, o.gap_after = g.gap_after, o.gap_calibrated = g.gap_calibrated;
  } catch (const std::exception& e) {
    o.error = std::string("simulation: ") + e.what();
  }
  return o;
}

// the case in a child process, ended at `timeout` s: a crash is "failed", the time limit "timeout"
Outcome RunCaseIsolated(const ref::SuiteCase& c, const double durations[3], bool verbose, double timeout) {
  int pipe_ends[2];
  if (pipe(pipe_ends) != 0) return RunCase(c, durations, verbose);
  std::fflush(stdout), std::fflush(stderr);
  const pid_t child = fork();
  if (child < 0) {
    close(pipe_ends[0]), close(pipe_ends[1]);
    return RunCase(c, durations, verbose);
  }
  if (child == 0) {
    close(pipe_ends[0]);
    const std::string line = Encode(RunCase(c, durations, verbose));
    size_t written = 0;
    while (written < line.size()) {
      const ssize_t n = write(pipe_ends[1], line.data() + written, line.size() - written);
      if (n <= 0) break;
      written += static_cast<size_t>(n);
    }
    close(pipe_ends[1]);
    _exit(0);
  }
  close(pipe_ends[1]);
  std::string received;
  const auto start = std::chrono::steady_clock::now();
  bool timed_out = false;
  for (;;) {
    const double left = timeout - std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (left <= 0) {
      timed_out = true;
      break;
    }
    pollfd fd{pipe_ends[0], POLLIN, 0};
    const int ready = poll(&fd, 1, static_cast<int>(std::min(left, 60.0) * 1000) + 1);
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) continue;
    char buffer[4096];
    const ssize_t n = read(pipe_ends[0], buffer, sizeof(buffer));
    if (n <= 0) break;  // the child closed its end: done, or died
    received.append(buffer, static_cast<size_t>(n));
  }
  close(pipe_ends[0]);
  if (timed_out) kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  if (timed_out) {
    Outcome o;
    o.verdict = "timeout";
    o.error = "over the time limit of " + std::to_string(static_cast<int>(timeout)) + " s";
    return o;
  }
  if (received.empty()) {
    Outcome o;
    o.error = WIFSIGNALED(status) ? "the case's process died of signal " + std::to_string(WTERMSIG(status))
                                  : "the case's process reported nothing";
    return o;
  }
  return Decode(received);
}

double Median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

bool IsLibraryEffect(const std::string& name) {
  return name != "none" && name != "unexplained" && name != "failed" && name != "timeout";
}

// rows and columns of the confusion matrix: docs/effects.md's order, then none, unexplained, failed
const std::vector<std::string>& Labels() {
  static const std::vector<std::string> labels = {"valve_delay", "valve_deadband", "friction", "leakage", "heat_transfer",
                                                  "supply_drop", "line_dynamics", "payload", "sensor_bias", "none",
                                                  "unexplained", "failed"};
  return labels;
}

void PrintConfusion(const std::map<std::string, std::map<std::string, int>>& confusion) {
  std::vector<std::string> columns;
  for (const std::string& label : Labels()) {
    for (const auto& [truth, row] : confusion) {
      if (row.count(label) && std::find(columns.begin(), columns.end(), label) == columns.end()) columns.push_back(label);
    }
  }
  for (const char* must : {"none", "unexplained", "failed"}) {
    if (std::find(columns.begin(), columns.end(), must) == columns.end()) columns.push_back(must);
  }
  std::printf("\nconfusion matrix (rows: truth; columns: verdict on the case, timeouts under failed)\n| truth \\ verdict |");
  for (const std::string& c : columns) std::printf(" %s |", c.c_str());
  std::printf("\n|---|");
  for (size_t i = 0; i < columns.size(); ++i) std::printf("---|");
  std::printf("\n");
  for (const std::string& truth : Labels()) {
    auto row = confusion.find(truth);
    if (row == confusion.end()) continue;
    std::printf("| %s |", truth.c_str());
    for (const std::string& c : columns) {
      auto cell = row->second.find(c);
      std::printf(" %s |", cell == row->second.end() ? "" : std::to_string(cell->second).c_str());
    }
    std::printf("\n");
  }
}

// the command line's options (see the usage at the top)
struct Arguments {
  std::string only_case, only_rig;
  long limit = -1;
  double timeout = 300;
  double durations[3] = {ref::kDefaultDurations[0], ref::kDefaultDurations[1], ref::kDefaultDurations[2]};
  bool verbose = false;
};

// argv into *args: 0, or the exit code after printing why not
int ParseArguments(int argc, char** argv, Arguments* args) {
  auto number = [&](int* i, const char* option, double* out) {
    char* end = nullptr;
    const char* text = *i + 1 < argc ? argv[++*i] : "";
    *out = std::strtod(text, &end);
    if (!*text || *end || !(*out > 0) || !std::isfinite(*out)) {
      std::fprintf(stderr, "%s: expected a number > 0, got '%s'\n", option, text);
      return false;
    }
    return true;
  };
  for (int i = 1; i < argc; ++i) {
    double value = 0;
    if (!std::strcmp(argv[i], "--case") && i + 1 < argc) {
      args->only_case = argv[++i];
    } else if (!std::strcmp(argv[i], "--rig") && i + 1 < argc) {
      args->only_rig = argv[++i];
      if (args->only_rig != "A" && args->only_rig != "B" && args->only_rig != "C") {
        std::fprintf(stderr, "--rig: expected A, B or C, got '%s'\n", args->only_rig.c_str());
        return 2;
      }
    } else if (!std::strcmp(argv[i], "--limit")) {
      if (!number(&i, "--limit", &value)) return 2;
      args->limit = static_cast<long>(value);
    } else if (!std::strcmp(argv[i], "--timeout")) {
      if (!number(&i, "--timeout", &args->timeout)) return 2;
    } else if (!std::strcmp(argv[i], "--durations")) {
      for (double& d : args->durations) {
        if (!number(&i, "--durations", &d)) return 2;
      }
    } else if (!std::strcmp(argv[i], "--verbose")) {
      args->verbose = true;
    } else {
      std::fprintf(stderr, "bench_diagnose_suite: unknown argument '%s' (see the usage at the top of bench_diagnose_suite.cc)\n",
                   argv[i]);
      return 2;
    }
  }
  return 0;
}

// the suite's cases that --case, --rig and --limit leave
std::vector<ref::SuiteCase> SelectCases(const Arguments& args) {
  std::vector<ref::SuiteCase> cases;
  for (const ref::SuiteCase& c : ref::SuiteCases()) {
    if (!args.only_case.empty() && c.id.find(args.only_case) == std::string::npos) continue;
    if (!args.only_rig.empty() && args.only_rig != ref::RigLetter(c.rig)) continue;
    if (args.limit >= 0 && static_cast<long>(cases.size()) >= args.limit) break;
    cases.push_back(c);
  }
  return cases;
}

// the verdicts so far: truths against verdicts, the test-log shrinks of the in-library cases named
// right, counts
struct Tally {
  std::map<std::string, std::map<std::string, int>> confusion;
  std::vector<double> shrinks;
  int right = 0, clean = 0, named_on_clean = 0;
};

// one case run in its own process, its line printed and its verdict tallied
void RunAndTally(const ref::SuiteCase& c, const Arguments& args, Tally* tally) {
  const auto t0 = std::chrono::steady_clock::now();
  const Outcome o = RunCaseIsolated(c, args.durations, args.verbose, args.timeout);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const bool ok = o.verdict == c.truth && (c.truth != "unexplained" || o.effects.empty());
  tally->right += ok;
  if (c.truth == "none") ++tally->clean, tally->named_on_clean += IsLibraryEffect(o.verdict);
  const double shrink = 100 * (o.gap_before - o.gap_after) / o.gap_before;
  if (ok && IsLibraryEffect(c.truth) && std::isfinite(shrink)) tally->shrinks.push_back(shrink);
  tally->confusion[c.truth][o.verdict == "timeout" ? "failed" : o.verdict]++;
  std::string verdict = o.verdict;
  if (!o.effects.empty() && o.effects != o.verdict) verdict += " (" + o.effects + ")";
  std::printf("%-24s %s %4.0f Hz noise %.2f  truth %-14s verdict %-28s %-5s test gap %.4f -> %.4f (%6.1f %%)  %6.1f s%s%s\n",
              c.id.c_str(), ref::RigLetter(c.rig), c.rate, c.noise, c.truth.c_str(), verdict.c_str(), ok ? "right" : "WRONG",
              o.gap_before, o.gap_after, shrink, seconds, o.error.empty() ? "" : "  ", o.error.c_str());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  Arguments args;
  if (int status = ParseArguments(argc, argv, &args); status != 0) return status;
  pneumatic::benchmarks::PrintMachine(PNEUMATIC_BUILD_TYPE);
  const std::vector<ref::SuiteCase> cases = SelectCases(args);
  const double* durations = args.durations;
  std::printf("%zu cases; logs of %.0f / %.0f / %.0f s (train / selection / test); time limit %.0f s per case\n", cases.size(),
              durations[0], durations[1], durations[2], args.timeout);
  const auto start = std::chrono::steady_clock::now();
  Tally tally;
  for (size_t i = 0; i < cases.size(); ++i) {
    const ref::SuiteCase& c = cases[i];
    std::fprintf(stderr, "[%zu/%zu] %s (%s, %s)\n", i + 1, cases.size(), c.id.c_str(), c.truth.c_str(), c.description.c_str());
    RunAndTally(c, args, &tally);
  }
  PrintConfusion(tally.confusion);
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const int n = static_cast<int>(cases.size());
  std::printf("\nright: %d of %d (%.1f %%; target >= 90 %%)\n", tally.right, n, n ? 100.0 * tally.right / n : 0.0);
  std::printf("library effects named on parameters-only logs: %d of %d (target 0)\n", tally.named_on_clean, tally.clean);
  std::printf("median test-log shrink of the in-library cases named right: %.1f %% over %zu cases (target >= 60 %%)\n",
              Median(tally.shrinks), tally.shrinks.size());
  std::printf("total time: %.0f s\n", total);
  return 0;
}
