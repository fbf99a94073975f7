// A closed-loop controller's configuration: a JSON object from a file (`pneumo rollout
// --controller-config`) or carried by the model itself, and the pid controller's gains read from it.
#ifndef PNEUMATIC_CONTROLLER_CONFIG_H_
#define PNEUMATIC_CONTROLLER_CONFIG_H_

#include <functional>
#include <string>

#include <mujoco/mujoco.h>
#include <nlohmann/json.hpp>

#include "simulation/closed_loop.h"

namespace pneumatic {

// Parses JSON text into *out; "" or the error (a syntax error, a number beyond a double), naming `where`.
std::string ParseJson(const std::string& text, const std::string& where, nlohmann::json* out);
// Parses the JSON file at `path` into *out; "" or the error, naming the file.
std::string ReadJsonFile(const std::string& path, nlohmann::json* out);

// A model carries the configuration its controllers were tuned with as custom text, the same JSON
// object --controller-config reads from a file:
//   <custom><text name="pneumo:controller:pid" data='{"bandwidth": 8, "pressure_margin": 30000}'/></custom>
constexpr char kModelControllerConfigPrefix[] = "pneumo:controller:";

// The configuration model m carries for `controller` into *out, with *where set to the text's
// name for errors; *found false (and "") if it carries none. "" or the error, naming the element.
std::string ModelControllerConfig(const mjModel* m, const std::string& controller, nlohmann::json* out,
                                  std::string* where, bool* found);

// Reads the gains into options->gains and options->cylinder_gains: {"kp": 1.5, ..., "cylinders":
// {"knee": {"kp": 3}}}, the keys of PositionPidGains for every cylinder, then per cylinder by name
// (each starting from the former). "" or the error, naming `where` (the file or the model's text)
// and the key.
std::string ReadControllerConfig(const nlohmann::json& config, const std::string& where, ClosedLoopOptions* options);
// the same from the JSON file at `path`
std::string ReadControllerConfig(const std::string& path, ClosedLoopOptions* options);

// The controller of a closed-loop run on m by name ("pid", "none" or one of PaperController's), configured
// from `config` when given (`config_source` names it: a file, an argument), else from the configuration m
// carries for it (`model_path` names m in messages; `say` hears where it came from), else from the
// controller's defaults: sets options->controller and the gains or the factory, and *summary_controller
// to the {"name", "configuration"} of the run's summary (SummaryJson). "" or the error.
std::string ConfigureController(const mjModel* m, const std::string& model_path, const std::string& controller,
                                const nlohmann::json* config, const std::string& config_source,
                                ClosedLoopOptions* options, nlohmann::json* summary_controller,
                                const std::function<void(const std::string&)>& say);

}  // namespace pneumatic

#endif  // PNEUMATIC_CONTROLLER_CONFIG_H_
