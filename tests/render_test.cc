// Golden-image tests of the off-screen renderer (pneumo/rendering/render.h, pneumo/rendering/frames.h).
//
// Fixed states of the three rigs and of the humanoid (models_mjcf/humanoid_pneumatic.xml, when it
// exists) are rendered at 320 x 240 and compared with tests/golden/<name>.png by CompareImages:
// a pixel matches if a pixel of the other image within 1 px is within 32/255 on every channel,
// and the comparison fails when more than kMaxDifferingFraction of the pixels do not match. That
// survives anti-aliasing and an edge one pixel over (another Mesa version), and the tests below
// show that it does not survive a moved joint or a chamber coloured for the other side.
//
// After a deliberate change of the pictures (a model, the colours, the camera, MuJoCo or Mesa),
// regenerate the goldens, look at them, and commit them:
//
//   PNEUMATIC_UPDATE_GOLDENS=1 ctest --test-dir build -R Render
//
// (every test of this file starts with "Render"; or run build/bin/render_test with that variable
// set). While updating, the tests that must fail the comparison are skipped. A failing comparison writes the picture
// it got as <name>.actual.png in the test's working directory (build/tests) and prints this command.
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "formats/log_csv.h"
#include "pneumatic/pneumatic.h"
#include "rendering/frames.h"
#include "rendering/render.h"

