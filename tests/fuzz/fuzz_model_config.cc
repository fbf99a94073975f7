// libFuzzer target: the pneumatic MJCF configuration. The input is the text of a shipped rig's
// "pneumatic:cyl" element (its first byte picks the rig), written into a copy of that rig's compiled
// model in place of its own text; Attach must refuse it with a message or accept it, and an accepted
// model is stepped 50 steps under the tests' command pattern. Any crash, leak, undefined behaviour or
// hang is a finding; so is a state that turns NaN without MuJoCo's warning.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "pneumatic/pneumatic.h"
#include "test_util.h"

namespace {

constexpr int kRoom = 8192;  // bytes of configuration text the compiled models have room for

struct Rig {
  mjModel* model = nullptr;  // compiled with a long configuration text, not attached
  int text = -1;             // index of its "pneumatic:cyl" text element
};

// the rig's MJCF with its configuration text padded to kRoom characters (spaces the parser skips)
Rig Load(const char* file) {
  std::string xml = pneumatic::testing::ReadText(pneumatic::testing::ShippedModel(file));
  const size_t data = xml.find("data=\"", xml.find("name=\"pneumatic:cyl\"")) + 6;
  const size_t end = xml.find('"', data);
  xml.insert(end, std::string(kRoom - (end - data), ' '));
  std::string error;
  Rig rig;
  rig.model = pneumatic::testing::LoadModelFromString(xml, &error);
  if (!rig.model) {
    std::fprintf(stderr, "%s: %s\n", file, error.c_str());
    std::abort();
  }
  rig.text = mj_name2id(rig.model, mjOBJ_TEXT, "pneumatic:cyl");
  return rig;
}

// the four rigs, freed at exit (LeakSanitizer checks after the static destructors)
struct Rigs {
  std::vector<Rig> all;
  Rigs() {
    for (const char* file : pneumatic::testing::kShippedRigs) all.push_back(Load(file));
  }
  ~Rigs() {
    for (Rig& rig : all) mj_deleteModel(rig.model);
  }
};

bool warned = false;
void OnWarning(const char*) { warned = true; }

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const Rigs rigs;
  mju_user_warning = OnWarning;
  if (size == 0) return 0;
  const Rig& rig = rigs.all[data[0] % rigs.all.size()];
  mjModel* m = mj_copyModel(nullptr, rig.model);
  const std::string text(reinterpret_cast<const char*>(data) + 1, std::min<size_t>(size - 1, kRoom));
  char* slot = m->text_data + m->text_adr[rig.text];
  std::memset(slot, ' ', static_cast<size_t>(m->text_size[rig.text] - 1));
  std::memcpy(slot, text.c_str(), std::strlen(text.c_str()));  // up to an embedded NUL, as MuJoCo would hold it

  std::string error;
  if (pneumatic::Attach(m, &error)) {
    const std::vector<pneumatic::CylinderInfo> cylinders = pneumatic::Cylinders(m);
    mjData* d = mj_makeData(m);
    warned = false;
    for (int step = 0; step < 50; ++step) {
      for (const pneumatic::CylinderInfo& c : cylinders) pneumatic::testing::PatternCommand(c, d, step);
      mj_step(m, d);
    }
    for (int i = 0; i < m->na; ++i) {
      if (!std::isfinite(d->act[i]) && !warned) {
        std::fprintf(stderr, "act[%d] is %g after 50 steps, with no MuJoCo warning\n", i, d->act[i]);
        std::abort();
      }
    }
    mj_deleteData(d);
  } else if (error.empty()) {
    std::fprintf(stderr, "Attach refused the configuration without a message\n");
    std::abort();
  }
  mj_deleteModel(m);
  return 0;
}
