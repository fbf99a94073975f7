#include "cylinder.h"

#include <algorithm>
#include <cmath>

namespace pneumatic {
namespace {

std::string ActuatorName(const mjModel* m, int id) {
  const char* name = mj_id2name(m, mjOBJ_ACTUATOR, id);
  return name ? name : "#" + std::to_string(id);
}

// a valve command actuator's force must be zero: gaintype user (the extension returns 0)
// or fixed gain 0, and no bias
bool HasZeroForce(const mjModel* m, int id) {
  bool zero_gain = m->actuator_gaintype[id] == mjGAIN_USER ||
                   (m->actuator_gaintype[id] == mjGAIN_FIXED && m->actuator_gainprm[id * mjNGAIN] == 0);
  return zero_gain && m->actuator_biastype[id] == mjBIAS_NONE;
}

bool SameTransmission(const mjModel* m, int a, int b) {
  if (m->actuator_trntype[a] != m->actuator_trntype[b]) return false;
  for (int i = 0; i < 2; ++i) {
    if (m->actuator_trnid[2 * a + i] != m->actuator_trnid[2 * b + i]) return false;
  }
  for (int i = 0; i < 6; ++i) {
    if (m->actuator_gear[6 * a + i] != m->actuator_gear[6 * b + i]) return false;
  }
  return true;
}

// a control as mj_fwdActuation uses it: clamped to ctrlrange unless clamping is disabled
double ClampedControl(const mjModel* m, const mjData* d, int id) {
  double u = d->ctrl[id];
  if (m->actuator_ctrllimited[id] && !(m->opt.disableflags & mjDSBL_CLAMPCTRL)) {
    u = Clip(u, m->actuator_ctrlrange[2 * id], m->actuator_ctrlrange[2 * id + 1]);
  }
  return u;
}

double Act(const mjModel* m, const mjData* d, int id) { return d->act[ActIndex(m, id)]; }
double& ActDot(const mjModel* m, mjData* d, int id) { return d->act_dot[ActIndex(m, id)]; }

// a body's or joint's name, or "#id" for an unnamed one
std::string ObjectName(const mjModel* m, mjtObj type, int id) {
  const char* name = mj_id2name(m, type, id);
  return name ? name : "#" + std::to_string(id);
}

// mount=hinge_sites: the chamber actuators drive one hinge with gear 1; "<name>.cap" sits on the
// parent of the hinge's body, "<name>.rod" on the hinge's body, which no other joint moves. Returns
// what is wrong, or "" after filling info's sites and hinge
std::string BindHingeSites(const mjModel* m, const std::string& name, int actuator, CylinderInfo* info) {
  int joint = m->actuator_trnid[2 * actuator];
  if (m->actuator_trntype[actuator] != mjTRN_JOINT || m->jnt_type[joint] != mjJNT_HINGE) {
    return "the chamber actuators must drive the hinge the cylinder turns (joint=\"...\" of a hinge)";
  }
  const mjtNum* gear = m->actuator_gear + 6 * actuator;
  if (gear[0] != 1) {
    return "the chamber actuators need gear=\"1\": their force is the cylinder's torque on the hinge (gear " +
           FormatNumber(gear[0]) + ")";
  }
  int body = m->jnt_bodyid[joint];
  if (m->body_jntnum[body] != 1) {
    return "body '" + ObjectName(m, mjOBJ_BODY, body) + "' of hinge '" + ObjectName(m, mjOBJ_JOINT, joint) +
           "' has other joints: the rod site would move with them too";
  }
  const int wanted_body[2] = {m->body_parentid[body], body};
  const char* suffix[2] = {".cap", ".rod"};
  const char* what[2] = {"the barrel's end, on the parent of the hinge's body", "the rod's end, on the hinge's body"};
  int site[2];
  for (int i = 0; i < 2; ++i) {
    std::string site_name = name + suffix[i];
    site[i] = mj_name2id(m, mjOBJ_SITE, site_name.c_str());
    const std::string wanted = what[i] + std::string(" '") + ObjectName(m, mjOBJ_BODY, wanted_body[i]) + "'";
    if (site[i] < 0) return "site '" + site_name + "' is missing (" + wanted + ")";
    if (m->site_bodyid[site[i]] != wanted_body[i]) {
      return "site '" + site_name + "' is on body '" + ObjectName(m, mjOBJ_BODY, m->site_bodyid[site[i]]) +
             "'; it must be " + wanted;
    }
  }
  info->cap_site = site[0], info->rod_site = site[1], info->hinge = joint;
  return "";
}

// "cylinder '<name>': actuator '<actuator>': <message>": an actuator the configuration needs, as the model has it
std::string ActuatorProblem(const std::string& cylinder, const std::string& actuator, const std::string& message) {
  return "cylinder '" + cylinder + "': actuator '" + actuator + "': " + message;
}

// "cylinder '<name>': key '<key>': <message>": a key the model contradicts
std::string KeyProblem(const std::string& cylinder, const std::string& key, const std::string& message) {
  return "cylinder '" + cylinder + "': key '" + key + "': " + message;
}

// role r's actuator is missing: "missing: <why> (role '<suffix>', required by <keys>)", with "{}" in
// `why` standing for the cylinder's name
std::string MissingRole(const std::string& cylinder, const RoleSpec& r, std::string why) {
  for (size_t at = why.find("{}"); at != std::string::npos; at = why.find("{}", at + cylinder.size())) {
    why.replace(at, 2, cylinder);
  }
  return ActuatorProblem(cylinder, cylinder + "." + r.suffix,
                         "missing: " + why + " (role '" + r.suffix + "', required by " + r.required_by + ")");
}

// the valve roles of the role table (roles.h) this configuration uses: its valve commands (their ctrl)
// and its valve states (their act), in ValveInputs order
void ValveRoles(const CylinderConfig& cfg, std::vector<const RoleSpec*>* commands,
                std::vector<const RoleSpec*>* states) {
  int row_count = 0;
  const RoleSpec* rows = RoleTable(&row_count);
  for (int i = 0; i < row_count; ++i) {
    const RoleSpec& r = rows[i];
    if (r.owner != RoleOwner::kCylinder || r.role != Role::kCommand) continue;
    if (r.command(&cfg)) commands->push_back(&r);
    if (r.state(&cfg)) states->push_back(&r);
  }
}

// switched PWM: the step holds a bounded number of carrier edges
std::string PwmCarrierProblem(const mjModel* m, const CylinderConfig& cfg) {
  if (cfg.input == CommandInput::kPwm && cfg.pwm_frequency * m->opt.timestep > kMaxPwmPeriodsPerStep) {
    return KeyProblem(cfg.name, "pwm_frequency", FormatNumber(cfg.pwm_frequency) + " Hz puts more than " +
                                                     FormatNumber(kMaxPwmPeriodsPerStep) + " carrier periods in one " +
                                                     FormatNumber(m->opt.timestep) +
                                                     " s step; use a shorter timestep or the averaged model (pwm_frequency=0)");
  }
  return "";
}

}  // namespace

// mount=hinge_sites: the cylinder's length L = |rod - cap| and its lever arm dL/dq = u . (a x (rod - anchor)),
// u the unit vector from cap to rod, a the hinge's axis through its anchor (the velocity of a point
// turning about an axis; the project's own form of the two-site spatial tendon's length and moment)
HingeGeometry HingeSitesGeometry(const mjData* d, const CylinderInfo& c) {
  // written out rather than through mju_sub3, mju_cross and mju_norm3: it runs several times per step
  // for every such cylinder, and MuJoCo's vector functions are calls into its library
  const mjtNum* cap = d->site_xpos + 3 * c.cap_site;
  const mjtNum* rod = d->site_xpos + 3 * c.rod_site;
  const mjtNum* a = d->xaxis + 3 * c.hinge;
  const mjtNum* anchor = d->xanchor + 3 * c.hinge;
  const double span[3] = {rod[0] - cap[0], rod[1] - cap[1], rod[2] - cap[2]};
  const double lever[3] = {rod[0] - anchor[0], rod[1] - anchor[1], rod[2] - anchor[2]};
  // the rod end's velocity per unit hinge rate, a x lever
  const double turn[3] = {a[1] * lever[2] - a[2] * lever[1], a[2] * lever[0] - a[0] * lever[2],
                          a[0] * lever[1] - a[1] * lever[0]};
  HingeGeometry g;
  g.length = std::sqrt(span[0] * span[0] + span[1] * span[1] + span[2] * span[2]);
  g.arm = g.length > 0 ? (span[0] * turn[0] + span[1] * turn[1] + span[2] * turn[2]) / g.length : 0;
  return g;
}

std::optional<Cylinder> Cylinder::FromModel(const mjModel* m, CylinderConfig config, bool gains_written,
                                            std::string* error) {
  Cylinder c;
  c.config_ = std::move(config);
  // each step binds one group of the actuators the role table (roles.h) asks of this configuration and
  // checks them against the model; the first problem found is the error
  std::string problem = c.BindChambers(m, gains_written);
  if (problem.empty()) problem = c.BindTransmission(m);
  if (problem.empty()) problem = c.BindValves(m);
  if (problem.empty()) problem = c.BindFriction(m);
  if (problem.empty()) problem = c.BindExtraStates(m);
  if (problem.empty()) problem = c.RefuseOtherActuators(m);
  if (problem.empty()) problem = PwmCarrierProblem(m, c.config_);
  if (!problem.empty()) {
    *error = problem;
    return std::nullopt;
  }
  c.PrepareSteps();
  return c;
}

// chambers: user dynamics and gain, no bias, one shared transmission
std::string Cylinder::BindChambers(const mjModel* m, bool gains_written) {
  const CylinderConfig& cfg = config_;
  const std::string& name = cfg.name;
  auto fail = [&](const std::string& actuator, const std::string& message) {
    return ActuatorProblem(name, actuator, message);
  };
  const char* chamber_names[2] = {"P", "N"};
  for (int k = 0; k < 2; ++k) {
    const RoleSpec& role = *FindRole(RoleOwner::kCylinder, chamber_names[k]);
    std::string full = name + "." + chamber_names[k];
    int id = mj_name2id(m, mjOBJ_ACTUATOR, full.c_str());
    if (id < 0) return MissingRole(name, role, role.missing);
    if (m->actuator_dyntype[id] != mjDYN_USER) return fail(full, "needs dyntype=\"user\" (its act is the chamber's gauge pressure)");
    // user as written in MJCF; fixed once attached (WriteGains: +A_P, -A_N)
    double area_gain = k == 0 ? cfg.chamber[0].area : -cfg.chamber[1].area;
    bool fixed = m->actuator_gaintype[id] == mjGAIN_FIXED;
    if (cfg.mount == Mount::kHingeSites) {
      // the gain changes with the lever arm: the extension's gain callback gives it
      if (m->actuator_gaintype[id] != mjGAIN_USER) {
        return fail(full, "needs gaintype=\"user\" (with mount=hinge_sites its force is area * gauge pressure * "
                          "lever arm, which the extension computes)");
      }
    } else if (!(m->actuator_gaintype[id] == mjGAIN_USER || (fixed && gains_written) ||
                 (fixed && m->actuator_gainprm[id * mjNGAIN] == area_gain))) {
      return fail(full, "needs gaintype=\"user\" (force = area * gauge pressure)");
    }
    if (m->actuator_biastype[id] != mjBIAS_NONE) return fail(full, "needs biastype=\"none\"");
    if (m->actuator_actlimited[id]) return fail(full, "must not be actlimited: MuJoCo would clip the chamber pressure");
    if (m->actuator_gear[6 * id] == 0) return fail(full, "gear is 0: the cylinder could neither move nor push");
    info_.chamber_actuator[k] = id;
    actuators_.push_back({id, {Role::kChamber, -1, k}});
  }
  return "";
}

// the chambers' transmission: a slide or hinge joint (its dof kept for the step), a slider-crank or a
// tendon, the same for both chambers; with mount=hinge_sites, the hinge and the sites the cylinder spans
std::string Cylinder::BindTransmission(const mjModel* m) {
  const std::string& name = config_.name;
  int p_id = info_.chamber_actuator[0], n_id = info_.chamber_actuator[1];
  std::string p_name = name + ".P";
  int trntype = m->actuator_trntype[p_id];
  if (trntype == mjTRN_JOINT || trntype == mjTRN_JOINTINPARENT) {
    int joint = m->actuator_trnid[2 * p_id];
    if (m->jnt_type[joint] != mjJNT_SLIDE && m->jnt_type[joint] != mjJNT_HINGE) {
      return ActuatorProblem(name, p_name, "a cylinder drives a slide or hinge joint, a slider-crank or a tendon; joint '" +
                                               std::string(mj_id2name(m, mjOBJ_JOINT, joint) ? mj_id2name(m, mjOBJ_JOINT, joint) : "?") +
                                               "' is a ball or free joint");
    }
  } else if (trntype != mjTRN_SLIDERCRANK && trntype != mjTRN_TENDON) {
    return ActuatorProblem(name, p_name, "a cylinder drives a slide or hinge joint, a slider-crank or a tendon (site transmissions have no stroke)");
  }
  if (trntype == mjTRN_JOINT || trntype == mjTRN_JOINTINPARENT) dof_ = m->jnt_dofadr[m->actuator_trnid[2 * p_id]];
  if (!SameTransmission(m, p_id, n_id)) {
    return ActuatorProblem(name, name + ".N", "must use the same transmission and gear as '" + p_name + "'");
  }
  if (config_.mount == Mount::kHingeSites) {
    if (std::string problem = BindHingeSites(m, name, p_id, &info_); !problem.empty()) {
      return KeyProblem(name, "mount", "hinge_sites: " + problem);
    }
  }
  return "";
}

// valve commands (their ctrl) and valve states (their act), in ValveInputs order: valve actuators apply
// no force; those holding a valve state have user dynamics
std::string Cylinder::BindValves(const mjModel* m) {
  const CylinderConfig& cfg = config_;
  const std::string& name = cfg.name;
  auto fail = [&](const std::string& actuator, const std::string& message) {
    return ActuatorProblem(name, actuator, message);
  };
  std::vector<const RoleSpec*> commands, states;
  ValveRoles(cfg, &commands, &states);
  const bool in_chambers = cfg.commands == CommandPlace::kChambers;
  for (const RoleSpec* r : commands) {
    std::string full = name + "." + r->suffix;
    // commands=chambers (no valve states, at most two commands: the parser sees to it): command i is
    // the ctrl of chamber i's actuator (uP, u and duty: P; uN: N)
    int id = in_chambers ? info_.chamber_actuator[r->index] : mj_name2id(m, mjOBJ_ACTUATOR, full.c_str());
    if (id < 0) return MissingRole(name, *r, r->missing);
    command_id_[r->index] = id;
    info_.command_actuators.push_back({r->suffix, id});
  }
  if (in_chambers) commands.clear();  // held by the chambers, whose checks are in BindChambers
  for (const RoleSpec* r : states) {
    std::string full = name + "." + r->suffix;
    int id = mj_name2id(m, mjOBJ_ACTUATOR, full.c_str());
    if (id < 0) return MissingRole(name, *r, "it holds the state of a valve with delays");
    state_id_[r->index] = id;
  }
  std::vector<const RoleSpec*> valve_roles = commands;
  for (const RoleSpec* role : states) {
    if (std::find(commands.begin(), commands.end(), role) == commands.end()) valve_roles.push_back(role);
  }
  for (const RoleSpec* role : valve_roles) {
    std::string full = name + "." + role->suffix;
    int id = mj_name2id(m, mjOBJ_ACTUATOR, full.c_str());
    if (!HasZeroForce(m, id)) {
      return fail(full, "a valve actuator applies no force: use gaintype=\"user\" (or gainprm=\"0\") and biastype=\"none\"");
    }
    auto state = std::find(states.begin(), states.end(), role);
    bool stateful = state != states.end();
    if (stateful && m->actuator_dyntype[id] != mjDYN_USER) {
      return fail(full, cfg.valve == ValveKind::kProportional53
                            ? "needs dyntype=\"user\": its act is the spool position (spool_time_constant > 0)"
                        : cfg.valve == ValveKind::kProportionalPerChamber
                            ? "needs dyntype=\"user\": its act is the valve's lagged voltage (spool_time_constant > 0)"
                            : "needs dyntype=\"user\": its act is the valve armature (delay_open/delay_close > 0)");
    }
    if (stateful && m->actuator_actlimited[id]) {
      return fail(full, "must not be actlimited: MuJoCo would clip the valve state");
    }
    if (!stateful && m->actuator_dyntype[id] != mjDYN_NONE) {
      return fail(full, "needs dyntype=\"none\": this valve has no state (no spool lag or switching delay)");
    }
    // index: which ValveInputs::state entry this actuator's act holds
    int index = stateful ? role->index : -1;
    actuators_.push_back({id, {Role::kCommand, -1, index}});
  }
  return "";
}

// seal friction: Coulomb level below the transmission's frictionloss (the static level)
std::string Cylinder::BindFriction(const mjModel* m) {
  const CylinderConfig& cfg = config_;
  const std::string& name = cfg.name;
  auto fail = [&](const std::string& actuator, const std::string& message) {
    return ActuatorProblem(name, actuator, message);
  };
  int p_id = info_.chamber_actuator[0];
  int trntype = m->actuator_trntype[p_id];
  std::string friction_name = name + ".friction";
  int friction_id = mj_name2id(m, mjOBJ_ACTUATOR, friction_name.c_str());
  const RoleSpec& friction_role = *FindRole(RoleOwner::kCylinder, "friction");
  if (!RoleRequired(friction_role, &cfg)) {
    return friction_id >= 0 ? fail(friction_name, "present but coulomb_friction is not set") : "";
  }
  if (friction_id < 0) return MissingRole(name, friction_role, friction_role.missing);
  if (m->actuator_dyntype[friction_id] != mjDYN_NONE || m->actuator_biastype[friction_id] != mjBIAS_USER ||
      !(m->actuator_gaintype[friction_id] == mjGAIN_USER ||
        (m->actuator_gaintype[friction_id] == mjGAIN_FIXED && m->actuator_gainprm[friction_id * mjNGAIN] == 0))) {
    return fail(friction_name, "needs dyntype=\"none\", gaintype=\"user\" and biastype=\"user\"");
  }
  if (!SameTransmission(m, p_id, friction_id)) return fail(friction_name, "must use the same transmission as '" + name + ".P'");
  double gear = std::fabs(m->actuator_gear[6 * p_id]);
  int target = m->actuator_trnid[2 * p_id];
  double frictionloss = trntype == mjTRN_TENDON     ? m->tendon_frictionloss[target]
                        : trntype == mjTRN_SLIDERCRANK ? -1
                                                    : m->dof_frictionloss[m->jnt_dofadr[target]];
  if (cfg.friction_model == FrictionModel::kLuGre) {
    // LuGre holds the piston itself (its bristles): a frictionloss constraint would add a second static level
    if (frictionloss > 0) {
      const char* what = trntype == mjTRN_TENDON ? "tendon" : "joint";
      const char* object = mj_id2name(m, trntype == mjTRN_TENDON ? mjOBJ_TENDON : mjOBJ_JOINT, target);
      return KeyProblem(name, "friction_model", std::string("lugre provides the static friction itself ") +
                                                    "(static_friction), but " + what + " '" + (object ? object : "?") +
                                                    "' has frictionloss=" + FormatNumber(frictionloss) + "; set it to 0");
    }
  } else {
    if (frictionloss < 0) return fail(friction_name, "seal friction needs a joint or tendon transmission (its frictionloss is the static friction)");
    static_friction_ = gear > 0 ? frictionloss / gear : 0;
    if (*cfg.coulomb_friction > static_friction_) {
      return KeyProblem(name, "coulomb_friction", std::to_string(*cfg.coulomb_friction) +
                                                      " exceeds the static friction, the frictionloss of the transmission (" +
                                                      std::to_string(static_friction_) + "); set frictionloss to the static level");
    }
  }
  actuators_.push_back({friction_id, {Role::kFriction, -1, 0}});
  return "";
}

// extra states (rows of Role::kState: a delay line, a bristle, a gas temperature): user dynamics,
// no force; the step writes their act_dot
std::string Cylinder::BindExtraStates(const mjModel* m) {
  const std::string& name = config_.name;
  int row_count = 0;
  const RoleSpec* rows = RoleTable(&row_count);
  for (int i = 0; i < row_count; ++i) {
    const RoleSpec& r = rows[i];
    if (r.owner != RoleOwner::kCylinder || r.role != Role::kState || !r.state(&config_)) continue;
    std::string full = name + "." + r.suffix;
    int id = mj_name2id(m, mjOBJ_ACTUATOR, full.c_str());
    if (id < 0) return MissingRole(name, r, r.missing);
    if (std::string problem = StateActuatorProblem(m, id, r); !problem.empty()) return ActuatorProblem(name, full, problem);
    if (r.index < 0 || r.index >= kMaxExtraStates) mju_error("pneumatic: role table: extra-state slot out of range");
    extra_state_id_[r.index] = id;
    if (r.index == kLineP || r.index == kLineN) info_.line_actuator[r.index - kLineP] = id;
    has_extra_states_ = true;
    actuators_.push_back({id, {Role::kState, -1, r.index}});
  }
  return "";
}

// every other "<name>.*" actuator is a typo, belongs to another valve arrangement, or is a
// role this configuration does not use (the role table says which keys need it)
std::string Cylinder::RefuseOtherActuators(const mjModel* m) const {
  const CylinderConfig& cfg = config_;
  const std::string& name = cfg.name;
  const bool in_chambers = cfg.commands == CommandPlace::kChambers;
  std::string prefix = name + ".";
  for (int id = 0; id < m->nu; ++id) {
    std::string actuator = ActuatorName(m, id);
    if (actuator.rfind(prefix, 0) != 0) continue;
    bool known = std::any_of(actuators_.begin(), actuators_.end(), [&](const auto& a) { return a.first == id; });
    if (known) continue;
    std::string why = "has no role in this cylinder (valve and input decide the command actuators)";
    const RoleSpec* r = FindRole(RoleOwner::kCylinder, actuator.substr(prefix.size()));
    if (r && in_chambers && r->role == Role::kCommand && r->command(&cfg)) {
      why = "commands=chambers reads this command from the ctrl of '" + name + (r->index == 0 ? ".P" : ".N") +
            "': remove this actuator, or set commands=actuators";
    } else if (r) {
      why += ": role '" + std::string(r->suffix) + "' is used with " + r->required_by;
    }
    return ActuatorProblem(name, actuator, why);
  }
  return "";
}

// what every step reads of the bound cylinder: its public info, its chambers' models, and the path a
// step takes (batched, held voltages)
void Cylinder::PrepareSteps() {
  const CylinderConfig& cfg = config_;
  info_.name = cfg.name;
  info_.p_atm = cfg.p_atm;
  info_.p_supply = cfg.p_supply;
  info_.p_exhaust = cfg.p_exhaust;
  info_.x_mid = cfg.x_mid;
  for (int k = 0; k < 2; ++k) chamber_model_[k] = MakeChamberModel(cfg, k);
  // the chambers the batched linearized step takes: each on its own, physical and isothermal, straight
  // behind its valve, with nothing but the linearized step's own terms (Step takes every other case)
  bool batched = cfg.step == ChamberStep::kLinearized && cfg.thermal_model != ThermalModel::kEnergy &&
                 !(cfg.piston_leak_conductance > 0) && !(cfg.piston_leak_area > 0);
  for (int k = 0; k < 2; ++k) {
    batched = batched && cfg.chamber[k].model == PressureModel::kPhysical && !(cfg.chamber[k].line_volume > 0) &&
              Batchable(chamber_model_[k]);
  }
  batched_ = batched;
  // a valve per chamber without a lag or a dead time holds its openings over the step (PortSchedule's own
  // case); with no valve states and no extra states, its two voltages are all a step reads besides the
  // chambers and the piston (BeginStep)
  held_voltage_ = cfg.valve == ValveKind::kProportionalPerChamber &&
                  !(cfg.CommandDeadTime() > 0 || cfg.spool_time_constant > 0);
  voltages_only_ = held_voltage_ && !has_extra_states_ && cfg.friction_model != FrictionModel::kLuGre &&
                   command_id_[0] >= 0 && command_id_[1] >= 0 &&
                   command_id_[2] < 0 && command_id_[3] < 0 && ChambersFollowEndVelocity();
  for (int i = 0; i < 4; ++i) voltages_only_ = voltages_only_ && state_id_[i] < 0;
}

bool Cylinder::NeedsEndVelocity() const {
  return ChambersFollowEndVelocity() || config_.friction_model == FrictionModel::kLuGre;
}

bool Cylinder::ChambersFollowEndVelocity() const {
  bool physical = config_.chamber[0].model == PressureModel::kPhysical ||
                  config_.chamber[1].model == PressureModel::kPhysical;
  return physical && config_.step != ChamberStep::kExplicit;
}

int Cylinder::DelaySlot(int channel) const {
  return (config_.valve == ValveKind::kProportional53 ? kDelay : kDelayPerChamber) + 2 * channel;
}

ValveInputs Cylinder::ReadValves(const mjModel* m, const mjData* d, bool zero_commands) const {
  ValveInputs in;
  in.time = d->time;
  in.step = m->opt.timestep;
  for (int i = 0; i < 4; ++i) {
    if (command_id_[i] >= 0 && !zero_commands) in.command[i] = ClampedControl(m, d, command_id_[i]);
    if (state_id_[i] >= 0) in.state[i] = Act(m, d, state_id_[i]);
  }
  for (int ch = 0; ch < DelayChannels(config_); ++ch) {
    for (int j = 0; j < 2; ++j) in.delay[ch][j] = Act(m, d, extra_state_id_[DelaySlot(ch) + j]);
  }
  return in;
}

VolumePath Cylinder::Volume(int chamber, double x, double x_rate) const {
  const ChamberConfig& k = config_.chamber[chamber];
  // chamber P grows with x, chamber N shrinks (docs/rigs.md volumes)
  double sign = chamber == 0 ? 1.0 : -1.0;
  VolumePath v;
  v.dead_volume = k.dead_volume;
  v.area = k.area;
  v.stroke = config_.stroke;
  v.swept = config_.stroke / 2 + sign * x;
  v.swept_rate = sign * x_rate;
  return v;
}

double Cylinder::LargestVolume() const {
  double v = 0;
  for (int k = 0; k < 2; ++k) v += config_.chamber[k].dead_volume + config_.chamber[k].area * config_.stroke;
  return v;
}

void Cylinder::ReadChamberPressures(const mjModel* m, const mjData* d, double p0[2]) const {
  for (int k = 0; k < 2; ++k) p0[k] = Act(m, d, info_.chamber_actuator[k]) + config_.p_atm;
}

double Cylinder::ChamberGain(const mjData* d, int chamber) const {
  // force A_P (p_P - p_atm) - A_N (p_N - p_atm) on the piston, docs/rigs.md; paper 001 eq. (1), times dx/dq
  double arm = HingeSitesGeometry(d, info_).arm;
  return chamber == 0 ? config_.chamber[0].area * arm : -config_.chamber[1].area * arm;
}

Cylinder::PistonMotion Cylinder::Motion(const mjModel* m, const mjData* d, const mjtNum* end_velocity) const {
  const int p = info_.chamber_actuator[0];
  PistonMotion motion;
  if (info_.rod_site >= 0) {
    // mount=hinge_sites: the chamber actuators' velocity is the hinge's (gear 1)
    const HingeGeometry g = HingeSitesGeometry(d, info_);
    motion.x = g.length - info_.x_mid;
    motion.velocity = g.arm * d->actuator_velocity[p];
    motion.end_rate = end_velocity ? g.arm * end_velocity[dof_] : motion.velocity;
    return motion;
  }
  motion.x = d->actuator_length[p] - info_.x_mid;
  motion.velocity = d->actuator_velocity[p];
  motion.end_rate = motion.velocity;
  if (end_velocity) {
    // the piston's rate is the actuator moment times the joint velocities; a joint's is one entry
    const mjtNum* moment = d->actuator_moment + static_cast<size_t>(p) * m->nv;
    motion.end_rate = dof_ >= 0 ? moment[dof_] * end_velocity[dof_] : mju_dot(moment, end_velocity, m->nv);
  }
  return motion;
}

Cylinder::PistonMotion Cylinder::StartStep(const mjModel* m, mjData* d, const PassInputs& pass,
                                           ValveInputs* valves_out, double p0[2], double* x_rate) const {
  const double h = m->opt.timestep;
  ValveInputs& valves = *valves_out;
  valves = ReadValves(m, d, pass.zero_commands);
  for (int i = 0; i < 4; ++i) {
    if (state_id_[i] >= 0) ActDot(m, d, state_id_[i]) = (ValveStateAtEnd(config_, i, valves) - valves.state[i]) / h;
  }
  // extra states of the role table hold their value unless their physics below writes their rate
  if (has_extra_states_) {
    for (int id : extra_state_id_) {
      if (id >= 0) ActDot(m, d, id) = 0;
    }
  }
  // spool_dead_time: each delay line over the step with its command held, exactly (valves.h, ValveSignal)
  for (int ch = 0; ch < DelayChannels(config_); ++ch) {
    double end[2];
    ProportionalSignal(config_, ch, valves).DelayState(h, end);
    for (int j = 0; j < 2; ++j) ActDot(m, d, extra_state_id_[DelaySlot(ch) + j]) = (end[j] - valves.delay[ch][j]) / h;
  }
  ReadChamberPressures(m, d, p0);
  // MuJoCo's Euler and implicit integrators move the piston over the step with the velocity at its
  // end; the chamber steps follow that path (plain explicit Euler uses the velocity at the start)
  const PistonMotion motion = Motion(m, d, pass.end_velocity && NeedsEndVelocity() ? pass.end_velocity : nullptr);
  *x_rate = ChambersFollowEndVelocity() ? motion.end_rate : motion.velocity;
  // LuGre bristles: moved over the step at the velocity MuJoCo moves the piston with (the end-of-step
  // velocity, as the chambers' volumes), in closed form
  if (config_.friction_model == FrictionModel::kLuGre) {
    int id = extra_state_id_[kBristle];
    ActDot(m, d, id) = BristleMeanRate(Act(m, d, id), motion.end_rate, h);
  }
  return motion;
}

void Cylinder::BeginStep(const mjModel* m, mjData* d, const PassInputs& pass, BatchedChamber chambers[2]) const {
  const double h = m->opt.timestep;
  ValveInputs valves;
  double p0[2];
  double x_rate = 0;
  PistonMotion motion;
  if (voltages_only_) {
    // StartStep's work where the two valve voltages are all the cylinder's inputs: nothing else to read or
    // to step
    for (int k = 0; k < 2; ++k) valves.command[k] = pass.zero_commands ? 0.0 : ClampedControl(m, d, command_id_[k]);
    ReadChamberPressures(m, d, p0);
    motion = Motion(m, d, pass.end_velocity);
    x_rate = motion.end_rate;
  } else {
    motion = StartStep(m, d, pass, &valves, p0, &x_rate);
  }
  for (int k = 0; k < 2; ++k) {
    BatchedChamber& c = chambers[k];
    c.model = &chamber_model_[k];
    if (held_voltage_) {
      c.open_start = c.open_end = ProportionalValveAreas(config_.chamber[k], valves.command[k], config_.deadband_voltage);
      c.held = true;
    } else {
      const PortSchedule ports(config_, k, valves);
      c.open_start = ports.At(0), c.open_end = ports.At(h);
      c.held = ports.breakpoints().empty();
    }
    c.volume = Volume(k, motion.x, x_rate);
    c.p0 = p0[k];
    c.p1 = p0[k];
    c.done = false;
  }
}

void Cylinder::EndStep(const mjModel* m, mjData* d, const PassInputs& pass, const BatchedChamber chambers[2]) const {
  const double h = m->opt.timestep;
  for (int k = 0; k < 2; ++k) {
    const BatchedChamber& c = chambers[k];
    double p1 = c.p1;
    if (!c.done) {
      // the adaptive implicit step where the linearized one asks for it, as Step takes it
      const PortSchedule ports(config_, k, ReadValves(m, d, pass.zero_commands));
      p1 = PhysicalPressureStep(chamber_model_[k], ports, c.volume, c.p0, h);
    }
    ActDot(m, d, info_.chamber_actuator[k]) = (p1 - c.p0) / h;
  }
}

void Cylinder::Step(const mjModel* m, mjData* d, const PassInputs& pass, const double* supply_pressure,
                    double* supply_drawn) const {
  const double h = m->opt.timestep;
  ValveInputs valves;
  double p0[2], rate[2];
  double x_rate = 0;
  const PistonMotion motion = StartStep(m, d, pass, &valves, p0, &x_rate);
  // the chambers' models; a reservoir's pressure at the start of the step on the supply ports (copies
  // made only then, in storage left uninitialised otherwise: a ChamberModel is large, and the common
  // case needs none)
  const ChamberModel* models = chamber_model_;
  InlineVector<ChamberModel, 2> fed;
  if (supply_pressure) {
    for (int k = 0; k < 2; ++k) fed.push_back(chamber_model_[k]), fed[k].p_supply = *supply_pressure;
    models = fed.begin();
  }

  // act_dot of each chamber: (p(t + h) - p(t)) / h, or dp/dt for step=explicit
  bool physical[2];
  for (int k = 0; k < 2; ++k) physical[k] = config_.chamber[k].model == PressureModel::kPhysical;

  // the identified model (paper 000 eq. 10), chamber by chamber, with the exact step of eq. 7
  for (int k = 0; k < 2; ++k) {
    if (physical[k]) continue;
    // the chamber's own valve voltage, or the single 5/3 valve's duplicated (paper 000 Section V)
    double u = config_.valve == ValveKind::kProportionalPerChamber ? valves.command[k] : valves.command[0];
    SteadyStateAndRate sr = IdentifiedModel(config_.chamber[k].identified, u, motion.x, motion.velocity);
    rate[k] = config_.step == ChamberStep::kExplicit ? (sr.s - p0[k]) * sr.r
                                                     : (IdentifiedPressureStep(sr, p0[k], h) - p0[k]) / h;
  }
  if (config_.thermal_model == ThermalModel::kEnergy) {
    StepEnergy(m, d, models, valves, motion, x_rate, p0, supply_drawn);
    return;
  }
  if (physical[0] || physical[1]) PhysicalRates(m, d, models, valves, motion, x_rate, p0, rate, supply_drawn);
  for (int k = 0; k < 2; ++k) ActDot(m, d, info_.chamber_actuator[k]) = rate[k];
}

// thermal_model=energy (both chambers physical, step linearized or exact: the parser sees to it): each
// chamber's pressure and gas temperature by the energy equation's own implicit step; the leak across
// the piston as an exchange of mass and enthalpy at fixed volumes in two halves around those steps
// (Strang splitting, EnergyLeakExchange), which keeps the gas's mass and energy exactly
void Cylinder::StepEnergy(const mjModel* m, mjData* d, const ChamberModel models[2], const ValveInputs& valves,
                          const PistonMotion& motion, double x_rate, const double p0[2], double* supply_drawn) const {
  const double h = m->opt.timestep;
  const double leak = config_.piston_leak_conductance;
  PortSchedule ports[2] = {{config_, 0, valves}, {config_, 1, valves}};
  const VolumePath volume[2] = {Volume(0, motion.x, x_rate), Volume(1, motion.x, x_rate)};
  GasState start[2], gas[2];
  for (int k = 0; k < 2; ++k) {
    start[k] = {p0[k], Act(m, d, extra_state_id_[kTemperatureP + k]) + config_.temperature};
    gas[k] = start[k];
  }
  const bool leaks = leak > 0 || config_.piston_leak_area > 0;
  const double v_start[2] = {volume[0].At(0), volume[1].At(0)}, v_end[2] = {volume[0].At(h), volume[1].At(h)};
  if (leaks) EnergyLeakExchange(models, v_start, leak, config_.piston_leak_area, h / 2, gas);
  GasState end[2];
  for (int k = 0; k < 2; ++k) {
    double drawn = 0;
    end[k] = EnergyPressureStep(models[k], ports[k], volume[k], 0, 0, gas[1 - k], gas[k], h,
                                supply_drawn ? &drawn : nullptr);
    if (supply_drawn) *supply_drawn += drawn;
  }
  if (leaks) EnergyLeakExchange(models, v_end, leak, config_.piston_leak_area, h / 2, end);
  for (int k = 0; k < 2; ++k) {
    ActDot(m, d, info_.chamber_actuator[k]) = (end[k].p - p0[k]) / h;
    ActDot(m, d, extra_state_id_[kTemperatureP + k]) = (end[k].t - start[k].t) / h;
  }
}

// the physical model: the valves' openings over the step and the volumes along the piston's path;
// writes rate[k] of each physical chamber (and the act_dot of its line, if it has one)
void Cylinder::PhysicalRates(const mjModel* m, mjData* d, const ChamberModel models[2], const ValveInputs& valves,
                             const PistonMotion& motion, double x_rate, const double p0[2], double rate[2],
                             double* supply_drawn) const {
  const double h = m->opt.timestep;
  const double leak = config_.piston_leak_conductance;
  bool physical[2];
  for (int k = 0; k < 2; ++k) physical[k] = config_.chamber[k].model == PressureModel::kPhysical;
  PortSchedule ports[2] = {{config_, 0, valves}, {config_, 1, valves}};
  VolumePath volume[2] = {Volume(0, motion.x, x_rate), Volume(1, motion.x, x_rate)};
  double p1[2] = {0, 0};
  bool done[2] = {false, false};
  bool line[2] = {false, false};
  for (int k = 0; k < 2; ++k) line[k] = physical[k] && config_.chamber[k].line_volume > 0;
  // the leaks across the piston, as exchanges at fixed volumes in two halves around the chambers' steps
  // (Strang splitting), where those steps do not hold them: the orifice (piston_leak_area) always, the
  // laminar leak (piston_leak_conductance) when a chamber is behind a line (its step holds one chamber);
  // the chambers step from pin, what the first halves leave
  const bool both_implicit = physical[0] && physical[1] && config_.step != ChamberStep::kExplicit;
  const double orifice = both_implicit ? config_.piston_leak_area : 0;
  const bool split_laminar = both_implicit && leak > 0 && (line[0] || line[1]);
  double pin[2] = {p0[0], p0[1]};
  const double v_start_both[2] = {volume[0].At(0), volume[1].At(0)}, v_end_both[2] = {volume[0].At(h), volume[1].At(h)};
  if (orifice > 0) PistonOrificeExchange(models, v_start_both, orifice, h / 2, pin);
  const double p_before_laminar[2] = {pin[0], pin[1]};  // where the supply's accounting starts
  if (split_laminar) PistonLeakExchange(models, v_start_both, leak, h / 2, pin);
  const double line_drawn = StepLines(m, d, models, ports, volume, line, pin, supply_drawn != nullptr, p1, done);
  if (config_.step == ChamberStep::kLinearized) {
    // both chambers in one call where both take it (coupled by the leak across the piston, or
    // each on its own), else the one that does
    const PortSchedule* schedules[2] = {&ports[0], &ports[1]};
    const bool takes[2] = {physical[0] && !line[0], physical[1] && !line[1]};
    if (takes[0] && takes[1]) {
      LinearizedPressureStep(2, models, schedules, volume, leak, pin, h, p1, done);
    } else {
      for (int k = 0; k < 2; ++k) {
        if (!takes[k]) continue;
        LinearizedPressureStep(1, &models[k], &schedules[k], &volume[k], 0, &pin[k], h, &p1[k], &done[k]);
      }
    }
  }
  if (config_.step == ChamberStep::kExplicit) {
    ExplicitRates(models, ports, volume, p0, rate);
  } else if (!done[0] || !done[1]) {
    // the adaptive implicit step (step=exact, or where the linearized step asks for it), chamber by chamber;
    // the leak across the piston, solved exactly, in two halves around it (Strang splitting)
    // (taken here unless split_laminar took it around every chamber's step)
    bool coupled = leak > 0 && physical[0] && physical[1] && !split_laminar;
    double p[2] = {pin[0], pin[1]};
    if (coupled) PistonLeakExchange(models, v_start_both, leak, h / 2, p);
    for (int k = 0; k < 2; ++k) {
      if (physical[k] && !done[k]) p1[k] = PhysicalPressureStep(models[k], ports[k], volume[k], p[k], h);
    }
    if (coupled) PistonLeakExchange(models, v_end_both, leak, h / 2, p1);
  }
  if (split_laminar) PistonLeakExchange(models, v_end_both, leak, h / 2, p1);
  const double p1_chambers[2] = {p1[0], p1[1]};  // before the orifice's second half
  if (orifice > 0) PistonOrificeExchange(models, v_end_both, orifice, h / 2, p1);
  for (int k = 0; k < 2; ++k) {
    if (physical[k] && config_.step != ChamberStep::kExplicit) rate[k] = (p1[k] - p0[k]) / h;
  }
  if (supply_drawn) AddSupplyDrawn(models, ports, volume, line, line_drawn, p0, p_before_laminar, p1_chambers, h, supply_drawn);
}

// a chamber behind a line (line_volume > 0; the parser refuses step=explicit with it): line and
// chamber together by their own implicit step from pin, which writes the line's act_dot, p1 and done of
// the chamber; returns the mass its supply port draws over the step (0 unless count_supply)
double Cylinder::StepLines(const mjModel* m, mjData* d, const ChamberModel models[2], const PortSchedule ports[2],
                           const VolumePath volume[2], const bool line[2], const double pin[2], bool count_supply,
                           double p1[2], bool done[2]) const {
  const double h = m->opt.timestep;
  double line_drawn = 0;
  for (int k = 0; k < 2; ++k) {
    if (!line[k]) continue;
    int id = extra_state_id_[kLineP + k];
    double line0 = Act(m, d, id) + config_.p_atm, line1 = line0, drawn = 0;
    LinePressureStep(models[k], ports[k], volume[k], line0, pin[k], h, &line1, &p1[k], count_supply ? &drawn : nullptr);
    ActDot(m, d, id) = (line1 - line0) / h;
    line_drawn += drawn;
    done[k] = true;
  }
  return line_drawn;
}

// step=explicit: dp/dt of each physical chamber at the start of the step (MuJoCo's plain Euler)
void Cylinder::ExplicitRates(const ChamberModel models[2], const PortSchedule ports[2], const VolumePath volume[2],
                             const double p0[2], double rate[2]) const {
  const double leak = config_.piston_leak_conductance;
  bool physical[2];
  for (int k = 0; k < 2; ++k) physical[k] = config_.chamber[k].model == PressureModel::kPhysical;
  for (int k = 0; k < 2; ++k) {
    if (physical[k]) {
      rate[k] = PressureRate(models[k], ports[k].At(0), p0[k], volume[k].At(0), volume[k].RateAt(0), leak,
                             p0[1 - k]);
      if (config_.piston_leak_area > 0 && physical[1 - k]) {
        // the orifice across the piston, as the chamber takes it: n r T Q(p_other -> p) / V
        rate[k] += models[k].polytropic_index * models[k].gas_rt *
                   MassFlow(models[k].leak_law, config_.piston_leak_area, p0[1 - k], p0[k]) / volume[k].At(0);
      }
    }
  }
}

// the mass the supply ports draw over the step, for the reservoir, added to *supply_drawn: the lines'
// (line_drawn), then each other chamber's from p_start to p_end, the pressures its own step began and
// ended at (both chambers are physical: the parser refuses supply= with the identified model)
void Cylinder::AddSupplyDrawn(const ChamberModel models[2], const PortSchedule ports[2], const VolumePath volume[2],
                              const bool line[2], double line_drawn, const double p0[2], const double p_start[2],
                              const double p_end[2], double h, double* supply_drawn) const {
  const double leak = config_.piston_leak_conductance;
  bool physical[2];
  for (int k = 0; k < 2; ++k) physical[k] = config_.chamber[k].model == PressureModel::kPhysical;
  double coupled_leak = leak > 0 && physical[0] && physical[1] ? leak : 0;
  if (line[0] || line[1]) *supply_drawn += line_drawn;
  for (int k = 0; k < 2; ++k) {
    if (!physical[k] || line[k]) continue;
    if (config_.step == ChamberStep::kExplicit) {
      // plain explicit Euler: the flow at the start of the step, as the chamber takes it
      double opening = ports[k].At(0).supply;
      *supply_drawn += opening > 0 ? h * MassFlow(models[k].flow, opening, models[k].p_supply, p0[k]) : 0.0;
    } else {
      *supply_drawn += SupplyMassOverStep(models[k], ports[k].At(0), ports[k].At(h), volume[k], p_start[k],
                                          p_end[k], coupled_leak, p_start[1 - k], p_end[1 - k], h);
    }
  }
}

void Cylinder::WriteGains(mjModel* m) const {
  // force A_P (p_P - p_atm) - A_N (p_N - p_atm), docs/rigs.md; paper 001 eq. (1)
  for (const auto& [id, role] : actuators_) {
    // mount=hinge_sites: times the lever arm, which changes with the angle (ChamberGain, the gain callback)
    if (role.role == Role::kChamber && config_.mount == Mount::kHingeSites) continue;
    m->actuator_gaintype[id] = mjGAIN_FIXED;
    mjtNum* gain = m->actuator_gainprm + id * mjNGAIN;
    for (int i = 0; i < mjNGAIN; ++i) gain[i] = 0;
    if (role.role == Role::kChamber) gain[0] = role.index == 0 ? config_.chamber[0].area : -config_.chamber[1].area;
  }
}

double Cylinder::BristleMeanRate(double z, double v, double h) const {
  // LuGre, Canudas de Wit et al. 1995 eqs. (2)-(3): dz/dt = v - sigma0 |v| z / g(v),
  // g(v) = F_c + (F_s - F_c) exp(-(v/v_s)^2). With v held over the step the equation is linear in z,
  // dz/dt = v - a z with a = sigma0 |v| / g(v) (up to 1e5 1/s: stiff), and its exact solution is
  // z(h) = z + h phi1(-a h) (v - a z), phi1(x) = (e^x - 1)/x; this returns (z(h) - z)/h
  const CylinderConfig& c = config_;
  double ratio = v / c.stribeck_velocity;
  double f_c = c.coulomb_friction.value_or(0);
  double g = f_c + (c.static_friction - f_c) * std::exp(-ratio * ratio);
  g = std::max(g, 1e-12 * c.static_friction);  // F_c = 0 at high speed: the bristles carry no load
  double a = c.bristle_stiffness * std::fabs(v) / g;
  double x = -a * h;
  double phi1 = std::fabs(x) < 1e-8 ? 1 + x / 2 : std::expm1(x) / x;
  return phi1 * (v - a * z);
}

double Cylinder::FrictionBias(const mjModel* m, const mjData* d) const {
  if (config_.friction_model == FrictionModel::kLuGre) {
    // LuGre, Canudas de Wit et al. 1995 eq. (4): F = sigma0 z + sigma1 dz/dt + sigma2 v against the motion.
    // dz/dt is taken as its mean over the coming step at the present velocity (exact for a held v,
    // BristleMeanRate): a bristle that relaxes within a step does not push for the whole step
    // (the project's own discretisation; it equals dz/dt as h -> 0)
    double v = PistonVelocity(m, d, info_);
    double z = Act(m, d, extra_state_id_[kBristle]);
    double rate = BristleMeanRate(z, v, m->opt.timestep);
    return -(config_.bristle_stiffness * z + config_.bristle_damping * rate + config_.viscous_friction * v);
  }
  // Stribeck curve F(v) = F_c + (F_s - F_c) exp(-(v/v_s)^2) against the motion (the project's own
  // form of the papers' static and Coulomb levels, paper 001 Section III): frictionloss
  // gives F_s, this term gives back (F_s - F_c)(1 - exp(-(v/v_s)^2)) along it. Its slope is zero
  // at rest, so it cannot turn the soft frictionloss constraint's creep into a breakaway
  double v = PistonVelocity(m, d, info_);
  double ratio = v / config_.stribeck_velocity;
  double give_back = (static_friction_ - config_.coulomb_friction.value_or(static_friction_)) *
                     (1 - std::exp(-ratio * ratio));
  return v > 0 ? give_back : -give_back;
}

double PistonPosition(const mjModel*, const mjData* d, const CylinderInfo& c) {
  if (c.rod_site >= 0) return HingeSitesGeometry(d, c).length - c.x_mid;
  return d->actuator_length[c.chamber_actuator[0]] - c.x_mid;
}

double PistonVelocity(const mjModel*, const mjData* d, const CylinderInfo& c) {
  // with mount=hinge_sites the chamber actuator's velocity is the hinge's (gear 1), taken by MuJoCo at the
  // same stage as the sites' positions (after mj_step: the step's start, as a tendon's would be)
  if (c.rod_site >= 0) return HingeSitesGeometry(d, c).arm * d->actuator_velocity[c.chamber_actuator[0]];
  return d->actuator_velocity[c.chamber_actuator[0]];
}

void PistonJacobian(const mjModel* m, const mjData* d, const CylinderInfo& c, mjtNum* row) {
  if (c.rod_site >= 0) {
    mju_zero(row, m->nv);
    row[m->jnt_dofadr[c.hinge]] = HingeSitesGeometry(d, c).arm;
    return;
  }
  mju_copy(row, d->actuator_moment + static_cast<size_t>(c.chamber_actuator[0]) * m->nv, m->nv);
}

std::optional<double> HingeAngleAt(const mjModel* m, const mjData* d, const CylinderInfo& c, double x,
                                   double* lever_arm, std::string* error) {
  if (c.rod_site < 0) {
    *error = "cylinder '" + c.name + "' is not mounted between sites (mount=hinge_sites)";
    return std::nullopt;
  }
  // turning the hinge by t from its present angle moves the rod end to
  // anchor + rho_par + cos t rho_perp + sin t (a x rho), rho = rod - anchor split along the axis a and
  // across it; with w = cap - anchor the length obeys L^2(t) = K - 2 (A cos t + B sin t),
  // K = |rho_par - w|^2 + |rho_perp|^2, A = w . rho_perp, B = w . (a x rho) (the project's own form)
  const mjtNum* cap = d->site_xpos + 3 * c.cap_site;
  const mjtNum* rod = d->site_xpos + 3 * c.rod_site;
  const mjtNum* a = d->xaxis + 3 * c.hinge;
  const mjtNum* anchor = d->xanchor + 3 * c.hinge;
  mjtNum rho[3], w[3], along[3], across[3], turned[3], offset[3];
  mju_sub3(rho, rod, anchor);
  mju_sub3(w, cap, anchor);
  mju_scl3(along, a, mju_dot3(a, rho));
  mju_sub3(across, rho, along);
  mju_cross(turned, a, rho);
  mju_sub3(offset, along, w);
  const double k = mju_dot3(offset, offset) + mju_dot3(across, across);
  const double big_a = mju_dot3(w, across), big_b = mju_dot3(w, turned);
  const double length = x + c.x_mid;
  const double radius = std::hypot(big_a, big_b);
  const double wanted = (k - length * length) / 2;  // = A cos t + B sin t = R cos(t - phi)
  if (!(length > 0) || !(std::fabs(wanted) <= radius)) {
    *error = "cylinder '" + c.name + "': no angle of hinge '" + ObjectName(m, mjOBJ_JOINT, c.hinge) +
             "' puts its sites " + FormatNumber(length) + " m apart (x = " + FormatNumber(x) + " m)";
    return std::nullopt;
  }
  const double phi = std::atan2(big_b, big_a), spread = std::acos(wanted / radius);
  // the two solutions phi +- spread, each wrapped into (-pi, pi]; the smaller turn wins
  auto wrap = [](double t) { return t - 2 * mjPI * std::round(t / (2 * mjPI)); };
  const double t1 = wrap(phi + spread), t2 = wrap(phi - spread);
  const double t = std::fabs(t1) <= std::fabs(t2) ? t1 : t2;
  if (lever_arm) *lever_arm = (big_a * std::sin(t) - big_b * std::cos(t)) / length;
  return d->qpos[m->jnt_qposadr[c.hinge]] + t;
}

int DrivenJoint(const mjModel* m, const CylinderInfo& c) {
  int id = c.chamber_actuator[0];
  if (c.rod_site >= 0 || id < 0) return -1;
  int type = m->actuator_trntype[id];
  return (type == mjTRN_JOINT || type == mjTRN_JOINTINPARENT) ? m->actuator_trnid[2 * id] : -1;
}

double ChamberPressure(const mjModel* m, const mjData* d, const CylinderInfo& c, Chamber k) {
  return Act(m, d, c.chamber_actuator[static_cast<int>(k)]) + c.p_atm;
}

void SetChamberPressure(const mjModel* m, mjData* d, const CylinderInfo& c, Chamber k, double pressure) {
  d->act[ActIndex(m, c.chamber_actuator[static_cast<int>(k)])] = pressure - c.p_atm;
}

std::optional<double> LinePressure(const mjModel* m, const mjData* d, const CylinderInfo& c, Chamber k) {
  const int id = c.line_actuator[static_cast<int>(k)];
  if (id < 0) return std::nullopt;
  return Act(m, d, id) + c.p_atm;
}

bool SetLinePressure(const mjModel* m, mjData* d, const CylinderInfo& c, Chamber k, double pressure) {
  const int id = c.line_actuator[static_cast<int>(k)];
  if (id < 0) return false;
  d->act[ActIndex(m, id)] = pressure - c.p_atm;
  return true;
}

}  // namespace pneumatic
