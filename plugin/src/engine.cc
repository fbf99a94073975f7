// The extension's hold on MuJoCo: each cylinder's parameters stored in its model,
// the callbacks that find them there, and the pass that steps every cylinder at once.
//
// Storage: every actuator of a cylinder carries two numbers at the front of its
// actuator_user data: a tag, and the model's fingerprint (a hash of every cylinder's
// parameters and actuator ids). The cylinder's "<name>.P" actuator also carries its
// whole configuration, packed as numbers (PackConfig). mj_copyModel copies all of
// it, so a copy steps like its original; nothing outside the model refers to it.
//
// Decoding: the step needs the configuration decoded (flow-law constants, actuator
// ids). Each thread keeps the last few decoded models keyed by fingerprint. Equal
// fingerprints mean equal parameters and ids, so a cached entry is never stale: a
// freed model leaves only an entry no other model can match, and a changed
// parameter gives a new fingerprint.
//
// The pass: MuJoCo 2.2.2's mj_fwdActuation computes every actuator force, then
// act_dot in increasing actuator id. The first pneumatic actuator with user
// dynamics (the model's leader) computes the act_dot of every cylinder at once,
// with one control check and one velocity prediction; the others return theirs.
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cmath>
#include <cstring>
#include <memory>
#include <mutex>
#include <sstream>

#include "cylinder.h"
#include "pneumatic/pneumatic.h"
#include "velocity_prediction.h"

namespace pneumatic {
namespace {

constexpr char kConfigPrefix[] = "pneumatic:";

// actuator_user slots: [0] tag, [1] fingerprint, then the packed configuration ("<name>.P" only)
constexpr int kTagSlot = 0, kFingerprintSlot = 1, kConfigSlot = 2;
// tags: arbitrary values no model would hold by chance
constexpr double kMemberTag = 7.3612e-291;  // an actuator of a cylinder
constexpr double kHomeTag = 7.3613e-291;    // "<name>.P", which holds the configuration
constexpr double kDetachedTag = 7.3614e-291;  // an actuator of a detached cylinder (its gain stays fixed)

// everything a step needs, decoded from a model
struct CompiledModel {
  double fingerprint = 0;
  std::vector<Cylinder> cylinders;
  std::vector<ActuatorRole> roles;  // by actuator id
  int leader = -1;                  // the pneumatic actuator whose act_dot MuJoCo asks for first
  bool predicts_velocity = false;   // some cylinder follows the predicted end-of-step velocity
};

// the callbacks installed before ours, for every actuator that is not pneumatic; atomic, since
// Attach may install while other threads step other models
struct Previous {
  std::mutex installing;
  std::atomic<mjfAct> dyn{nullptr};
  std::atomic<mjfAct> bias{nullptr};
};
Previous& GetPrevious() {
  static Previous previous;
  return previous;
}

const double* UserData(const mjModel* m, int id) {
  return m->nuser_actuator > kConfigSlot ? m->actuator_user + static_cast<size_t>(id) * m->nuser_actuator : nullptr;
}

bool IsTagged(const mjModel* m, int id) {
  const double* user = UserData(m, id);
  return user && (user[kTagSlot] == kMemberTag || user[kTagSlot] == kHomeTag);
}

// FNV-1a over the bytes of everything a decoding takes from the model: every cylinder's name,
// packed configuration, actuator ids and roles, and its transmission (type, target, gear, the
// joint's dof and frictionloss); 52 bits, so that a double holds it exactly
double Fingerprint(const mjModel* m, const std::vector<Cylinder>& cylinders) {
  uint64_t hash = 1469598103934665603ULL;
  auto mix = [&](const void* data, size_t size) {
    const unsigned char* bytes = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < size; ++i) hash = (hash ^ bytes[i]) * 1099511628211ULL;
  };
  mix(&m->nu, sizeof(m->nu));
  std::vector<double> packed(PackedConfigSize());
  for (const Cylinder& c : cylinders) {
    mix(c.info().name.data(), c.info().name.size());
    PackConfig(c.config(), packed.data());
    mix(packed.data(), packed.size() * sizeof(double));
    for (const auto& [id, role] : c.actuators()) {
      mix(&id, sizeof(id));
      mix(&role.role, sizeof(role.role));
      mix(&role.index, sizeof(role.index));
    }
    int p = c.info().chamber_actuator[0];
    mix(m->actuator_trntype + p, sizeof(int));
    mix(m->actuator_trnid + 2 * p, 2 * sizeof(int));
    mix(m->actuator_gear + 6 * p, 6 * sizeof(mjtNum));
    Cylinder::Binding binding = c.binding();
    mix(&binding.dof, sizeof(binding.dof));  // field by field: no padding bytes
    mix(&binding.static_friction, sizeof(binding.static_friction));
  }
  return static_cast<double>(hash & ((uint64_t{1} << 52) - 1));
}

// roles by actuator, the leader and the fingerprint of a model's bound cylinders
std::unique_ptr<CompiledModel> Finish(const mjModel* m, std::vector<Cylinder> cylinders) {
  auto model = std::make_unique<CompiledModel>();
  model->roles.assign(m->nu, ActuatorRole{});
  for (size_t c = 0; c < cylinders.size(); ++c) {
    for (auto [id, role] : cylinders[c].actuators()) {
      role.cylinder = static_cast<int>(c);
      model->roles[id] = role;
      if (m->actuator_dyntype[id] == mjDYN_USER && (model->leader < 0 || id < model->leader)) model->leader = id;
    }
    model->predicts_velocity |= cylinders[c].NeedsEndVelocity();
  }
  model->fingerprint = Fingerprint(m, cylinders);
  model->cylinders = std::move(cylinders);
  return model;
}

// the cylinders as the MJCF text elements "pneumatic:<name>" describe them
std::unique_ptr<CompiledModel> CompileFromText(const mjModel* m, std::string* error) {
  std::vector<Cylinder> cylinders;
  // a model attached before has fixed chamber gains, which the binding then accepts
  bool attached_before = false;
  for (int id = 0; id < m->nu; ++id) {
    const double* user = UserData(m, id);
    attached_before |= IsTagged(m, id) || (user && user[kTagSlot] == kDetachedTag);
  }
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
    std::optional<Cylinder> cylinder = Cylinder::FromModel(m, std::move(*config), attached_before, error);
    if (!cylinder) return nullptr;
    cylinders.push_back(std::move(*cylinder));
  }
  return Finish(m, std::move(cylinders));
}

