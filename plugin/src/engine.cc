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
// ids, the static friction a joint's frictionloss gives). Each thread keeps the last
// few decodings, each keyed by the stored fingerprint and by the values of the
// mjModel fields it read that users may edit between steps (EditableFields: gears,
// frictionloss, types, timestep, integrator; domain randomisation writes them). The
// first callback MuJoCo makes for a model in each forward pass (its gate) compares
// those fields and decodes the model again when they changed, so an edit reads the
// same on every thread, as if the model had been attached with the edited values. An
// edit that makes the model invalid (RK4, a timestep the PWM carrier does not allow,
// a gear of 0) is warned of once and holds every pneumatic state, on every thread,
// until it is undone. Equal fingerprints and fields mean equal decodings, so a cached
// entry is never stale: a freed model leaves only an entry no other model can match.
//
// The pass: MuJoCo 2.2.2's mj_fwdActuation computes every actuator force, then
// act_dot in increasing actuator id. The first pneumatic actuator with user
// dynamics (the model's leader) computes the act_dot of every cylinder at once,
// with one control check and one velocity prediction; the others return theirs.
//
// Supply reservoirs ("pneumatic_reservoir:<name>", reservoir.h) are stored the same way: their
// "<name>.pressure" actuator carries its own tag, the fingerprint and the reservoir's packed
// configuration, and the "<cylinder>.P" actuator of each cylinder it feeds carries the
// reservoir actuator's id (plus one) after its packed configuration. The pass steps a reservoir
// together with the chambers it feeds (StepPass).
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cmath>
#include <cstring>
#include <memory>
#include <mutex>
#include <sstream>

#include "chamber_batch.h"
#include "cylinder.h"
#include "pneumatic/pneumatic.h"
#include "reservoir.h"
#include "velocity_prediction.h"

