// `pneumo render MODEL.xml --out frame.png [--log LOG.csv [--time T]]`: one picture of a model (its
// reset state, or the state of a log's row), drawn by rendering/frames.h.
#ifndef PNEUMATIC_CLI_RENDER_COMMAND_H_
#define PNEUMATIC_CLI_RENDER_COMMAND_H_

#include <CLI/CLI.hpp>

#include "cli/command_support.h"
#include "rendering/frames.h"

namespace pneumatic {

// RenderToFile for the command line: prints "pneumo render: MESSAGE" to standard error and
// returns 1 on failure, 0 on success.
int RunRender(const RenderOptions& options);

}  // namespace pneumatic

namespace pneumatic::cli {

// Adds `pneumo render` to app.
Command AddRenderCommand(CLI::App& app);

}  // namespace pneumatic::cli

#endif  // PNEUMATIC_CLI_RENDER_COMMAND_H_
