#include "rendering/frames.h"

#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>

#include "formats/model_loading.h"
#include "pneumatic/pneumatic.h"
#include "simulation/prescribed_motion.h"
#include "simulation/rollout.h"

extern char** environ;

namespace pneumatic {
namespace {

std::string Seconds(double t) {
  std::ostringstream text;
  text.precision(9);
  text << t << " s";
  return text.str();
}

}  // namespace

std::string SetStateFromLog(const mjModel* m, mjData* d, const log::Log& log, std::optional<double> time) {
  std::vector<CylinderInfo> cylinders;
  if (std::string problem = AttachedCylinders(m, &cylinders); !problem.empty()) return problem;
  if (log.rows() == 0) return "the log has no rows";
  std::size_t row = 0;
  if (time) {
    const double first = log.time.front(), last = log.time.back();
    const double slack = 1e-9 * std::max(log.Period(), 1e-3);
    if (!std::isfinite(*time) || *time < first - slack || *time > last + std::max(log.Period(), slack)) {
      return "time " + Seconds(*time) + " is outside the log (" + Seconds(first) + " to " + Seconds(last) + ")";
    }
    while (row + 1 < log.rows() && log.time[row + 1] <= *time + slack) ++row;
  }
  // hinges of cylinders mounted between sites: solved from x on d's present pose (its kinematics), all
  // before any is set
  mj_kinematics(m, d);
  JointState state;
  for (const CylinderInfo& c : cylinders) {
    if (int col = log.FindColumn(c.name, "p_P"); col >= 0 && c.chamber_actuator[0] >= 0) {
      SetChamberPressure(m, d, c, Chamber::kP, log.values[col][row]);
    }
    if (int col = log.FindColumn(c.name, "p_N"); col >= 0 && c.chamber_actuator[1] >= 0) {
      SetChamberPressure(m, d, c, Chamber::kN, log.values[col][row]);
    }
    int x = log.FindColumn(c.name, "x"), v = log.FindColumn(c.name, "v");
    std::optional<double> position, velocity;
    if (x >= 0) position = log.values[x][row];
    if (v >= 0) velocity = log.values[v][row];
    if (std::string e = PistonJointState(m, d, c, position, velocity, std::nullopt, 0, &state); !e.empty()) return e;
  }
  state.WriteTo(d);
  d->time = log.time[row];
  return "";
}

std::string RenderToFile(const RenderOptions& options) {
  if (options.time && !options.log_path) return "--time needs a log (--log) to take the state from";
  std::string error;
  ModelPtr m = LoadAttachedModel(options.model_path, &error);
  if (!m) return error;
  std::unique_ptr<mjData, void (*)(mjData*)> d(mj_makeData(m.get()), mj_deleteData);
  if (!d) return "mj_makeData failed";
  if (options.log_path) {
    log::ReadOptions read;
    for (const CylinderInfo& c : Cylinders(m.get())) read.cylinders.insert(c.name);
    read.uniform_time = false;
    log::ReadResult result = log::ReadLog(*options.log_path, read);
    if (!result.log) return result.error;
    if (std::string problem = SetStateFromLog(m.get(), d.get(), *result.log, options.time); !problem.empty()) {
      return *options.log_path + ": " + problem;
    }
  }
  mj_forward(m.get(), d.get());
  auto renderer = OffscreenRenderer::Create(m.get(), options.width, options.height, &error, options.quality);
  if (!renderer) return error;
  std::vector<unsigned char> rgb;
  if (std::string problem = renderer->Render(d.get(), options.camera, &rgb); !problem.empty()) return problem;
  return WritePng(options.out_path, options.width, options.height, rgb);
}

// ---------------------------------------------------------------------------------------------

std::string FindOnPath(const std::string& program) {
  const char* path = std::getenv("PATH");
  if (!path) return "";
  std::stringstream dirs(path);
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (dir.empty()) continue;
    std::string candidate = dir + "/" + program;
    struct stat info;
    if (::stat(candidate.c_str(), &info) == 0 && S_ISREG(info.st_mode) && ::access(candidate.c_str(), X_OK) == 0) {
      return candidate;
    }
  }
  return "";
}

std::unique_ptr<FrameWriter> FrameWriter::Create(const mjModel* m, const FrameOptions& options, std::string* error) {
  auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return nullptr;
  };
  if (!(options.fps > 0) || !std::isfinite(options.fps)) return fail("the frame rate must be positive");
  if (options.dir.empty()) return fail("no directory for the frames");
  struct stat info;
  if (::stat(options.dir.c_str(), &info) == 0) {
    if (!S_ISDIR(info.st_mode)) return fail(options.dir + ": not a directory");
  } else if (::mkdir(options.dir.c_str(), 0777) != 0) {
    return fail(options.dir + ": cannot create the frame directory: " + std::strerror(errno));
  }
  std::unique_ptr<FrameWriter> w(new FrameWriter());
  w->options_ = options;
  w->renderer_ = OffscreenRenderer::Create(m, options.width, options.height, error, options.quality);
  if (!w->renderer_) return nullptr;
  // an unknown camera is reported now rather than at the first frame
  if (!options.camera.empty() && mj_name2id(m, mjOBJ_CAMERA, options.camera.c_str()) < 0) {
    return fail("the model has no camera '" + options.camera + "'");
  }
  return w;
}

std::string FrameWriter::FramePath(int k) const {
  char name[32];
  std::snprintf(name, sizeof(name), "frame_%05d.png", k);
  return options_.dir + "/" + name;
}

std::string FrameWriter::Offer(const mjData* d) {
  if (!started_) {
    started_ = true;
    t0_ = d->time;
  }
  const double period = 1.0 / options_.fps;
  bool drawn = false;
  while (d->time >= t0_ + next_frame_ * period - 1e-9) {
    if (!drawn) {
      if (std::string problem = renderer_->Render(d, options_.camera, &rgb_); !problem.empty()) return problem;
      drawn = true;
    }
    if (std::string problem = WritePng(FramePath(next_frame_), options_.width, options_.height, rgb_); !problem.empty()) {
      return problem;
    }
    ++next_frame_;
  }
  return "";
}

std::string FrameWriter::Finish() {
  if (!options_.mp4 || next_frame_ == 0) return "";
  std::string ffmpeg = FindOnPath("ffmpeg");
  if (ffmpeg.empty()) return "";
  std::string video = options_.dir + "/video.mp4";
  std::ostringstream fps;
  fps.precision(17);
  fps << options_.fps;
  std::vector<std::string> args = {ffmpeg, "-nostdin", "-y", "-loglevel", "error", "-framerate", fps.str(),
                                   "-i", options_.dir + "/frame_%05d.png", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                                   "-c:v", "libx264", "-pix_fmt", "yuv420p", video};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (int e = posix_spawn(&pid, ffmpeg.c_str(), nullptr, nullptr, argv.data(), environ); e != 0) {
    return "cannot run " + ffmpeg + ": " + std::strerror(e);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return "waiting for ffmpeg failed: " + std::string(std::strerror(errno));
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) return "ffmpeg failed to write " + video;
  video_path_ = video;
  return "";
}

}  // namespace pneumatic
