#include "studies/study.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>
#include <sstream>
#include <system_error>

#include "diagnosis/report.h"
#include "formats/log_csv.h"
#include "formats/model_loading.h"
#include "formats/output_file.h"
#include "formats/report_files.h"
#include "identification/identify_log.h"
#include "pneumatic/pneumatic.h"
#include "simulation/model_edits.h"
#include "simulation/controller_config.h"
#include "simulation/parallel_for.h"
#include "simulation/rollout_summary.h"

namespace pneumatic::study {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using ojson = nlohmann::ordered_json;

constexpr char kInterrupted[] = "interrupted";

// the plan as compared with the one a study folder holds: where its points run does not matter
ojson Identity(ojson document) {
  if (document.is_object()) document.erase("scheduler");
  return document;
}

// a CSV field: quoted when it holds a comma, a quote or a line break (RFC 4180)
std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

// a record's value in results.csv: numbers as JSON writes them (the shortest text that reads back
// to the same double), text as it is, null (a NaN figure) empty
std::string CsvValue(const ojson& value) {
  if (value.is_null()) return "";
  if (value.is_string()) return CsvField(value.get<std::string>());
  return CsvField(value.dump());
}

std::string ReadText(const std::string& path, std::string* text) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return path + ": cannot read";
  std::stringstream s;
  s << in.rdbuf();
  *text = s.str();
  return "";
}

// the values of the figure `name` in the identification's PARAMS.json, flattened
void IdentifyFigures(const json& report, ojson* figures) {
  auto number = [&](const std::string& name, const json& v) {
    if (v.is_number()) (*figures)[name] = v.get<double>();
  };
  if (report.contains("chambers")) {
    for (const auto& [chamber, fit] : report["chambers"].items()) number(chamber + ".one_step_fit_pct", fit.value("one_step_fit_pct", json()));
  }
  const json heldout = report.value("heldout", json::object()).value("parametric", json::object());
  if (heldout.contains("chambers")) {
    for (const auto& [chamber, fit] : heldout["chambers"].items()) {
      number("heldout." + chamber + ".one_step_fit_pct", fit.value("one_step_fit_pct", json()));
    }
  }
  number("heldout.pooled_drift_std_pct", heldout.value("pooled_drift_std_pct_at_horizon", json()));
  if (report.contains("physical")) {
    const json& physical = report["physical"];
    const json parameters = physical.value("parameters", json::object());
    for (const auto& [cylinder, keys] : parameters.items()) {
      for (const auto& [key, entry] : keys.items()) number(cylinder + ":" + key, entry.value("value", json()));
    }
    number("physical.rms_before_pa", physical.value("rms_before_pa", json()));
    number("physical.rms_after_pa", physical.value("rms_after_pa", json()));
  }
}

}  // namespace

std::unique_ptr<Study> Study::Open(const std::string& plan_path, const std::string& out_dir, std::string* error) {
  std::unique_ptr<Study> s(new Study());
  if (std::string e = ReadPlan(plan_path, &s->plan_); !e.empty()) return *error = e, nullptr;
  s->points_ = ExpandPoints(s->plan_);
  s->out_dir_ = out_dir;
  const Plan& plan = s->plan_;
  if (plan.kind == "rollout") {
    ModelPtr model = LoadAttachedModel(plan.model, error);
    if (!model) return nullptr;
    s->model_ = model.release();
    ClosedLoopOptions& o = s->base_;
    o.duration = plan.duration;
    o.control_rate = plan.control_rate;
    o.noise_pressure = plan.noise_pressure;
    o.noise_position = plan.noise_position;
    o.seed = plan.seed;
    if (std::string e = ConfigureController(s->model_, plan.model_label, plan.controller,
                                            plan.controller_config.is_null() ? nullptr : &plan.controller_config,
                                            plan.controller_config_source, &o, &s->controller_, nullptr);
        !e.empty()) {
      return *error = plan.path + ": " + e, nullptr;
    }
    if (!plan.reference.empty()) {
      log::ReadOptions read;
      for (const CylinderInfo& c : Cylinders(s->model_)) read.cylinders.insert(c.name);
      read.uniform_time = false;
      log::ReadResult r = log::ReadLog(plan.reference, read);
      if (!r.log) return *error = plan.path + ": what.reference: " + r.error, nullptr;
      s->reference_ = std::make_unique<log::Log>(std::move(*r.log));
      o.reference = s->reference_.get();
    }
  }
  // the folder: this plan's, or a new one
  const std::string copy = out_dir + "/plan.json";
  std::error_code ec;
  if (fs::exists(copy, ec)) {
    std::string text;
    if (std::string e = ReadText(copy, &text); !e.empty()) return *error = e, nullptr;
    ojson held;
    try {
      held = ojson::parse(text);
    } catch (const nlohmann::json::exception& e) {
      return *error = copy + ": " + e.what(), nullptr;
    }
    if (Identity(held) != Identity(plan.document)) {
      *error = out_dir + " holds the study of another plan (" + copy + " differs from " + plan.path +
               "): give another --out, or remove the folder to start again";
      return nullptr;
    }
  } else if (fs::exists(out_dir, ec) && !fs::is_directory(out_dir, ec)) {
    return *error = out_dir + ": exists and is not a folder", nullptr;
  }
  fs::create_directories(out_dir + "/points", ec);
  if (ec) return *error = out_dir + "/points: cannot create: " + ec.message(), nullptr;
  if (!fs::exists(copy, ec)) {
    if (std::string e = WriteOutput(copy, plan.text, "a JSON file"); !e.empty()) return *error = e, nullptr;
  }
  return s;
}

