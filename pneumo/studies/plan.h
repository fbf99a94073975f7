// A parameter study's plan (`pneumo study PLAN.json`, docs/study.md): a model, what runs at each
// point (a closed-loop rollout, an identification or a diagnosis of a log) and the points: a grid
// and seeded random draws over values set by key (simulation/model_edits.h), or a list of logs.
#ifndef PNEUMATIC_STUDIES_PLAN_H_
#define PNEUMATIC_STUDIES_PLAN_H_

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace pneumatic::study {

// one log a point identifies or diagnoses, with the logs that go with it
struct PointLog {
  std::string log, heldout, test;  // paths as resolved (relative to the plan's folder)
  std::string label;               // the log as the plan names it (results.csv's "log" column)
};

struct RandomParameter {
  std::string key;
  bool log_uniform = false;
  double low = 0, high = 0;
};

struct Plan {
  std::string path;     // the plan file
  std::string text;     // its bytes (copied into the study's folder)
  nlohmann::ordered_json document;  // parsed; its "scheduler" aside, what makes two plans the same
  std::string model;    // resolved path
  std::string model_label;  // as the plan names it, for the files a point writes (the same bytes however the
                            // plan's own path is spelled)
  std::string kind;     // "rollout", "identify" or "diagnose"
  // rollout
  std::string controller = "pid";
  nlohmann::json controller_config;  // null: the model's own or the defaults
  std::string controller_config_source;  // where it came from, as the summaries name it
  std::string reference;
  double duration = 0, control_rate = 100, noise_pressure = 0, noise_position = 0;
  std::uint64_t seed = 1;
  // identify / diagnose: the options shared by every log
  std::string heldout, test;
  std::vector<std::string> fit_keys;
  bool parametric = true, physical = true;
  double refine_horizon_s = 0;
  double horizon_s = 0.2;
  int max_effects = 2, calibration_iterations = 20;
  int threads = 1;  // threads inside one point (identification, diagnosis)
  // the points
  std::vector<std::pair<std::string, std::vector<double>>> grid;  // in the plan's order, the last fastest
  std::vector<RandomParameter> random;
  int random_count = 0;
  std::uint64_t random_seed = 1;
  std::vector<PointLog> logs;
  std::string scheduler;  // "" or a Dask scheduler's address
};

struct Point {
  std::size_t index = 0;
  std::vector<std::pair<std::string, double>> values;  // key -> value, in the plan's key order
  const PointLog* log = nullptr;                        // identify/diagnose over logs
};

// The most points a plan may make (a grid's combinations times its random draws, or its logs).
inline constexpr std::size_t kMaxPoints = 1000000;

// Reads and checks the plan at `path`. "" or the error, naming the file and the key
// ("plan.json: points.grid.cyl:supply_pressure: expected a non-empty array of numbers").
std::string ReadPlan(const std::string& path, Plan* plan);
// The same for a plan's text, as if read from `path` (relative paths in it resolve against its folder).
std::string ParsePlan(const std::string& text, const std::string& path, Plan* plan);
// How many points ExpandPoints makes (kMaxPoints + 1 for any count beyond kMaxPoints).
std::size_t CountPoints(const Plan& plan);

// The keys of the plan's points, in results.csv's order: the grid's, then the random draws'.
std::vector<std::string> ParameterKeys(const Plan& plan);

// Every point, in order: each grid point (the last key fastest) with each random draw (draw d of
// parameter j from a Stream seeded by the plan's random seed, the same on every machine), or each log.
std::vector<Point> ExpandPoints(const Plan& plan);

}  // namespace pneumatic::study

#endif  // PNEUMATIC_STUDIES_PLAN_H_
