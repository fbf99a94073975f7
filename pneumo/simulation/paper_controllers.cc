#include "simulation/paper_controllers.h"

#include <cstdio>
#include <memory>
#include <vector>

#include "karpenko_pid.h"
#include "laib_smc.h"
#include "position_stiffness.h"
#include "simulation/controller_config.h"
#include "sliding_mode.h"

namespace pneumatic {
namespace {

using nlohmann::json;

// The papers' controllers take "key=value ..." configurations (their key tables name units and
// ranges); their JSON configuration gives them as a flat object of numbers.
std::string JsonToKeyValues(const json& config, const std::string& where, std::string* text) {
  if (!config.is_object()) return where + ": expected a JSON object of key: number";
  for (const auto& [key, value] : config.items()) {
    if (!value.is_number()) return where + ": key '" + key + "' must be a number";
    char number[64];
    std::snprintf(number, sizeof(number), "%.17g", value.get<double>());
    *text += key + "=" + number + " ";
  }
  return "";
}

}  // namespace

std::string PaperController(const std::string& name, const json* config, const std::string& where,
                            ClosedLoopOptions* out) {
  std::string text;
  if (config) {
    if (std::string e = JsonToKeyValues(*config, where, &text); !e.empty()) return e;
  }
  std::string error;
  out->controller = "custom";
  if (name == "sliding3" || name == "sliding7") {
    SlidingModeParams params;
    params.modes = name == "sliding3" ? 3 : 7;
    if (!text.empty() && !ParseSlidingModeConfig(text, &params, &error)) return where + ": " + error;
    out->make_controller = [params](const std::vector<ValveDrive>& drives, double period, std::string* e) {
      std::vector<ValveDrive> copy = drives;
      SlidingModeParams p = params;
      if (!drives.empty()) p.p_supply = drives[0].p_supply, p.p_exhaust = drives[0].p_exhaust;
      return std::unique_ptr<Controller>(SlidingModeController::Create(copy, p, period, e));
    };
  } else if (name == "karpenko") {
    KarpenkoPidParams params;
    if (!text.empty() && !ParseKarpenkoPidConfig(text, &params, &error)) return where + ": " + error;
    out->make_controller = [params](const std::vector<ValveDrive>& drives, double period, std::string* e) {
      return std::unique_ptr<Controller>(KarpenkoPid::Create(drives, params, period, e));
    };
  } else if (name == "laib") {
    LaibSmcParams params;
    if (!text.empty() && !ParseLaibSmcConfig(text, &params, &error)) return where + ": " + error;
    out->make_controller = [params](const std::vector<ValveDrive>& drives, double period, std::string* e) {
      return std::unique_ptr<Controller>(LaibSmcController::Create(drives, params, period, e));
    };
  } else if (name == "position_stiffness") {
    PositionStiffnessParams params;
    if (std::string e = ParsePositionStiffnessConfig(text, &params); !e.empty()) return where + ": " + e;
    out->make_controller = [params](const std::vector<ValveDrive>& drives, double period, std::string* e) {
      return std::unique_ptr<Controller>(PositionStiffness::Create(drives, params, period, e));
    };
  } else {
    return "unknown controller '" + name + "'";
  }
  return "";
}

std::string ConfigureController(const mjModel* m, const std::string& model_path, const std::string& name,
                                const json* config, const std::string& config_source, ClosedLoopOptions* out,
                                json* description, std::string* carried) {
  carried->clear();
  out->controller = name;
  json own;
  std::string source = config_source;
  bool configured = config != nullptr;
  if (!configured) {
    if (std::string e = ModelControllerConfig(m, name, &own, &source, &configured); !e.empty()) {
      return model_path + ": " + e;
    }
    if (configured) {
      source = model_path + ": " + source;
      *carried = source;
      config = &own;
    }
  }
  if (name == "pid" || name == "none") {
    if (configured) {
      if (std::string e = ReadControllerConfig(*config, source, out); !e.empty()) return e;
    }
  } else if (std::string e = PaperController(name, configured ? config : nullptr, configured ? source : name, out);
             !e.empty()) {
    return e;
  }
  *description = {{"name", name}, {"configuration", configured ? source : "the controller's defaults"}};
  return "";
}

}  // namespace pneumatic
