// Off-screen rendering of a model with pneumatic cylinders (OSMesa: no display, no GLFW), the
// PNG files it writes and reads, and the image comparison of the golden-image tests.
//
// Chamber pressure is drawn in colour: every cylinder gets one colour on a diverging map of
// b = (p_P - p_N) / (p_supply - p_exhaust), clamped to [-1, 1]: grey when balanced, red as P
// pushes (b -> +1), blue as N pushes (b -> -1), PressureColor(). What carries the colour:
//  - a cylinder on a tendon (a linear cylinder between two sites): the tendon, drawn with the
//    bore radius sqrt(A_P / pi) instead of its width, so it looks like the cylinder's body;
//  - a cylinder with mount=hinge_sites: a capsule of the bore radius between its two sites;
//  - a cylinder on a slide joint: a cylinder of the bore radius along the joint axis, one stroke
//    long, centred where the joint's anchor is at mid-stroke (the chamber space the piston
//    travels in; the model's own piston geoms move through it);
//  - a rotary cylinder on a hinge: a disc around the hinge axis at the joint's anchor, the size
//    of a vane housing of the cylinder's displacement (radius cbrt(area / 0.44));
//  - a slider-crank: a capsule of the bore radius from the slider site to the crank site.
// Cylinders on other transmissions (site, ball or free joints) are not coloured.
#ifndef PNEUMATIC_RENDER_H_
#define PNEUMATIC_RENDER_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "pneumatic/pneumatic.h"

namespace pneumatic {

// ---------------------------------------------------------------------------------------------
// PNG files: 8-bit RGB, non-interlaced (zlib deflate). The reader also takes 8-bit RGBA and
// greyscale (alpha dropped, grey expanded) and every row filter, and checks every chunk's CRC.

// CRC-32 of the PNG specification (ISO 3309, polynomial 0xEDB88320), continued from `crc`:
// Crc32("IEND") = 0xAE426082, the last four bytes of every PNG file.
std::uint32_t Crc32(const unsigned char* data, std::size_t size, std::uint32_t crc = 0);

// The PNG file of an image: rgb holds height rows of width RGB triples, top row first.
// "" or why not (a size that does not match, zlib failing).
std::string EncodePng(int width, int height, const std::vector<unsigned char>& rgb, std::string* png);

// Writes EncodePng's bytes to `path` through WriteOutput (pneumo/formats/output_file.h): a regular file is
// replaced whole or not at all, a device or FIFO is written in place, "-" is standard output.
// "" or a one-line message starting with the path.
std::string WritePng(const std::string& path, int width, int height, const std::vector<unsigned char>& rgb);

// Decodes a PNG file's bytes into an RGB image (top row first). "" or why not.
std::string DecodePng(const std::string& png, int* width, int* height, std::vector<unsigned char>* rgb);

// Reads a PNG file. "" or "PATH: why not".
std::string ReadPng(const std::string& path, int* width, int* height, std::vector<unsigned char>* rgb);

// ---------------------------------------------------------------------------------------------
// Image comparison that survives harmless rasteriser differences (anti-aliasing, an edge one
// pixel over, small shading changes between Mesa versions) but not a moved limb or a wrong
// pressure colour: a pixel of one image "matches" if some pixel of the other image within
// `shift` pixels (Chebyshev distance) is within `threshold` on each of R, G and B; it is compared
// both ways, so a thin object that appears or disappears counts as well.
struct CompareOptions {
  int threshold = 32;  // per-channel difference (0..255) that still counts as equal
  int shift = 1;       // pixels an edge may move
};

struct ImageDifference {
  bool same_size = false;        // false: nothing else was compared
  std::size_t compared = 0;      // 2 * width * height: every pixel of each image against the other
  std::size_t differing = 0;     // of those, the pixels without a match
  double differing_fraction = 0; // differing / compared
  int max_difference = 0;        // the largest per-channel distance to the best match (0..255)
  int max_difference_x = -1, max_difference_y = -1;  // where (x right, y down)
};

// a and b: RGB images of width x height (top row first, though the result does not depend on it).
ImageDifference CompareImages(int width, int height, const std::vector<unsigned char>& a,
                              const std::vector<unsigned char>& b, const CompareOptions& options = {});

// One line for a failure message: "12 of 153600 pixel comparisons fail (0.0078 %), largest
// difference 187 at (120, 88)".
std::string DescribeDifference(const ImageDifference& difference);

// ---------------------------------------------------------------------------------------------
// Pressure colour

// b = (p_P - p_N) / (p_supply - p_exhaust), clamped to [-1, 1]; 0 for a single-chamber cylinder
// without an N actuator uses p_N = p_atm. Needs d->act of the cylinder's chambers.
double PressureBalance(const mjModel* m, const mjData* d, const CylinderInfo& c);

// The diverging map: grey (0.6, 0.6, 0.6) at 0, red (0.85, 0.12, 0.1) at +1 (P pushes), blue
// (0.1, 0.3, 0.9) at -1 (N pushes), linear in between; alpha 1.
std::array<float, 4> PressureColor(double balance);

// ---------------------------------------------------------------------------------------------
// The renderer

// What the picture costs. The defaults are the fast ones measured in benchmarks/bench_render
// (README of this class): no multisampling, shadows from a 1024 px shadow map, no reflections,
// no skybox. Stock() is MuJoCo 2.2.2's own settings, for comparison.
struct RenderQuality {
  int samples = 0;           // multisamples of the offscreen buffer (vis.quality.offsamples)
  bool shadows = true;       // mjRND_SHADOW
  int shadow_size = 1024;    // shadow map texture size (vis.quality.shadowsize)
  bool reflections = false;  // mjRND_REFLECTION (floors with reflectance)
  bool skybox = false;       // mjRND_SKYBOX
  bool pressure_colors = true;  // colour the cylinders as above
  // a model without <light> has only MuJoCo's headlight (ambient 0.1, diffuse 0.4): brighten it
  // to ambient 0.4, diffuse 0.6, specular 0.2 in the renderer's copy
  bool brighten_unlit = true;
  // the colour behind the model where there is no skybox (MuJoCo: black)
  std::array<float, 3> background = {0.85f, 0.88f, 0.92f};
  static RenderQuality Stock() { return {4, true, 4096, true, true, true, false, {0, 0, 0}}; }
};

// Renders a model off screen with OSMesa (no display). One renderer draws one model at one
// size; it keeps its own copy of the model (with the quality settings and an offscreen buffer
// large enough for the size), so the model given to Create may be freed afterwards, and every
// mjData of that model (or of a model with the same structure) can be drawn. Several renderers
// may coexist; use each from one thread at a time.
class OffscreenRenderer {
 public:
  // Null and *error if the size is not positive, larger than OSMesa's maximum viewport, or the
  // OpenGL context cannot be made. The model's <visual><global offwidth offheight> (default
  // 640 x 480) is the size of MuJoCo's offscreen buffer; a larger request enlarges it in the
  // renderer's copy of the model, so any size up to the OSMesa maximum works.
  static std::unique_ptr<OffscreenRenderer> Create(const mjModel* m, int width, int height, std::string* error,
                                                   const RenderQuality& quality = {});
  ~OffscreenRenderer();
  OffscreenRenderer(const OffscreenRenderer&) = delete;
  OffscreenRenderer& operator=(const OffscreenRenderer&) = delete;