Study::~Study() {
  if (model_) {
    Detach(model_);
    mj_deleteModel(model_);
  }
}

std::string Study::PointDir(std::size_t index) const { return out_dir_ + "/points/" + std::to_string(index); }

bool Study::Finished(std::size_t index) const {
  std::error_code ec;
  return fs::is_regular_file(PointDir(index) + "/" + kRecordName, ec);
}

std::vector<std::size_t> Study::Unfinished() const {
  std::vector<std::size_t> left;
  for (const Point& p : points_) {
    if (!Finished(p.index)) left.push_back(p.index);
  }
  return left;
}

std::string Study::RunRollout(const Point& p, const std::string& dir, const std::atomic<bool>* stop, ojson* figures,
                              bool* interrupted) const {
  std::unique_ptr<mjModel, void (*)(mjModel*)> copy(mj_copyModel(nullptr, model_), mj_deleteModel);
  for (const auto& [key, value] : p.values) {
    if (std::string e = SetModelValue(copy.get(), key, value); !e.empty()) return e;
  }
  ClosedLoopOptions o = base_;
  if (stop) o.observer = [stop](const mjData*) { return stop->load() ? std::string(kInterrupted) : std::string(); };
  ClosedLoopResult result = RunClosedLoop(copy.get(), o);
  if (!result.log) {
    *interrupted = stop && stop->load() && result.error.find(kInterrupted) != std::string::npos;
    return result.error;
  }
  const std::string run = "point " + std::to_string(p.index);
  result.log->comments.insert(result.log->comments.begin(), "model: " + plan_.model_label);
  result.log->comments.push_back("study " + run);
  if (std::string e = log::WriteLog(dir + "/rollout.csv", *result.log); !e.empty()) return e;
  // the summary without its wall-clock figures: a point's files are the same bytes on any machine
  json summary = SummaryJson(result.summary, run, controller_);
  summary.erase("wall_s");
  summary.erase("real_time_factor");
  if (std::string e = WriteOutput(dir + "/summary.json", summary.dump(2) + "\n", "a JSON file"); !e.empty()) return e;
  for (const CylinderSummary& c : result.summary.cylinders) {
    (*figures)[c.name + ".rms_tracking_error"] = c.rms_tracking_error;
    (*figures)[c.name + ".max_tracking_error"] = c.max_tracking_error;
  }
  (*figures)["warnings"] = result.summary.warnings.size();
  return "";
}

std::string Study::RunIdentify(const Point& p, const std::string& dir, ojson* figures) const {
  IdentifyOptions o;
  o.model_path = plan_.model;
  o.log_path = p.log->log;
  o.heldout_path = p.log->heldout;
  o.out_path = dir + "/identify.json";
  o.plot_path = dir + "/identify.drift.png";
  o.fit_keys = plan_.fit_keys;
  o.parametric = plan_.parametric;
  o.physical = plan_.physical;
  o.refine_horizon_s = plan_.refine_horizon_s;
  o.threads = plan_.threads;
  if (std::string e = CheckIdentifyOptions(o); !e.empty()) return e;
  const IdentifySay quiet = [](const std::string&) {};
  IdentifyResult result = IdentifyLog(o, quiet);
  if (!result.error.empty()) return result.error;
  if (std::string e = WriteIdentifyOutputs(o, result, quiet); !e.empty()) return e;
  IdentifyFigures(result.report, figures);
  return "";
}

std::string Study::RunDiagnose(const Point& p, const std::string& dir, ojson* figures) const {
  DiagnoseLogOptions o;
  o.model_path = plan_.model;
  o.train_path = p.log->log;
  o.heldout_path = p.log->heldout;
  o.test_path = p.log->test;
  o.diagnose.horizon_s = plan_.horizon_s;
  o.diagnose.max_effects = plan_.max_effects;
  o.diagnose.calibration_iterations = plan_.calibration_iterations;
  o.diagnose.threads = plan_.threads;
  diagnosis::Diagnosis d;
  json j;
  if (std::string e = DiagnoseLog(o, &d, &j); !e.empty()) return e;
  if (std::string e = WriteOutput(dir + "/diagnose.json", j.dump(2) + "\n", "a JSON file"); !e.empty()) return e;
  (*figures)["verdict"] = d.verdict;
  for (const char* key : {"heldout_gap_before", "heldout_gap_after", "shrink_pct"}) {
    const json v = j["verdict"].value(key, json());
    if (v.is_number()) (*figures)[key] = v.get<double>();
  }
  if (j.contains("test")) {
    for (const char* key : {"gap_before", "gap_after"}) {
      const json v = j["test"].value(key, json());
      if (v.is_number()) (*figures)[std::string("test.") + key] = v.get<double>();
    }
  }
  return "";
}