// the cylinders as stored in the model's actuator_user data
std::unique_ptr<CompiledModel> CompileFromStorage(const mjModel* m, std::string* error) {
  std::vector<Cylinder> cylinders;
  for (int id = 0; id < m->nu; ++id) {
    const double* user = UserData(m, id);
    if (!user || user[kTagSlot] != kHomeTag) continue;
    std::string actuator = mj_id2name(m, mjOBJ_ACTUATOR, id) ? mj_id2name(m, mjOBJ_ACTUATOR, id) : "";
    std::string name = actuator.size() > 2 ? actuator.substr(0, actuator.size() - 2) : "";
    std::optional<CylinderConfig> config = UnpackConfig(name, user + kConfigSlot, error);
    if (!config) return nullptr;
    std::optional<Cylinder> cylinder = Cylinder::FromModel(m, std::move(*config), true, error);
    if (!cylinder) return nullptr;
    cylinders.push_back(std::move(*cylinder));
  }
  return Finish(m, std::move(cylinders));
}

// writes the cylinders' tags, fingerprint, configurations and gains into m
void Store(mjModel* m, const CompiledModel& model) {
  for (const Cylinder& c : model.cylinders) {
    for (const auto& [id, role] : c.actuators()) {
      double* user = m->actuator_user + static_cast<size_t>(id) * m->nuser_actuator;
      bool home = id == c.info().chamber_actuator[0];
      user[kTagSlot] = home ? kHomeTag : kMemberTag;
      user[kFingerprintSlot] = model.fingerprint;
      if (home) PackConfig(c.config(), user + kConfigSlot);
    }
    c.WriteGains(m);
  }
}