namespace pneumatic {
namespace {

constexpr char kConfigPrefix[] = "pneumatic:";

// actuator_user slots: [0] tag, [1] fingerprint, then the packed configuration ("<name>.P" only); the
// last slot (LeaderSlot) says which actuator leads the pass
constexpr int kTagSlot = 0, kFingerprintSlot = 1, kConfigSlot = 2;
// tags: arbitrary values no model would hold by chance
constexpr double kMemberTag = 7.3612e-291;  // an actuator of a cylinder
constexpr double kHomeTag = 7.3613e-291;    // "<name>.P", which holds the configuration
constexpr double kDetachedTag = 7.3614e-291;  // an actuator of a detached cylinder (its gain stays fixed)
constexpr double kReservoirTag = 7.3615e-291;  // "<reservoir>.pressure", which holds the reservoir's configuration
constexpr char kReservoirPrefix[] = "pneumatic_reservoir:";

// the slot of "<cylinder>.P"'s user data that holds its supply reservoir's actuator id plus one (0: none)
int SupplySlot() { return kConfigSlot + PackedConfigSize(); }
// the slot of every stored actuator's user data that is 1 for the model's leader, 0 for the others
int LeaderSlot() { return ActuatorUserSize() - 1; }

// everything a step needs, decoded from a model
struct CompiledModel {
  double fingerprint = 0;
  std::vector<Cylinder> cylinders;
  std::vector<BoundReservoir> reservoirs;
  std::vector<int> supply;          // by cylinder: the index of the reservoir feeding it, or -1
  std::vector<ActuatorRole> roles;  // by actuator id
  int leader = -1;                  // the pneumatic actuator whose act_dot MuJoCo asks for first
  bool predicts_velocity = false;   // some cylinder follows the predicted end-of-step velocity
  bool pose_dependent_gains = false;  // some cylinder has mount=hinge_sites: its gains are our gain callback's
};

// the callbacks installed before ours, for every actuator that is not pneumatic; atomic, since
// Attach may install while other threads step other models
struct Previous {
  std::mutex installing;
  std::atomic<mjfAct> dyn{nullptr};
  std::atomic<mjfAct> gain{nullptr};
  std::atomic<mjfAct> bias{nullptr};
};
Previous& GetPrevious() {
  static Previous previous;
  return previous;
}

// an actuator that is not pneumatic, passed to the callback installed before ours; without one, what
// MuJoCo 2.2.2 gives without a callback (`none`: gain 1, bias 0, act_dot 0). A callback that was
// installed after ours and passes what it does not handle on to ours (Attach then put ours back in
// front, chaining to it) comes back here for the same actuator: it gets `none` too, not a loop
mjtNum CallPrevious(const std::atomic<mjfAct>& slot, const mjModel* m, const mjData* d, int id, mjtNum none) {
  thread_local int depth = 0;
  mjfAct previous = slot.load(std::memory_order_relaxed);
  if (!previous || depth > 0) return none;
  ++depth;
  mjtNum value = previous(m, d, id);
  --depth;
  return value;
}

// an actuator's user data, if it has room for what the extension stores (StoreModel sees to it)
const double* UserData(const mjModel* m, int id) {
  return m->nuser_actuator >= ActuatorUserSize() ? m->actuator_user + static_cast<size_t>(id) * m->nuser_actuator
                                                 : nullptr;
}

bool IsTagged(const mjModel* m, int id) {
  const double* user = UserData(m, id);
  return user && (user[kTagSlot] == kMemberTag || user[kTagSlot] == kHomeTag || user[kTagSlot] == kReservoirTag);
}

// FNV-1a over the bytes of what Attach stores and names: every cylinder's name, packed
// configuration, actuator ids and roles, and the reservoirs and their links; 52 bits, so that a
// double holds it exactly. The mjModel fields a user may edit are not in it (EditableFields)
double Fingerprint(const mjModel* m, const std::vector<Cylinder>& cylinders,
                   const std::vector<BoundReservoir>& reservoirs, const std::vector<int>& supply) {
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
    if (c.info().rod_site >= 0) {  // mount=hinge_sites: the sites, found by name
      mix(&c.info().cap_site, sizeof(c.info().cap_site));
      mix(&c.info().rod_site, sizeof(c.info().rod_site));
    }
  }
  // reservoirs and the links to them (nothing for a model without: its fingerprint is as before)
  if (!reservoirs.empty()) {
    std::vector<double> packed_reservoir(PackedReservoirSize());
    for (const BoundReservoir& r : reservoirs) {
      mix(r.config.name.data(), r.config.name.size());
      PackReservoirConfig(r.config, packed_reservoir.data());
      mix(packed_reservoir.data(), packed_reservoir.size() * sizeof(double));
      mix(&r.actuator, sizeof(r.actuator));
    }
    for (int link : supply) mix(&link, sizeof(link));
  }
  return static_cast<double>(hash & ((uint64_t{1} << 52) - 1));
}

// Links each cylinder with supply=<name> to its reservoir: the reservoir takes the compressor
// pressure (p_supply) and the gas (r T) of the cylinders it feeds, which must agree; it must feed
// at least one cylinder, and its volume must exceed theirs (the stability condition of the step
// that couples them, StepPass). False and *error naming reservoir, cylinder and key otherwise.
bool Link(const std::vector<Cylinder>& cylinders, std::vector<BoundReservoir>* reservoirs, std::vector<int>* supply,
          std::string* error) {
  supply->assign(cylinders.size(), -1);
  for (BoundReservoir& r : *reservoirs) r.cylinders.clear();
  for (size_t c = 0; c < cylinders.size(); ++c) {
    const CylinderConfig& config = cylinders[c].config();
    if (config.supply.empty()) continue;
    auto found = std::find_if(reservoirs->begin(), reservoirs->end(),
                              [&](const BoundReservoir& r) { return r.config.name == config.supply; });
    if (found == reservoirs->end()) {
      *error = "cylinder '" + config.name + "': key 'supply': no reservoir '" + config.supply +
               "' in the model (a <text name=\"pneumatic_reservoir:" + config.supply + "\"> element)";
      return false;
    }
    (*supply)[c] = static_cast<int>(found - reservoirs->begin());
    found->cylinders.push_back(static_cast<int>(c));
  }
  for (BoundReservoir& r : *reservoirs) {
    std::string res = "reservoir '" + r.config.name + "': ";
    if (r.cylinders.empty()) {
      *error = res + "feeds no cylinder: its state '" + r.config.name + "." + kReservoirStateRole +
               "' would never be used; give the cylinders it feeds supply=" + r.config.name + ", or remove it";
      return false;
    }
    const CylinderConfig& first = cylinders[r.cylinders[0]].config();
    double chambers = 0;
    for (int c : r.cylinders) {
      const CylinderConfig& other = cylinders[c].config();
      chambers += cylinders[c].LargestVolume();
      const char* key = other.p_supply != first.p_supply         ? "p_supply"
                        : other.temperature != first.temperature   ? "temperature"
                        : other.gas_constant != first.gas_constant ? "gas_constant"
                                                                   : nullptr;
      if (key) {
        *error = "cylinder '" + other.name + "': key '" + key + "': differs from cylinder '" + first.name +
                 "', which reservoir '" + r.config.name + "' also feeds: a reservoir has one compressor (p_supply) "
                 "and holds one gas (temperature, gas_constant)";
        return false;
      }
    }
    if (!(r.config.volume > chambers)) {
      *error = res + "key 'volume': " + FormatNumber(r.config.volume) +
               " m^3 must exceed the largest volume of the chambers it feeds together, " + FormatNumber(chambers) +
               " m^3: the step that couples them is stable at any timestep only then (plugin/README.md)";
      return false;
    }
    r.model.p_source = first.p_supply;
    r.model.gas_rt = first.gas_constant * first.temperature;
    r.model.volume = r.config.volume;
    r.model.line_conductance = r.config.line_conductance;
    r.model.line = Iso6358Constants(r.config.line_critical_ratio);
  }
  return true;
}

// roles by actuator, the leader and the fingerprint of a model's bound cylinders and reservoirs;
// null and *error if the reservoirs do not link
std::unique_ptr<CompiledModel> Finish(const mjModel* m, std::vector<Cylinder> cylinders,
                                      std::vector<BoundReservoir> reservoirs, std::string* error) {
  auto model = std::make_unique<CompiledModel>();
  // the chamber steps rely on act += h * act_dot once per step
  if (!cylinders.empty() && m->opt.integrator == mjINT_RK4) {
    *error = "cylinder '" + cylinders[0].info().name + "': option 'integrator': RK4 is not supported: it evaluates "
             "act_dot at intermediate stages, where the whole-step chamber update does not apply; use "
             "integrator=\"Euler\" or \"implicit\"";
    return nullptr;
  }
  if (!Link(cylinders, &reservoirs, &model->supply, error)) return nullptr;
  model->roles.assign(m->nu, ActuatorRole{});
  for (size_t c = 0; c < cylinders.size(); ++c) {
    for (auto [id, role] : cylinders[c].actuators()) {
      role.cylinder = static_cast<int>(c);
      model->roles[id] = role;
      if (m->actuator_dyntype[id] == mjDYN_USER && (model->leader < 0 || id < model->leader)) model->leader = id;
    }
    model->predicts_velocity |= cylinders[c].NeedsEndVelocity();
    model->pose_dependent_gains |= cylinders[c].config().mount == Mount::kHingeSites;
  }
  for (size_t r = 0; r < reservoirs.size(); ++r) {
    int id = reservoirs[r].actuator;
    model->roles[id] = ActuatorRole{Role::kReservoir, static_cast<int>(r), 0};
    if (m->actuator_dyntype[id] == mjDYN_USER && (model->leader < 0 || id < model->leader)) model->leader = id;
  }
  model->fingerprint = Fingerprint(m, cylinders, reservoirs, model->supply);
  model->cylinders = std::move(cylinders);
  model->reservoirs = std::move(reservoirs);
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
  std::vector<BoundReservoir> reservoirs;
  for (int i = 0; i < m->ntext; ++i) {
    std::string element = m->names + m->name_textadr[i];
    if (element.rfind(kReservoirPrefix, 0) != 0) continue;
    std::string name = element.substr(sizeof(kReservoirPrefix) - 1);
    if (name.empty()) {
      *error = "custom text '" + element + "': missing the reservoir name after 'pneumatic_reservoir:'";
      return nullptr;
    }
    std::optional<ReservoirConfig> config = ParseReservoirConfig(name, m->text_data + m->text_adr[i], error);
    if (!config) return nullptr;
    std::optional<BoundReservoir> reservoir = BindReservoir(m, std::move(*config), error);
    if (!reservoir) return nullptr;
    reservoirs.push_back(std::move(*reservoir));
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
    for (const BoundReservoir& r : reservoirs) {
      if (r.config.name == name) {
        *error = "cylinder '" + name + "': a reservoir has the same name (their actuators share the prefix '" + name + ".')";
        return nullptr;
      }
    }
    std::optional<Cylinder> cylinder = Cylinder::FromModel(m, std::move(*config), attached_before, error);
    if (!cylinder) return nullptr;
    cylinders.push_back(std::move(*cylinder));
  }
  return Finish(m, std::move(cylinders), std::move(reservoirs), error);
}

// the cylinders as stored in the model's actuator_user data
std::unique_ptr<CompiledModel> CompileFromStorage(const mjModel* m, std::string* error) {
  // reservoirs first: the cylinders name theirs by its actuator
  std::vector<BoundReservoir> reservoirs;
  const size_t suffix = std::strlen(kReservoirStateRole) + 1;  // ".pressure"
  auto actuator_name = [&](int id) {
    const char* name = id >= 0 && id < m->nu ? mj_id2name(m, mjOBJ_ACTUATOR, id) : nullptr;
    return std::string(name ? name : "");
  };
  for (int id = 0; id < m->nu; ++id) {
    const double* user = UserData(m, id);
    if (!user || user[kTagSlot] != kReservoirTag) continue;
    std::string actuator = actuator_name(id);
    std::string name = actuator.size() > suffix ? actuator.substr(0, actuator.size() - suffix) : "";
    std::optional<ReservoirConfig> config = UnpackReservoirConfig(name, user + kConfigSlot, error);
    if (!config) return nullptr;
    std::optional<BoundReservoir> reservoir = BindReservoir(m, std::move(*config), error);
    if (!reservoir) return nullptr;
    reservoirs.push_back(std::move(*reservoir));
  }
  std::vector<Cylinder> cylinders;
  for (int id = 0; id < m->nu; ++id) {
    const double* user = UserData(m, id);
    if (!user || user[kTagSlot] != kHomeTag) continue;
    std::string actuator = actuator_name(id);
    std::string name = actuator.size() > 2 ? actuator.substr(0, actuator.size() - 2) : "";
    std::string supply;
    if (int link = static_cast<int>(user[SupplySlot()]); link > 0) {
      std::string reservoir = actuator_name(link - 1);
      supply = reservoir.size() > suffix ? reservoir.substr(0, reservoir.size() - suffix) : "?";
    }
    std::optional<CylinderConfig> config = UnpackConfig(name, user + kConfigSlot, error, supply);
    if (!config) return nullptr;
    std::optional<Cylinder> cylinder = Cylinder::FromModel(m, std::move(*config), true, error);
    if (!cylinder) return nullptr;
    cylinders.push_back(std::move(*cylinder));
  }
  return Finish(m, std::move(cylinders), std::move(reservoirs), error);
}

// writes the cylinders' tags, fingerprint, configurations and gains into m
void Store(mjModel* m, const CompiledModel& model) {
  for (const Cylinder& c : model.cylinders) {
    for (const auto& [id, role] : c.actuators()) {
      double* user = m->actuator_user + static_cast<size_t>(id) * m->nuser_actuator;
      bool home = id == c.info().chamber_actuator[0];
      user[kTagSlot] = home ? kHomeTag : kMemberTag;
      user[kFingerprintSlot] = model.fingerprint;
      user[LeaderSlot()] = id == model.leader;
      if (home) PackConfig(c.config(), user + kConfigSlot);
    }
    c.WriteGains(m);
  }
  for (size_t c = 0; c < model.cylinders.size(); ++c) {
    int link = model.supply[c] < 0 ? 0 : model.reservoirs[model.supply[c]].actuator + 1;
    m->actuator_user[static_cast<size_t>(model.cylinders[c].info().chamber_actuator[0]) * m->nuser_actuator +
                     SupplySlot()] = link;
  }
  for (const BoundReservoir& r : model.reservoirs) {
    double* user = m->actuator_user + static_cast<size_t>(r.actuator) * m->nuser_actuator;
    user[kTagSlot] = kReservoirTag;
    user[kFingerprintSlot] = model.fingerprint;
    user[LeaderSlot()] = r.actuator == model.leader;
    PackReservoirConfig(r.config, user + kConfigSlot);
    // no force: a fixed gain of 0
    m->actuator_gaintype[r.actuator] = mjGAIN_FIXED;
    for (int i = 0; i < mjNGAIN; ++i) m->actuator_gainprm[r.actuator * mjNGAIN + i] = 0;
  }
}

// The mjModel fields a decoding reads that a user may write between steps, in a fixed order (fields
// that MuJoCo fixes at compile time, such as counts, names and the body tree, are not among them):
// the options the step's validity depends on, every actuator's types, transmission, gear and gain,
// and every dof's and tendon's frictionloss. `visit(value)` returns false to stop early; returns
// false if it was stopped.
template <class Visit>
bool VisitEditableFields(const mjModel* m, Visit&& visit) {
  if (!visit(m->opt.timestep) || !visit(m->opt.integrator)) return false;
  for (int id = 0; id < m->nu; ++id) {
    if (!visit(m->actuator_trntype[id]) || !visit(m->actuator_dyntype[id]) || !visit(m->actuator_gaintype[id]) ||
        !visit(m->actuator_biastype[id]) || !visit(m->actuator_actlimited[id]) || !visit(m->actuator_trnid[2 * id]) ||
        !visit(m->actuator_trnid[2 * id + 1]) || !visit(m->actuator_gainprm[mjNGAIN * id])) {
      return false;
    }
    for (int i = 0; i < 6; ++i) {
      if (!visit(m->actuator_gear[6 * id + i])) return false;
    }
  }
  for (int i = 0; i < m->nv; ++i) {
    if (!visit(m->dof_frictionloss[i])) return false;
  }
  for (int i = 0; i < m->ntendon; ++i) {
    if (!visit(m->tendon_frictionloss[i])) return false;
  }
  return true;
}

std::vector<double> EditableFields(const mjModel* m) {
  std::vector<double> fields;
  VisitEditableFields(m, [&](double value) {
    fields.push_back(value);
    return true;
  });
  return fields;
}

// true if m's editable fields have the values in `fields`, bit for bit
bool SameEditableFields(const mjModel* m, const std::vector<double>& fields) {
  size_t i = 0;
  bool same = VisitEditableFields(m, [&](double value) {
    return i < fields.size() && std::memcmp(&value, &fields[i++], sizeof(double)) == 0;
  });
  return same && i == fields.size();
}

// the callback (our gain, bias or dynamics) that MuJoCo 2.2.2's mj_fwdActuation calls first for a
// model in a forward pass: forces (gain, then bias) in increasing actuator id, then act_dot. It
// checks the model's editable fields once per pass; every later callback of the pass trusts it
struct Gate {
  int actuator = -1;
  enum Callback { kGain, kBias, kDynamics } callback = kDynamics;
};
bool ActGainIsOurs();
void KeepCallbacks(const CompiledModel& model);
Gate FindGate(const mjModel* m) {
  for (int id = 0; id < m->nu; ++id) {
    if (!IsTagged(m, id)) continue;
    if (m->actuator_gaintype[id] == mjGAIN_USER && ActGainIsOurs()) return {id, Gate::kGain};
    if (m->actuator_biastype[id] == mjBIAS_USER) return {id, Gate::kBias};
  }
  for (int id = m->nu - m->na; id < m->nu; ++id) {
    if (IsTagged(m, id) && m->actuator_dyntype[id] == mjDYN_USER) return {id, Gate::kDynamics};
  }
  return {};
}

// a model decoded on this thread for one set of editable fields; `model` is null when those fields
// make it invalid (or its storage is damaged), and `problem` says why
struct Decoding {
  double fingerprint = 0;
  std::vector<double> fields;
  Gate gate;
  std::shared_ptr<const CompiledModel> model;
  std::string problem;
};

// MuJoCo's warning, once per process for each message (every thread that meets a model's problem
// meets the same message)
void WarnOnce(const std::string& message) {
  static std::mutex mutex;
  static std::vector<std::string> said;
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (std::find(said.begin(), said.end(), message) != said.end()) return;
    said.push_back(message);
  }
  mju_warning_s("%s", message.c_str());
}

