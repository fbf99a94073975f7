#include "formats/model_loading.h"

#include <algorithm>

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

ModelPtr LoadModelFromText(const std::string& xml, const std::string& virtual_name, std::string* error) {
  auto vfs = std::make_unique<mjVFS>();  // megabytes of file names: not on the stack
  mj_defaultVFS(vfs.get());
  if (mj_makeEmptyFileVFS(vfs.get(), virtual_name.c_str(), static_cast<int>(xml.size())) != 0) {
    *error = "cannot make the virtual file '" + virtual_name + "'";
    mj_deleteVFS(vfs.get());
    return ModelPtr(nullptr, mj_deleteModel);
  }
  std::copy(xml.begin(), xml.end(), static_cast<char*>(vfs->filedata[mj_findFileVFS(vfs.get(), virtual_name.c_str())]));
  char buffer[1000] = "";
  ModelPtr m(mj_loadXML(virtual_name.c_str(), vfs.get(), buffer, sizeof(buffer)), mj_deleteModel);
  mj_deleteVFS(vfs.get());
  if (!m) *error = buffer;
  return m;
}

}  // namespace pneumatic
