// What the files of the Python module `pneumatic` share: the model a Python object holds, the
// errors raised as Python exceptions, JSON as Python objects, and the functions that add each
// topic's classes and functions to the module.
#ifndef PNEUMATIC_PYTHON_BINDINGS_H_
#define PNEUMATIC_PYTHON_BINDINGS_H_

#include <memory>
#include <shared_mutex>
#include <stdexcept>
#include <string>

#include <mujoco/mujoco.h>
#include <nlohmann/json.hpp>
#include <pybind11/pybind11.h>

namespace pneumatic::python {

namespace py = pybind11;

// An attached model and the file it came from. Its parameters change under the unique lock (set);
// stepping and rollouts read them under the shared lock, so a set() from one Python thread waits for
// the steps of another rather than racing them.
struct Model {
  std::shared_ptr<mjModel> model;
  std::string path;
  mutable std::shared_mutex lock;
  const mjModel* get() const { return model.get(); }
};
using ModelHandle = std::shared_ptr<Model>;

// The input was refused (a file, a log, an option, a parameter's value): Python's ValueError.
struct InputError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};
// A run failed: Python's RuntimeError.
struct RunError : std::runtime_error {
  using std::runtime_error::runtime_error;
};
inline void RefuseIf(const std::string& error) {
  if (!error.empty()) throw InputError(error);
}
inline void FailIf(const std::string& error) {
  if (!error.empty()) throw RunError(error);
}

// Loads the MJCF file at `path` with the extension attached (InputError naming the file if refused).
ModelHandle LoadModel(const std::string& path);

// JSON as Python objects (dict, list, str, int, float, bool, None) and back
py::object ToPython(const nlohmann::json& j);
nlohmann::json ToJson(const py::handle& object);

void BindModel(py::module_& m);
void BindSimulation(py::module_& m);
void BindRollout(py::module_& m);
void BindAnalysis(py::module_& m);

}  // namespace pneumatic::python

#endif  // PNEUMATIC_PYTHON_BINDINGS_H_