// this thread's decodings, most recently used first
struct ThreadCache {
  static constexpr size_t kSize = 8;
  std::vector<std::shared_ptr<const Decoding>> entries;

  // the decoding of m's fingerprint and present fields, moved to the front; null if there is none
  const Decoding* Find(const mjModel* m, double fingerprint) {
    for (size_t i = 0; i < entries.size(); ++i) {
      if (entries[i]->fingerprint != fingerprint || !SameEditableFields(m, entries[i]->fields)) continue;
      if (i > 0) std::rotate(entries.begin(), entries.begin() + i, entries.begin() + i + 1);
      return entries[0].get();
    }
    return nullptr;
  }
  const Decoding* Add(std::shared_ptr<const Decoding> decoding) {
    entries.insert(entries.begin(), std::move(decoding));
    if (entries.size() > kSize) entries.pop_back();
    return entries[0].get();
  }
};
ThreadCache& GetThreadCache() {
  thread_local ThreadCache cache;
  return cache;
}

std::shared_ptr<Decoding> MakeDecoding(const mjModel* m, double fingerprint, std::shared_ptr<const CompiledModel> model,
                                       std::string problem) {
  auto decoding = std::make_shared<Decoding>();
  decoding->fingerprint = fingerprint;
  decoding->fields = EditableFields(m);
  decoding->gate = FindGate(m);
  decoding->model = std::move(model);
  decoding->problem = std::move(problem);
  return decoding;
}

