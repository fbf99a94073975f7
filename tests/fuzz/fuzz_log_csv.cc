// libFuzzer target: the CSV log reader. The input is a log file's bytes; ParseLog must return a log
// or an error naming file, line and column, and a log it returns must pass the in-memory checks.
// Any crash, leak, undefined behaviour or hang is a finding.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

#include "formats/log_csv.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  for (bool uniform : {false, true}) {
    std::istringstream in(bytes);
    pneumatic::log::ReadOptions options;
    options.uniform_time = uniform;
    if (uniform) options.cylinders = {"cyl"};
    pneumatic::log::ReadResult result = pneumatic::log::ParseLog(in, "fuzz.csv", options);
    if (result.log) {
      if (std::string problem = pneumatic::log::ValidateLog(*result.log, uniform); !problem.empty()) {
        std::fprintf(stderr, "the reader returned a log its own check refuses: %s\n", problem.c_str());
        std::abort();
      }
    } else if (result.error.rfind("fuzz.csv:", 0) != 0) {
      std::fprintf(stderr, "an error that does not name the file: %s\n", result.error.c_str());
      std::abort();
    }
  }
  return 0;
}
