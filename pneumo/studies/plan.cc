#include "studies/plan.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "simulation/model_edits.h"
#include "simulation/random_stream.h"

namespace pneumatic::study {
namespace {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

// reads a plan's keys, each error naming the file and the key's path in it
class Reader {
 public:
  Reader(std::string file, fs::path folder) : file_(std::move(file)), folder_(std::move(folder)) {}

  std::string Error(const std::string& where, const std::string& what) const {
    return file_ + ": " + (where.empty() ? "" : where + ": ") + what;
  }
  // the keys of object `o` (at `where`) must be among `known`
  std::string Known(const ojson& o, const std::string& where, const std::set<std::string>& known) const {
    for (const auto& [key, value] : o.items()) {
      if (known.count(key) == 0) {
        std::string list;
        for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
        return Error(Join(where, key), "unknown key (expected one of " + list + ")");
      }
    }
    return "";
  }
  std::string Text(const ojson& o, const std::string& where, const std::string& key, std::string* out,
                   bool required = false) const {
    if (!o.contains(key)) return required ? Error(Join(where, key), "required") : "";
    if (!o[key].is_string() || o[key].get<std::string>().empty()) return Error(Join(where, key), "expected a non-empty text");
    *out = o[key].get<std::string>();
    return "";
  }
  std::string Path(const ojson& o, const std::string& where, const std::string& key, std::string* out,
                   bool required = false) const {
    std::string text;
    if (std::string e = Text(o, where, key, &text, required); !e.empty() || text.empty()) return e;
    *out = Resolve(text);
    return "";
  }
  std::string Resolve(const std::string& text) const {
    const fs::path p(text);
    return p.is_absolute() ? text : (folder_ / p).lexically_normal().string();
  }
  std::string Number(const ojson& o, const std::string& where, const std::string& key, double* out, double low,
                     bool low_open) const {
    if (!o.contains(key)) return "";
    const ojson& v = o[key];
    if (!v.is_number() || !std::isfinite(v.get<double>()) || (low_open ? !(v.get<double>() > low) : !(v.get<double>() >= low))) {
      return Error(Join(where, key), std::string("expected a number ") + (low_open ? "> " : ">= ") + Format(low));
    }
    *out = v.get<double>();
    return "";
  }
  std::string Integer(const ojson& o, const std::string& where, const std::string& key, long long* out, long long low,
                      long long high) const {
    if (!o.contains(key)) return "";
    const ojson& v = o[key];
    if (!v.is_number_integer() || v.get<long long>() < low || v.get<long long>() > high) {
      return Error(Join(where, key), "expected a whole number from " + std::to_string(low) + " to " + std::to_string(high));
    }
    *out = v.get<long long>();
    return "";
  }
  std::string Flag(const ojson& o, const std::string& where, const std::string& key, bool* out) const {
    if (!o.contains(key)) return "";
    if (!o[key].is_boolean()) return Error(Join(where, key), "expected true or false");
    *out = o[key].get<bool>();
    return "";
  }
  static std::string Join(const std::string& where, const std::string& key) { return where.empty() ? key : where + "." + key; }
  static std::string Format(double v) {
    std::ostringstream s;
    s << v;
    return s.str();
  }