// m's decoding for its present fields, from this thread's cache or decoded now from what m stores
const Decoding* Decode(const mjModel* m, double fingerprint) {
  ThreadCache& cache = GetThreadCache();
  if (const Decoding* found = cache.Find(m, fingerprint)) return found;
  std::string error;
  std::shared_ptr<CompiledModel> model = CompileFromStorage(m, &error);
  if (model && model->fingerprint != fingerprint) model = nullptr, error = "";
  std::string problem;
  if (!model) {
    problem = error.empty() ? "pneumatic: the cylinder parameters stored in this model are damaged (fingerprint "
                              "mismatch); attach it again"
                            : "pneumatic: the model cannot be stepped as its fields now stand (edited after Attach): " +
                                  error + "; its pneumatic states hold until the fields are set back";
    WarnOnce(problem);
  }
  return cache.Add(MakeDecoding(m, fingerprint, std::move(model), problem));
}

// the same, with the extension's callbacks kept in front of any the program installed since (KeepCallbacks):
// every look at a model outside the hot path goes through here
const Decoding* Resolve(const mjModel* m, double fingerprint) {
  const Decoding* decoding = Decode(m, fingerprint);
  if (decoding->model) KeepCallbacks(*decoding->model);
  return decoding;
}

// the decoding that actuator `id` of m belongs to, or null if it is not pneumatic; `callback` says
// which of ours asks, so that the model's gate checks its fields
const Decoding* Lookup(const mjModel* m, int id, Gate::Callback callback) {
  if (!IsTagged(m, id)) return nullptr;
  const double fingerprint = UserData(m, id)[kFingerprintSlot];
  ThreadCache& cache = GetThreadCache();
  // the hot path: a later callback of the pass whose gate resolved the model
  if (!cache.entries.empty()) {
    const Decoding& front = *cache.entries[0];
    if (front.fingerprint == fingerprint && !(front.gate.actuator == id && front.gate.callback == callback)) {
      return &front;
    }
  }
  return Resolve(m, fingerprint);
}

