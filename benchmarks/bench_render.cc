// Off-screen rendering speed (OSMesa, llvmpipe) at 640 x 480: frames per second of
// OffscreenRenderer::Render (mjv_updateScene, the pressure colours, mjr_render, mjr_readPixels and
// the row flip) for each shipped rig and the humanoid (models_mjcf/humanoid_pneumatic.xml, if it
// exists), under several rendering settings, and the cost of encoding one frame as PNG.
// Each setting draws for about `seconds` of wall time (argument 1, default 1) three times,
// interleaved, and the median is printed. The state is the model's reset state after one
// mj_forward, with the chambers of every cylinder at supply (P) and exhaust (N).
//
//   build/bin/bench_render [seconds]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "machine.h"
#include "pneumatic/pneumatic.h"
#include "rendering/render.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Setting {
  const char* name;
  pneumatic::RenderQuality quality;
};

double FramesPerSecond(pneumatic::OffscreenRenderer* renderer, const mjData* d, double seconds) {
  std::vector<unsigned char> rgb;
  renderer->Render(d, "", &rgb);  // warm-up: shaders, textures, shadow map
  int frames = 0;
  auto start = Clock::now();
  double elapsed = 0;
  while (elapsed < seconds || frames < 3) {
    renderer->Render(d, "", &rgb);
    ++frames;
    elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  }
  return frames / elapsed;
}

// the picture settings compared, from MuJoCo's stock one to the cheapest
std::vector<Setting> Settings() {
  pneumatic::RenderQuality fast;  // the renderer's defaults
  pneumatic::RenderQuality no_shadows = fast;
  no_shadows.shadows = false;
  pneumatic::RenderQuality msaa = fast;
  msaa.samples = 4;
  return {
      {"stock MuJoCo 2.2.2 (4x MSAA, shadows 4096, reflections, skybox)", pneumatic::RenderQuality::Stock()},
      {"4x MSAA, shadows 1024, no reflections, no skybox", msaa},
      {"default: no MSAA, shadows 1024, no reflections, no skybox", fast},
      {"no MSAA, no shadows, no reflections, no skybox", no_shadows},
  };
}

// models_mjcf/NAME attached, and its data with every P chamber at supply and every N chamber at
// exhaust; false after printing why
bool LoadPressurised(const std::string& name, mjModel** m, mjData** d) {
  std::string path = std::string(PNEUMATIC_MODELS_DIR) + "/" + name;
  char load_error[1000] = "";
  *m = mj_loadXML(path.c_str(), nullptr, load_error, sizeof(load_error));
  if (!*m) {
    std::fprintf(stderr, "%s: %s\n", path.c_str(), load_error);
    return false;
  }
  std::string error;
  if (!pneumatic::Attach(*m, &error)) {
    std::fprintf(stderr, "%s: %s\n", path.c_str(), error.c_str());
    return false;
  }
  *d = mj_makeData(*m);
  for (const pneumatic::CylinderInfo& c : pneumatic::Cylinders(*m)) {
    if (c.chamber_actuator[0] >= 0) pneumatic::SetChamberPressure(*m, *d, c, pneumatic::Chamber::kP, c.p_supply);
    if (c.chamber_actuator[1] >= 0) pneumatic::SetChamberPressure(*m, *d, c, pneumatic::Chamber::kN, c.p_exhaust);
  }
  mj_forward(*m, *d);
  return true;
}

// milliseconds per PNG encoding of the renderer's picture of d; *bytes, the PNG's size
double EncodeMs(pneumatic::OffscreenRenderer* renderer, const mjData* d, int width, int height, size_t* bytes) {
  std::vector<unsigned char> rgb;
  renderer->Render(d, "", &rgb);
  std::string png;
  auto start = Clock::now();
  int encodes = 0;
  while (std::chrono::duration<double>(Clock::now() - start).count() < 0.5 || encodes < 3) {
    pneumatic::EncodePng(width, height, rgb, &png);
    ++encodes;
  }
  *bytes = png.size();
  return 1e3 * std::chrono::duration<double>(Clock::now() - start).count() / encodes;
}

// the table's row of one model: frames/s under every setting (median of 3), and the PNG encoding;
// false after printing why
bool BenchModel(const std::string& name, const std::vector<Setting>& settings, int width, int height, double seconds) {
  mjModel* m = nullptr;
  mjData* d = nullptr;
  if (!LoadPressurised(name, &m, &d)) return false;
  std::string error;
  std::vector<std::unique_ptr<pneumatic::OffscreenRenderer>> renderers;
  for (const Setting& s : settings) {
    renderers.push_back(pneumatic::OffscreenRenderer::Create(m, width, height, &error, s.quality));
    if (!renderers.back()) {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), error.c_str());
      return false;
    }
  }
  std::vector<std::vector<double>> runs(settings.size());
  for (int run = 0; run < 3; ++run) {
    for (size_t i = 0; i < settings.size(); ++i) {
      std::fprintf(stderr, "%s, %s, run %d\n", name.c_str(), settings[i].name, run + 1);
      runs[i].push_back(FramesPerSecond(renderers[i].get(), d, seconds));
    }
  }
  // one PNG encoding of the default picture
  size_t png_bytes = 0;
  const double encode_ms = EncodeMs(renderers[2].get(), d, width, height, &png_bytes);

  std::printf("| %s |", name.c_str());
  for (auto& r : runs) {
    std::sort(r.begin(), r.end());
    std::printf(" %.1f |", r[1]);
  }
  std::printf(" %.1f (%zu kB) |\n", encode_ms, png_bytes / 1024);
  std::fflush(stdout);
  renderers.clear();
  mj_deleteData(d);
  mj_deleteModel(m);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = argc > 1 ? std::atof(argv[1]) : 1.0;
  if (!(seconds > 0)) seconds = 1.0;
  pneumatic::benchmarks::PrintMachine(PNEUMATIC_BUILD_TYPE);
  const int width = 640, height = 480;
  const std::vector<Setting> settings = Settings();

  std::vector<std::string> models = {"rig_onoff.xml", "rig_proportional.xml", "rig_per_chamber.xml"};
  if (std::filesystem::exists(std::string(PNEUMATIC_MODELS_DIR) + "/humanoid_pneumatic.xml")) {
    models.push_back("humanoid_pneumatic.xml");
  } else {
    std::printf("(models_mjcf/humanoid_pneumatic.xml not found: humanoid skipped)\n\n");
  }

  std::printf("### Off-screen rendering, %d x %d, frames/s (median of 3)\n\n", width, height);
  std::printf("| model |");
  for (const Setting& s : settings) std::printf(" %s |", s.name);
  std::printf(" PNG encode, ms |\n|---|");
  for (size_t i = 0; i < settings.size(); ++i) std::printf("---:|");
  std::printf("---:|\n");
  for (const std::string& name : models) {
    if (!BenchModel(name, settings, width, height, seconds)) return 1;
  }
  return 0;
}
