// pneumatic.identify and pneumatic.diagnose: `pneumo identify` and `pneumo diagnose` as library
// calls (identification/identify_log.h, diagnosis/report.h), their JSON documents as Python objects.
#include <functional>
#include <string>
#include <vector>

#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include "diagnosis/report.h"
#include "identification/identify_log.h"
#include "python/bindings.h"

namespace pneumatic::python {
namespace {

// an error naming one of the inputs ("<path>: ..." or "<path>:LINE:COLUMN: ...") refuses that input;
// any other is the run's failure
[[noreturn]] void Raise(const std::string& error, const std::vector<std::string>& inputs) {
  for (const std::string& input : inputs) {
    if (!input.empty() && error.rfind(input + ":", 0) == 0) throw InputError(error);
  }
  throw RunError(error);
}

// the progress lines for a Python callable (called with the GIL, from whichever thread says them), or none
std::function<void(const std::string&)> Progress(const py::object& progress) {
  if (progress.is_none()) return nullptr;
  return [progress](const std::string& line) {
    py::gil_scoped_acquire acquire;
    try {
      progress(line);
    } catch (py::error_already_set& e) {
      e.discard_as_unraisable("pneumatic: the progress callable");
    }
  };
}

py::object Identify(const std::string& model_path, const std::string& log_path, const std::string& heldout,
                    const std::vector<std::string>& fit, bool parametric, bool physical, double refine_horizon,
                    int threads, const std::string& out, const std::string& plot, const std::string& write_model,
                    const std::string& write_identified_model, const py::object& progress) {
  IdentifyOptions o;
  o.model_path = model_path, o.log_path = log_path, o.heldout_path = heldout, o.fit_keys = fit;
  o.parametric = parametric, o.physical = physical, o.refine_horizon_s = refine_horizon, o.threads = threads;
  o.out_path = out, o.plot_path = plot, o.write_model_path = write_model, o.write_identified_model_path = write_identified_model;
  if (out.empty() && !(plot.empty() && write_model.empty() && write_identified_model.empty())) {
    throw InputError("plot, write_model and write_identified_model are written with out (PARAMS.json): give out");
  }
  if (!(refine_horizon >= 0 && refine_horizon <= 10)) throw InputError("refine_horizon is in [0, 10] s");
  if (threads < 1 || threads > 64) throw InputError("threads is in [1, 64]");
  RefuseIf(CheckIdentifyOptions(o));
  const auto say = Progress(progress);
  const IdentifySay quiet = [](const std::string&) {};
  IdentifyResult result;
  std::string written;
  {
    py::gil_scoped_release release;
    result = IdentifyLog(o, say ? say : quiet);
    if (result.error.empty() && !out.empty()) written = WriteIdentifyOutputs(o, result, say ? say : quiet);
  }
  if (!result.error.empty()) Raise(result.error, {model_path, log_path, heldout});
  FailIf(written);
  return ToPython(result.report);
}

py::object Diagnose(const std::string& model_path, const std::string& train, const std::string& heldout,
                    const std::string& test, const std::string& report, int calibration_iterations, double horizon,
                    int max_effects, int threads, const py::object& progress) {
  DiagnoseLogOptions o;
  o.model_path = model_path, o.train_path = train, o.heldout_path = heldout, o.test_path = test, o.report_dir = report;
  // the ranges of `pneumo diagnose`'s options
  if (calibration_iterations < 0 || calibration_iterations > 200) throw InputError("calibration_iterations is in [0, 200]");
  if (!(horizon >= 0.005 && horizon <= 10)) throw InputError("horizon is in [0.005, 10] s");
  if (max_effects < 1 || max_effects > 5) throw InputError("max_effects is in [1, 5]");
  if (threads < 1 || threads > 64) throw InputError("threads is in [1, 64]");
  o.diagnose.calibration_iterations = calibration_iterations;
  o.diagnose.horizon_s = horizon;
  o.diagnose.max_effects = max_effects;
  o.diagnose.threads = threads;
  if (auto say = Progress(progress)) o.diagnose.progress = say;
  diagnosis::Diagnosis d;
  nlohmann::json document;
  std::string error;
  {
    py::gil_scoped_release release;
    error = DiagnoseLog(o, &d, &document);
  }
  if (!error.empty()) Raise(error, {model_path, train, heldout, test, report});
  return ToPython(document);
}

}  // namespace

void BindAnalysis(py::module_& m) {
  const IdentifyOptions identify_defaults;
  m.def("identify", &Identify, py::arg("model_path"), py::arg("log_path"), py::kw_only(), py::arg("heldout") = "",
        py::arg("fit") = std::vector<std::string>{}, py::arg("parametric") = identify_defaults.parametric,
        py::arg("physical") = identify_defaults.physical, py::arg("refine_horizon") = identify_defaults.refine_horizon_s,
        py::arg("threads") = identify_defaults.threads, py::arg("out") = "", py::arg("plot") = "",
        py::arg("write_model") = "", py::arg("write_identified_model") = "", py::arg("progress") = py::none(),
        "`pneumo identify`: paper 000's c1..c9 per chamber (parametric) and the physical parameters (physical; fit: "
        "[\"<cylinder>:<key>\", ...], default each cylinder's usual set) fitted to the log at log_path, validated on "
        "heldout. Returns PARAMS.json's document as a dict; with out, also writes it (and plot, write_model, "
        "write_identified_model) as the command does. progress: a callable given each progress line. Without the GIL");
  const diagnosis::DiagnoseOptions diagnose_defaults;
  m.def("diagnose", &Diagnose, py::arg("model_path"), py::arg("train_log"), py::kw_only(), py::arg("heldout") = "",
        py::arg("test") = "", py::arg("report") = "",
        py::arg("calibration_iterations") = diagnose_defaults.calibration_iterations,
        py::arg("horizon") = diagnose_defaults.horizon_s, py::arg("max_effects") = diagnose_defaults.max_effects,
        py::arg("threads") = diagnose_defaults.threads, py::arg("progress") = py::none(),
        "`pneumo diagnose`: which unmodelled effect explains the gap between the model and the training log, judged on "
        "heldout (default: the last 30 % of the training log) and graded on test. Returns the JSON the command prints "
        "as a dict; with report, writes the HTML report into that folder. Without the GIL");
}

}  // namespace pneumatic::python
