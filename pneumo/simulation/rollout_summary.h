// The JSON summary of a closed-loop run (`pneumo rollout --summary`): the controller and where its
// configuration came from, steps, real-time factor, tracking errors, pressure ranges, warnings.
#ifndef PNEUMATIC_ROLLOUT_SUMMARY_H_
#define PNEUMATIC_ROLLOUT_SUMMARY_H_

#include <string>

#include <nlohmann/json.hpp>

#include "simulation/closed_loop.h"

namespace pneumatic {

// The summary of the run named `run` (e.g. "seed1", "light-seed2"); `controller`: its name and where
// its configuration came from (a file, the model, its defaults)
nlohmann::json SummaryJson(const ClosedLoopSummary& s, const std::string& run, const nlohmann::json& controller);

}  // namespace pneumatic

#endif  // PNEUMATIC_ROLLOUT_SUMMARY_H_
