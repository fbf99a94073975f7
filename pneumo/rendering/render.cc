#include "rendering/render.h"

#include <GL/osmesa.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

#include "formats/output_file.h"

// Mesa's OSMesa keeps a few hundred bytes of its own state after OSMesaDestroyContext (measured
// under LeakSanitizer: 640 bytes per process, every allocation made inside libOSMesa). Those leaks
// are Mesa's, not ours: suppress them, and only those, in any program that links the renderer
// (LeakSanitizer reads this hook; other builds never call it).
extern "C" const char* __lsan_default_suppressions() { return "leak:libOSMesa.so\n"; }

namespace pneumatic {
namespace {

constexpr unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

void PutBigEndian(std::string* out, std::uint32_t value) {
  for (int shift = 24; shift >= 0; shift -= 8) out->push_back(static_cast<char>((value >> shift) & 0xff));
}

std::uint32_t GetBigEndian(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
}

void PutChunk(std::string* out, const char type[4], const std::string& data) {
  PutBigEndian(out, static_cast<std::uint32_t>(data.size()));
  std::string body(type, 4);
  body += data;
  out->append(body);
  PutBigEndian(out, Crc32(reinterpret_cast<const unsigned char*>(body.data()), body.size()));
}

// the Paeth predictor of the PNG specification
int Paeth(int a, int b, int c) {
  int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return a;
  return pb <= pc ? b : c;
}

// filters a row (filter type 0..4) given the previous raw row (zeros for the first), bpp bytes a pixel
void FilterRow(int type, const unsigned char* row, const unsigned char* previous, std::size_t size, int bpp,
               unsigned char* out) {
  for (std::size_t i = 0; i < size; ++i) {
    int a = i >= static_cast<std::size_t>(bpp) ? row[i - bpp] : 0;
    int b = previous[i];
    int c = i >= static_cast<std::size_t>(bpp) ? previous[i - bpp] : 0;
    int predicted = type == 1 ? a : type == 2 ? b : type == 3 ? (a + b) / 2 : type == 4 ? Paeth(a, b, c) : 0;
    out[i] = static_cast<unsigned char>(row[i] - predicted);
  }
}

// the inverse, in place: `row` holds the filtered bytes and becomes the raw ones
bool UnfilterRow(int type, unsigned char* row, const unsigned char* previous, std::size_t size, int bpp) {
  if (type < 0 || type > 4) return false;
  for (std::size_t i = 0; i < size; ++i) {
    int a = i >= static_cast<std::size_t>(bpp) ? row[i - bpp] : 0;
    int b = previous[i];
    int c = i >= static_cast<std::size_t>(bpp) ? previous[i - bpp] : 0;
    int predicted = type == 1 ? a : type == 2 ? b : type == 3 ? (a + b) / 2 : type == 4 ? Paeth(a, b, c) : 0;
    row[i] = static_cast<unsigned char>(row[i] + predicted);
  }
  return true;
}

double Clamp(double v, double lo, double hi) { return std::min(hi, std::max(lo, v)); }

unsigned char ToByte(float v) { return static_cast<unsigned char>(std::lround(255 * Clamp(v, 0, 1))); }

// the bore radius sqrt(A_P / pi) of a linear cylinder, from its P.area
double BoreRadius(const mjModel* m, const CylinderInfo& c) {
  std::string ignored;
  std::optional<double> area = GetParameter(m, c.name, "P.area", &ignored);
  return area && *area > 0 ? std::sqrt(*area / mjPI) : 0.01;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// PNG

std::uint32_t Crc32(const unsigned char* data, std::size_t size, std::uint32_t crc) {
  static const auto table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t n = 0; n < 256; ++n) {
      std::uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  crc = ~crc;
  for (std::size_t i = 0; i < size; ++i) crc = table[(crc ^ data[i]) & 0xff] ^ (crc >> 8);
  return ~crc;
}

std::string EncodePng(int width, int height, const std::vector<unsigned char>& rgb, std::string* png) {
  if (width <= 0 || height <= 0) return "the image size must be positive, not " + std::to_string(width) + " x " + std::to_string(height);
  const std::size_t stride = static_cast<std::size_t>(width) * 3;
  if (rgb.size() != stride * static_cast<std::size_t>(height)) {
    return "the image holds " + std::to_string(rgb.size()) + " bytes, not " + std::to_string(width) + " x " +
           std::to_string(height) + " x 3";
  }
  // each row with the filter whose output has the smallest sum of absolute values (the PNG
  // specification's heuristic): rendered images then deflate to a few percent
  std::vector<unsigned char> filtered((stride + 1) * static_cast<std::size_t>(height));
  std::vector<unsigned char> zeros(stride, 0), candidate(stride);
  for (int y = 0; y < height; ++y) {
    const unsigned char* row = rgb.data() + stride * y;
    const unsigned char* previous = y > 0 ? row - stride : zeros.data();
    unsigned char* out = filtered.data() + (stride + 1) * y;
    long best_cost = -1;
    for (int type = 0; type <= 4; ++type) {
      FilterRow(type, row, previous, stride, 3, candidate.data());
      long cost = 0;
      for (unsigned char v : candidate) cost += v < 128 ? v : 256 - v;
      if (best_cost < 0 || cost < best_cost) {
        best_cost = cost;
        out[0] = static_cast<unsigned char>(type);
        std::copy(candidate.begin(), candidate.end(), out + 1);
      }
    }
  }
  uLongf compressed_size = compressBound(static_cast<uLong>(filtered.size()));
  std::string compressed(compressed_size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(compressed.data()), &compressed_size, filtered.data(),
                static_cast<uLong>(filtered.size()), 3) != Z_OK) {
    return "zlib failed to compress the image";
  }
  compressed.resize(compressed_size);

  png->assign(reinterpret_cast<const char*>(kPngSignature), sizeof(kPngSignature));
  std::string header;
  PutBigEndian(&header, static_cast<std::uint32_t>(width));
  PutBigEndian(&header, static_cast<std::uint32_t>(height));
  header += std::string("\x08\x02\x00\x00\x00", 5);  // 8 bits, RGB, deflate, adaptive filters, no interlace
  PutChunk(png, "IHDR", header);
  PutChunk(png, "IDAT", compressed);
  PutChunk(png, "IEND", "");
  return "";
}

std::string WritePng(const std::string& path, int width, int height, const std::vector<unsigned char>& rgb) {
  std::string png;
  if (std::string problem = EncodePng(width, height, rgb, &png); !problem.empty()) return path + ": " + problem;
  return WriteOutput(path, png, "a PNG image");
}

std::string DecodePng(const std::string& png, int* width, int* height, std::vector<unsigned char>* rgb) {
  const auto* bytes = reinterpret_cast<const unsigned char*>(png.data());
  if (png.size() < 8 || std::memcmp(bytes, kPngSignature, 8) != 0) return "not a PNG file (no PNG signature)";
  std::size_t at = 8;
  std::uint32_t w = 0, h = 0;
  int color_type = -1;
  bool ended = false;
  std::string idat;
  while (!ended) {
    if (png.size() - at < 12) return "truncated PNG file (a chunk ends past the end of the file)";
    std::uint32_t length = GetBigEndian(bytes + at);
    if (length > png.size() - at - 12) return "truncated PNG file (a chunk ends past the end of the file)";
    std::string type(png, at + 4, 4);
    const unsigned char* data = bytes + at + 8;
    if (Crc32(bytes + at + 4, length + 4) != GetBigEndian(data + length)) {
      return "corrupt PNG file: CRC mismatch in chunk '" + type + "'";
    }
    if (type == "IHDR") {
      if (length != 13) return "bad IHDR chunk";
      w = GetBigEndian(data);
      h = GetBigEndian(data + 4);
      int depth = data[8];
      color_type = data[9];
      if (depth != 8 || (color_type != 0 && color_type != 2 && color_type != 6)) {
        return "unsupported PNG format (bit depth " + std::to_string(depth) + ", colour type " +
               std::to_string(color_type) + "): only 8-bit grey, RGB and RGBA are read";
      }
      if (data[10] != 0 || data[11] != 0) return "unsupported PNG compression or filter method";
      if (data[12] != 0) return "interlaced PNG files are not read";
      if (w == 0 || h == 0 || w > 16384 || h > 16384) return "unsupported PNG size " + std::to_string(w) + " x " + std::to_string(h);
    } else if (type == "IDAT") {
      idat.append(reinterpret_cast<const char*>(data), length);
    } else if (type == "IEND") {
      ended = true;
    } else if (!(type[0] & 0x20)) {
      return "unsupported critical PNG chunk '" + type + "'";
    }
    at += 12 + length;
  }
  if (color_type < 0) return "PNG file without IHDR chunk";
  const int channels = color_type == 2 ? 3 : color_type == 6 ? 4 : 1;
  const std::size_t stride = static_cast<std::size_t>(w) * channels;
  std::vector<unsigned char> raw((stride + 1) * h);
  uLongf raw_size = static_cast<uLongf>(raw.size());
  if (uncompress(raw.data(), &raw_size, reinterpret_cast<const Bytef*>(idat.data()), static_cast<uLong>(idat.size())) != Z_OK ||
      raw_size != raw.size()) {
    return "corrupt PNG file: the image data does not inflate to " + std::to_string(w) + " x " + std::to_string(h) + " pixels";
  }
  std::vector<unsigned char> zeros(stride, 0);
  rgb->assign(static_cast<std::size_t>(w) * h * 3, 0);
  for (std::uint32_t y = 0; y < h; ++y) {
    unsigned char* row = raw.data() + (stride + 1) * y;
    const unsigned char* previous = y > 0 ? row - (stride + 1) + 1 : zeros.data();
    if (!UnfilterRow(row[0], row + 1, previous, stride, channels)) return "corrupt PNG file: unknown row filter";
    for (std::uint32_t x = 0; x < w; ++x) {
      unsigned char* out = rgb->data() + (static_cast<std::size_t>(y) * w + x) * 3;
      const unsigned char* in = row + 1 + static_cast<std::size_t>(x) * channels;
      for (int k = 0; k < 3; ++k) out[k] = in[channels == 1 ? 0 : k];
    }
  }
  *width = static_cast<int>(w);
  *height = static_cast<int>(h);
  return "";
}

std::string ReadPng(const std::string& path, int* width, int* height, std::vector<unsigned char>* rgb) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return path + ": cannot open: " + std::strerror(errno);
  std::string png((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) return path + ": cannot read";
  if (std::string problem = DecodePng(png, width, height, rgb); !problem.empty()) return path + ": " + problem;
  return "";
}

// ---------------------------------------------------------------------------------------------
// comparison

ImageDifference CompareImages(int width, int height, const std::vector<unsigned char>& a,
                              const std::vector<unsigned char>& b, const CompareOptions& options) {
  ImageDifference result;
  const std::size_t pixels = static_cast<std::size_t>(std::max(width, 0)) * std::max(height, 0);
  if (width <= 0 || height <= 0 || a.size() != pixels * 3 || b.size() != pixels * 3) return result;
  result.same_size = true;
  // the distance of each pixel of `from` to its best match in `to` within the shift window
  auto one_way = [&](const std::vector<unsigned char>& from, const std::vector<unsigned char>& to) {
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const unsigned char* p = from.data() + (static_cast<std::size_t>(y) * width + x) * 3;
        int best = 256;
        for (int dy = -options.shift; dy <= options.shift && best > 0; ++dy) {
          int yy = y + dy;
          if (yy < 0 || yy >= height) continue;
          for (int dx = -options.shift; dx <= options.shift && best > 0; ++dx) {
            int xx = x + dx;
            if (xx < 0 || xx >= width) continue;
            const unsigned char* q = to.data() + (static_cast<std::size_t>(yy) * width + xx) * 3;
            int d = std::max({std::abs(p[0] - q[0]), std::abs(p[1] - q[1]), std::abs(p[2] - q[2])});
            best = std::min(best, d);
          }
        }
        if (best > options.threshold) ++result.differing;
        if (best > result.max_difference) {
          result.max_difference = best;
          result.max_difference_x = x;
          result.max_difference_y = y;
        }
      }
    }
  };
  one_way(a, b);
  one_way(b, a);
  result.compared = 2 * pixels;
  result.differing_fraction = static_cast<double>(result.differing) / static_cast<double>(result.compared);
  return result;
}