namespace pneumatic {
namespace {

constexpr int kWidth = 320, kHeight = 240;
constexpr double kMaxDifferingFraction = 0.0002;  // 0.02 % of the pixel comparisons (31 at 320 x 240)
const char kRegenerate[] = "PNEUMATIC_UPDATE_GOLDENS=1 ctest --test-dir build -R Render";

bool UpdatingGoldens() {
  const char* v = std::getenv("PNEUMATIC_UPDATE_GOLDENS");
  return v && *v && std::string(v) != "0";
}

std::string ModelPath(const std::string& name) { return std::string(PNEUMATIC_MODELS_DIR) + "/" + name; }
std::string GoldenPath(const std::string& name) { return std::string(PNEUMATIC_GOLDEN_DIR) + "/" + name + ".png"; }

// a model loaded from models_mjcf/, attached, with its data
struct Scene {
  mjModel* m = nullptr;
  mjData* d = nullptr;
  std::vector<CylinderInfo> cylinders;
  ~Scene() {
    if (d) mj_deleteData(d);
    if (m) mj_deleteModel(m);
  }
  bool Load(const std::string& file, std::string* error) {
    char buffer[1000] = "";
    m = mj_loadXML(ModelPath(file).c_str(), nullptr, buffer, sizeof(buffer));
    if (!m) {
      *error = buffer;
      return false;
    }
    if (!Attach(m, error)) return false;
    d = mj_makeData(m);
    cylinders = Cylinders(m);
    return true;
  }
  const CylinderInfo& Cylinder(const std::string& name) const {
    for (const CylinderInfo& c : cylinders) {
      if (c.name == name) return c;
    }
    ADD_FAILURE() << "no cylinder " << name;
    return cylinders.front();
  }
  void SetPressures(const std::string& cylinder, double p_P, double p_N) {
    const CylinderInfo& c = Cylinder(cylinder);
    SetChamberPressure(m, d, c, Chamber::kP, p_P);
    SetChamberPressure(m, d, c, Chamber::kN, p_N);
  }
  // a hinge in degrees, a slide in metres
  void SetJoint(const std::string& joint, double value) {
    int id = mj_name2id(m, mjOBJ_JOINT, joint.c_str());
    ASSERT_GE(id, 0) << joint;
    d->qpos[m->jnt_qposadr[id]] = m->jnt_type[id] == mjJNT_HINGE ? value * mjPI / 180 : value;
  }
  // the golden's view: the free camera turned to (azimuth, elevation) and moved to `zoom` times
  // its distance
  double azimuth = 90, elevation = -45, zoom = 1;
  std::string lookat_body;  // "" = the model's centre
  std::vector<unsigned char> Render() {
    mj_forward(m, d);
    std::string error;
    auto renderer = OffscreenRenderer::Create(m, kWidth, kHeight, &error);
    EXPECT_TRUE(renderer) << error;
    std::vector<unsigned char> rgb;
    if (!renderer) return rgb;
    mjvCamera camera = renderer->FreeCamera();
    camera.azimuth = azimuth;
    camera.elevation = elevation;
    camera.distance *= zoom;
    if (!lookat_body.empty()) {
      int body = mj_name2id(m, mjOBJ_BODY, lookat_body.c_str());
      EXPECT_GE(body, 0) << lookat_body;
      if (body >= 0) mju_copy3(camera.lookat, d->xpos + 3 * body);
    }
    EXPECT_EQ(renderer->Render(d, camera, &rgb), "");
    return rgb;
  }
};

// the fixed states of the goldens; `variant` changes one thing: "moved" a joint, "swapped" the
// pressures of one cylinder's chambers
bool MakeState(const std::string& name, const std::string& variant, Scene* s, std::string* error) {
  // the rigs from the side and close; the humanoid from the front left
  s->azimuth = 90, s->elevation = -20, s->zoom = 0.45;
  if (name == "rig_onoff") {
    if (!s->Load("rig_onoff.xml", error)) return false;
    s->SetJoint("x", variant == "moved" ? 0.03 : 0.02);                     // 2 cm towards N
    if (variant == "swapped") s->SetPressures("cyl", 1.0e5, 3.0e5);
    else s->SetPressures("cyl", 3.0e5, 1.0e5);                              // P at supply: red
  } else if (name == "rig_proportional") {
    if (!s->Load("rig_proportional.xml", error)) return false;
    s->SetJoint("x", variant == "moved" ? 0.0 : -0.1);
    if (variant == "swapped") s->SetPressures("cyl", 2.0e5, 4.0e5);
    else s->SetPressures("cyl", 4.0e5, 2.0e5);                              // P pushes, half: light red
  } else if (name == "rig_per_chamber") {
    if (!s->Load("rig_per_chamber.xml", error)) return false;
    s->SetJoint("x", variant == "moved" ? 0.02 : -0.02);
    if (variant == "swapped") s->SetPressures("cyl", 1.5e5, 5.5e5);
    else s->SetPressures("cyl", 5.5e5, 1.5e5);                              // P pushes: red
  } else if (name == "humanoid") {
    if (!s->Load("humanoid_pneumatic.xml", error)) return false;
    s->azimuth = 150, s->elevation = -15, s->zoom = 0.8;
    s->lookat_body = "l_shoulder_pitch", s->zoom = 0.35;  // the left arm, close
    // a raised left arm, a bent right knee, the head turned
    s->SetJoint("l_shoulder_pitch", -60);
    s->SetJoint("l_elbow", variant == "moved" ? 10 : 45);
    s->SetJoint("r_hip_pitch", -30);
    s->SetJoint("r_knee", 60);
    s->SetJoint("neck_yaw", 30);
    for (const CylinderInfo& c : s->cylinders) s->SetPressures(c.name, 3.6e5, 3.6e5);  // all balanced: grey
    s->SetPressures("l_elbow", 6.2e5, 1.0e5);
    s->SetPressures("r_knee", 1.0e5, 6.2e5);
    s->SetPressures("r_hip_pitch", 5.0e5, 2.0e5);
    if (variant == "swapped") s->SetPressures("l_elbow", 1.0e5, 6.2e5);
  } else {
    *error = "unknown state " + name;
    return false;
  }
  return true;
}

bool HumanoidPresent() { return std::filesystem::exists(ModelPath("humanoid_pneumatic.xml")); }

std::vector<unsigned char> RenderState(const std::string& name, const std::string& variant) {
  Scene s;
  std::string error;
  if (!MakeState(name, variant, &s, &error)) {
    ADD_FAILURE() << name << ": " << error;
    return {};
  }
  return s.Render();
}

ImageDifference CompareWithGolden(const std::string& name, const std::vector<unsigned char>& rgb) {
  int w = 0, h = 0;
  std::vector<unsigned char> golden;
  std::string problem = ReadPng(GoldenPath(name), &w, &h, &golden);
  EXPECT_EQ(problem, "") << "regenerate the goldens with: " << kRegenerate;
  EXPECT_EQ(w, kWidth);
  EXPECT_EQ(h, kHeight);
  return CompareImages(kWidth, kHeight, golden, rgb);
}

class GoldenTest : public ::testing::TestWithParam<std::string> {};

TEST_P(GoldenTest, MatchesGolden) {
  const std::string name = GetParam();
  if (name == "humanoid" && !HumanoidPresent()) GTEST_SKIP() << "models_mjcf/humanoid_pneumatic.xml not present";
  std::vector<unsigned char> rgb = RenderState(name, "");
  ASSERT_EQ(rgb.size(), static_cast<size_t>(kWidth * kHeight * 3));
  if (UpdatingGoldens()) {
    ASSERT_EQ(WritePng(GoldenPath(name), kWidth, kHeight, rgb), "");
    std::printf("wrote %s\n", GoldenPath(name).c_str());
    return;
  }
  ImageDifference diff = CompareWithGolden(name, rgb);
  std::printf("%s: %s\n", name.c_str(), DescribeDifference(diff).c_str());
  if (!diff.same_size || diff.differing_fraction > kMaxDifferingFraction) {
    std::string actual = name + ".actual.png";
    WritePng(actual, kWidth, kHeight, rgb);
    ADD_FAILURE() << name << " does not match " << GoldenPath(name) << ": " << DescribeDifference(diff)
                  << " (at most " << 100 * kMaxDifferingFraction << " % may differ). The picture rendered is "
                  << std::filesystem::absolute(actual).string()
                  << ". If the change is intended, regenerate the goldens with:\n  " << kRegenerate;
  }
}

INSTANTIATE_TEST_SUITE_P(Render, GoldenTest,
                         ::testing::Values("rig_onoff", "rig_proportional", "rig_per_chamber", "humanoid"));

// the comparison must catch what the goldens are there for: a moved joint and a chamber drawn
// for the other side each fail it
class DetectsChange : public ::testing::TestWithParam<std::tuple<std::string, std::string>> {};

TEST_P(DetectsChange, FailsTheComparison) {
  const auto& [name, variant] = GetParam();
  if (name == "humanoid" && !HumanoidPresent()) GTEST_SKIP() << "models_mjcf/humanoid_pneumatic.xml not present";
  if (UpdatingGoldens()) GTEST_SKIP() << "updating the goldens";
  std::vector<unsigned char> rgb = RenderState(name, variant);
  ImageDifference diff = CompareWithGolden(name, rgb);
  std::printf("%s, %s: %s\n", name.c_str(), variant.c_str(), DescribeDifference(diff).c_str());
  EXPECT_TRUE(diff.same_size);
  // well beyond the tolerance, not just over it
  EXPECT_GT(diff.differing_fraction, 2 * kMaxDifferingFraction) << DescribeDifference(diff);
}

INSTANTIATE_TEST_SUITE_P(Render, DetectsChange,
                         ::testing::Combine(::testing::Values("rig_onoff", "rig_proportional", "rig_per_chamber", "humanoid"),
                                            ::testing::Values("moved", "swapped")));

TEST(Render, SameStateRendersIdenticallyTwice) {
  Scene s;
  std::string error;
  ASSERT_TRUE(MakeState("rig_proportional", "", &s, &error)) << error;
  mj_forward(s.m, s.d);
  auto renderer = OffscreenRenderer::Create(s.m, kWidth, kHeight, &error);
  ASSERT_TRUE(renderer) << error;
  std::vector<unsigned char> first, second, third;
  ASSERT_EQ(renderer->Render(s.d, "", &first), "");
  ASSERT_EQ(renderer->Render(s.d, "", &second), "");
  EXPECT_TRUE(first == second);
  // and a second renderer of the same model draws the same pixels
  auto other = OffscreenRenderer::Create(s.m, kWidth, kHeight, &error);
  ASSERT_TRUE(other) << error;
  ASSERT_EQ(other->Render(s.d, "", &third), "");
  EXPECT_TRUE(first == third);
}

TEST(Render, PressureColourFollowsTheBalance) {
  EXPECT_EQ(PressureColor(0), (std::array<float, 4>{0.6f, 0.6f, 0.6f, 1.0f}));
  std::array<float, 4> red = PressureColor(1), blue = PressureColor(-1);
  EXPECT_GT(red[0], 0.8f);
  EXPECT_LT(red[2], 0.2f);
  EXPECT_GT(blue[2], 0.8f);
  EXPECT_LT(blue[0], 0.2f);
  EXPECT_EQ(PressureColor(5), red);  // clamped
  Scene s;
  std::string error;
  ASSERT_TRUE(s.Load("rig_per_chamber.xml", &error)) << error;
  s.SetPressures("cyl", 6.2e5, 1.0e5);
  EXPECT_DOUBLE_EQ(PressureBalance(s.m, s.d, s.cylinders[0]), 1.0);
  s.SetPressures("cyl", 2.0e5, 4.6e5);
  EXPECT_NEAR(PressureBalance(s.m, s.d, s.cylinders[0]), -0.5, 1e-12);
}

// the model's offscreen buffer is 640 x 480: a larger picture enlarges it in the renderer's copy
TEST(Render, LargerThanTheModelsOffscreenBuffer) {
  Scene s;
  std::string error;
  ASSERT_TRUE(s.Load("rig_onoff.xml", &error)) << error;
  ASSERT_EQ(s.m->vis.global.offwidth, 640);
  mj_forward(s.m, s.d);
  auto renderer = OffscreenRenderer::Create(s.m, 800, 600, &error);
  ASSERT_TRUE(renderer) << error;
  std::vector<unsigned char> rgb;
  ASSERT_EQ(renderer->Render(s.d, "", &rgb), "");
  EXPECT_EQ(rgb.size(), 800u * 600u * 3u);
  EXPECT_EQ(s.m->vis.global.offwidth, 640);  // the caller's model is untouched
  EXPECT_FALSE(OffscreenRenderer::Create(s.m, 0, 10, &error));
  EXPECT_NE(error.find("positive"), std::string::npos) << error;
}

TEST(Render, UnknownCameraNamesTheModelsCameras) {
  Scene s;
  std::string error;
  ASSERT_TRUE(s.Load("rig_onoff.xml", &error)) << error;
  mj_forward(s.m, s.d);
  auto renderer = OffscreenRenderer::Create(s.m, 64, 48, &error);
  ASSERT_TRUE(renderer) << error;
  std::vector<unsigned char> rgb;
  std::string problem = renderer->Render(s.d, "side", &rgb);
  EXPECT_NE(problem.find("no camera 'side'"), std::string::npos) << problem;
}

// ---------------------------------------------------------------------------------------------
// PNG

TEST(RenderPng, Crc32KnownValues) {
  const std::string iend = "IEND", check = "123456789";
  EXPECT_EQ(Crc32(reinterpret_cast<const unsigned char*>(iend.data()), iend.size()), 0xAE426082u);
  EXPECT_EQ(Crc32(reinterpret_cast<const unsigned char*>(check.data()), check.size()), 0xCBF43926u);
  // continued over pieces
  uint32_t crc = Crc32(reinterpret_cast<const unsigned char*>(check.data()), 4);
  EXPECT_EQ(Crc32(reinterpret_cast<const unsigned char*>(check.data()) + 4, 5, crc), 0xCBF43926u);
}

std::vector<unsigned char> TestImage(int w, int h, unsigned seed) {
  std::mt19937 random(seed);
  std::vector<unsigned char> rgb(static_cast<size_t>(w) * h * 3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      unsigned char* p = rgb.data() + (static_cast<size_t>(y) * w + x) * 3;
      // smooth gradients (every filter gets used) with noise in one corner
      p[0] = static_cast<unsigned char>(x * 255 / w);
      p[1] = static_cast<unsigned char>(y * 255 / h);
      p[2] = static_cast<unsigned char>(x < w / 4 && y < h / 4 ? random() & 0xff : (x + y) & 0xff);
    }
  }
  return rgb;
}

TEST(RenderPng, EncodeDecodeRoundTrip) {
  for (auto [w, h] : {std::pair{1, 1}, std::pair{7, 3}, std::pair{320, 240}}) {
    std::vector<unsigned char> rgb = TestImage(w, h, 1), back;
    std::string png;
    ASSERT_EQ(EncodePng(w, h, rgb, &png), "");
    // signature, IHDR first, IEND with its fixed CRC last
    EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
    EXPECT_EQ(png.substr(12, 4), "IHDR");
    EXPECT_EQ(png.substr(png.size() - 12), std::string("\0\0\0\0IEND\xAE\x42\x60\x82", 12));
    int w2 = 0, h2 = 0;
    ASSERT_EQ(DecodePng(png, &w2, &h2, &back), "");
    EXPECT_EQ(w2, w);
    EXPECT_EQ(h2, h);
    EXPECT_TRUE(back == rgb) << w << " x " << h;
  }
}

TEST(RenderPng, WriteReadFileRoundTripAndCorruption) {
  const std::string path = ::testing::TempDir() + "/render_test_roundtrip.png";
  std::vector<unsigned char> rgb = TestImage(64, 48, 2), back;
  ASSERT_EQ(WritePng(path, 64, 48, rgb), "");
  int w = 0, h = 0;
  ASSERT_EQ(ReadPng(path, &w, &h, &back), "");
  EXPECT_EQ(w, 64);
  EXPECT_EQ(h, 48);
  EXPECT_TRUE(back == rgb);
  // one flipped bit in the image data is caught by the chunk's CRC
  std::string png;
  ASSERT_EQ(EncodePng(64, 48, rgb, &png), "");
  png[45] = static_cast<char>(png[45] ^ 0x10);
  std::string problem = DecodePng(png, &w, &h, &back);
  EXPECT_NE(problem.find("CRC mismatch in chunk 'IDAT'"), std::string::npos) << problem;
  EXPECT_NE(DecodePng("GIF89a", &w, &h, &back).find("not a PNG"), std::string::npos);
  EXPECT_NE(ReadPng(path + ".missing", &w, &h, &back).find("cannot open"), std::string::npos);
  EXPECT_NE(EncodePng(2, 2, std::vector<unsigned char>(5), &png), "");
  // an output that is a device is written in place (output_file.h), never replaced
  EXPECT_EQ(WritePng("/dev/null", 64, 48, rgb), "");
  std::filesystem::remove(path);
}

// ---------------------------------------------------------------------------------------------
// comparison

TEST(RenderCompareImages, ToleratesOnePixelShiftsAndSmallShadingButNotMore) {
  const int w = 40, h = 30;
  std::vector<unsigned char> a(w * h * 3, 200);
  auto square = [&](std::vector<unsigned char>* image, int x0, int y0, unsigned char r, unsigned char g, unsigned char b) {
    for (int y = y0; y < y0 + 10; ++y) {
      for (int x = x0; x < x0 + 10; ++x) {
        unsigned char* p = image->data() + (y * w + x) * 3;
        p[0] = r, p[1] = g, p[2] = b;
      }
    }
  };
  std::vector<unsigned char> b = a, c = a, d = a, e = a;
  square(&a, 10, 10, 200, 30, 30);
  square(&b, 11, 9, 210, 40, 20);   // one pixel over, slightly other shade: equal
  square(&c, 13, 10, 200, 30, 30);  // three pixels over: differs
  square(&d, 10, 10, 30, 60, 220);  // recoloured: differs
  ImageDifference ab = CompareImages(w, h, a, b), ac = CompareImages(w, h, a, c), ad = CompareImages(w, h, a, d);
  EXPECT_TRUE(ab.same_size);
  EXPECT_EQ(ab.differing, 0u) << DescribeDifference(ab);
  EXPECT_LE(ab.max_difference, 32);
  EXPECT_GE(ac.differing, 2u * 2u * 10u) << DescribeDifference(ac);  // at least two columns of 10 each way
  EXPECT_EQ(ad.differing, 2u * 100u) << DescribeDifference(ad);
  EXPECT_EQ(ad.max_difference, 190);
  EXPECT_DOUBLE_EQ(ad.differing_fraction, 200.0 / (2 * w * h));
  EXPECT_FALSE(CompareImages(w, h, a, std::vector<unsigned char>(3)).same_size);
}

// ---------------------------------------------------------------------------------------------
// the command and the frame writer

TEST(RenderCommand, SetsTheHumanoidsPoseFromTheCylindersInItsLog) {
  // a pose of the humanoid (every joint at a fixed fraction of its range, moving) as a log row of each
  // cylinder's p_P, p_N, x and v: its vanes' angles come back through their joints, and the 28 linear
  // cylinders' (mount=hinge_sites) by solving each hinge for the sites' distance x + x_mid
  Scene s;
  std::string error;
  ASSERT_TRUE(s.Load("humanoid_pneumatic.xml", &error)) << error;
  const mjModel* m = s.m;
  for (int j = 0; j < m->njnt; ++j) {
    const double lo = m->jnt_range[2 * j], hi = m->jnt_range[2 * j + 1], f = 0.1 + 0.8 * ((j * 7) % 11) / 10.0;
    s.d->qpos[m->jnt_qposadr[j]] = lo + f * (hi - lo);
    s.d->qvel[m->jnt_dofadr[j]] = 0.3 * (j % 5 - 2);
  }
  mj_forward(m, s.d);
  const std::vector<double> pose(s.d->qpos, s.d->qpos + m->nq), rates(s.d->qvel, s.d->qvel + m->nv);
  log::Log log;
  log.time = {0.25};
  int linear = 0;
  for (const CylinderInfo& c : s.cylinders) {
    linear += c.rod_site >= 0;
    const double row[4] = {ChamberPressure(m, s.d, c, Chamber::kP) + 1e5, ChamberPressure(m, s.d, c, Chamber::kN),
                           PistonPosition(m, s.d, c), PistonVelocity(m, s.d, c)};
    const char* signal[4] = {"p_P", "p_N", "x", "v"};
    for (int k = 0; k < 4; ++k) log.columns.push_back({c.name, signal[k]}), log.values.push_back({row[k]});
  }
  EXPECT_EQ(linear, 28);
  mj_resetData(m, s.d);
  ASSERT_EQ(SetStateFromLog(m, s.d, log, std::nullopt), "");
  for (int i = 0; i < m->nq; ++i) EXPECT_NEAR(s.d->qpos[i], pose[i], 1e-12) << "qpos " << i;
  for (int i = 0; i < m->nv; ++i) EXPECT_NEAR(s.d->qvel[i], rates[i], 1e-12) << "qvel " << i;
  // and an x no hinge angle reaches (a linear cylinder 1 m longer) is refused, naming the cylinder and the hinge
  size_t first_linear = 0;
  while (s.cylinders[first_linear].rod_site < 0) ++first_linear;
  log.values[4 * first_linear + 2][0] += 1.0;
  error = SetStateFromLog(m, s.d, log, std::nullopt);
  EXPECT_NE(error.find("cylinder '" + s.cylinders[first_linear].name + "'"), std::string::npos) << error;
  EXPECT_NE(error.find("no angle of hinge"), std::string::npos) << error;
}

TEST(RenderCommand, RendersALogRowAtATime) {
  const std::string dir = ::testing::TempDir();
  log::Log log;
  log.columns = {{"cyl", "p_P"}, {"cyl", "p_N"}, {"cyl", "x"}};
  log.time = {0.0, 0.5, 1.0};
  log.values = {{1e5, 3e5, 1e5}, {1e5, 1e5, 3e5}, {0.0, 0.03, -0.03}};
  const std::string log_path = dir + "/render_test_log.csv";
  ASSERT_EQ(log::WriteLog(log_path, log), "");

  // the state of the row at 0.7 s is the row at 0.5 s
  Scene s;
  std::string error;
  ASSERT_TRUE(s.Load("rig_onoff.xml", &error)) << error;
  ASSERT_EQ(SetStateFromLog(s.m, s.d, log, 0.7), "");
  EXPECT_DOUBLE_EQ(ChamberPressure(s.m, s.d, s.cylinders[0], Chamber::kP), 3e5);
  mj_forward(s.m, s.d);
  EXPECT_NEAR(PistonPosition(s.m, s.d, s.cylinders[0]), 0.03, 1e-12);
  EXPECT_DOUBLE_EQ(s.d->time, 0.5);
  EXPECT_NE(SetStateFromLog(s.m, s.d, log, 2.5).find("outside the log"), std::string::npos);

  RenderOptions options;
  options.model_path = ModelPath("rig_onoff.xml");
  options.out_path = dir + "/render_test_frame.png";
  options.log_path = log_path;
  options.time = 0.7;
  options.width = 160;
  options.height = 120;
  ASSERT_EQ(RenderToFile(options), "");
  int w = 0, h = 0;
  std::vector<unsigned char> rgb;
  ASSERT_EQ(ReadPng(options.out_path, &w, &h, &rgb), "");
  EXPECT_EQ(w, 160);
  EXPECT_EQ(h, 120);
  // the same through the renderer directly
  std::vector<unsigned char> direct;
  auto renderer = OffscreenRenderer::Create(s.m, 160, 120, &error);
  ASSERT_TRUE(renderer) << error;
  ASSERT_EQ(renderer->Render(s.d, "", &direct), "");
  EXPECT_TRUE(rgb == direct);

  options.time = 9;
  EXPECT_NE(RenderToFile(options).find("outside the log"), std::string::npos);
  options.log_path.reset();
  EXPECT_NE(RenderToFile(options).find("needs a log"), std::string::npos);
  options.time.reset();
  options.model_path = ModelPath("missing.xml");
  EXPECT_NE(RenderToFile(options), "");
  std::filesystem::remove(log_path);
  std::filesystem::remove(dir + "/render_test_frame.png");
}

// frame options of 20 frames/s into a fresh directory
FrameOptions TwentyFramesPerSecond(const std::string& dir, int width, int height, bool mp4) {
  std::filesystem::remove_all(dir);
  FrameOptions options;
  options.dir = dir;
  options.fps = 20;
  options.width = width;
  options.height = height;
  options.mp4 = mp4;
  return options;
}

// rig B stepped for 0.2 s at its 0.1 ms step with its valve open, each step offered to `frames`: frames
// at 0, 0.05, 0.1, 0.15, 0.2 s
void OfferRigBForFifthOfASecond(Scene* s, FrameWriter* frames) {
  s->d->ctrl[mj_name2id(s->m, mjOBJ_ACTUATOR, "cyl.u")] = 3;
  mj_forward(s->m, s->d);
  while (s->d->time < 0.2 - 1e-9) {
    ASSERT_EQ(frames->Offer(s->d), "");
    mj_step(s->m, s->d);
  }
  ASSERT_EQ(frames->Offer(s->d), "");
}

TEST(RenderFrameWriter, WritesOneFramePerPeriodOfSimulatedTime) {
  const std::string dir = ::testing::TempDir() + "/render_test_frames";
  FrameOptions options = TwentyFramesPerSecond(dir, 64, 48, false);
  Scene s;
  std::string error;
  ASSERT_TRUE(s.Load("rig_proportional.xml", &error)) << error;
  auto frames = FrameWriter::Create(s.m, options, &error);
  ASSERT_TRUE(frames) << error;
  ASSERT_NO_FATAL_FAILURE(OfferRigBForFifthOfASecond(&s, frames.get()));
  EXPECT_EQ(frames->frames_written(), 5);
  for (int k = 0; k < 5; ++k) EXPECT_TRUE(std::filesystem::exists(dir + "/frame_0000" + std::to_string(k) + ".png")) << k;
  EXPECT_FALSE(std::filesystem::exists(dir + "/frame_00005.png"));
  // coarser steps than frames: the picture is repeated so the sequence keeps time
  s.d->time += 0.1;
  ASSERT_EQ(frames->Offer(s.d), "");
  EXPECT_EQ(frames->frames_written(), 7);
  EXPECT_EQ(frames->Finish(), "");
  EXPECT_EQ(frames->video_path(), "");
  options.fps = 0;
  EXPECT_FALSE(FrameWriter::Create(s.m, options, &error));
  std::filesystem::remove_all(dir);
}

// With Debian's ffmpeg on the PATH (scripts/install-deps installs it), Finish() encodes the frames
// into DIR/video.mp4: H.264 with one picture per frame, an odd size padded by a pixel to even.
TEST(RenderFrameWriter, EncodesTheFramesIntoAnMp4WithFfmpeg) {
  if (FindOnPath("ffmpeg").empty() || FindOnPath("ffprobe").empty()) GTEST_SKIP() << "ffmpeg is not installed";
  const std::string dir = ::testing::TempDir() + "/render_test_video";
  Scene s;
  std::string error;
  ASSERT_TRUE(s.Load("rig_proportional.xml", &error)) << error;
  auto frames = FrameWriter::Create(s.m, TwentyFramesPerSecond(dir, 65, 49, true), &error);
  ASSERT_TRUE(frames) << error;
  ASSERT_NO_FATAL_FAILURE(OfferRigBForFifthOfASecond(&s, frames.get()));
  ASSERT_EQ(frames->frames_written(), 5);
  ASSERT_EQ(frames->Finish(), "");
  ASSERT_EQ(frames->video_path(), dir + "/video.mp4");
  const std::string probe = "ffprobe -v error -count_frames -select_streams v:0 -show_entries "
                            "stream=codec_name,width,height,nb_read_frames -of csv=p=0 '" + dir + "/video.mp4'";
  std::FILE* pipe = ::popen(probe.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  char line[200] = "";
  const bool read = std::fgets(line, sizeof(line), pipe) != nullptr;
  ::pclose(pipe);
  ASSERT_TRUE(read) << probe;
  EXPECT_EQ(std::string(line), "h264,66,50,5\n");
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace pneumatic
