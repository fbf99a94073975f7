// Writes a 4 s reference log of each rig of docs/rigs.md (the
// deterministic excitation, integrated with RK4 at 1 us) into a folder, as
// logs of docs/log_format.md that `pneumo rollout` can replay.
// PATTERN `fast` writes FastSwitchingExcitation()'s logs (every command held
// 10-80 ms) as rig_*_fast_reference.csv instead; `default` (the default) the others.
//
// usage: write_reference_logs OUT_DIR [SECONDS] [SEED] [PATTERN]
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "reference_log.h"

int main(int argc, char** argv) {
  using namespace pneumatic;
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s OUT_DIR [SECONDS] [SEED] [default|fast]\n", argv[0]);
    return 2;
  }
  std::filesystem::path out = argv[1];
  double seconds = argc > 2 ? std::atof(argv[2]) : 4.0;
  auto seed = static_cast<uint32_t>(argc > 3 ? std::atoi(argv[3]) : 1);
  if (!(seconds > 0)) {
    std::fprintf(stderr, "SECONDS must be positive\n");
    return 2;
  }
  std::string pattern_name = argc > 4 ? argv[4] : "default";
  if (pattern_name != "default" && pattern_name != "fast") {
    std::fprintf(stderr, "PATTERN must be default or fast\n");
    return 2;
  }
  const bool fast = pattern_name == "fast";
  const auto pattern = fast ? reference::ExcitationPattern::kFastSwitching : reference::ExcitationPattern::kDefault;
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  for (reference::Rig rig : {reference::Rig::kOnOff, reference::Rig::kProportional, reference::Rig::kPerChamber}) {
    auto samples = reference::Simulate(reference::DefaultParams(rig), reference::RigState{},
                                       reference::Excitation(rig, seconds, seed, 0, pattern), reference::ControlPeriod(rig), 1e-6);
    std::string name = std::string(reference::RigModelFile(rig));
    name = name.substr(0, name.size() - 4) + (fast ? "_fast_reference.csv" : "_reference.csv");
    std::string error = log::WriteLog((out / name).string(), reference::ToLog(rig, samples));
    if (!error.empty()) {
      std::fprintf(stderr, "%s\n", error.c_str());
      return 1;
    }
    std::fprintf(stderr, "wrote %s\n", (out / name).c_str());
  }
  return 0;
}
