#include "simulation/controller_config.h"

#include "simulation/paper_controllers.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <utility>
#include <vector>

namespace pneumatic {

using nlohmann::json;

std::string ParseJson(const std::string& text, const std::string& where, json* out) {
  try {
    *out = json::parse(text);
  } catch (const json::exception& e) {  // a syntax error, or a number beyond a double (1e400)
    return where + ": " + e.what();
  }
  return "";
}

std::string ReadJsonFile(const std::string& path, json* out) {
  std::ifstream in(path);
  if (!in) return path + ": cannot read";
  std::stringstream text;
  text << in.rdbuf();
  return ParseJson(text.str(), path, out);
}

namespace {

// gains from a JSON object; unknown keys and values that are not finite numbers are refused
std::string ReadGains(const json& object, const std::string& where, PositionPidGains* gains) {
  static const std::vector<std::pair<const char*, double PositionPidGains::*>> kKeys = {
      {"kp", &PositionPidGains::kp},
      {"ki", &PositionPidGains::ki},
      {"kd", &PositionPidGains::kd},
      {"co_contraction", &PositionPidGains::co_contraction},
      {"swing", &PositionPidGains::swing},
      {"onoff_band", &PositionPidGains::onoff_band},
      {"bandwidth", &PositionPidGains::bandwidth},
      {"pressure_margin", &PositionPidGains::pressure_margin},
      {"pressure_step", &PositionPidGains::pressure_step}};
  for (const auto& item : object.items()) {
    const std::string& key = item.key();
    const json& value = item.value();
    if (key == "cylinders") continue;
    auto it = std::find_if(kKeys.begin(), kKeys.end(), [&](const auto& k) { return key == k.first; });
    if (it == kKeys.end()) return where + ": unknown key '" + key + "' (kp, ki, kd, co_contraction, swing, onoff_band, bandwidth, pressure_margin, pressure_step, cylinders)";
    if (!value.is_number() || !std::isfinite(value.get<double>()) || value.get<double>() < 0) {
      return where + ": key '" + key + "' must be a number >= 0";
    }
    gains->*(it->second) = value.get<double>();
  }
  return "";
}

}  // namespace

std::string ModelControllerConfig(const mjModel* m, const std::string& controller, json* out, std::string* where,
                                  bool* found) {
  *found = false;
  const std::string element = kModelControllerConfigPrefix + controller;
  for (int i = 0; i < m->ntext; ++i) {
    if (element != m->names + m->name_textadr[i]) continue;
    *where = "the model's custom text '" + element + "'";
    if (std::string e = ParseJson(m->text_data + m->text_adr[i], *where, out); !e.empty()) return e;
    *found = true;
    return "";
  }
  return "";
}

std::string ReadControllerConfig(const json& config, const std::string& where, ClosedLoopOptions* options) {
  if (!config.is_object()) return where + ": expected a JSON object";
  if (std::string e = ReadGains(config, where, &options->gains); !e.empty()) return e;
  if (config.contains("cylinders")) {
    if (!config["cylinders"].is_object()) return where + ": 'cylinders' must be an object of cylinder names";
    for (const auto& [name, object] : config["cylinders"].items()) {
      PositionPidGains gains = options->gains;
      if (std::string e = ReadGains(object, where + ": cylinders." + name, &gains); !e.empty()) return e;
      options->cylinder_gains[name] = gains;
    }
  }
  return "";
}

std::string ReadControllerConfig(const std::string& path, ClosedLoopOptions* options) {
  json config;
  if (std::string e = ReadJsonFile(path, &config); !e.empty()) return e;
  return ReadControllerConfig(config, path, options);
}

std::string ConfigureController(const mjModel* m, const std::string& model_path, const std::string& controller,
                                const json* config, const std::string& config_source, ClosedLoopOptions* options,
                                json* summary_controller, const std::function<void(const std::string&)>& say) {
  options->controller = controller;
  json carried;
  std::string source = config_source;
  bool configured = config != nullptr;
  if (!configured) {
    if (std::string e = ModelControllerConfig(m, controller, &carried, &source, &configured); !e.empty()) {
      return model_path + ": " + e;
    }
    if (configured) {
      config = &carried;
      source = model_path + ": " + source;
      if (say) say(controller + " configuration from " + source);
    }
  }
  if (controller == "pid" || controller == "none") {
    if (configured) {
      if (std::string e = ReadControllerConfig(*config, source, options); !e.empty()) return e;
    }
  } else if (std::string e = PaperController(controller, configured ? config : nullptr, configured ? source : controller,
                                             options);
             !e.empty()) {
    return e;
  }
  *summary_controller = {{"name", controller}, {"configuration", configured ? source : "the controller's defaults"}};
  return "";
}

}  // namespace pneumatic