std::string DescribeDifference(const ImageDifference& difference) {
  if (!difference.same_size) return "the images differ in size";
  std::ostringstream text;
  text << difference.differing << " of " << difference.compared << " pixel comparisons fail (" << 100 * difference.differing_fraction << " %), largest difference " << difference.max_difference;
  if (difference.max_difference_x >= 0) text << " at (" << difference.max_difference_x << ", " << difference.max_difference_y << ")";
  return text.str();
}

// ---------------------------------------------------------------------------------------------
// pressure colour

double PressureBalance(const mjModel* m, const mjData* d, const CylinderInfo& c) {
  double p_P = c.chamber_actuator[0] >= 0 ? ChamberPressure(m, d, c, Chamber::kP) : c.p_atm;
  double p_N = c.chamber_actuator[1] >= 0 ? ChamberPressure(m, d, c, Chamber::kN) : c.p_atm;
  double span = c.p_supply - c.p_exhaust;
  if (!(span > 0) || !std::isfinite(p_P - p_N)) return 0;
  return Clamp((p_P - p_N) / span, -1, 1);
}

std::array<float, 4> PressureColor(double balance) {
  const float grey[3] = {0.6f, 0.6f, 0.6f}, red[3] = {0.85f, 0.12f, 0.1f}, blue[3] = {0.1f, 0.3f, 0.9f};
  double b = std::isfinite(balance) ? Clamp(balance, -1, 1) : 0;
  const float* end = b >= 0 ? red : blue;
  float s = static_cast<float>(std::fabs(b));
  return {grey[0] + s * (end[0] - grey[0]), grey[1] + s * (end[1] - grey[1]), grey[2] + s * (end[2] - grey[2]), 1.0f};
}

