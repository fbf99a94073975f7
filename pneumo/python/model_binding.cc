// pneumatic.load, pneumatic.Model: an attached model, its cylinders with their parameters (value,
// unit, valid range, meaning) and log columns, a parameter read and set by key "<cylinder>:<key>" as
// `pneumo rollout --variations` spells it, set checked exactly as the MJCF is (pneumatic::SetParameter).
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include <pybind11/stl.h>

#include "formats/log_csv.h"
#include "formats/model_loading.h"
#include "pneumatic/pneumatic.h"
#include "simulation/model_edits.h"
#include "python/bindings.h"

namespace pneumatic::python {
namespace {

// a model's parameter value: a number, or a choice as its text
using Value = std::variant<double, std::string>;

struct Parameter {
  std::string key;  // as in the MJCF text: "stroke", "P.area"
  Value value;
  const ParameterDoc* doc = nullptr;
};

struct Column {
  std::string name, signal, kind, unit, meaning;
};

struct Cylinder {
  std::string name;
  std::vector<Parameter> parameters;
  std::vector<Column> commands, measured;  // the log columns of its valve commands; of what a rollout records
};

std::pair<std::string, std::string> SplitKey(const std::string& key) {
  const size_t colon = key.find(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == key.size()) {
    throw InputError("'" + key + "' is not <cylinder>:<key>, e.g. cyl:dead_volume or cyl:P.area");
  }
  return {key.substr(0, colon), key.substr(colon + 1)};
}

// the row of Parameters() for a key with or without its chamber prefix, or null
const ParameterDoc* FindDoc(const std::string& key) {
  const std::string bare = key.size() > 2 && (key.rfind("P.", 0) == 0 || key.rfind("N.", 0) == 0) ? key.substr(2) : key;
  for (const ParameterDoc& doc : Parameters()) {
    if (doc.key == bare) return &doc;
  }
  return nullptr;
}

std::optional<Value> Get(const mjModel* m, const std::string& cylinder, const std::string& key, std::string* error) {
  const ParameterDoc* doc = FindDoc(key);
  if (doc && doc->is_choice) {
    if (std::optional<std::string> text = GetChoice(m, cylinder, key, error)) return Value(*text);
    return std::nullopt;
  }
  if (std::optional<double> number = GetParameter(m, cylinder, key, error)) return Value(*number);
  return std::nullopt;
}

Column ColumnOf(const std::string& cylinder, const std::string& signal) {
  const log::SignalInfo* info = log::FindSignal(signal);
  static const char* kKinds[] = {"command", "measured", "reference"};
  return {cylinder + "." + signal, signal, info ? kKinds[static_cast<int>(info->kind)] : "", info ? info->unit : "",
          info ? info->meaning : ""};
}

std::vector<Cylinder> CylindersOf(const Model& model) {
  std::shared_lock lock(model.lock);
  const mjModel* m = model.get();
  std::vector<Cylinder> out;
  for (const CylinderInfo& info : Cylinders(m)) {
    Cylinder c{info.name, {}, {}, {}};
    for (const ParameterDoc& doc : Parameters()) {
      std::vector<std::string> keys = {doc.key};
      if (doc.scope == "chamber") keys = {"P." + doc.key, "N." + doc.key};
      for (const std::string& key : keys) {
        std::string ignored;  // a key that does not apply to this cylinder is left out
        if (std::optional<Value> value = Get(m, info.name, key, &ignored)) c.parameters.push_back({key, *value, &doc});
      }
    }
    for (const auto& [signal, actuator] : info.command_actuators) c.commands.push_back(ColumnOf(info.name, signal));
    for (const char* signal : {"p_P", "p_N", "x", "v", "p_S"}) c.measured.push_back(ColumnOf(info.name, signal));
    out.push_back(std::move(c));
  }
  return out;
}

Value GetByKey(const Model& model, const std::string& key) {
  const auto [cylinder, name] = SplitKey(key);
  std::shared_lock lock(model.lock);
  std::string error;
  std::optional<Value> value = Get(model.get(), cylinder, name, &error);
  if (!value) throw InputError(error);
  return *value;
}

void SetByKey(Model& model, const std::string& key, const Value& value) {
  if ((key.rfind("body:", 0) == 0 || key.rfind("joint:", 0) == 0) && std::holds_alternative<double>(value)) {
    // a MuJoCo field as parameter studies name it ("body:<name>:mass", "joint:<name>:damping",
    // "joint:<name>:frictionloss"): SetModelValue
    std::unique_lock lock(model.lock);
    if (std::string e = SetModelValue(model.model.get(), key, std::get<double>(value)); !e.empty()) throw InputError(e);
    return;
  }
  const auto [cylinder, name] = SplitKey(key);
  std::unique_lock lock(model.lock);
  std::string error;
  const bool set = std::holds_alternative<double>(value)
                       ? SetParameter(model.model.get(), cylinder, name, std::get<double>(value), &error)
                       : SetParameter(model.model.get(), cylinder, name, std::get<std::string>(value), &error);
  if (!set) throw InputError(error);
}

void DeleteModel(mjModel* m) {
  Detach(m);
  mj_deleteModel(m);
}

ModelHandle CopyModel(const Model& model) {
  auto copy = std::make_shared<Model>();
  std::shared_lock lock(model.lock);
  mjModel* m = mj_copyModel(nullptr, model.get());
  if (!m) throw RunError("MuJoCo could not copy the model " + model.path);
  copy->model = std::shared_ptr<mjModel>(m, DeleteModel);
  copy->path = model.path;
  return copy;
}

std::string ValueText(const Value& value) {
  return std::holds_alternative<double>(value) ? py::repr(py::float_(std::get<double>(value))).cast<std::string>()
                                               : "'" + std::get<std::string>(value) + "'";
}

}  // namespace

ModelHandle LoadModel(const std::string& path) {
  std::string error;
  ModelPtr loaded = LoadAttachedModel(path, &error);
  if (!loaded) throw InputError(error);
  auto model = std::make_shared<Model>();
  model->model = std::shared_ptr<mjModel>(loaded.release(), DeleteModel);
  model->path = path;
  return model;
}

void BindModel(py::module_& m) {
  py::class_<Parameter>(m, "Parameter", "a cylinder's parameter: its value and its row of docs/parameters.md")
      .def_readonly("key", &Parameter::key, "the MJCF key, with P. or N. for one chamber's")
      .def_readonly("value", &Parameter::value, "a number in `unit`, or a choice's text")
      .def_property_readonly("unit", [](const Parameter& p) { return p.doc->unit; })
      .def_property_readonly("valid", [](const Parameter& p) { return p.doc->valid; }, "the range or the choices")
      .def_property_readonly("default", [](const Parameter& p) { return p.doc->default_value; })
      .def_property_readonly("meaning", [](const Parameter& p) { return p.doc->meaning; })
      .def_property_readonly("scope", [](const Parameter& p) { return p.doc->scope; })
      .def("__repr__", [](const Parameter& p) {
        return "<Parameter " + p.key + " = " + ValueText(p.value) + (p.doc->unit.empty() ? "" : " " + p.doc->unit) + ">";
      });
  py::class_<Column>(m, "Column", "a log column (docs/log_format.md)")
      .def_readonly("name", &Column::name, "\"<cylinder>.<signal>\"")
      .def_readonly("signal", &Column::signal)
      .def_readonly("kind", &Column::kind, "command, measured or reference")
      .def_readonly("unit", &Column::unit)
      .def_readonly("meaning", &Column::meaning)
      .def("__repr__", [](const Column& c) { return "<Column " + c.name + " (" + c.kind + ", " + c.unit + ")>"; });
  py::class_<Cylinder>(m, "Cylinder", "a pneumatic cylinder of a model")
      .def_readonly("name", &Cylinder::name)
      .def_property_readonly(
          "parameters",
          [](const Cylinder& c) {
            py::dict out;
            for (const Parameter& p : c.parameters) out[py::str(p.key)] = p;
            return out;
          },
          "key -> Parameter, every key that applies to this cylinder")
      .def_readonly("commands", &Cylinder::commands, "the log columns of its valve commands")
      .def_readonly("measured", &Cylinder::measured, "the log columns a rollout records for it: p_P, p_N, x, v, p_S")
      .def("__repr__", [](const Cylinder& c) { return "<Cylinder " + c.name + ">"; });

  py::class_<Model, ModelHandle>(m, "Model", "an MJCF model with its pneumatic cylinders attached")
      .def_readonly("path", &Model::path, "the file it was loaded from")
      .def_property_readonly("cylinders", &CylindersOf, "the cylinders, in the model's order")
      .def_property_readonly("timestep", [](const Model& model) { return model.get()->opt.timestep; }, "s")
      .def("get", &GetByKey, py::arg("key"),
           "a parameter by \"<cylinder>:<key>\" (\"cyl:dead_volume\", \"cyl:P.area\"): a number in its unit, or a "
           "choice's text; ValueError for an unknown cylinder or a key that does not apply")
      .def("set", &SetByKey, py::arg("key"), py::arg("value"),
           "sets a parameter by \"<cylinder>:<key>\", checked exactly as the MJCF is (range, the keys that apply, "
           "relations); a chamber key without P. or N. sets both; also \"body:<name>:mass\", "
           "\"joint:<name>:damping\" and \"joint:<name>:frictionloss\" (as pneumo study names them). ValueError "
           "naming the cylinder and key, and the model unchanged, when refused")
      .def("copy", &CopyModel, "a copy with the same parameters, which steps exactly like this model")
      .def("configuration", [](const Model& model, const std::string& cylinder) {
             std::shared_lock lock(model.lock);
             std::string error;
             std::optional<std::string> text = ConfigurationText(model.get(), cylinder, &error);
             if (!text) throw InputError(error);
             return *text;
           }, py::arg("cylinder"), "the cylinder's parameters as the text of its MJCF element \"pneumatic:<cylinder>\"")
      .def("__repr__", [](const Model& model) { return "<pneumatic.Model " + model.path + ">"; });

  m.def("load", &LoadModel, py::arg("path"),
        "loads an MJCF file and attaches its cylinders; ValueError with MuJoCo's or the extension's message if refused");
}

}  // namespace pneumatic::python