 private:
  std::string file_;
  fs::path folder_;
};

std::string ReadWhat(const Reader& r, const ojson& what, Plan* plan) {
  if (!what.is_object()) return r.Error("what", "expected an object with \"kind\": rollout, identify or diagnose");
  if (std::string e = r.Text(what, "what", "kind", &plan->kind, true); !e.empty()) return e;
  long long integer = 0;
  if (plan->kind == "rollout") {
    if (std::string e = r.Known(what, "what", {"kind", "controller", "controller_config", "reference", "duration",
                                               "control_rate", "seed", "noise_pressure", "noise_position"});
        !e.empty()) {
      return e;
    }
    if (std::string e = r.Text(what, "what", "controller", &plan->controller); !e.empty()) return e;
    static const std::set<std::string> kControllers = {"pid", "none", "position_stiffness", "sliding3", "sliding7",
                                                       "karpenko", "laib"};
    if (kControllers.count(plan->controller) == 0) {
      return r.Error("what.controller", "'" + plan->controller + "' is not one of pid, none, position_stiffness, "
                                        "sliding3, sliding7, karpenko, laib");
    }
    if (what.contains("controller_config")) {
      const ojson& c = what["controller_config"];
      if (c.is_string()) {
        std::string file;
        if (std::string e = r.Path(what, "what", "controller_config", &file); !e.empty()) return e;
        plan->controller_config_source = c.get<std::string>();
        std::ifstream in(file);
        if (!in) return r.Error("what.controller_config", file + ": cannot read");
        std::stringstream text;
        text << in.rdbuf();
        try {
          plan->controller_config = nlohmann::json::parse(text.str());
        } catch (const nlohmann::json::exception& e) {
          return r.Error("what.controller_config", file + ": " + e.what());
        }
      } else if (c.is_object()) {
        plan->controller_config = nlohmann::json::parse(c.dump());
        plan->controller_config_source = "the plan's what.controller_config";
      } else {
        return r.Error("what.controller_config", "expected an object of the controller's keys, or a JSON file's path");
      }
    }
    if (std::string e = r.Path(what, "what", "reference", &plan->reference); !e.empty()) return e;
    if (!what.contains("duration")) return r.Error("what.duration", "required (s)");
    if (std::string e = r.Number(what, "what", "duration", &plan->duration, 0, true); !e.empty()) return e;
    if (std::string e = r.Number(what, "what", "control_rate", &plan->control_rate, 0, true); !e.empty()) return e;
    if (std::string e = r.Number(what, "what", "noise_pressure", &plan->noise_pressure, 0, false); !e.empty()) return e;
    if (std::string e = r.Number(what, "what", "noise_position", &plan->noise_position, 0, false); !e.empty()) return e;
    integer = 1;
    if (std::string e = r.Integer(what, "what", "seed", &integer, 0, (1LL << 53)); !e.empty()) return e;
    plan->seed = static_cast<std::uint64_t>(integer);
    return "";
  }
  if (plan->kind == "identify") {
    if (std::string e = r.Known(what, "what", {"kind", "heldout", "fit", "parametric", "physical", "refine_horizon",
                                               "threads"});
        !e.empty()) {
      return e;
    }
    if (what.contains("fit")) {
      if (!what["fit"].is_array()) return r.Error("what.fit", "expected an array of \"<cylinder>:<key>\"");
      for (const ojson& key : what["fit"]) {
        if (!key.is_string()) return r.Error("what.fit", "expected an array of \"<cylinder>:<key>\"");
        plan->fit_keys.push_back(key.get<std::string>());
      }
    }
    if (std::string e = r.Flag(what, "what", "parametric", &plan->parametric); !e.empty()) return e;
    if (std::string e = r.Flag(what, "what", "physical", &plan->physical); !e.empty()) return e;
    if (std::string e = r.Number(what, "what", "refine_horizon", &plan->refine_horizon_s, 0, false); !e.empty()) return e;
  } else if (plan->kind == "diagnose") {
    if (std::string e = r.Known(what, "what", {"kind", "heldout", "test", "horizon", "max_effects",
                                               "calibration_iterations", "threads"});
        !e.empty()) {
      return e;
    }
    if (std::string e = r.Path(what, "what", "test", &plan->test); !e.empty()) return e;
    if (std::string e = r.Number(what, "what", "horizon", &plan->horizon_s, 0.005, false); !e.empty()) return e;
    integer = plan->max_effects;
    if (std::string e = r.Integer(what, "what", "max_effects", &integer, 1, 5); !e.empty()) return e;
    plan->max_effects = static_cast<int>(integer);
    integer = plan->calibration_iterations;
    if (std::string e = r.Integer(what, "what", "calibration_iterations", &integer, 0, 200); !e.empty()) return e;
    plan->calibration_iterations = static_cast<int>(integer);
  } else {
    return r.Error("what.kind", "'" + plan->kind + "' is not rollout, identify or diagnose");
  }
  if (std::string e = r.Path(what, "what", "heldout", &plan->heldout); !e.empty()) return e;
  integer = plan->threads;
  if (std::string e = r.Integer(what, "what", "threads", &integer, 1, 64); !e.empty()) return e;
  plan->threads = static_cast<int>(integer);
  return "";
}

std::string ReadPoints(const Reader& r, const ojson& points, Plan* plan) {
  if (!points.is_object()) return r.Error("points", "expected an object with \"grid\", \"random\" or \"logs\"");
  if (std::string e = r.Known(points, "points", {"grid", "random", "logs"}); !e.empty()) return e;
  std::set<std::string> keys;
  auto key_form = [&](const std::string& where, const std::string& key) {
    if (key == "log") return r.Error(where, "'log' names the logs' column; it is not a parameter");
    if (std::string e = CheckModelKeyForm(key); !e.empty()) return r.Error(where, e);
    if (!keys.insert(key).second) return r.Error(where, "'" + key + "' is given twice");
    return std::string();
  };
  if (points.contains("grid")) {
    const ojson& grid = points["grid"];
    if (!grid.is_object() || grid.empty()) return r.Error("points.grid", "expected an object {\"<key>\": [values]}");
    for (const auto& [key, values] : grid.items()) {
      const std::string where = "points.grid." + key;
      if (std::string e = key_form(where, key); !e.empty()) return e;
      if (!values.is_array() || values.empty()) return r.Error(where, "expected a non-empty array of numbers");
      std::vector<double> list;
      for (const ojson& v : values) {
        if (!v.is_number() || !std::isfinite(v.get<double>())) return r.Error(where, "expected a non-empty array of numbers");
        list.push_back(v.get<double>());
      }
      plan->grid.emplace_back(key, list);
    }
  }
  if (points.contains("random")) {
    const ojson& random = points["random"];
    if (!random.is_object()) return r.Error("points.random", "expected {\"count\", \"seed\", \"parameters\"}");
    if (std::string e = r.Known(random, "points.random", {"count", "seed", "parameters"}); !e.empty()) return e;
    long long count = 0, seed = 1;
    if (!random.contains("count")) return r.Error("points.random.count", "required");
    if (std::string e = r.Integer(random, "points.random", "count", &count, 1, 1000000); !e.empty()) return e;
    if (!random.contains("seed")) return r.Error("points.random.seed", "required (the draws are reproducible from it)");
    if (std::string e = r.Integer(random, "points.random", "seed", &seed, 0, (1LL << 53)); !e.empty()) return e;
    plan->random_count = static_cast<int>(count);
    plan->random_seed = static_cast<std::uint64_t>(seed);
    if (!random.contains("parameters") || !random["parameters"].is_object() || random["parameters"].empty()) {
      return r.Error("points.random.parameters", "expected an object {\"<key>\": {\"uniform\": [low, high]}}");
    }
    for (const auto& [key, law] : random["parameters"].items()) {
      const std::string where = "points.random.parameters." + key;
      if (std::string e = key_form(where, key); !e.empty()) return e;
      const char* expected = "expected {\"uniform\": [low, high]} or {\"log_uniform\": [low, high]}, low < high";
      if (!law.is_object() || law.size() != 1) return r.Error(where, expected);
      RandomParameter p{key, law.contains("log_uniform"), 0, 0};
      const ojson& range = p.log_uniform ? law["log_uniform"] : law.contains("uniform") ? law["uniform"] : ojson();
      if (!range.is_array() || range.size() != 2 || !range[0].is_number() || !range[1].is_number()) {
        return r.Error(where, expected);
      }
      p.low = range[0].get<double>(), p.high = range[1].get<double>();
      if (!std::isfinite(p.low) || !std::isfinite(p.high) || !(p.low < p.high)) return r.Error(where, expected);
      if (p.log_uniform && !(p.low > 0)) return r.Error(where, "log_uniform needs 0 < low < high");
      plan->random.push_back(p);
    }
  }
  if (points.contains("logs")) {
    const ojson& logs = points["logs"];
    if (plan->kind == "rollout") return r.Error("points.logs", "a rollout study's points are a grid or random draws");
    if (!plan->grid.empty() || !plan->random.empty()) {
      return r.Error("points.logs", "logs are not combined with a grid or random draws");
    }
    if (!logs.is_array() || logs.empty()) return r.Error("points.logs", "expected a non-empty array of log files");
    for (size_t i = 0; i < logs.size(); ++i) {
      const ojson& item = logs[i];
      const std::string where = "points.logs[" + std::to_string(i) + "]";
      PointLog log;
      if (item.is_string()) {
        log.label = item.get<std::string>();
        log.log = r.Resolve(log.label);
      } else if (item.is_object()) {
        if (std::string e = r.Known(item, where, {"log", "heldout", "test"}); !e.empty()) return e;
        if (std::string e = r.Text(item, where, "log", &log.label, true); !e.empty()) return e;
        log.log = r.Resolve(log.label);
        if (std::string e = r.Path(item, where, "heldout", &log.heldout); !e.empty()) return e;
        if (std::string e = r.Path(item, where, "test", &log.test); !e.empty()) return e;
        if (plan->kind == "identify" && !log.test.empty()) return r.Error(where + ".test", "identify takes no test log");
      } else {
        return r.Error(where, "expected a log's path, or {\"log\", \"heldout\", \"test\"}");
      }
      if (log.log.empty()) return r.Error(where, "expected a log's path");
      if (log.heldout.empty()) log.heldout = plan->heldout;
      if (log.test.empty()) log.test = plan->test;
      plan->logs.push_back(log);
    }
  } else if (plan->kind != "rollout") {
    return r.Error("points.logs", "required: the logs to " + plan->kind + " (one point each)");
  }
  if (plan->kind == "rollout" && plan->grid.empty() && plan->random.empty()) {
    return r.Error("points", "expected \"grid\" or \"random\" (or both)");
  }
  if (CountPoints(*plan) > kMaxPoints) {
    return r.Error("points", "the grid times the random draws make more than " + std::to_string(kMaxPoints) +
                                 " points: split the study");
  }
  return "";
}

}  // namespace

std::string ReadPlan(const std::string& path, Plan* plan) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *plan = Plan{};
    return path + ": cannot read";
  }
  std::stringstream text;
  text << in.rdbuf();
  return ParsePlan(text.str(), path, plan);
}

