#include "model_loading.h"

#include "pneumatic/pneumatic.h"

namespace pneumatic {

ModelPtr LoadAttachedModel(const std::string& path, std::string* error) {
  char buffer[1000] = "";
  ModelPtr m(mj_loadXML(path.c_str(), nullptr, buffer, sizeof(buffer)), mj_deleteModel);
  if (!m) {
    *error = path + ": " + buffer;
    return ModelPtr(nullptr, mj_deleteModel);
  }
  std::string why;
  if (!Attach(m.get(), &why)) {
    *error = path + ": " + why;
    return ModelPtr(nullptr, mj_deleteModel);
  }
  return m;
}

}  // namespace pneumatic
