// Writing a copy of an MJCF model file with the cylinders' current parameters: how a fit
// (pneumo identify --write-model) hands its result back as a model that loads and runs.
#ifndef PNEUMATIC_MODEL_FILE_H_
#define PNEUMATIC_MODEL_FILE_H_

#include <string>

#include <mujoco/mujoco.h>

namespace pneumatic {

// Writes to `out_path` the MJCF text of `source_path` with the data of every "pneumatic:<cylinder>"
// element replaced by the configuration stored in m (ConfigurationText: every key that applies,
// exact numbers) and `note` as an XML comment above each replaced element; everything else stays
// as written. m must be attached and loaded from `source_path` (its parameters possibly changed
// with SetParameter). The written file is then loaded and stepped once to check that it loads and
// runs. Returns "" or the error: a cylinder whose element is not in the file itself (e.g. in an
// included file), an output that cannot be written (as WriteOutput), a written model that does
// not load (e.g. relative asset paths from another directory).
std::string WriteModelWithParameters(const std::string& source_path, const mjModel* m, const std::string& out_path,
                                     const std::string& note);

}  // namespace pneumatic

#endif  // PNEUMATIC_MODEL_FILE_H_