std::string ParsePlan(const std::string& text, const std::string& path, Plan* plan) {
  *plan = Plan{};
  plan->path = path;
  plan->text = text;
  try {
    plan->document = ojson::parse(plan->text);
  } catch (const nlohmann::json::exception& e) {
    return path + ": " + e.what();
  }
  const Reader r(path, fs::path(path).parent_path());
  const ojson& d = plan->document;
  if (!d.is_object()) return r.Error("", "expected a JSON object with \"model\", \"what\" and \"points\"");
  if (std::string e = r.Known(d, "", {"model", "what", "points", "scheduler", "description"}); !e.empty()) return e;
  if (std::string e = r.Text(d, "", "model", &plan->model_label, true); !e.empty()) return e;
  plan->model = r.Resolve(plan->model_label);
  if (!d.contains("what")) return r.Error("what", "required");
  if (std::string e = ReadWhat(r, d["what"], plan); !e.empty()) return e;
  if (!d.contains("points")) return r.Error("points", "required");
  if (std::string e = ReadPoints(r, d["points"], plan); !e.empty()) return e;
  if (std::string e = r.Text(d, "", "scheduler", &plan->scheduler); !e.empty()) return e;
  if (!plan->scheduler.empty() && plan->scheduler.find("://") == std::string::npos) {
    return r.Error("scheduler", "expected a Dask scheduler's address, e.g. tcp://host:8786");
  }
  return "";
}

