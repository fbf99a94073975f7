// What `pneumo render MODEL.xml --out frame.png [--log LOG.csv [--time T]]` draws: one picture of a
// model (its reset state, or the state of a log's row), and FrameWriter: the frame sequence (and MP4)
// of `pneumo rollout ... --frames DIR --fps 30`.
#ifndef PNEUMATIC_FRAMES_H_
#define PNEUMATIC_FRAMES_H_

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "formats/log_csv.h"
#include "rendering/render.h"

namespace pneumatic {

struct RenderOptions {
  std::string model_path;
  std::string out_path;                // PNG; "-" is standard output
  std::optional<std::string> log_path; // draw the state of one of its rows
  std::optional<double> time;          // that row: the last one at or before `time` (s); unset: the first. Needs the log.
  int width = 640, height = 480;
  std::string camera;                  // "" = free camera looking at the whole model
  RenderQuality quality;
};

// Writes the state of `log` at `time` (the last row at or before it; nullopt: the first row) into
// d: chamber pressures from p_P and p_N, and for cylinders driven directly by a slide or hinge
// joint the piston position x (and velocity v) through the joint, as `pneumo rollout` starts
// from a log. What the log does not give stays as it is in d. "" or why not: a time outside the
// log, or x or v of a cylinder on a tendon or slider-crank (its joints cannot be solved from x). A
// cylinder mounted between sites (mount=hinge_sites) gets the hinge angle nearest d's present one
// whose site distance is x + x_mid (HingeAngleAt), and q' = v / (dL/dq).
// Call mj_forward afterwards.
std::string SetStateFromLog(const mjModel* m, mjData* d, const log::Log& log, std::optional<double> time);

// Loads and attaches the model, sets the state (the model's reset state, or the log's row),
// runs mj_forward and writes the picture. "" or the message (naming the file at fault).
std::string RenderToFile(const RenderOptions& options);

struct FrameOptions {
  std::string dir;         // created if missing (one level); frames are DIR/frame_00000.png, ...
  double fps = 30;         // frames per second of simulated time
  int width = 640, height = 480;
  std::string camera;      // "" = free camera looking at the whole model
  bool mp4 = true;         // Finish() also writes DIR/video.mp4 when ffmpeg is on the PATH
  RenderQuality quality;
};

// Writes the frames of a rollout. Usage:
//   std::string error;
//   auto frames = pneumatic::FrameWriter::Create(m, frame_options, &error);   // null: error
//   ... for every step (or every log row) of the rollout, after mj_step / mj_forward:
//   if (std::string e = frames->Offer(d); !e.empty()) ...                      // failed
//   std::string e = frames->Finish();                                          // the MP4, if possible
// Frame k shows simulated time t0 + k / fps, t0 the time of the first Offer: Offer draws d when
// its time has reached the next frame's (within 1e-9 s), and writes that one picture for every
// frame time it has passed, so the sequence keeps real time even when the steps are coarser
// than 1 / fps. Offer d as it is at the frame's time, before stepping past it. Offering after
// every mj_step of a fine-step model costs a comparison per step; drawing costs a render per frame.
class FrameWriter {
 public:
  static std::unique_ptr<FrameWriter> Create(const mjModel* m, const FrameOptions& options, std::string* error);

  // Draws and writes the frames that are due at d->time. "" or why not (a write failed).
  std::string Offer(const mjData* d);

  // Without ffmpeg, or with mp4 false: does nothing and returns "". With ffmpeg on the PATH:
  // encodes DIR/frame_%05d.png at `fps` into DIR/video.mp4 (H.264, yuv420p; odd sizes padded
  // by a pixel) and returns "" or ffmpeg's failure.
  std::string Finish();

  int frames_written() const { return next_frame_; }
  // the path of frame k
  std::string FramePath(int k) const;
  // "" if no MP4 was made, else its path (after Finish)
  const std::string& video_path() const { return video_path_; }

 private:
  FrameWriter() = default;
  FrameOptions options_;
  std::unique_ptr<OffscreenRenderer> renderer_;
  std::vector<unsigned char> rgb_;
  bool started_ = false;
  double t0_ = 0;
  int next_frame_ = 0;
  std::string video_path_;
};

// The full path of an executable on the PATH, or "" (used to find ffmpeg).
std::string FindOnPath(const std::string& program);

}  // namespace pneumatic

#endif  // PNEUMATIC_FRAMES_H_
