// Prints the state each shipped model reaches after a fixed command pattern (every cylinder driven by
// test_util.h's PatternCommand), one line a model: its name and an FNV-1a hash of the state's bytes
// (stderr names the chamber path taken, vector lanes or scalar). scripts/test runs it in the build
// with the vector lanes and in the one without (PNEUMATIC_VECTOR_LANES=OFF) and compares the hashes:
// the two paths must agree bit for bit.
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "chamber_batch.h"
#include "pneumatic/pneumatic.h"
#include "test_util.h"

namespace {

uint64_t Hash(const std::vector<double>& values) {
  uint64_t hash = 1469598103934665603ULL;
  const unsigned char* bytes = reinterpret_cast<const unsigned char*>(values.data());
  for (size_t i = 0; i < values.size() * sizeof(double); ++i) hash = (hash ^ bytes[i]) * 1099511628211ULL;
  return hash;
}

}  // namespace

int main() {
  const char* models[] = {"rig_onoff.xml", "rig_proportional.xml", "rig_per_chamber.xml", "rig_proportional_full.xml",
                          "humanoid_pneumatic.xml"};
  constexpr int kSteps = 4000;
  int failures = 0;
  for (const char* file : models) {
    std::string path = std::string(PNEUMATIC_MODELS_DIR) + "/" + file;
    char load_error[1000] = "";
    std::string error;
    mjModel* m = mj_loadXML(path.c_str(), nullptr, load_error, sizeof(load_error));
    if (!m || !pneumatic::Attach(m, &error)) {
      std::fprintf(stderr, "%s: %s%s\n", path.c_str(), load_error, error.c_str());
      ++failures;
      if (m) mj_deleteModel(m);
      continue;
    }
    const std::vector<pneumatic::CylinderInfo> cylinders = pneumatic::Cylinders(m);
    mjData* d = mj_makeData(m);
    for (int step = 0; step < kSteps; ++step) {
      for (const pneumatic::CylinderInfo& c : cylinders) pneumatic::testing::PatternCommand(c, d, step);
      mj_step(m, d);
    }
    std::printf("%s %016llx\n", file, static_cast<unsigned long long>(Hash(pneumatic::testing::State(m, d))));
    mj_deleteData(d);
    mj_deleteModel(m);
  }
  std::fprintf(stderr, "chamber step: %s\n", pneumatic::VectorLanesAvailable() ? "vector lanes" : "scalar");
  return failures == 0 ? 0 : 1;
}
