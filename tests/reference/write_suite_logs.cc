// Writes the graded diagnosis suite's logs (tests/reference/suite_cases.h): for every case
// OUT_DIR/<id>/train.csv, selection.csv and test.csv (docs/log_format.md), and OUT_DIR/cases.json,
// the manifest: each case's id, rig, model file, rate, noise factor, truth, description, drawn
// parameter perturbations, sensors and seeds. --case TEXT: only the cases whose id contains TEXT;
// --durations T S X: the three logs' durations in s (10, 6 and 6 by default).
//
// usage: write_suite_logs OUT_DIR [--case TEXT] [--durations TRAIN SELECTION TEST]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "reference_log.h"
#include "suite_cases.h"

namespace {

using pneumatic::reference::SuiteCase;

nlohmann::json Manifest(const SuiteCase& c, const double durations[3]) {
  const pneumatic::reference::Perturbation& p = c.perturbation;
  nlohmann::json j;
  j["id"] = c.id;
  j["rig"] = pneumatic::reference::RigLetter(c.rig);
  j["model"] = std::string("models_mjcf/") + pneumatic::reference::RigModelFile(c.rig);
  j["rate_hz"] = c.rate;
  j["noise"] = c.noise;
  j["truth"] = c.truth;
  j["description"] = c.description;
  j["perturbation"] = {{"flow", p.flow},
                       {"critical_ratio", p.critical_ratio},
                       {"polytropic_index", p.polytropic_index},
                       {"dead_volume_P", p.dead_volume_P},
                       {"dead_volume_N", p.dead_volume_N},
                       {"damping", p.damping}};
  j["sensors"] = {{"noise_pressure_pa", c.sensors.noise_pressure},
                  {"noise_position_m", c.sensors.noise_position},
                  {"pressure_lag_s", c.sensors.pressure_lag},
                  {"position_quantum_m", c.sensors.position_quantum}};
  for (int i = 0; i < 3; ++i) {
    const std::string part = pneumatic::reference::LogPartName(i);
    j["logs"][part] = {{"file", c.id + "/" + part + ".csv"}, {"seed", c.seeds[static_cast<size_t>(i)]}, {"duration_s", durations[i]}};
  }
  return j;
}

}  // namespace

int main(int argc, char** argv) {
  namespace ref = pneumatic::reference;
  if (argc < 2 || argv[1][0] == '-') {
    std::fprintf(stderr, "usage: %s OUT_DIR [--case TEXT] [--durations TRAIN SELECTION TEST]\n", argv[0]);
    return 2;
  }
  const std::filesystem::path out = argv[1];
  std::string only;
  double durations[3] = {ref::kDefaultDurations[0], ref::kDefaultDurations[1], ref::kDefaultDurations[2]};
  for (int i = 2; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--case") && i + 1 < argc) {
      only = argv[++i];
    } else if (!std::strcmp(argv[i], "--durations") && i + 3 < argc) {
      for (double& d : durations) {
        char* end = nullptr;
        d = std::strtod(argv[++i], &end);
        if (*end != '\0' || !(d > 0)) {
          std::fprintf(stderr, "--durations: expected three numbers > 0, got '%s'\n", argv[i]);
          return 2;
        }
      }
    } else {
      std::fprintf(stderr, "write_suite_logs: unknown argument '%s'\n", argv[i]);
      return 2;
    }
  }
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) {
    std::fprintf(stderr, "%s: %s\n", out.c_str(), ec.message().c_str());
    return 1;
  }
  const auto start = std::chrono::steady_clock::now();
  nlohmann::json manifest = nlohmann::json::array();
  for (const SuiteCase& c : ref::SuiteCases()) {
    if (!only.empty() && c.id.find(only) == std::string::npos) continue;
    std::filesystem::create_directories(out / c.id, ec);
    for (int which = 0; which < 3; ++which) {
      const std::filesystem::path file = out / c.id / (std::string(ref::LogPartName(which)) + ".csv");
      const std::string error = pneumatic::log::WriteLog(file.string(), ref::SimulateCase(c, which, durations[which]));
      if (!error.empty()) {
        std::fprintf(stderr, "%s\n", error.c_str());
        return 1;
      }
    }
    manifest.push_back(Manifest(c, durations));
    std::fprintf(stderr, "%-28s %s %5.0f Hz  noise %.2f  %-14s %s\n", c.id.c_str(), ref::RigLetter(c.rig), c.rate, c.noise,
                 c.truth.c_str(), c.description.c_str());
  }
  std::ofstream json(out / "cases.json");
  json << manifest.dump(2) << "\n";
  if (!json) {
    std::fprintf(stderr, "%s: writing failed\n", (out / "cases.json").c_str());
    return 1;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fprintf(stderr, "wrote %zu cases to %s in %.1f s\n", manifest.size(), out.c_str(), seconds);
  return 0;
}
