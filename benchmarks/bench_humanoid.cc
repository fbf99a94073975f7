// The pneumatic humanoid against its motor twin (issue 15, item 7). Prints Markdown.
//
// Stepping: models_mjcf/humanoid_pneumatic.xml (36 cylinders, 72 chambers), its identified-model
// variant and humanoid_motors.xml, each stepped from its reset state with constant commands (the
// valves at their centre plus 0.5 V, the motors at 0), reset every 2 s of simulated time; also
// humanoid_pneumatic.xml not attached (its chambers stay at p_atm and push nothing, the robot hangs
// limp as the twin with its motors at 0 does): what MuJoCo alone spends on its two actuators per
// cylinder (its linear cylinders are mount=hinge_sites: no MuJoCo tendons), the floor under the
// pneumatic model's cost whatever the extension does; and humanoid_pneumatic.xml with its linear
// cylinders on spatial tendons over the same two sites instead of mount=hinge_sites, what that mount
// saves (the same physics to round-off, tests/transmission_test). Each model runs about 1 s of wall
// time after a 0.2 s warm-up, five runs alternating the models, the median reported. The real-time
// factor is simulated time over wall time.
//
// Rollouts: `pneumo rollout --controller pid --controller-config models_mjcf/humanoid_pid.json` on
// the humanoid (pneumo/closed_loop.h; the shipped gains, as scripts/demo runs it: every tick also
// computes each cylinder's mobility for them), 2 s each, 4 runs with 1 thread, then 4 runs over 2
// threads (each on its own copy of the model).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <mujoco/mujoco.h>

#include "closed_loop.h"
#include "controller_config.h"
#include "machine.h"
#include "pneumatic/pneumatic.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Model {
  const char* name;
  const char* file;
  bool attach = true;  // false: MuJoCo's own work on the model's actuators, no pressure physics
  bool on_tendons = false;  // true: the linear cylinders on spatial tendons (OnSpatialTendons)
  mjModel* m = nullptr;
  mjData* d = nullptr;
};

// the MJCF text with every mount=hinge_sites cylinder on a spatial tendon over its two sites instead
// (mount=transmission): the same physics to round-off (tests/transmission_test), with MuJoCo's tendon work
std::string OnSpatialTendons(std::string xml) {
  const std::string key = " mount=hinge_sites";
  std::string tendons = "<tendon>\n";
  for (size_t at = xml.find(key); at != std::string::npos; at = xml.find(key)) {
    const size_t name_start = xml.rfind("pneumatic:", at) + std::strlen("pneumatic:");
    const std::string name = xml.substr(name_start, xml.find('"', name_start) - name_start);
    xml.erase(at, key.size());
    tendons += "<spatial name=\"" + name + "\"><site site=\"" + name + ".cap\"/><site site=\"" + name + ".rod\"/></spatial>\n";
    for (const char* chamber : {".P", ".N"}) {
      const std::string element = "name=\"" + name + chamber + "\" joint=\"";
      const size_t joint = xml.find(element);
      if (joint == std::string::npos) return "";
      const size_t value = joint + element.size() - std::strlen("joint=\"");
      xml.replace(value, xml.find('"', value + std::strlen("joint=\"")) + 1 - value, "tendon=\"" + name + "\"");
    }
  }
  return xml.replace(xml.find("<actuator>"), 0, tendons + "</tendon>\n");
}

mjModel* Load(const std::string& file, bool attach, bool on_tendons = false) {
  char error[1000] = "";
  const std::string path = std::string(PNEUMATIC_MODELS_DIR) + "/" + file;
  mjModel* m = nullptr;
  if (on_tendons) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    const std::string xml = OnSpatialTendons(text.str());
    auto vfs = std::make_unique<mjVFS>();  // 2 MB of file names: not on the stack
    mj_defaultVFS(vfs.get());
    mj_makeEmptyFileVFS(vfs.get(), "model.xml", static_cast<int>(xml.size()));
    std::memcpy(vfs->filedata[0], xml.data(), xml.size());
    m = xml.empty() ? nullptr : mj_loadXML("model.xml", vfs.get(), error, sizeof(error));
    mj_deleteVFS(vfs.get());
  } else {
    m = mj_loadXML(path.c_str(), nullptr, error, sizeof(error));
  }
  std::string why;
  if (!m || (attach && !pneumatic::Attach(m, &why))) {
    std::fprintf(stderr, "%s: %s%s\n", file.c_str(), error, why.c_str());
    std::exit(1);
  }
  return m;
}