// this thread's decoded models, most recently used first
struct ThreadCache {
  static constexpr size_t kSize = 8;
  std::vector<std::shared_ptr<const CompiledModel>> models;

  std::shared_ptr<const CompiledModel> Find(double fingerprint) {
    for (size_t i = 0; i < models.size(); ++i) {
      if (models[i]->fingerprint != fingerprint) continue;
      if (i > 0) std::rotate(models.begin(), models.begin() + i, models.begin() + i + 1);
      return models[0];
    }
    return nullptr;
  }
  void Add(std::shared_ptr<const CompiledModel> model) {
    models.insert(models.begin(), std::move(model));
    if (models.size() > kSize) models.pop_back();
  }
};
ThreadCache& GetThreadCache() {
  thread_local ThreadCache cache;
  return cache;
}

// the decoded model that actuator `id` of m belongs to, or null if it is not pneumatic
const CompiledModel* Lookup(const mjModel* m, int id) {
  if (!IsTagged(m, id)) return nullptr;
  double fingerprint = UserData(m, id)[kFingerprintSlot];
  ThreadCache& cache = GetThreadCache();
  // the hot path: the model stepped last on this thread
  if (!cache.models.empty() && cache.models[0]->fingerprint == fingerprint) return cache.models[0].get();
  if (auto found = cache.Find(fingerprint)) return found.get();
  // first step of this model on this thread: decode what the model stores
  std::string error;
  std::shared_ptr<CompiledModel> model = CompileFromStorage(m, &error);
  if (!model || model->fingerprint != fingerprint) {
    mju_warning_s("pneumatic: the cylinder parameters stored in this model are damaged (%s); attach it again",
                  model ? "fingerprint mismatch" : error.c_str());
    return nullptr;
  }
  cache.Add(model);
  return model.get();
}

// MuJoCo zeroes every control (mjWARN_BADCTRL) if any clamped control is NaN or beyond 1e10
bool AnyBadControl(const mjModel* m, const mjData* d) {
  bool clamp = !(m->opt.disableflags & mjDSBL_CLAMPCTRL);
  for (int id = 0; id < m->nu; ++id) {
    double u = d->ctrl[id];
    if (clamp && m->actuator_ctrllimited[id]) {
      u = mju_clip(u, m->actuator_ctrlrange[2 * id], m->actuator_ctrlrange[2 * id + 1]);
    }
    if (!(std::fabs(u) <= mjMAXVAL)) return true;  // mju_isBad, inlined: NaN or beyond 1e10
  }
  return false;
}

// the forces the velocity prediction reads are current when act_dot is computed (MuJoCo 2.2.2
// computes actuator forces first); a chamber whose force is not its gain times its act says otherwise
bool ForcesAreCurrent(const mjModel* m, const mjData* d, const CompiledModel& model) {
  for (const Cylinder& c : model.cylinders) {
    int id = c.info().chamber_actuator[0];
    double force = m->actuator_gainprm[id * mjNGAIN] * d->act[id - (m->nu - m->na)];
    if (m->actuator_forcelimited[id]) force = mju_clip(force, m->actuator_forcerange[2 * id], m->actuator_forcerange[2 * id + 1]);
    if (d->actuator_force[id] != force) return false;
  }
  return true;
}

// every cylinder's act_dot for this forward pass
void StepPass(const CompiledModel& model, const mjModel* m, mjData* d) {
  PassInputs pass;
  pass.zero_commands = AnyBadControl(m, d);
  mjMARKSTACK;
  if (model.predicts_velocity) {
    if (!ForcesAreCurrent(m, d, model)) {
      static std::atomic<bool> warned{false};
      if (!warned.exchange(true)) {
        mju_warning("pneumatic: actuator forces are not current when act_dot is computed (MuJoCo's call order "
                    "differs from 2.2.2's); the chamber volumes follow a velocity predicted from stale forces");
      }
    }
    mjtNum* velocity = mj_stackAlloc(d, m->nv);
    PredictEndOfStepVelocity(m, d, velocity);
    pass.end_velocity = velocity;
  }
  for (const Cylinder& c : model.cylinders) c.Step(m, d, pass);
  mjFREESTACK;
}

