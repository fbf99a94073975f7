// libFuzzer target: the JSON files that set a model's values by key. An input whose first character
// is '[' is a variations file (`pneumo rollout --variations`: ParseJson, then ReadVariations of
// simulation/model_edits.h), any other a study's plan (`pneumo study PLAN.json`, studies/plan.h).
// Each must be accepted or refused with an error naming the file; a plan accepted must make at most
// kMaxPoints points, each random value inside its range. Any crash, uncaught exception, leak,
// undefined behaviour or hang is a finding.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "simulation/controller_config.h"
#include "simulation/model_edits.h"
#include "studies/plan.h"

namespace {

void Finding(const std::string& what) {
  std::fprintf(stderr, "%s\n", what.c_str());
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace pneumatic::study;
  const std::string text(reinterpret_cast<const char*>(data), size);
  if (!text.empty() && text[0] == '[') {
    nlohmann::json list;
    std::vector<pneumatic::Variation> variations;
    std::string error = pneumatic::ParseJson(text, "fuzz/variations.json", &list);
    if (error.empty()) error = pneumatic::ReadVariations(list, "fuzz/variations.json", &variations);
    if (error.rfind("fuzz/variations.json", 0) != 0 && !error.empty()) Finding("an error that does not name the file: " + error);
    if (error.empty() && variations.empty()) Finding("an accepted variations file without a variation");
    return 0;
  }
  Plan plan;
  const std::string error = ParsePlan(text, "fuzz/plan.json", &plan);
  if (!error.empty()) {
    if (error.rfind("fuzz/plan.json", 0) != 0) Finding("an error that does not name the file: " + error);
    return 0;
  }
  const std::size_t count = CountPoints(plan);
  if (count == 0 || count > kMaxPoints) Finding("an accepted plan makes " + std::to_string(count) + " points");
  if (count > 1000) return 0;  // expanding a large plan is right but slow; its count is checked above
  const std::vector<Point> points = ExpandPoints(plan);
  if (points.size() != count) Finding("ExpandPoints made another number of points than CountPoints");
  const std::size_t keys = ParameterKeys(plan).size();
  for (const Point& p : points) {
    if (p.log == nullptr && p.values.size() != keys) Finding("a point without a value for every key");
    for (std::size_t j = 0; j < plan.random.size() && p.log == nullptr; ++j) {
      const RandomParameter& r = plan.random[j];
      const double v = p.values[plan.grid.size() + j].second;
      if (!(v >= r.low && v <= r.high)) Finding("a random draw of " + r.key + " outside its range");
    }
  }
  return 0;
}