void Reset(const mjModel* m, mjData* d) {
  mj_resetData(m, d);
  for (const auto& c : pneumatic::Cylinders(m)) {
    for (const auto& [signal, id] : c.command_actuators) d->ctrl[id] = 5.5;
  }
}

// microseconds per mj_step over about `seconds` of wall time
double MicrosecondsPerStep(const Model& model, double seconds) {
  const long reset_steps = std::lround(2.0 / model.m->opt.timestep);
  long steps = 0;
  const auto start = Clock::now();
  double elapsed = 0;
  while (elapsed < seconds) {
    for (int i = 0; i < 100; ++i, ++steps) {
      if (steps % reset_steps == 0) Reset(model.m, model.d);
      mj_step(model.m, model.d);
    }
    elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  }
  return 1e6 * elapsed / static_cast<double>(steps);
}

// rollouts per second of 2 s closed-loop runs: `runs` runs over `threads` threads
double RolloutsPerSecond(const mjModel* m, int runs, int threads) {
  pneumatic::ClosedLoopOptions options;
  const std::string gains = std::string(PNEUMATIC_MODELS_DIR) + "/humanoid_pid.json";
  if (std::string error = pneumatic::ReadControllerConfig(gains, &options); !error.empty()) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return 0;
  }
  options.duration = 2;
  const auto start = Clock::now();
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&, t]() {
      std::unique_ptr<mjModel, void (*)(mjModel*)> copy(mj_copyModel(nullptr, m), mj_deleteModel);
      for (int r = t; r < runs; r += threads) {
        pneumatic::ClosedLoopResult result = pneumatic::RunClosedLoop(copy.get(), options);
        if (!result.log) std::fprintf(stderr, "rollout failed: %s\n", result.error.c_str());
      }
    });
  }
  for (std::thread& w : workers) w.join();
  return runs / std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

int main() {
  // the twin last: the ratios are to it
  std::vector<Model> models = {
      {"humanoid_pneumatic", "humanoid_pneumatic.xml"},
      {"humanoid_pneumatic_identified", "humanoid_pneumatic_identified.xml"},
      {"humanoid_pneumatic, not attached (MuJoCo alone: its actuators, no pressure physics)",
       "humanoid_pneumatic.xml", false},
      {"humanoid_pneumatic on 28 spatial tendons over the same sites (mount=transmission)", "humanoid_pneumatic.xml",
       true, true},
      {"humanoid_motors", "humanoid_motors.xml"}};
  for (Model& model : models) {
    model.m = Load(model.file, model.attach, model.on_tendons);
    model.d = mj_makeData(model.m);
  }
  std::vector<std::vector<double>> us(models.size());
  for (Model& model : models) MicrosecondsPerStep(model, 0.2);  // warm-up
  for (int run = 0; run < 5; ++run) {
    for (size_t i = 0; i < models.size(); ++i) us[i].push_back(MicrosecondsPerStep(models[i], 1.0));
    std::fprintf(stderr, "stepping: run %d of 5\n", run + 1);
  }
  std::printf("### The pneumatic humanoid against its motor twin\n\n");
  pneumatic::benchmarks::PrintMachine(PNEUMATIC_BUILD_TYPE);
  std::printf("\n| model | actuators | us per step | steps/s | real-time factor | vs motors |\n|---|---:|---:|---:|---:|---:|\n");
  std::vector<double> median(models.size());
  for (size_t i = 0; i < models.size(); ++i) {
    std::sort(us[i].begin(), us[i].end());
    median[i] = us[i][2];
  }
  for (size_t i = 0; i < models.size(); ++i) {
    std::printf("| %s | %d | %.2f | %.0f | %.1f | %.2f |\n", models[i].name, models[i].m->nu, median[i], 1e6 / median[i],
                1e6 * models[i].m->opt.timestep / median[i], median[i] / median.back());
  }
  std::printf("\nPneumatic over motors: +%.0f %% (the issue's target: at most +10 %%); %.3f us per chamber step.\n",
              100 * (median[0] / median.back() - 1), (median[0] - median.back()) / 72);

  std::printf("\n### Closed-loop rollouts of the humanoid (PID with humanoid_pid.json, 2 s each)\n\n| threads | rollouts/s |\n|---:|---:|\n");
  const double one = RolloutsPerSecond(models[0].m, 4, 1), two = RolloutsPerSecond(models[0].m, 4, 2);
  std::printf("| 1 | %.2f |\n| 2 | %.2f (%.2fx) |\n", one, two, two / one);
  for (Model& model : models) {
    mj_deleteData(model.d);
    if (model.attach) pneumatic::Detach(model.m);
    mj_deleteModel(model.m);
  }
  return 0;
}
