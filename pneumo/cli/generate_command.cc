#include "cli/generate_command.h"

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "formats/log_csv.h"
#include "formats/output_file.h"
#include "simulation/generate.h"

namespace pneumatic::cli {
namespace {

int RunGenerate(const std::string& model_path, const std::string& out_path, const pneumatic::GenerateOptions& options) {
  if (std::string e = pneumatic::CheckOutputPath(out_path, "a log file"); !e.empty()) return Fail(e);
  AttachedModel model;
  if (std::string e = Load(model_path, &model); !e.empty()) return Fail(e);
  auto start = std::chrono::steady_clock::now();
  pneumatic::GenerateResult result = pneumatic::Generate(model.model, options);
  if (!result.log) return Fail(model_path + ": " + result.error);
  double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.log->comments.insert(result.log->comments.begin(), "model: " + model_path);
  if (std::string e = pneumatic::log::WriteLog(out_path, *result.log); !e.empty()) return Fail(e);
  std::fprintf(stderr, "pneumo: wrote %s: %zu rows, %.3f s simulated in %.3f s\n", out_path.c_str(),
               result.log->rows(), static_cast<double>(result.log->rows()) * options.period, wall);
  return 0;
}

}  // namespace

Command AddGenerateCommand(CLI::App& app) {
  struct Arguments {
    pneumatic::GenerateOptions generate_options;
    std::string generate_model, generate_out;
  };
  auto arguments = std::make_shared<Arguments>();
  pneumatic::GenerateOptions& generate_options = arguments->generate_options;
  std::string &generate_model = arguments->generate_model, &generate_out = arguments->generate_out;
  CLI::App* generate = app.add_subcommand(
      "generate",
      "closed-loop identification log of a rig with one proportional valve per chamber (rig C), as paper 000 V.C "
      "recorded its data");
  generate->footer(
      "Every 10 ms (100 Hz, commands held: zero-order hold), for each cylinder:\n"
      "  ref = 4 sines, f uniform in 0.1..0.8 Hz, amplitude 1/f, random phases, faded in over 1 s, scaled so its peak "
      "is 70 % of the half stroke\n"
      "  d   = PID(ref, x): kp 60 V/m, ki 60 V/(m s), kd 1.5 V s/m on x, |d| <= 4 V (controllers/pid.h)\n"
      "  c   = 0.25 V + 0.75 V (sin + sin)/2, f uniform in 0.03..0.15 Hz: the slowly varying co-contraction, "
      "-0.5..1 V\n"
      "  uP  = clamp(5 + c + d, 3, 7) V,  uN = clamp(5 + c - d, 3, 7) V (paper 000 uses 3 < u < 7 V)\n"
      "Logged: uP, uN, p_P, p_N, x, v, ref. Measured columns are INSTANTANEOUS samples at the row's time, before the "
      "row's command acts (docs/log_format.md), not paper 000's averages of 200 samples over each 10 ms period. Gaussian "
      "noise is added to the logged p_P, p_N, x and v (sqrt(2) x-noise / 10 ms, a finite difference's); the controller "
      "sees the noise-free x. Defaults (paper 000 gives no figures): 500 Pa (0.1 % of supply - exhaust on rig C) and "
      "0.1 mm (0.1 % of its stroke). Same arguments, same file bit for bit; use different seeds for training and "
      "held-out logs.");
  generate->add_option("model", generate_model, "MJCF model whose cylinders are all valve=proportional_per_chamber")
      ->required();
  generate->add_option("--duration", generate_options.duration, "seconds to record (paper 000: 100 s)")->required();
  generate->add_option("--seed", generate_options.seed, "seed of the reference, the co-contraction and the noise")
      ->required();
  generate->add_option("--out", generate_out, "log to write (docs/log_format.md)")->required();
  generate->add_option("--noise-pressure", generate_options.noise_pressure, "pressure sensor noise, Pa (std)")->capture_default_str();
  generate->add_option("--noise-position", generate_options.noise_position, "position sensor noise, m (std)")->capture_default_str();
  return {generate, [arguments] {
    return RunGenerate(arguments->generate_model, arguments->generate_out, arguments->generate_options);
  }};
}

}  // namespace pneumatic::cli
