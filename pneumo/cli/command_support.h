// What the verbs of the command line share: a verb as its subcommand and what runs it, the
// "pneumo: " failure message, and a model file loaded with the extension attached.
#ifndef PNEUMATIC_CLI_COMMAND_SUPPORT_H_
#define PNEUMATIC_CLI_COMMAND_SUPPORT_H_

#include <cstdio>
#include <functional>
#include <string>

#include <CLI/CLI.hpp>
#include <mujoco/mujoco.h>

#include "pneumatic/pneumatic.h"

namespace pneumatic::cli {

// One verb: its subcommand of the app (options bound to storage the verb owns) and what runs it
// once the command line is parsed, returning the exit code.
struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

// a model loaded from MJCF and attached to the extension, released in order
struct AttachedModel {
  mjModel* model = nullptr;
  ~AttachedModel() {
    if (model) {
      pneumatic::Detach(model);
      mj_deleteModel(model);
    }
  }
};

inline int Fail(const std::string& message) {
  std::fprintf(stderr, "pneumo: %s\n", message.c_str());
  return 1;
}

// loads and attaches; an empty string on success
inline std::string Load(const std::string& path, AttachedModel* out) {
  char error[1000] = "";
  out->model = mj_loadXML(path.c_str(), nullptr, error, sizeof(error));
  if (!out->model) return path + ": " + error;
  std::string attach_error;
  if (!pneumatic::Attach(out->model, &attach_error)) return path + ": " + attach_error;
  return "";
}

}  // namespace pneumatic::cli

#endif  // PNEUMATIC_CLI_COMMAND_SUPPORT_H_
