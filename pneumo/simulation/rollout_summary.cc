#include "simulation/rollout_summary.h"

namespace pneumatic {

using nlohmann::json;

json SummaryJson(const ClosedLoopSummary& s, const std::string& run, const json& controller) {
  json cylinders = json::object();
  for (const CylinderSummary& c : s.cylinders) {
    cylinders[c.name] = {{"rms_tracking_error", c.rms_tracking_error},
                         {"max_tracking_error", c.max_tracking_error},
                         {"p_P_range_pa", {c.p_min[0], c.p_max[0]}},
                         {"p_N_range_pa", {c.p_min[1], c.p_max[1]}},
                         {"within_supply_range", c.within_supply_range}};
  }
  return {{"run", run},
          {"controller", controller},
          {"steps", s.steps},
          {"simulated_s", s.simulated_s},
          {"wall_s", s.wall_s},
          {"real_time_factor", s.real_time_factor},
          {"cylinders", cylinders},
          {"warnings", s.warnings}};
}

}  // namespace pneumatic
