// The one place that touches MuJoCo's global callbacks: a registry of attached
// models, and the three callbacks that dispatch an actuator to its cylinder.
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <unordered_map>

#include "cylinder.h"
#include "pneumatic/pneumatic.h"

namespace pneumatic {
namespace {

constexpr char kConfigPrefix[] = "pneumatic:";

struct AttachedModel {
  std::vector<Cylinder> cylinders;
  std::vector<ActuatorRole> roles;  // by actuator id
};

// models are added and removed rarely, looked up on every actuator of every step:
// a shared lock lets steps on different threads read at once
struct Registry {
  std::shared_mutex mutex;
  std::unordered_map<const mjModel*, std::unique_ptr<AttachedModel>> models;
  mjfAct previous_dyn = nullptr;
  mjfAct previous_gain = nullptr;
  mjfAct previous_bias = nullptr;
};

Registry& GetRegistry() {
  static Registry registry;
  return registry;
}

// the attached model m, or nullptr; call under the lock
const AttachedModel* Find(const Registry& r, const mjModel* m) {
  auto it = r.models.find(m);
  return it == r.models.end() ? nullptr : it->second.get();
}

mjtNum ActDyn(const mjModel* m, const mjData* d, int id) {
  Registry& r = GetRegistry();
  std::shared_lock lock(r.mutex);
  const AttachedModel* model = Find(r, m);
  ActuatorRole role = model ? model->roles[id] : ActuatorRole{};
  switch (role.role) {
    case Role::kChamber: return model->cylinders[role.cylinder].ChamberActDot(m, d, role.index);
    case Role::kCommand: return role.index >= 0 ? model->cylinders[role.cylinder].ValveActDot(m, d, role.index) : 0;
    case Role::kFriction: return 0;
    case Role::kNone: break;
  }
  return r.previous_dyn ? r.previous_dyn(m, d, id) : 0;
}

mjtNum ActGain(const mjModel* m, const mjData* d, int id) {
  Registry& r = GetRegistry();
  std::shared_lock lock(r.mutex);
  const AttachedModel* model = Find(r, m);
  ActuatorRole role = model ? model->roles[id] : ActuatorRole{};
  switch (role.role) {
    case Role::kChamber: return model->cylinders[role.cylinder].ChamberGain(role.index);
    case Role::kCommand:
    case Role::kFriction: return 0;
    case Role::kNone: break;
  }
  // MuJoCo's own default for a user gain without a callback is 1
  return r.previous_gain ? r.previous_gain(m, d, id) : 1;
}

mjtNum ActBias(const mjModel* m, const mjData* d, int id) {
  Registry& r = GetRegistry();
  std::shared_lock lock(r.mutex);
  const AttachedModel* model = Find(r, m);
  ActuatorRole role = model ? model->roles[id] : ActuatorRole{};
  switch (role.role) {
    case Role::kFriction: return model->cylinders[role.cylinder].FrictionBias(m, d);
    case Role::kChamber:
    case Role::kCommand: return 0;
    case Role::kNone: break;
  }
  return r.previous_bias ? r.previous_bias(m, d, id) : 0;
}

// reads and binds every "pneumatic:<name>" text element of m
std::unique_ptr<AttachedModel> Build(const mjModel* m, std::string* error) {
  auto model = std::make_unique<AttachedModel>();
  model->roles.assign(m->nu, ActuatorRole{});
  for (int i = 0; i < m->ntext; ++i) {
    std::string element = m->names + m->name_textadr[i];
    if (element.rfind(kConfigPrefix, 0) != 0) continue;
    std::string name = element.substr(sizeof(kConfigPrefix) - 1);
    if (name.empty()) {
      *error = "custom text '" + element + "': missing the cylinder name after 'pneumatic:'";
      return nullptr;
    }
    std::optional<CylinderConfig> config = ParseCylinderConfig(name, m->text_data + m->text_adr[i], error);
    if (!config) return nullptr;
    std::optional<Cylinder> cylinder = Cylinder::FromModel(m, std::move(*config), error);
    if (!cylinder) return nullptr;
    int index = static_cast<int>(model->cylinders.size());
    for (auto [id, role] : cylinder->actuators()) {
      role.cylinder = index;
      model->roles[id] = role;
    }
    model->cylinders.push_back(std::move(*cylinder));
  }
  // the exact chamber step relies on act += h * act_dot once per step
  if (!model->cylinders.empty() && m->opt.integrator == mjINT_RK4) {
    *error = "integrator RK4 is not supported: it evaluates act_dot at intermediate stages, where the "
             "exact chamber step does not apply; use integrator=\"Euler\" or \"implicit\"";
    return nullptr;
  }
  return model;
}

}  // namespace

bool Attach(const mjModel* m, std::string* error) {
  std::string ignored;
  if (!error) error = &ignored;
  if (!m) {
    *error = "model is null";
    return false;
  }
  std::unique_ptr<AttachedModel> model = Build(m, error);
  if (!model) return false;
  Registry& r = GetRegistry();
  std::unique_lock lock(r.mutex);
  if (r.models.empty()) {
    r.previous_dyn = mjcb_act_dyn;
    r.previous_gain = mjcb_act_gain;
    r.previous_bias = mjcb_act_bias;
    mjcb_act_dyn = ActDyn;
    mjcb_act_gain = ActGain;
    mjcb_act_bias = ActBias;
  }
  r.models[m] = std::move(model);
  return true;
}

void Detach(const mjModel* m) {
  Registry& r = GetRegistry();
  std::unique_lock lock(r.mutex);
  if (!r.models.erase(m) || !r.models.empty()) return;
  // restore what was there before, unless someone replaced our callbacks meanwhile
  if (mjcb_act_dyn == ActDyn) mjcb_act_dyn = r.previous_dyn;
  if (mjcb_act_gain == ActGain) mjcb_act_gain = r.previous_gain;
  if (mjcb_act_bias == ActBias) mjcb_act_bias = r.previous_bias;
}

bool IsAttached(const mjModel* m) {
  Registry& r = GetRegistry();
  std::shared_lock lock(r.mutex);
  return Find(r, m) != nullptr;
}

std::vector<CylinderInfo> Cylinders(const mjModel* m) {
  Registry& r = GetRegistry();
  std::shared_lock lock(r.mutex);
  std::vector<CylinderInfo> out;
  if (const AttachedModel* model = Find(r, m)) {
    for (const Cylinder& c : model->cylinders) out.push_back(c.info());
  }
  return out;
}

}  // namespace pneumatic
