// A parameter study (`pneumo study`, docs/study.md): the points of a plan (studies/plan.h) run on
// threads, or one at a time by a Dask worker, each writing its own files into OUT/points/<index>/
// and, last, its record (record.json, the completion marker: the point's parameters, figures of
// merit, status and error), written whole or not at all. A study started again on the same folder
// runs only the points without a record; results.csv and the plots are built from the records
// alone, so they are the same bytes however the points were run, interrupted or spread out.
#ifndef PNEUMATIC_STUDIES_STUDY_H_
#define PNEUMATIC_STUDIES_STUDY_H_

#include <atomic>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>
#include <nlohmann/json.hpp>

#include "simulation/closed_loop.h"
#include "studies/plan.h"

namespace pneumatic::study {

constexpr char kRecordName[] = "record.json";

struct Progress {
  std::size_t total = 0;      // points in the plan
  std::size_t finished = 0;   // with a record, from before and from this run
  std::size_t ran = 0;        // run by this call
  std::size_t failed = 0;     // of those, recorded as failed
  double elapsed_s = 0;       // since this call started
};

// What a point's run came to.
enum class PointOutcome { kOk, kFailed, kInterrupted };

class Study {
 public:
  // Reads the plan and prepares `out_dir`: created with points/ and a copy of the plan (plan.json);
  // a folder holding another plan's study is refused (its "scheduler" aside). Null and *error.
  static std::unique_ptr<Study> Open(const std::string& plan_path, const std::string& out_dir, std::string* error);
  ~Study();

  const Plan& plan() const { return plan_; }
  const std::vector<Point>& points() const { return points_; }
  std::string PointDir(std::size_t index) const;
  bool Finished(std::size_t index) const;  // its record exists
  std::vector<std::size_t> Unfinished() const;

  // Runs point `index`, writes its files and then its record; a failure of the point itself (a value
  // refused, a run that diverges, a log that cannot be fitted) is recorded with its error. With *stop
  // set while it runs (a rollout checks at every step) it ends without a record: kInterrupted.
  // "" or the error that stops the study (its record could not be written).
  std::string RunPoint(std::size_t index, const std::atomic<bool>* stop, PointOutcome* outcome) const;

  // Runs every unfinished point, `jobs` at a time, until all are finished or *stop is set (points
  // under way finish, unless they are rollouts, which end unrecorded); `progress` after each point.
  // "" or the first error that stopped the study.
  std::string Run(int jobs, const std::atomic<bool>* stop, const std::function<void(const Progress&)>& progress) const;

  // Writes OUT/results.csv from the records (every point must be finished) and, with `plots`, a PNG
  // per figure of merit against each parameter in OUT/plots/ (scripts/plot_study.py). "" or the error.
  std::string Collect(bool plots) const;

 private:
  Study() = default;
  std::string RunRollout(const Point& p, const std::string& dir, const std::atomic<bool>* stop,
                         nlohmann::ordered_json* figures, bool* interrupted) const;
  std::string RunIdentify(const Point& p, const std::string& dir, nlohmann::ordered_json* figures) const;
  std::string RunDiagnose(const Point& p, const std::string& dir, nlohmann::ordered_json* figures) const;

  Plan plan_;
  std::vector<Point> points_;
  std::string out_dir_;
  mjModel* model_ = nullptr;  // attached (rollout studies)
  ClosedLoopOptions base_;    // a rollout's options, but for its seed
  std::unique_ptr<log::Log> reference_;
  nlohmann::json controller_;  // the summary's {"name", "configuration"}
};

}  // namespace pneumatic::study

#endif  // PNEUMATIC_STUDIES_STUDY_H_