  // Draws d (positions as of its last mj_forward or mj_step: xpos, xmat, ten_wrapadr, ...; the
  // chamber pressures from d->act) from `camera`: "" is a free camera looking at the whole model
  // (mjv_defaultFreeCamera), otherwise the name of a <camera> of the model. Fills rgb with
  // height rows of width RGB triples, top row first. "" or why not (an unknown camera names the
  // model's cameras).
  std::string Render(const mjData* d, const std::string& camera, std::vector<unsigned char>* rgb);

  // The same from a camera of the caller's: free (e.g. FreeCamera() moved closer), tracking a
  // body, or fixed. "" or why not (a camera or body id out of range).
  std::string Render(const mjData* d, const mjvCamera& camera, std::vector<unsigned char>* rgb);

  // The free camera of Render(d, ""): mjv_defaultFreeCamera, looking at the model's centre from
  // its <visual><global azimuth elevation> at 1.5 times its extent.
  mjvCamera FreeCamera() const;

  int width() const { return width_; }
  int height() const { return height_; }
  const mjModel* model() const { return model_; }

 private:
  OffscreenRenderer() = default;
  void AddPressureColors(const mjData* d);

  int width_ = 0, height_ = 0;
  RenderQuality quality_;
  mjModel* model_ = nullptr;              // the renderer's copy
  std::vector<CylinderInfo> cylinders_;
  void* osmesa_ = nullptr;                // OSMesaContext
  std::vector<unsigned char> buffer_;     // OSMesa's window-system buffer (RGBA)
  std::vector<unsigned char> flipped_;    // mjr_readPixels' bottom-up rows
  std::vector<float> depth_;              // and their depth, for the background
  mjvScene scene_;
  mjrContext context_;
  mjvOption option_;
  bool scene_made_ = false, context_made_ = false;
};

}  // namespace pneumatic

#endif  // PNEUMATIC_RENDER_H_