// ---------------------------------------------------------------------------------------------
// renderer

std::unique_ptr<OffscreenRenderer> OffscreenRenderer::Create(const mjModel* m, int width, int height, std::string* error,
                                                             const RenderQuality& quality) {
  auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return nullptr;
  };
  if (!m) return fail("no model to render");
  if (width <= 0 || height <= 0) {
    return fail("the image size must be positive, not " + std::to_string(width) + " x " + std::to_string(height));
  }
  std::unique_ptr<OffscreenRenderer> r(new OffscreenRenderer());
  r->width_ = width;
  r->height_ = height;
  r->quality_ = quality;

  // OSMesa draws into a buffer of ours; MuJoCo then renders into its own framebuffer object of
  // offwidth x offheight inside that context
  OSMesaContext osmesa = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 0, nullptr);
  if (!osmesa) return fail("OSMesa could not create an OpenGL context (OSMesaCreateContextExt)");
  r->osmesa_ = osmesa;
  r->buffer_.assign(static_cast<std::size_t>(width) * height * 4, 0);
  if (!OSMesaMakeCurrent(osmesa, r->buffer_.data(), GL_UNSIGNED_BYTE, width, height)) {
    return fail("OSMesa could not make a " + std::to_string(width) + " x " + std::to_string(height) +
                " context current (OSMesaMakeCurrent)");
  }
  GLint max_width = 0, max_height = 0;
  OSMesaGetIntegerv(OSMESA_MAX_WIDTH, &max_width);
  OSMesaGetIntegerv(OSMESA_MAX_HEIGHT, &max_height);
  if ((max_width > 0 && width > max_width) || (max_height > 0 && height > max_height)) {
    return fail("the image size " + std::to_string(width) + " x " + std::to_string(height) + " exceeds OSMesa's maximum " +
                std::to_string(max_width) + " x " + std::to_string(max_height));
  }

  // the renderer's copy: the quality settings, and an offscreen buffer at least as large as the
  // image (the model's <visual><global offwidth offheight>, 640 x 480 unless it says otherwise)
  r->model_ = mj_copyModel(nullptr, m);
  if (!r->model_) return fail("mj_copyModel failed");
  mjModel* copy = r->model_;
  copy->vis.global.offwidth = std::max(copy->vis.global.offwidth, width);
  copy->vis.global.offheight = std::max(copy->vis.global.offheight, height);
  copy->vis.quality.offsamples = std::max(0, quality.samples);
  copy->vis.quality.shadowsize = std::max(64, quality.shadow_size);
  if (copy->nlight == 0 && quality.brighten_unlit) {
    // the headlight alone, at MuJoCo's defaults (ambient 0.1, diffuse 0.4), leaves a model without
    // <light> too dark to read
    for (int k = 0; k < 3; ++k) {
      copy->vis.headlight.ambient[k] = std::max(copy->vis.headlight.ambient[k], 0.4f);
      copy->vis.headlight.diffuse[k] = std::max(copy->vis.headlight.diffuse[k], 0.6f);
      copy->vis.headlight.specular[k] = std::min(copy->vis.headlight.specular[k], 0.2f);
    }
  }
  if (quality.pressure_colors) r->cylinders_ = Cylinders(copy);

  // room for every geom, tendon segment and decoration MuJoCo adds, and one marker per cylinder
  mjv_defaultScene(&r->scene_);
  mjv_makeScene(copy, &r->scene_, 2000 + copy->ngeom + 4 * copy->ntendon + 64 * copy->nwrap + 2 * copy->nu);
  r->scene_made_ = true;
  r->scene_.flags[mjRND_SHADOW] = quality.shadows;
  r->scene_.flags[mjRND_REFLECTION] = quality.reflections;
  r->scene_.flags[mjRND_SKYBOX] = quality.skybox;
  mjr_defaultContext(&r->context_);
  mjr_makeContext(copy, &r->context_, mjFONTSCALE_100);
  r->context_made_ = true;
  mjr_setBuffer(mjFB_OFFSCREEN, &r->context_);
  if (r->context_.currentBuffer != mjFB_OFFSCREEN) return fail("MuJoCo has no offscreen buffer in the OSMesa context");
  if (r->context_.offWidth < width || r->context_.offHeight < height) {
    return fail("MuJoCo's offscreen buffer is " + std::to_string(r->context_.offWidth) + " x " +
                std::to_string(r->context_.offHeight) + ", smaller than the " + std::to_string(width) + " x " +
                std::to_string(height) + " requested");
  }
  mjv_defaultOption(&r->option_);
  r->flipped_.resize(static_cast<std::size_t>(width) * height * 3);
  r->depth_.resize(static_cast<std::size_t>(width) * height);
  return r;
}

