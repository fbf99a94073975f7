// The pid controller's gains from a JSON file (`pneumo rollout --controller pid --controller-config`).
#ifndef PNEUMATIC_CONTROLLER_CONFIG_H_
#define PNEUMATIC_CONTROLLER_CONFIG_H_

#include <string>

#include <nlohmann/json.hpp>

#include "closed_loop.h"

namespace pneumatic {

// Parses the JSON file at `path` into *out; "" or the error, naming the file.
std::string ReadJsonFile(const std::string& path, nlohmann::json* out);

// Reads the gains into options->gains and options->cylinder_gains: {"kp": 1.5, ..., "cylinders":
// {"knee": {"kp": 3}}}, the keys of PositionPidGains for every cylinder, then per cylinder by name
// (each starting from the former). "" or the error, naming the file and the key.
std::string ReadControllerConfig(const std::string& path, ClosedLoopOptions* options);

}  // namespace pneumatic

#endif  // PNEUMATIC_CONTROLLER_CONFIG_H_