// MuJoCo zeroes every control (mjWARN_BADCTRL) if any clamped control is NaN or beyond 1e10
bool AnyBadControl(const mjModel* m, const mjData* d) {
  bool clamp = !(m->opt.disableflags & mjDSBL_CLAMPCTRL);
  for (int id = 0; id < m->nu; ++id) {
    double u = d->ctrl[id];
    if (clamp && m->actuator_ctrllimited[id]) {
      u = Clip(u, m->actuator_ctrlrange[2 * id], m->actuator_ctrlrange[2 * id + 1]);
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
    double gain = c.config().mount == Mount::kHingeSites ? c.ChamberGain(d, 0) : m->actuator_gainprm[id * mjNGAIN];
    double force = gain * d->act[ActIndex(m, id)];
    if (m->actuator_forcelimited[id]) force = Clip(force, m->actuator_forcerange[2 * id], m->actuator_forcerange[2 * id + 1]);
    if (d->actuator_force[id] != force) return false;
  }
  return true;
}

// The cylinders and the reservoirs that feed them, stepped together (the order is the method):
//  1. each reservoir's pressure p_r(t) is read from its act;
//  2. each cylinder steps with its supply ports at p_r(t) for the whole step (its chambers' own
//     step, unchanged: linearized, exact or explicit) and adds the mass its supply ports drew
//     over the step to the reservoir's account (SupplyMassOverStep);
//  3. each reservoir steps with that draw, evenly spread over the step, and the inflow through its
//     line solved implicitly (ReservoirPressureStep).
// What one chamber draws leaves the reservoir in the same step, so the gas is conserved. The
// chambers step implicitly against a reservoir held at p_r(t), the reservoir explicitly in their
// draw: in the stiff limit (valves wide open, long steps) each step moves the reservoir-chamber
// pressure differences by the factor -(sum of V_chamber / n) / V_reservoir, so the coupling is
// stable at any timestep when the reservoir is larger than the chambers it feeds together, as
// Link demands.
void StepWithReservoirs(const CompiledModel& model, const mjModel* m, mjData* d, const PassInputs& pass) {
  const double h = m->opt.timestep;
  const int n = static_cast<int>(model.reservoirs.size());
  mjtNum* pressure = mj_stackAlloc(d, 2 * n);  // inside the caller's mjMARKSTACK
  mjtNum* drawn = pressure + n;
  for (int r = 0; r < n; ++r) {
    const BoundReservoir& reservoir = model.reservoirs[r];
    pressure[r] = d->act[ActIndex(m, reservoir.actuator)] + reservoir.model.p_source;
    drawn[r] = 0;
  }
  for (size_t c = 0; c < model.cylinders.size(); ++c) {
    int r = model.supply[c];
    if (r < 0) {
      model.cylinders[c].Step(m, d, pass);
    } else {
      model.cylinders[c].Step(m, d, pass, &pressure[r], &drawn[r]);
    }
  }
  for (int r = 0; r < n; ++r) {
    const BoundReservoir& reservoir = model.reservoirs[r];
    double end = ReservoirPressureStep(reservoir.model, pressure[r], drawn[r], h);
    d->act_dot[ActIndex(m, reservoir.actuator)] = (end - pressure[r]) / h;
  }
}

// every cylinder's act_dot when no reservoir feeds them: the chambers LinearizedChambers takes, all
// together between each cylinder's BeginStep and EndStep; every other cylinder by its own Step
void StepCylinders(const CompiledModel& model, const mjModel* m, mjData* d, const PassInputs& pass) {
  int batched = 0;
  for (const Cylinder& c : model.cylinders) batched += c.Batched();
  // the chambers' inputs and results in the pass's stack (inside the caller's mjMARKSTACK; BeginStep
  // writes every field), where it has room: else each cylinder by its own Step, with the same result
  const int words = static_cast<int>((2 * batched * sizeof(BatchedChamber) + sizeof(mjtNum) - 1) / sizeof(mjtNum));
  if (batched == 0 || d->nstack - d->pstack < words) {
    for (const Cylinder& c : model.cylinders) c.Step(m, d, pass);
    return;
  }
  BatchedChamber* chambers = reinterpret_cast<BatchedChamber*>(mj_stackAlloc(d, words));
  BatchedChamber* next = chambers;
  for (const Cylinder& c : model.cylinders) {
    if (c.Batched()) {
      c.BeginStep(m, d, pass, next);
      next += 2;
    } else {
      c.Step(m, d, pass);
    }
  }
  LinearizedChambers(chambers, 2 * batched, m->opt.timestep);
  next = chambers;
  for (const Cylinder& c : model.cylinders) {
    if (!c.Batched()) continue;
    c.EndStep(m, d, pass, next);
    next += 2;
  }
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
  if (model.reservoirs.empty()) {
    StepCylinders(model, m, d, pass);
  } else {
    StepWithReservoirs(model, m, d, pass);
  }
  mjFREESTACK;
}

// every act_dot of the model's stored actuators set to 0: their states hold
void HoldEveryState(const mjModel* m, mjData* d) {
  for (int id = m->nu - m->na; id < m->nu; ++id) {
    if (IsTagged(m, id)) d->act_dot[ActIndex(m, id)] = 0;
  }
}

mjtNum ActDyn(const mjModel* m, const mjData* d, int id) {
  // the hot path: a pneumatic actuator other than the leader, whose pass (earlier in this
  // mj_fwdActuation: MuJoCo asks in increasing id) wrote its act_dot
  if (IsTagged(m, id) && UserData(m, id)[LeaderSlot()] == 0) return d->act_dot[ActIndex(m, id)];
  const Decoding* decoding = Lookup(m, id, Gate::kDynamics);
  if (!decoding) {
    return CallPrevious(GetPrevious().dyn, m, d, id, 0);
  }
  mjData* data = const_cast<mjData*>(d);
  if (!decoding->model) {
    // the leader of a model that cannot be stepped (Resolve warned): every pneumatic state holds
    HoldEveryState(m, data);
    return 0;
  }
  // the pass writes every pneumatic act_dot of d at once; act_dot is MuJoCo's output slot for them
  const CompiledModel& model = *decoding->model;
  if (id == model.leader) StepPass(model, m, data);
  return d->act_dot[ActIndex(m, id)];
}

// gaintype="user": the chambers of a cylinder with mount=hinge_sites (their gain follows the lever arm);
// every other pneumatic actuator with a user gain applies no force, nor does any of a model that
// cannot be stepped
mjtNum ActGain(const mjModel* m, const mjData* d, int id) {
  const Decoding* decoding = Lookup(m, id, Gate::kGain);
  if (!decoding) {
    return CallPrevious(GetPrevious().gain, m, d, id, 1);
  }
  const CompiledModel* model = decoding->model.get();
  if (model && model->roles[id].role == Role::kChamber) {
    const Cylinder& c = model->cylinders[model->roles[id].cylinder];
    if (c.config().mount == Mount::kHingeSites) return c.ChamberGain(d, model->roles[id].index);
  }
  return 0;
}

mjtNum ActBias(const mjModel* m, const mjData* d, int id) {
  const Decoding* decoding = Lookup(m, id, Gate::kBias);
  if (!decoding) {
    return CallPrevious(GetPrevious().bias, m, d, id, 0);
  }
  const CompiledModel* model = decoding->model.get();
  if (model && model->roles[id].role == Role::kFriction) {
    return model->cylinders[model->roles[id].cylinder].FrictionBias(m, d);
  }
  return 0;
}

bool ActGainIsOurs() { return mjcb_act_gain == ActGain; }

// ours in MuJoCo's global callbacks, keeping whatever was there to serve the other actuators;
// they stay installed (a model needs no detaching), and a later Attach takes them back if
// someone replaced them. The gain callback only for a model whose gains change with its pose
// (mount=hinge_sites): every other pneumatic gain is fixed in the model. Returns the names of
// those it took back from another callback, "" if none
std::string InstallCallbacks(bool gain) {
  Previous& previous = GetPrevious();
  std::lock_guard<std::mutex> lock(previous.installing);
  std::string replaced;
  auto take = [&](mjfAct& global, mjfAct ours, std::atomic<mjfAct>& before, const char* name) {
    if (global == ours) return;
    if (global) replaced += std::string(replaced.empty() ? "" : ", ") + name;
    before = global, global = ours;
  };
  take(mjcb_act_dyn, ActDyn, previous.dyn, "mjcb_act_dyn");
  if (gain) take(mjcb_act_gain, ActGain, previous.gain, "mjcb_act_gain");
  take(mjcb_act_bias, ActBias, previous.bias, "mjcb_act_bias");
  return replaced;
}

// A callback installed by the program after Attach, in place of one of ours the model needs: ours
// back in front, passing every actuator that is not pneumatic to it, and a warning once. Seen where
// the extension runs: an API call, or the gate of a pass whose first callback is still ours
void KeepCallbacks(const CompiledModel& model) {
  const bool gain = model.pose_dependent_gains;
  if (mjcb_act_dyn == ActDyn && mjcb_act_bias == ActBias && (!gain || mjcb_act_gain == ActGain)) return;
  std::string replaced = InstallCallbacks(gain);
  if (!replaced.empty()) {
    WarnOnce("pneumatic: " + replaced + " was replaced after Attach; the extension's callback is back in front "
             "and passes every actuator that is not pneumatic to the replacement (install your callbacks "
             "before Attach, which chains them, to avoid this)");
  }
}

// the decoded model of m, or null and *error
std::shared_ptr<const CompiledModel> Compiled(const mjModel* m, std::string* error) {
  if (!m) {
    *error = "model is null";
    return nullptr;
  }
  for (int id = 0; id < m->nu; ++id) {
    if (!IsTagged(m, id)) continue;
    const Decoding* decoding = Resolve(m, UserData(m, id)[kFingerprintSlot]);
    if (decoding->model) return decoding->model;
    *error = decoding->problem;
    return nullptr;
  }
  *error = "the model is not attached to the pneumatic extension";
  return nullptr;
}

// stores `model` in m and makes it the current decoding
bool StoreModel(mjModel* m, std::shared_ptr<CompiledModel> model, std::string* error) {
  if (SupplySlot() + 1 > LeaderSlot() || kConfigSlot + PackedReservoirSize() > LeaderSlot()) {
    mju_error("pneumatic: the parameter table outgrew ActuatorUserSize(); raise it");
  }
  if ((!model->cylinders.empty() || !model->reservoirs.empty()) && m->nuser_actuator < ActuatorUserSize()) {
    *error = "the model stores each cylinder's parameters in its actuators' user data: add <size nuser_actuator=\"" +
             std::to_string(ActuatorUserSize()) + "\"/> to the MJCF (it has " + std::to_string(m->nuser_actuator) + ")";
    return false;
  }
  Store(m, *model);
  InstallCallbacks(model->pose_dependent_gains);  // before the gate is found: it may be our gain callback
  const double fingerprint = model->fingerprint;
  GetThreadCache().Add(MakeDecoding(m, fingerprint, std::move(model), ""));
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
    for (size_t i = 0; i < model->cylinders.size(); ++i) {
      out.push_back(model->cylinders[i].info());
      if (const int r = model->supply[i]; r >= 0) out.back().supply_actuator = model->reservoirs[static_cast<size_t>(r)].actuator;
    }
  }
  return out;
}

