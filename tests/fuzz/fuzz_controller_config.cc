// libFuzzer target: the controllers' configurations and the other short texts users write. The first
// byte picks the parser, the rest is its text: the closed loop's JSON configuration
// (--controller-config, or a model's pneumo:controller text), the key=value configurations of the
// papers' controllers (Karpenko's PID, Laib's SMC, the sliding-mode controller, the position
// stiffness). Each must give a value or a message; any crash, uncaught exception, leak, undefined behaviour or hang is a finding.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <nlohmann/json.hpp>

#include "karpenko_pid.h"
#include "laib_smc.h"
#include "position_stiffness.h"
#include "simulation/controller_config.h"
#include "sliding_mode.h"

namespace {

void Refused(const std::string& error, const char* parser) {
  if (error.empty()) {
    std::fprintf(stderr, "%s refused its text without a message\n", parser);
    std::abort();
  }
}

// a key=value parser of the form bool Parse(text, &params, &error)
template <class Params>
void ParseKeyValues(const std::string& text, bool (*parse)(const std::string&, Params*, std::string*),
                    const char* parser) {
  Params params;
  std::string error;
  if (!parse(text, &params, &error)) Refused(error, parser);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  switch (data[0] % 5) {
    case 0: {
      nlohmann::json config;
      if (std::string e = pneumatic::ParseJson(text, "fuzz.json", &config); !e.empty()) return 0;
      pneumatic::ClosedLoopOptions options;
      (void)pneumatic::ReadControllerConfig(config, "fuzz.json", &options);
      break;
    }
    case 1:
      ParseKeyValues(text, pneumatic::ParseKarpenkoPidConfig, "ParseKarpenkoPidConfig");
      break;
    case 2:
      ParseKeyValues(text, pneumatic::ParseLaibSmcConfig, "ParseLaibSmcConfig");
      break;
    case 3:
      ParseKeyValues(text, pneumatic::ParseSlidingModeConfig, "ParseSlidingModeConfig");
      break;
    case 4: {
      pneumatic::PositionStiffnessParams params;
      (void)pneumatic::ParsePositionStiffnessConfig(text, &params);
      break;
    }
  }
  return 0;
}
