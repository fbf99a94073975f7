// The Python module `pneumatic`: the project's library calls for Python (docs/python.md). Errors
// carry the library's message: ValueError when an input is refused, RuntimeError when a run fails.
#include <cmath>
#include <limits>
#include <string>

#include <pybind11/pybind11.h>

#include "python/bindings.h"

namespace pneumatic::python {

py::object ToPython(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null:
      return py::none();
    case nlohmann::json::value_t::boolean:
      return py::bool_(j.get<bool>());
    case nlohmann::json::value_t::number_integer:
      return py::int_(j.get<std::int64_t>());
    case nlohmann::json::value_t::number_unsigned:
      return py::int_(j.get<std::uint64_t>());
    case nlohmann::json::value_t::number_float:
      return py::float_(j.get<double>());
    case nlohmann::json::value_t::string:
      return py::str(j.get<std::string>());
    case nlohmann::json::value_t::array: {
      py::list list;
      for (const nlohmann::json& item : j) list.append(ToPython(item));
      return std::move(list);
    }
    case nlohmann::json::value_t::object: {
      py::dict dict;
      for (const auto& [key, value] : j.items()) dict[py::str(key)] = ToPython(value);
      return std::move(dict);
    }
    default:  // binary and discarded values: no document of the project holds them
      return py::none();
  }
}

nlohmann::json ToJson(const py::handle& object) {
  if (object.is_none()) return nullptr;
  if (py::isinstance<py::bool_>(object)) return object.cast<bool>();
  if (py::isinstance<py::int_>(object)) return object.cast<std::int64_t>();
  if (py::isinstance<py::float_>(object)) return object.cast<double>();
  if (py::isinstance<py::str>(object)) return object.cast<std::string>();
  if (py::isinstance<py::dict>(object)) {
    nlohmann::json out = nlohmann::json::object();
    for (const auto& [key, value] : object.cast<py::dict>()) {
      if (!py::isinstance<py::str>(key)) throw InputError("a JSON object's keys are text, not " + py::repr(key).cast<std::string>());
      out[key.cast<std::string>()] = ToJson(value);
    }
    return out;
  }
  if (py::isinstance<py::list>(object) || py::isinstance<py::tuple>(object)) {
    nlohmann::json out = nlohmann::json::array();
    for (const py::handle item : object) out.push_back(ToJson(item));
    return out;
  }
  // numpy scalars and the like: as a float when they are one
  if (py::hasattr(object, "__float__")) return object.cast<double>();
  throw InputError("cannot be written as JSON: " + py::repr(object).cast<std::string>());
}

}  // namespace pneumatic::python

PYBIND11_MODULE(pneumatic, m) {
  namespace py = pybind11;
  using namespace pneumatic::python;
  m.doc() = "Pneumatic actuators for MuJoCo 2.2: models, stepping, rollouts, identification and diagnosis "
            "(docs/python.md). SI units, absolute pressures in Pa.";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InputError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const RunError& e) {
      PyErr_SetString(PyExc_RuntimeError, e.what());
    }
  });
  BindModel(m);
  BindSimulation(m);
  BindRollout(m);
  BindAnalysis(m);
}