mjtNum ActDyn(const mjModel* m, const mjData* d, int id) {
  const CompiledModel* model = Lookup(m, id);
  if (!model) {
    mjfAct previous = GetPrevious().dyn.load(std::memory_order_relaxed);
    return previous ? previous(m, d, id) : 0;
  }
  // the pass writes every pneumatic act_dot of d at once; act_dot is MuJoCo's output slot for them
  mjData* data = const_cast<mjData*>(d);
  if (id == model->leader) StepPass(*model, m, data);
  return d->act_dot[id - (m->nu - m->na)];
}

mjtNum ActBias(const mjModel* m, const mjData* d, int id) {
  const CompiledModel* model = Lookup(m, id);
  if (model && model->roles[id].role == Role::kFriction) {
    return model->cylinders[model->roles[id].cylinder].FrictionBias(m, d);
  }
  if (model) return 0;
  mjfAct previous = GetPrevious().bias.load(std::memory_order_relaxed);
  return previous ? previous(m, d, id) : 0;
}

// ours in MuJoCo's global callbacks, keeping whatever was there to serve the other actuators;
// they stay installed (a model needs no detaching), and a later Attach takes them back if
// someone replaced them
void InstallCallbacks() {
  Previous& previous = GetPrevious();
  std::lock_guard<std::mutex> lock(previous.installing);
  if (mjcb_act_dyn != ActDyn) previous.dyn = mjcb_act_dyn, mjcb_act_dyn = ActDyn;
  if (mjcb_act_bias != ActBias) previous.bias = mjcb_act_bias, mjcb_act_bias = ActBias;
}

// the decoded model of m, or null and *error
std::shared_ptr<const CompiledModel> Compiled(const mjModel* m, std::string* error) {
  if (!m) {
    *error = "model is null";
    return nullptr;
  }
  for (int id = 0; id < m->nu; ++id) {
    if (!IsTagged(m, id)) continue;
    if (!Lookup(m, id)) break;
    return GetThreadCache().Find(UserData(m, id)[kFingerprintSlot]);
  }
  *error = "the model is not attached to the pneumatic extension";
  return nullptr;
}

// stores `model` in m and makes it the current decoding
bool StoreModel(mjModel* m, std::shared_ptr<CompiledModel> model, std::string* error) {
  if (kConfigSlot + PackedConfigSize() > ActuatorUserSize()) {
    mju_error("pneumatic: the parameter table outgrew ActuatorUserSize(); raise it");
  }
  if (!model->cylinders.empty() && m->nuser_actuator < ActuatorUserSize()) {
    *error = "the model stores each cylinder's parameters in its actuators' user data: add <size nuser_actuator=\"" +
             std::to_string(ActuatorUserSize()) + "\"/> to the MJCF (it has " + std::to_string(m->nuser_actuator) + ")";
    return false;
  }
  // the chamber steps rely on act += h * act_dot once per step
  if (!model->cylinders.empty() && m->opt.integrator == mjINT_RK4) {
    *error = "integrator RK4 is not supported: it evaluates act_dot at intermediate stages, where the "
             "whole-step chamber update does not apply; use integrator=\"Euler\" or \"implicit\"";
    return false;
  }
  Store(m, *model);
  GetThreadCache().Add(std::move(model));
  InstallCallbacks();
  return true;
}

}  // namespace

// a round number with room for the keys that effects will add, so that models keep loading
int ActuatorUserSize() { return 128; }

bool Attach(mjModel* m, std::string* error) {
  std::string ignored;
  if (!error) error = &ignored;
  if (!m) {
    *error = "model is null";
    return false;
  }
  std::unique_ptr<CompiledModel> model = CompileFromText(m, error);
  return model && StoreModel(m, std::move(model), error);
}

void Detach(mjModel* m) {
  if (!m) return;
  for (int id = 0; id < m->nu; ++id) {
    if (IsTagged(m, id)) m->actuator_user[static_cast<size_t>(id) * m->nuser_actuator + kTagSlot] = kDetachedTag;
  }
}

bool IsAttached(const mjModel* m) {
  std::string ignored;
  return m && Compiled(m, &ignored) != nullptr;
}

