// The papers' controllers by name for a closed-loop run (`pneumo rollout --controller NAME`):
// sliding3 and sliding7 (paper 002, controllers/sliding_mode.h), karpenko (paper 001,
// controllers/karpenko_pid.h), laib (paper 003, controllers/laib_smc.h) and position_stiffness
// (controllers/position_stiffness.h), each made from its JSON configuration.
#ifndef PNEUMATIC_PAPER_CONTROLLERS_H_
#define PNEUMATIC_PAPER_CONTROLLERS_H_

#include <string>

#include <nlohmann/json.hpp>

#include "simulation/closed_loop.h"

namespace pneumatic {

// the factory of one of the papers' controllers, its configuration (`config` from `where`, if any)
// read now (errors name the key): out->controller becomes "custom" and out->make_controller the
// factory. "" or the error; an unknown name is refused.
std::string PaperController(const std::string& name, const nlohmann::json* config, const std::string& where,
                            ClosedLoopOptions* out);

// Any closed-loop controller by name (pid, none, or one of the papers') configured into *out: from
// `config` (read from `config_source`) when given, else from the configuration model m carries
// (ModelControllerConfig; `model_path` names it in messages), else the controller's defaults.
// *description is the summary's {"name", "configuration": where it came from}; *carried the model's
// element when the configuration came from the model, else "". "" or the error, naming the key.
std::string ConfigureController(const mjModel* m, const std::string& model_path, const std::string& name,
                                const nlohmann::json* config, const std::string& config_source, ClosedLoopOptions* out,
                                nlohmann::json* description, std::string* carried);

}  // namespace pneumatic

#endif  // PNEUMATIC_PAPER_CONTROLLERS_H_