OffscreenRenderer::~OffscreenRenderer() {
  if (osmesa_) OSMesaMakeCurrent(static_cast<OSMesaContext>(osmesa_), buffer_.data(), GL_UNSIGNED_BYTE, width_, height_);
  if (context_made_) mjr_freeContext(&context_);
  if (scene_made_) mjv_freeScene(&scene_);
  if (model_) mj_deleteModel(model_);
  if (osmesa_) OSMesaDestroyContext(static_cast<OSMesaContext>(osmesa_));
}

void OffscreenRenderer::AddPressureColors(const mjData* d) {
  const mjModel* m = model_;
  for (const CylinderInfo& c : cylinders_) {
    int actuator = c.chamber_actuator[0] >= 0 ? c.chamber_actuator[0] : c.chamber_actuator[1];
    if (actuator < 0) continue;
    std::array<float, 4> rgba = PressureColor(PressureBalance(m, d, c));
    double bore = BoreRadius(m, c);
    int type = m->actuator_trntype[actuator];
    int id = m->actuator_trnid[2 * actuator];

    if (type == mjTRN_TENDON) {
      // the tendon's own segments, drawn as the cylinder's body
      for (int i = 0; i < scene_.ngeom; ++i) {
        mjvGeom& g = scene_.geoms[i];
        if (g.objtype != mjOBJ_TENDON || g.objid != id) continue;
        std::copy(rgba.begin(), rgba.end(), g.rgba);
        if (g.type == mjGEOM_CAPSULE || g.type == mjGEOM_CYLINDER) {
          g.size[0] = g.size[1] = static_cast<float>(bore);
        } else if (g.type == mjGEOM_SPHERE) {
          g.size[0] = g.size[1] = g.size[2] = static_cast<float>(bore);
        }
      }
      continue;
    }
    if (scene_.ngeom >= scene_.maxgeom) return;
    mjvGeom* g = scene_.geoms + scene_.ngeom;
    mjtNum size[3], pos[3], mat[9], quat[4];
    int joint = DrivenJoint(m, c);
    if (c.rod_site >= 0) {
      // mount=hinge_sites: the barrel and rod between the two sites, as a spatial tendon over them is drawn
      const mjtNum* a = d->site_xpos + 3 * c.cap_site;
      const mjtNum* b = d->site_xpos + 3 * c.rod_site;
      mjv_initGeom(g, mjGEOM_CAPSULE, nullptr, nullptr, nullptr, rgba.data());
      mjv_makeConnector(g, mjGEOM_CAPSULE, bore, a[0], a[1], a[2], b[0], b[1], b[2]);
    } else if (joint >= 0 && (m->jnt_type[joint] == mjJNT_SLIDE || m->jnt_type[joint] == mjJNT_HINGE)) {
      const mjtNum* axis = d->xaxis + 3 * joint;
      mju_quatZ2Vec(quat, axis);
      mju_quat2Mat(mat, quat);
      mju_copy3(pos, d->xanchor + 3 * joint);
      if (m->jnt_type[joint] == mjJNT_SLIDE) {
        // the bore over the stroke, centred where the anchor is at mid-stroke
        double gear = m->actuator_gear[6 * actuator];
        // MuJoCo's anchor of a slide joint is where it is at qpos0 (the joint moves the body from there)
        double q_mid = gear != 0 ? c.x_mid / gear : 0;
        mju_addToScl3(pos, axis, q_mid - m->qpos0[m->jnt_qposadr[joint]]);
        std::string ignored;
        double stroke = GetParameter(m, c.name, "stroke", &ignored).value_or(0.1);
        // mjv_initGeom takes a cylinder's size as MJCF does: radius, half-length
        size[0] = 0.98 * bore;
        size[1] = 0.5 * stroke / std::max(std::fabs(gear), 1e-12);
        size[2] = 0;
      } else {
        // a rotary vane's housing: its area is the displacement per radian, (R^2 - r^2) h / 2,
        // which is 0.44 R^3 for a hub r = R / 3 and a vane height h = R
        std::string ignored;
        double displacement = GetParameter(m, c.name, "P.area", &ignored).value_or(0);
        double radius = displacement > 0 ? std::cbrt(displacement / 0.44) : 0.02 * m->stat.extent;
        size[0] = radius;
        size[1] = 0.5 * radius;
        size[2] = 0;
      }
      mjv_initGeom(g, mjGEOM_CYLINDER, size, pos, mat, rgba.data());
    } else if (type == mjTRN_SLIDERCRANK) {
      int crank = m->actuator_trnid[2 * actuator], slider = m->actuator_trnid[2 * actuator + 1];
      const mjtNum* a = d->site_xpos + 3 * slider;
      const mjtNum* b = d->site_xpos + 3 * crank;
      mjv_initGeom(g, mjGEOM_CAPSULE, nullptr, nullptr, nullptr, rgba.data());
      mjv_makeConnector(g, mjGEOM_CAPSULE, bore, a[0], a[1], a[2], b[0], b[1], b[2]);
    } else {
      continue;
    }
    g->category = mjCAT_DECOR;
    g->objtype = mjOBJ_ACTUATOR;
    g->objid = actuator;
    g->segid = scene_.ngeom;
    ++scene_.ngeom;
  }
}

