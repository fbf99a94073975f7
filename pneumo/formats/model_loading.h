// Loading an MJCF file with the extension attached, for the commands that start from a model file.
#ifndef PNEUMATIC_MODEL_LOADING_H_
#define PNEUMATIC_MODEL_LOADING_H_

#include <memory>
#include <string>

#include <mujoco/mujoco.h>

namespace pneumatic {

using ModelPtr = std::unique_ptr<mjModel, void (*)(mjModel*)>;

// Loads the MJCF file at `path` and attaches the extension; null and *error ("<path>: why") when
// MuJoCo refuses the file or the extension its configuration.
ModelPtr LoadAttachedModel(const std::string& path, std::string* error);

// Compiles MJCF text (not attached) through MuJoCo's virtual file system, as the file `virtual_name`:
// MuJoCo looks a file up there first, and resolves includes and assets relative to that name's
// directory. Null and *error (MuJoCo's message) on failure.
ModelPtr LoadModelFromText(const std::string& xml, const std::string& virtual_name, std::string* error);

}  // namespace pneumatic

#endif  // PNEUMATIC_MODEL_LOADING_H_
