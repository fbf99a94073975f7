// pneumatic.rollout: open loop (a log's or an array's commands replayed, constant commands,
// simulation/rollout.h) and closed loop under a controller (simulation/closed_loop.h), with the
// options of `pneumo rollout`; logs as dicts of numpy arrays, read and written by the project's log
// reader and writer (formats/log_csv.h).
#include <cstdint>
#include <optional>
#include <string>
#include <utility>

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "formats/log_csv.h"
#include "pneumatic/pneumatic.h"
#include "python/bindings.h"
#include "simulation/closed_loop.h"
#include "simulation/controller_config.h"
#include "simulation/rollout.h"
#include "simulation/rollout_summary.h"

namespace pneumatic::python {
namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

// keys of a log's dict that are not columns
bool IsColumnKey(const std::string& key) { return key != "time" && key != "comments" && key != "summary"; }

log::Column ColumnNamed(const std::string& name) {
  const size_t dot = name.rfind('.');
  if (dot == std::string::npos || dot == 0) throw InputError("'" + name + "' is not a log column <cylinder>.<signal>");
  return {name.substr(0, dot), name.substr(dot + 1)};
}

// a log from {"time": [...], "<cylinder>.<signal>": [...], "comments": [...]}, or from a 2-D array whose
// first column is time and whose other columns `columns` names; checked as the log reader checks a file
log::Log LogFromPython(const py::handle& object, const std::optional<std::vector<std::string>>& columns,
                       bool uniform_time) {
  log::Log out;
  auto add = [&](const std::string& name, const Array& values) {
    if (values.ndim() != 1) throw InputError("log column '" + name + "': expected one number per row");
    std::vector<double> v(values.data(), values.data() + values.shape(0));
    if (name == "time") {
      out.time = std::move(v);
    } else {
      out.columns.push_back(ColumnNamed(name));
      out.values.push_back(std::move(v));
    }
  };
  if (py::isinstance<py::dict>(object)) {
    if (columns) throw InputError("columns= names the columns of a 2-D array; a dict names its own");
    const py::dict dict = object.cast<py::dict>();
    if (!dict.contains("time")) throw InputError("a log needs a \"time\" column (s)");
    add("time", dict["time"].cast<Array>());
    for (const auto& [key, value] : dict) {
      const std::string name = key.cast<std::string>();
      if (name == "comments") out.comments = value.cast<std::vector<std::string>>();
      if (IsColumnKey(name)) add(name, value.cast<Array>());
    }
  } else {
    const Array table = object.cast<Array>();
    if (!columns) throw InputError("a 2-D array of commands needs columns=[...], the names of its columns after time");
    if (table.ndim() != 2 || table.shape(1) != static_cast<py::ssize_t>(columns->size() + 1)) {
      throw InputError("expected an array of shape (rows, " + std::to_string(columns->size() + 1) +
                       "): time, then the columns " + py::str(py::cast(*columns)).cast<std::string>());
    }
    const py::ssize_t rows = table.shape(0);
    auto at = table.unchecked<2>();
    for (size_t c = 0; c <= columns->size(); ++c) {
      std::vector<double> v(static_cast<size_t>(rows));
      for (py::ssize_t r = 0; r < rows; ++r) v[static_cast<size_t>(r)] = at(r, static_cast<py::ssize_t>(c));
      if (c == 0) {
        out.time = std::move(v);
      } else {
        out.columns.push_back(ColumnNamed((*columns)[c - 1]));
        out.values.push_back(std::move(v));
      }
    }
  }
  RefuseIf(log::ValidateLog(out, uniform_time));
  return out;
}

py::dict LogToPython(const log::Log& log) {
  py::dict out;
  out["time"] = Array(static_cast<py::ssize_t>(log.time.size()), log.time.data());
  for (size_t c = 0; c < log.columns.size(); ++c) {
    out[py::str(log.columns[c].name())] = Array(static_cast<py::ssize_t>(log.values[c].size()), log.values[c].data());
  }
  out["comments"] = py::cast(log.comments);
  return out;
}

// every column names a cylinder of m, as the log reader requires of a file for m
void CheckCylinders(const mjModel* m, const log::Log& log) {
  for (const log::Column& column : log.columns) {
    bool known = false;
    for (const CylinderInfo& c : Cylinders(m)) known = known || c.name == column.cylinder;
    if (!known) throw InputError("log column '" + column.name() + "': the model has no cylinder '" + column.cylinder + "'");
  }
}

struct RolloutArguments {
  py::object commands, columns, duration, set, controller, controller_config, reference;
  double period = 0, control_rate = 100, noise_pressure = 0, noise_position = 0;
  bool follow_motion = false;
  std::uint64_t seed = 1;
};

py::dict OpenLoop(const Model& model, const RolloutArguments& a) {
  const mjModel* m = model.get();
  RolloutOptions options;
  if (!a.duration.is_none()) options.duration = a.duration.cast<double>();
  options.period = a.period;
  options.follow_motion = a.follow_motion;
  if (!a.set.is_none()) options.constant_commands = a.set.cast<std::map<std::string, double>>();
  std::optional<log::Log> commands;
  std::string commands_path;
  if (py::isinstance<py::str>(a.commands)) {
    commands_path = a.commands.cast<std::string>();
    log::ReadResult r = ReadModelLog(m, commands_path, true);
    if (!r.log) throw InputError(r.error);
    commands = std::move(r.log);
  } else if (!a.commands.is_none()) {
    commands = LogFromPython(a.commands, a.columns.is_none() ? std::nullopt : a.columns.cast<std::optional<std::vector<std::string>>>(), true);
    CheckCylinders(m, *commands);
  }
  RolloutResult result;
  {
    py::gil_scoped_release release;
    std::shared_lock lock(model.lock);
    result = Rollout(m, commands ? &*commands : nullptr, options);
  }
  if (!result.log) throw RunError(result.error);
  // the comments `pneumo rollout` writes
  result.log->comments.insert(result.log->comments.begin(), "model: " + model.path);
  if (!commands_path.empty()) result.log->comments.insert(result.log->comments.begin() + 1, "commands: " + commands_path);
  return LogToPython(*result.log);
}

py::dict ClosedLoop(const Model& model, const RolloutArguments& a) {
  const mjModel* m = model.get();
  ClosedLoopOptions options;
  options.control_rate = a.control_rate;
  options.noise_pressure = a.noise_pressure;
  options.noise_position = a.noise_position;
  options.seed = a.seed;
  nlohmann::json config, controller;
  std::string source;
  const bool configured = !a.controller_config.is_none();
  if (py::isinstance<py::str>(a.controller_config)) {
    source = a.controller_config.cast<std::string>();
    RefuseIf(ReadJsonFile(source, &config));
  } else if (configured) {
    config = ToJson(a.controller_config);
    source = "controller_config";
  }
  const std::string name = a.controller.cast<std::string>();
  RefuseIf(ConfigureController(m, model.path, name, configured ? &config : nullptr, source, &options, &controller, nullptr));
  std::optional<log::Log> reference;
  if (!a.reference.is_none()) {
    log::ReadResult r = ReadModelLog(m, a.reference.cast<std::string>(), false);
    if (!r.log) throw InputError(r.error);
    reference = std::move(r.log);
    options.reference = &*reference;
  }
  if (!a.duration.is_none()) {
    options.duration = a.duration.cast<double>();
    if (!(options.duration > 0)) throw InputError("duration must be positive, s");
  } else if (!reference) {
    throw InputError("closed loop needs a duration (or a reference, whose span it then runs)");
  } else if (!((options.duration = reference->time.back()) > 0)) {
    throw InputError(a.reference.cast<std::string>() + ": its last row is at t = " + std::to_string(options.duration) +
                     " s, not after the run's start at 0 s: give a duration");
  }
  ClosedLoopResult result;
  {
    py::gil_scoped_release release;
    std::shared_lock lock(model.lock);
    result = RunClosedLoop(m, options);
  }
  if (!result.log) throw RunError(result.error);
  // the comments and the summary `pneumo rollout --controller` writes for a run of one seed
  const std::string run = "seed" + std::to_string(a.seed);
  result.log->comments.insert(result.log->comments.begin(), "model: " + model.path);
  result.log->comments.push_back("run " + run);
  py::dict out = LogToPython(*result.log);
  out["summary"] = ToPython(SummaryJson(result.summary, run, controller));
  return out;
}

py::dict RolloutCall(const ModelHandle& model, const RolloutArguments& a) {
  if (a.controller.is_none()) {
    for (const auto& [given, name] : {std::pair{!a.controller_config.is_none(), "controller_config"},
                                      std::pair{!a.reference.is_none(), "reference"}}) {
      if (given) throw InputError(std::string(name) + " needs a controller (closed loop)");
    }
    return OpenLoop(*model, a);
  }
  if (!a.commands.is_none() || !a.set.is_none() || a.follow_motion) {
    throw InputError("a controller runs closed loop: it does not take commands, set or follow_motion");
  }
  return ClosedLoop(*model, a);
}

}  // namespace