std::vector<ReservoirInfo> Reservoirs(const mjModel* m) {
  std::string ignored;
  std::vector<ReservoirInfo> out;
  if (auto model = m ? Compiled(m, &ignored) : nullptr) {
    for (const BoundReservoir& r : model->reservoirs) {
      ReservoirInfo info;
      info.name = r.config.name;
      info.actuator = r.actuator;
      info.p_source = r.model.p_source;
      info.volume = r.config.volume;
      for (int c : r.cylinders) info.cylinders.push_back(model->cylinders[c].info().name);
      out.push_back(info);
    }
  }
  return out;
}

double ReservoirPressure(const mjModel* m, const mjData* d, const ReservoirInfo& r) {
  return d->act[ActIndex(m, r.actuator)] + r.p_source;
}

void SetReservoirPressure(const mjModel* m, mjData* d, const ReservoirInfo& r, double pressure) {
  d->act[ActIndex(m, r.actuator)] = pressure - r.p_source;
}

double SupplyPressure(const mjModel* m, const mjData* d, const CylinderInfo& c) {
  if (c.supply_actuator < 0) return c.p_supply;
  return d->act[ActIndex(m, c.supply_actuator)] + c.p_supply;  // a reservoir's p_source is its cylinders' p_supply
}

bool SetSupplyPressure(const mjModel* m, mjData* d, const CylinderInfo& c, double pressure) {
  if (c.supply_actuator < 0) return false;
  d->act[ActIndex(m, c.supply_actuator)] = pressure - c.p_supply;
  return true;
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
  std::unique_ptr<CompiledModel> changed = Finish(m, std::move(cylinders), model->reservoirs, error);
  return changed && StoreModel(m, std::move(changed), error);
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

bool SetReservoirParameter(mjModel* m, const std::string& reservoir, const std::string& key, double value,
                           std::string* error) {
  std::string ignored;
  if (!error) error = &ignored;
  std::shared_ptr<const CompiledModel> model = Compiled(m, error);
  if (!model) return false;
  std::vector<BoundReservoir> reservoirs = model->reservoirs;
  auto found = std::find_if(reservoirs.begin(), reservoirs.end(),
                            [&](const BoundReservoir& r) { return r.config.name == reservoir; });
  if (found == reservoirs.end()) {
    *error = "no reservoir '" + reservoir + "' in the model";
    return false;
  }
  // the reservoir's text with the key's value replaced, through the parser that checks its range
  std::istringstream in(FormatReservoirConfig(found->config));
  std::string text, token;
  bool known = false;
  while (in >> token) {
    if (token.rfind(key + "=", 0) == 0) token = key + "=" + FormatNumber(value), known = true;
    text += (text.empty() ? "" : " ") + token;
  }
  if (!known) {
    *error = "reservoir '" + reservoir + "': unknown key '" + key + "' (see plugin/README.md, 'Supply reservoirs')";
    return false;
  }
  std::optional<ReservoirConfig> config = ParseReservoirConfig(reservoir, text, error);
  if (!config) return false;
  found->config = std::move(*config);
  std::unique_ptr<CompiledModel> changed = Finish(m, model->cylinders, std::move(reservoirs), error);
  return changed && StoreModel(m, std::move(changed), error);
}

}  // namespace pneumatic