mjvCamera OffscreenRenderer::FreeCamera() const {
  mjvCamera cam;
  mjv_defaultCamera(&cam);
  mjv_defaultFreeCamera(model_, &cam);
  return cam;
}

std::string OffscreenRenderer::Render(const mjData* d, const std::string& camera, std::vector<unsigned char>* rgb) {
  mjvCamera cam;
  mjv_defaultCamera(&cam);
  if (camera.empty()) {
    mjv_defaultFreeCamera(model_, &cam);
  } else {
    int id = mj_name2id(model_, mjOBJ_CAMERA, camera.c_str());
    if (id < 0) {
      std::string names;
      for (int i = 0; i < model_->ncam; ++i) {
        const char* name = model_->names + model_->name_camadr[i];
        names += (i ? ", '" : "'") + std::string(*name ? name : "(unnamed #" + std::to_string(i) + ")") + "'";
      }
      return "the model has no camera '" + camera + "' (" + (model_->ncam ? "its cameras: " + names : "it has no <camera>") +
             "; leave the camera out for a free camera looking at the whole model)";
    }
    cam.type = mjCAMERA_FIXED;
    cam.fixedcamid = id;
  }
  return Render(d, cam, rgb);
}

std::string OffscreenRenderer::Render(const mjData* d, const mjvCamera& camera, std::vector<unsigned char>* rgb) {
  if (!d) return "no state to render";
  if (camera.type == mjCAMERA_FIXED && (camera.fixedcamid < 0 || camera.fixedcamid >= model_->ncam)) {
    return "no camera #" + std::to_string(camera.fixedcamid) + " in the model";
  }
  if (camera.type == mjCAMERA_TRACKING && (camera.trackbodyid < 0 || camera.trackbodyid >= model_->nbody)) {
    return "no body #" + std::to_string(camera.trackbodyid) + " to track in the model";
  }
  if (!OSMesaMakeCurrent(static_cast<OSMesaContext>(osmesa_), buffer_.data(), GL_UNSIGNED_BYTE, width_, height_)) {
    return "OSMesa could not make the renderer's context current";
  }
  mjvCamera cam = camera;
  mjv_updateScene(model_, const_cast<mjData*>(d), &option_, nullptr, &cam, mjCAT_ALL, &scene_);
  if (!cylinders_.empty()) AddPressureColors(d);
  mjrRect viewport = {0, 0, width_, height_};
  mjr_setBuffer(mjFB_OFFSCREEN, &context_);
  mjr_render(viewport, &scene_, &context_);
  mjr_readPixels(flipped_.data(), depth_.data(), viewport, &context_);
  // MuJoCo clears to black: where nothing was drawn (depth at the far plane), the background
  // colour instead. A skybox, when drawn, is at the far plane too and is kept.
  if (!(quality_.skybox && model_->ntex > 0)) {
    const unsigned char background[3] = {ToByte(quality_.background[0]), ToByte(quality_.background[1]),
                                         ToByte(quality_.background[2])};
    for (std::size_t i = 0; i < depth_.size(); ++i) {
      if (depth_[i] >= 1.0f) std::memcpy(flipped_.data() + 3 * i, background, 3);
    }
  }
  // OpenGL's rows are bottom-up
  const std::size_t stride = static_cast<std::size_t>(width_) * 3;
  rgb->resize(flipped_.size());
  for (int y = 0; y < height_; ++y) {
    std::memcpy(rgb->data() + stride * y, flipped_.data() + stride * (height_ - 1 - y), stride);
  }
  return "";
}

}  // namespace pneumatic