std::vector<std::string> ParameterKeys(const Plan& plan) {
  std::vector<std::string> keys;
  for (const auto& [key, values] : plan.grid) keys.push_back(key);
  for (const RandomParameter& p : plan.random) keys.push_back(p.key);
  return keys;
}

std::size_t CountPoints(const Plan& plan) {
  if (!plan.logs.empty()) return plan.logs.size();
  std::size_t count = plan.random.empty() ? 1 : static_cast<std::size_t>(plan.random_count);
  for (const auto& [key, values] : plan.grid) {
    if (values.size() > (kMaxPoints + 1) / count) return kMaxPoints + 1;  // beyond the limit, without overflow
    count *= values.size();
  }
  return count;
}

std::vector<Point> ExpandPoints(const Plan& plan) {
  std::vector<Point> points;
  if (!plan.logs.empty()) {
    for (const PointLog& log : plan.logs) points.push_back({points.size(), {}, &log});
    return points;
  }
  size_t grid_points = 1;
  for (const auto& [key, values] : plan.grid) grid_points *= values.size();
  const size_t draws = plan.random.empty() ? 1 : static_cast<size_t>(plan.random_count);
  for (size_t g = 0; g < grid_points; ++g) {
    std::vector<std::pair<std::string, double>> grid_values(plan.grid.size());
    size_t rest = g;
    for (size_t j = plan.grid.size(); j-- > 0;) {  // the last key fastest
      const std::vector<double>& values = plan.grid[j].second;
      grid_values[j] = {plan.grid[j].first, values[rest % values.size()]};
      rest /= values.size();
    }
    for (size_t draw = 0; draw < draws; ++draw) {
      Point p{points.size(), grid_values, nullptr};
      for (size_t j = 0; j < plan.random.size(); ++j) {
        const RandomParameter& r = plan.random[j];
        const double u = Stream(plan.random_seed, draw, j).Uniform();
        const double value = r.log_uniform ? std::exp(std::log(r.low) + u * (std::log(r.high) - std::log(r.low)))
                                           : r.low + u * (r.high - r.low);
        p.values.emplace_back(r.key, value);
      }
      points.push_back(p);
    }
  }
  return points;
}

}  // namespace pneumatic::study
