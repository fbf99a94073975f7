#include "cli/render_command.h"

#include <iostream>
#include <memory>
#include <string>

namespace pneumatic {

int RunRender(const RenderOptions& options) {
  std::string problem = RenderToFile(options);
  if (problem.empty()) return 0;
  std::cerr << "pneumo render: " << problem << "\n";
  return 1;
}

}  // namespace pneumatic

namespace pneumatic::cli {

Command AddRenderCommand(CLI::App& app) {
  struct Arguments {
    pneumatic::RenderOptions render_options;
    std::string render_log;
    double render_time = 0;
  };
  auto arguments = std::make_shared<Arguments>();
  pneumatic::RenderOptions& render_options = arguments->render_options;
  CLI::App* render = app.add_subcommand(
      "render", "draw a model off screen (OSMesa) to a PNG, each cylinder coloured by its pressure difference");
  render->add_option("model", render_options.model_path, "MJCF model")->required();
  render->add_option("--out", render_options.out_path, "PNG to write")->required();
  std::string& render_log = arguments->render_log;
  double& render_time = arguments->render_time;
  render->add_option("--log", render_log, "draw the state of a row of this log (p_P, p_N, x, v)");
  render->add_option("--time", render_time, "the row: the last at or before this time, s (default: the first)");
  render->add_option("--width", render_options.width, "pixels")->capture_default_str()->check(CLI::Range(1, 8192));
  render->add_option("--height", render_options.height, "pixels")->capture_default_str()->check(CLI::Range(1, 8192));
  render->add_option("--camera", render_options.camera, "a camera of the model (default: a free camera on the whole model)");
  render->footer("Colours: grey where p_P = p_N, red as chamber P's pressure exceeds N's (P pushes), blue the reverse, "
                 "full at a difference of p_supply - p_exhaust.");
  return {render, [render, arguments] {
    if (render->count("--log")) arguments->render_options.log_path = arguments->render_log;
    if (render->count("--time")) arguments->render_options.time = arguments->render_time;
    return pneumatic::RunRender(arguments->render_options);
  }};
}

}  // namespace pneumatic::cli