std::vector<CylinderInfo> Cylinders(const mjModel* m) {
  std::string ignored;
  std::vector<CylinderInfo> out;
  if (auto model = m ? Compiled(m, &ignored) : nullptr) {
    for (const Cylinder& c : model->cylinders) out.push_back(c.info());
  }
  return out;
}

namespace {

// the index of cylinder `name` in an attached model, or -1 and *error
int FindCylinder(const CompiledModel& model, const std::string& name, std::string* error) {
  for (size_t i = 0; i < model.cylinders.size(); ++i) {
    if (model.cylinders[i].info().name == name) return static_cast<int>(i);
  }
  *error = "no cylinder '" + name + "' in the model";
  return -1;
}

// the compiled model of m and, in *config, the configuration of its cylinder `name`; null and
// *error if m is not attached or has no such cylinder
std::shared_ptr<const CompiledModel> CompiledCylinder(const mjModel* m, const std::string& name, std::string* error,
                                                      const CylinderConfig** config) {
  std::shared_ptr<const CompiledModel> model = Compiled(m, error);
  if (!model) return nullptr;
  int index = FindCylinder(*model, name, error);
  if (index < 0) return nullptr;
  *config = &model->cylinders[index].config();
  return model;
}

}  // namespace

std::optional<double> GetParameter(const mjModel* m, const std::string& cylinder, const std::string& key,
                                   std::string* error) {
  std::string ignored;
  const CylinderConfig* config = nullptr;
  std::shared_ptr<const CompiledModel> model = CompiledCylinder(m, cylinder, error ? error : &ignored, &config);
  if (!model) return std::nullopt;
  return ConfigValue(*config, key, error ? error : &ignored);
}

std::optional<std::string> GetChoice(const mjModel* m, const std::string& cylinder, const std::string& key,
                                     std::string* error) {
  std::string ignored;
  if (!error) error = &ignored;
  std::optional<double> index = GetParameter(m, cylinder, key, error);
  if (!index) return std::nullopt;
  const std::string base = key.rfind("P.", 0) == 0 || key.rfind("N.", 0) == 0 ? key.substr(2) : key;
  for (const ParameterDoc& doc : Parameters()) {
    if (doc.key != base) continue;
    if (!doc.is_choice) break;
    std::istringstream choices(doc.valid);
    std::string choice;
    for (int i = 0; choices >> choice; ++i) {
      if (i == static_cast<int>(*index)) return choice;
    }
  }
  *error = "cylinder '" + cylinder + "': key '" + key + "' is not a choice";
  return std::nullopt;
}

bool SetParameters(mjModel* m, const std::string& cylinder,
                   const std::vector<std::pair<std::string, std::string>>& values, std::string* error) {
  std::string ignored;
  if (!error) error = &ignored;
  std::shared_ptr<const CompiledModel> model = Compiled(m, error);
  if (!model) return false;
  int index = FindCylinder(*model, cylinder, error);
  if (index < 0) return false;
  std::optional<CylinderConfig> config = WithValues(model->cylinders[index].config(), values, error);
  if (!config) return false;
  std::optional<Cylinder> bound = Cylinder::FromModel(m, std::move(*config), true, error);
  if (!bound) return false;
  std::vector<Cylinder> cylinders = model->cylinders;
  cylinders[index] = std::move(*bound);
  return StoreModel(m, Finish(m, std::move(cylinders)), error);
}

bool SetParameter(mjModel* m, const std::string& cylinder, const std::string& key, const std::string& value,
                  std::string* error) {
  return SetParameters(m, cylinder, {{key, value}}, error);
}

std::optional<std::string> ConfigurationText(const mjModel* m, const std::string& cylinder, std::string* error) {
  std::string ignored;
  const CylinderConfig* config = nullptr;
  if (!CompiledCylinder(m, cylinder, error ? error : &ignored, &config)) return std::nullopt;
  return FormatConfig(*config);
}

bool SetParameter(mjModel* m, const std::string& cylinder, const std::string& key, double value, std::string* error) {
  return SetParameter(m, cylinder, key, FormatNumber(value), error);
}

}  // namespace pneumatic