std::string Study::RunPoint(std::size_t index, const std::atomic<bool>* stop, PointOutcome* outcome) const {
  const Point& p = points_.at(index);
  const std::string dir = PointDir(index);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return dir + ": cannot create: " + ec.message();
  ojson figures = ojson::object();
  bool interrupted = false;
  std::string error;
  try {
    if (plan_.kind == "rollout") {
      error = RunRollout(p, dir, stop, &figures, &interrupted);
    } else if (plan_.kind == "identify") {
      error = RunIdentify(p, dir, &figures);
    } else {
      error = RunDiagnose(p, dir, &figures);
    }
  } catch (const std::exception& e) {  // e.g. out of memory in a fit: the point's failure, not the study's
    error = std::string("unexpected error: ") + e.what();
  }
  if (interrupted) {
    *outcome = PointOutcome::kInterrupted;
    return "";
  }
  ojson record = {{"point", index}};
  if (p.log) record["log"] = p.log->label;
  record["parameters"] = ojson::object();
  for (const auto& [key, value] : p.values) record["parameters"][key] = value;
  record["status"] = error.empty() ? "ok" : "failed";
  record["error"] = error;
  record["figures"] = error.empty() ? figures : ojson::object();
  *outcome = error.empty() ? PointOutcome::kOk : PointOutcome::kFailed;
  // last: the point is finished once this file exists (written to a temporary, then renamed)
  return WriteOutput(dir + "/" + kRecordName, record.dump(2) + "\n", "a JSON file");
}

std::string Study::Run(int jobs, const std::atomic<bool>* stop,
                       const std::function<void(const Progress&)>& progress) const {
  const std::vector<std::size_t> left = Unfinished();
  const auto start = std::chrono::steady_clock::now();
  Progress state;
  state.total = points_.size();
  state.finished = points_.size() - left.size();
  std::mutex lock;
  std::string first_error;
  ParallelFor(left.size(), jobs, [&](std::size_t i) {
    {
      std::lock_guard<std::mutex> guard(lock);
      if ((stop && stop->load()) || !first_error.empty()) return;
    }
    PointOutcome outcome = PointOutcome::kOk;
    const std::string e = RunPoint(left[i], stop, &outcome);
    std::lock_guard<std::mutex> guard(lock);
    if (!e.empty()) {
      if (first_error.empty()) first_error = e;
      return;
    }
    if (outcome == PointOutcome::kInterrupted) return;
    ++state.ran, ++state.finished;
    if (outcome == PointOutcome::kFailed) ++state.failed;
    state.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (progress) progress(state);
  });
  return first_error;
}

std::string Study::Collect(bool plots) const {
  std::vector<ojson> records;
  for (const Point& p : points_) {
    const std::string path = PointDir(p.index) + "/" + kRecordName;
    std::string text;
    if (!Finished(p.index)) return "point " + std::to_string(p.index) + " is not finished (no " + path + ")";
    if (std::string e = ReadText(path, &text); !e.empty()) return e;
    try {
      records.push_back(ojson::parse(text));
    } catch (const nlohmann::json::exception& e) {
      return path + ": " + e.what();
    }
  }
  // the columns: the point, its log or parameters, every figure any point has (in the order the
  // points first give them), its status and error
  const std::vector<std::string> keys = ParameterKeys(plan_);
  std::vector<std::string> figures;
  std::set<std::string> seen;
  for (const ojson& r : records) {
    const ojson values = r.value("figures", ojson::object());
    for (const auto& [name, value] : values.items()) {
      if (seen.insert(name).second) figures.push_back(name);
    }
  }
  std::string csv = "point";
  if (!plan_.logs.empty()) csv += ",log";
  for (const std::string& k : keys) csv += "," + CsvField(k);
  for (const std::string& f : figures) csv += "," + CsvField(f);
  csv += ",status,error\n";
  for (const ojson& r : records) {
    csv += CsvValue(r["point"]);
    if (!plan_.logs.empty()) csv += "," + CsvValue(r.value("log", ojson()));
    const ojson parameters = r.value("parameters", ojson::object());
    for (const std::string& k : keys) csv += "," + CsvValue(parameters.value(k, ojson()));
    const ojson values = r.value("figures", ojson::object());
    for (const std::string& f : figures) csv += "," + CsvValue(values.value(f, ojson()));
    csv += "," + CsvValue(r.value("status", ojson())) + "," + CsvValue(r.value("error", ojson())) + "\n";
  }
  if (std::string e = WriteOutput(out_dir_ + "/results.csv", csv, "a CSV file"); !e.empty()) return e;
  if (!plots) return "";
  return RunPlotScript("plot_study.py", {out_dir_, std::to_string(plan_.logs.empty() ? keys.size() : 1)});
}

}  // namespace pneumatic::study