void BindRollout(py::module_& m) {
  m.def(
      "rollout",
      [](const py::object& model_or_path, py::object commands, py::object columns, py::object duration, double period,
         py::object set, bool follow_motion, py::object controller, py::object controller_config, py::object reference,
         double control_rate, std::uint64_t seed, double noise_pressure, double noise_position) {
        const ModelHandle model = py::isinstance<py::str>(model_or_path) ? LoadModel(model_or_path.cast<std::string>())
                                                                         : model_or_path.cast<ModelHandle>();
        return RolloutCall(model, {commands, columns, duration, set, controller, controller_config, reference, period,
                                   control_rate, noise_pressure, noise_position, follow_motion, seed});
      },
      py::arg("model"), py::arg("commands") = py::none(), py::kw_only(), py::arg("columns") = py::none(),
      py::arg("duration") = py::none(), py::arg("period") = 0.0, py::arg("set") = py::none(),
      py::arg("follow_motion") = false, py::arg("controller") = py::none(), py::arg("controller_config") = py::none(),
      py::arg("reference") = py::none(), py::arg("control_rate") = 100.0, py::arg("seed") = 1,
      py::arg("noise_pressure") = 0.0, py::arg("noise_position") = 0.0,
      "`pneumo rollout` on a Model (or a model file). Open loop: commands (a log file, a dict of columns, or a 2-D "
      "array with columns=), duration (s), period (s, without commands), set ({\"cyl.u\": 2.5}: constant commands), "
      "follow_motion. Closed loop with controller (pid, none, position_stiffness, sliding3, sliding7, karpenko, laib): "
      "controller_config (a dict or a JSON file; default: the model's, else the controller's defaults), reference (a "
      "log file with <cylinder>.ref), duration (default: the reference's span), control_rate (Hz), seed, "
      "noise_pressure (Pa), noise_position (m or rad). Returns the log as a dict: time and every column as numpy "
      "arrays, comments, and with a controller the summary of --summary. The GIL is released while it runs.");
  m.def(
      "read_log",
      [](const std::string& path, const py::object& model) {
        std::optional<log::Log> read;
        if (model.is_none()) {
          log::ReadOptions options;
          options.uniform_time = false;
          log::ReadResult r = log::ReadLog(path, options);
          if (!r.log) throw InputError(r.error);
          return LogToPython(*r.log);
        }
        log::ReadResult r = ReadModelLog(model.cast<ModelHandle>()->get(), path, false);
        if (!r.log) throw InputError(r.error);
        return LogToPython(*r.log);
      },
      py::arg("path"), py::arg("model") = py::none(),
      "reads a log file (docs/log_format.md) into a dict as rollout returns; with a model, every column must name one "
      "of its cylinders. ValueError \"FILE:LINE:COLUMN: message\" if the file is refused");
  m.def(
      "write_log",
      [](const std::string& path, const py::object& log) {
        log::Log written = LogFromPython(log, std::nullopt, false);
        FailIf(log::WriteLog(path, written));
      },
      py::arg("path"), py::arg("log"),
      "writes a dict as rollout returns (time, columns, comments) with the project's log writer: the same bytes as "
      "`pneumo rollout --out`, the file whole or untouched. ValueError for a log the reader would refuse");
}

}  // namespace pneumatic::python
