#include "simulation/closed_loop.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <memory>

#include "pneumatic/pneumatic.h"
#include "simulation/random_stream.h"
#include "simulation/rollout.h"
#include "simulation/step_state.h"

namespace pneumatic {
namespace {

enum Purpose : std::uint64_t { kSensorNoise = 11 };

// what pressure targets need of a per-chamber valve's chambers (ValveDrive::ChamberValve);
// drive->pressure_targets left false where a chamber is neither paper 000's identified model nor
// the physical one with thin-plate flow
void ReadChamberValves(const mjModel* m, const CylinderInfo& c, ValveDrive* drive) {
  std::string error;
  auto number = [&](const std::string& key, double* out) {
    std::optional<double> value = GetParameter(m, c.name, key, &error);
    if (value) *out = *value;
    return value.has_value();
  };
  double deadband = 0, temperature = 0, gas_constant = 0, kappa = 0, compressibility = 0;
  if (!number("deadband_voltage", &deadband) || !number("temperature", &temperature) ||
      !number("gas_constant", &gas_constant) || !number("heat_capacity_ratio", &kappa) ||
      !number("compressibility", &compressibility)) {
    return;
  }
  for (int k = 0; k < 2; ++k) {
    const std::string prefix = k == 0 ? "P." : "N.";
    std::optional<std::string> model = GetChoice(m, c.name, prefix + "pressure_model", &error);
    if (!model) return;
    ValveDrive::ChamberValve& v = drive->chamber[k];
    if (*model == "identified") {  // paper 000 eqs. 7-10
      v.identified = true;
      for (int i = 1; i <= 9; ++i) {
        if (!number(prefix + "c" + std::to_string(i), &v.c[i])) return;
      }
      if (!number(prefix + "c_gamma", &v.c_gamma) || !number(prefix + "c_b", &v.c_b) ||
          !number(prefix + "c_s", &v.c_s)) {
        return;
      }
      continue;
    }
    std::optional<std::string> flow = GetChoice(m, c.name, prefix + "flow", &error);
    if (*model != "physical" || !flow || *flow != "thin_plate") return;
    double discharge = 0, polytropic = 0;
    if (!number(prefix + "area", &v.area) || !number(prefix + "dead_volume", &v.dead_volume) ||
        !number(prefix + "area_gain", &v.area_gain) || !number(prefix + "u_supply_seal", &v.u_supply_seal) ||
        !number(prefix + "u_exhaust_seal", &v.u_exhaust_seal) ||
        !number(prefix + "leak_area_supply", &v.leak_supply) ||
        !number(prefix + "leak_area_exhaust", &v.leak_exhaust) ||
        !number(prefix + "area_smoothing", &v.area_smoothing) ||
        !number(prefix + "discharge_coefficient", &discharge) || !number(prefix + "polytropic_index", &polytropic)) {
      return;
    }
    v.u_supply_seal += deadband, v.u_exhaust_seal -= deadband;
    // paper 000 Appendix eqs. 11-13 (as plugin/src/flow.cc), eq. 2's n r T
    const double zrt = compressibility * gas_constant * temperature;
    v.flow_alpha = discharge * std::sqrt(2 / zrt * kappa / (kappa - 1));
    v.flow_beta = discharge * std::sqrt(kappa / zrt * std::pow(2 / (kappa + 1), (kappa + 1) / (kappa - 1)));
    v.flow_theta = std::pow((kappa + 1) / 2, kappa / (kappa - 1));
    v.kappa = kappa;
    v.rate_per_mass = polytropic * gas_constant * temperature;
  }
  drive->pressure_targets = true;
}

// how the controller reaches each cylinder's valves, read from the model
std::string DriveOf(const mjModel* m, const CylinderInfo& c, ValveDrive* drive) {
  std::string error;
  std::optional<std::string> valve = GetChoice(m, c.name, "valve", &error);
  std::optional<double> stroke = GetParameter(m, c.name, "stroke", &error);
  if (!valve || !stroke) return error;
  drive->half_stroke = *stroke / 2;
  drive->p_supply = c.p_supply, drive->p_exhaust = c.p_exhaust;
  std::optional<double> area_P = GetParameter(m, c.name, "P.area", &error);
  std::optional<double> area_N = GetParameter(m, c.name, "N.area", &error);
  if (!area_P || !area_N) return error;
  drive->force_span = (*area_P + *area_N) / 2 * (c.p_supply - c.p_exhaust);
  if (*valve == "proportional_per_chamber") {
    drive->kind = ValveDrive::Kind::kPerChamber;
    std::optional<double> u_c = GetParameter(m, c.name, "P.u_supply_seal", &error);
    std::optional<double> u_r = GetParameter(m, c.name, "P.u_exhaust_seal", &error);
    if (!u_c || !u_r) return error;
    drive->centre = (*u_c + *u_r) / 2;  // paper 000 Table I: c1 = (U_c + U_r) / 2, the sealed valve
    drive->command_min = drive->centre - 5, drive->command_max = drive->centre + 5;
    ReadChamberValves(m, c, drive);
    if (int id = c.CommandActuator("uP"); id >= 0 && m->actuator_ctrllimited[id]) {
      drive->command_min = m->actuator_ctrlrange[2 * id], drive->command_max = m->actuator_ctrlrange[2 * id + 1];
    }
  } else if (*valve == "proportional_5_3") {
    drive->kind = ValveDrive::Kind::kFiveThree;
    std::optional<double> u_max = GetParameter(m, c.name, "u_max", &error);
    if (!u_max) return error;
    drive->u_max = *u_max;
  } else {
    std::optional<std::string> input = GetChoice(m, c.name, "input", &error);
    if (!input) return error;
    drive->kind = *input == "pwm" ? ValveDrive::Kind::kDuty : ValveDrive::Kind::kOnOff;
  }
  return "";
}

// commands that leave every valve at rest: closed or centred
CylinderCommands RestCommands(const ValveDrive& drive) {
  switch (drive.kind) {
    case ValveDrive::Kind::kPerChamber: return {{"uP", drive.centre}, {"uN", drive.centre}};
    case ValveDrive::Kind::kFiveThree: return {{"u", 0}};
    case ValveDrive::Kind::kOnOff: return {{"u1", 0}, {"u2", 0}, {"u3", 0}, {"u4", 0}};
    case ValveDrive::Kind::kDuty: return {{"duty", 0}};
  }
  return {};
}

// the reference of one cylinder at time t: linear between the log's rows
class Reference {
 public:
  Reference(const log::Log* log, int column) : log_(log), column_(column) {}
  bool given() const { return column_ >= 0; }
  double At(double t) const {
    const std::vector<double>& time = log_->time;
    const std::vector<double>& ref = log_->values[static_cast<size_t>(column_)];
    if (t <= time.front()) return ref.front();
    if (t >= time.back()) return ref.back();
    size_t i = static_cast<size_t>(std::upper_bound(time.begin(), time.end(), t) - time.begin()) - 1;
    double s = (t - time[i]) / (time[i + 1] - time[i]);
    return ref[i] + s * (ref[i + 1] - ref[i]);
  }
  // the targets, row by row (given() only)
  const std::vector<double>& Rows() const { return log_->values[static_cast<size_t>(column_)]; }

 private:
  const log::Log* log_;
  int column_;
};

struct Channel {
  CylinderInfo info;
  ValveDrive drive;
  Reference reference{nullptr, -1};
  double hold = 0;  // the initial position, the target without a reference
  Stream noise;
  std::vector<std::pair<int, int>> command_columns;  // (actuator, output column) by the commands' order
};

// d's position and velocity stages at its present time, computed on `scratch` from d's qpos, qvel and
// mocap alone, so that d and its next step are untouched: what the sensors read at a tick. (mj_step
// leaves d's own position-dependent quantities, actuator lengths and velocities included, as its forward
// pass computed them at the start of the step: one model step old, while the pressures in act are
// current.) The position stage as mj_fwdPosition begins it; the actuator velocities as mj_fwdVelocity
// computes them, moment times qvel.
void PresentStages(const mjModel* m, const mjData* d, mjData* scratch) {
  mju_copy(scratch->qpos, d->qpos, m->nq);
  mju_copy(scratch->qvel, d->qvel, m->nv);
  mju_copy(scratch->mocap_pos, d->mocap_pos, 3 * m->nmocap);
  mju_copy(scratch->mocap_quat, d->mocap_quat, 4 * m->nmocap);
  mj_kinematics(m, scratch);
  mj_comPos(m, scratch);
  mj_tendon(m, scratch);
  mj_transmission(m, scratch);
  mju_mulMatVec(scratch->actuator_velocity, scratch->actuator_moment, scratch->qvel, m->nu, m->nv);
}

// |J|^4 / (J M J') of each cylinder's piston, J = dx/dq (CylinderMeasurement::mobility) at the pose of
// `present` (PresentStages; its inertia is computed here): the inertia the piston sees when the joints
// move along J alone (q' = J' x' / |J|^2, kinetic energy x'^2 J M J' / (2 |J|^4)); holding the other
// joints, rather than leaving them free (J M^-1 J'), is what their own controllers do. `workspace` holds
// 2 nv numbers.
void Mobilities(const mjModel* m, mjData* present, const std::vector<Channel>& channels,
                std::vector<mjtNum>* workspace, std::vector<double>* out) {
  mj_crb(m, present);
  workspace->resize(2 * static_cast<size_t>(m->nv));
  mjtNum* jacobian = workspace->data();
  mjtNum* inertia_times_jacobian = jacobian + m->nv;
  out->resize(channels.size());
  for (size_t i = 0; i < channels.size(); ++i) {
    PistonJacobian(m, present, channels[i].info, jacobian);
    mj_mulM(m, present, inertia_times_jacobian, jacobian);
    const double squared = mju_dot(jacobian, jacobian, m->nv), inertia = mju_dot(jacobian, inertia_times_jacobian, m->nv);
    (*out)[i] = inertia > 0 ? squared * squared / inertia : 0;
  }
}

// the controller's commands must be each cylinder's command signals, in the order of its rest commands
std::string CheckCommands(const std::vector<Channel>& channels, const std::vector<CylinderCommands>& commands) {
  if (commands.size() != channels.size()) return "the controller wrote commands for a different number of cylinders";
  for (size_t i = 0; i < channels.size(); ++i) {
    const CylinderCommands rest = RestCommands(channels[i].drive);
    bool same = commands[i].size() == rest.size();
    for (size_t j = 0; same && j < rest.size(); ++j) same = commands[i][j].first == rest[j].first;
    if (!same) return "the controller's commands for cylinder '" + channels[i].info.name + "' are not its valve's signals";
    for (const auto& [signal, value] : commands[i]) {
      if (!std::isfinite(value)) return "the controller wrote a non-finite " + channels[i].info.name + "." + signal;
    }
  }
  return "";
}

// a pid run's pressure targets (pressure_margin > 0) need proportional valves per chamber whose
// pressure models the controller can invert, and a margin and step that leave it room
std::string CheckPressureTargets(const Channel& ch, const PositionPidGains& gains) {
  const ValveDrive& drive = ch.drive;
  if (drive.kind != ValveDrive::Kind::kPerChamber || !drive.pressure_targets) {
    return "cylinder '" + ch.info.name + "': pressure_margin needs one proportional valve per chamber, " +
           "each chamber with the identified pressure model or the physical one with thin-plate flow";
  }
  if (!(2 * gains.pressure_margin < drive.p_supply - drive.p_exhaust)) {
    return "cylinder '" + ch.info.name + "': pressure_margin " + std::to_string(gains.pressure_margin) +
           " Pa leaves no pressure between p_exhaust + margin and p_supply - margin";
  }
  if (!(gains.pressure_step > 0 && gains.pressure_step <= 1)) {
    return "cylinder '" + ch.info.name + "': pressure_step must be in (0, 1]";
  }
  return "";
}

// a target the piston cannot reach: x within half the stroke of mid-stroke (m, or rad for a vane);
// the summary's warning, or ""
std::string UnreachableReference(const Channel& ch) {
  if (!ch.reference.given()) return "";
  const double half_stroke = ch.drive.half_stroke;
  const auto [low, high] = std::minmax_element(ch.reference.Rows().begin(), ch.reference.Rows().end());
  if (*low < -half_stroke || *high > half_stroke) {
    char text[300];
    std::snprintf(text, sizeof(text),
                  "cylinder '%s': its reference reaches %.6g, beyond the stroke (x within +-%.6g of mid-stroke): "
                  "the piston cannot follow there",
                  ch.info.name.c_str(), *low < -half_stroke ? *low : *high, half_stroke);
    return text;
  }
  return "";
}

using DataPtr = std::unique_ptr<mjData, void (*)(mjData*)>;

// One run of RunClosedLoop: the simulation, the channels, the controller, the log being written and
// the summary (the result's), which its steps share. Every step returns an error, or "" to go on.
class ClosedLoopRun {
 public:
  ClosedLoopRun(const mjModel* m, const ClosedLoopOptions& options, ClosedLoopResult* result)
      : m_(m), options_(options), result_(*result), summary_(result->summary) {}

  std::string Run() {
    if (std::string e = CheckOptions(); !e.empty()) return e;
    if (std::string e = StartSimulation(); !e.empty()) return e;
    if (std::string e = PrepareChannels(); !e.empty()) return e;
    AddMeasuredColumns();
    if (std::string e = PrepareController(); !e.empty()) return e;
    StartSummary();
    if (std::string e = PrepareLoop(); !e.empty()) return e;
    const auto start = std::chrono::steady_clock::now();
    const bool uses_mobility = controller_ && controller_->UsesMobility();
    mobility_.assign(channels_.size(), 0.0);
    for (long k = 0; k < ticks_; ++k) {
      if (std::string e = StepOneControlPeriod(k, uses_mobility); !e.empty()) return e;
    }
    FinishSummary(start);
    SaveFinalState();
    result_.log = std::move(out_);
    return "";
  }

 private:
  // the options, and the control period as a whole number of model steps
  std::string CheckOptions() {
    const ClosedLoopOptions& options = options_;
    if (std::string problem = AttachedCylinders(m_, &cylinders_); !problem.empty()) return problem;
    if (!(options.duration > 0) || !std::isfinite(options.duration)) return "the duration must be positive";
    if (!(options.control_rate > 0) || !std::isfinite(options.control_rate)) return "the control rate must be positive";
    if (options.controller != "pid" && options.controller != "none" &&
        !(options.controller == "custom" && options.make_controller)) {
      return "unknown controller '" + options.controller + "' (choices: pid none)";
    }
    if (!(options.noise_pressure >= 0) || !(options.noise_position >= 0)) return "sensor noise must be >= 0";
    if (options.command_delay_ticks < 0) return "the command delay must be >= 0 ticks";
    if (options.command_delay_ticks > 0 && options.resume) return "a run with a command delay cannot be resumed";
    period_ = 1 / options.control_rate;
    steps_per_tick_ = std::lround(period_ / m_->opt.timestep);
    if (steps_per_tick_ < 1 ||
        std::fabs(static_cast<double>(steps_per_tick_) * m_->opt.timestep - period_) > 1e-9 * period_) {
      return "the control period " + std::to_string(period_) + " s is not a whole number of model timesteps (" +
             std::to_string(m_->opt.timestep) + " s)";
    }
    ticks_ = std::lround(std::ceil(options.duration * options.control_rate - 1e-9));
    for (const auto& [name, gains] : options.cylinder_gains) {
      bool known = false;
      for (const CylinderInfo& c : cylinders_) known |= c.name == name;
      if (!known) return "controller gains for '" + name + "', which is not a cylinder of the model";
    }
    return "";
  }

  // the model's data at its first keyframe (or its reset state), or as the run to resume left it
  std::string StartSimulation() {
    d_.reset(mj_makeData(m_));
    if (!d_) return "mj_makeData failed";
    if (m_->nkey > 0) mj_resetDataKeyframe(m_, d_.get(), 0);
    mj_forward(m_, d_.get());
    if (options_.resume) {
      // the state as the interrupted run left it, after its last mj_step (no forward pass since)
      size_t size = 0;
      for (const auto& [array, n] : StepStateArrays(m_, d_.get())) size += static_cast<size_t>(n);
      if (options_.resume->mujoco.size() != size || options_.resume->hold.size() != cylinders_.size() ||
          options_.resume->noise.size() != cylinders_.size()) {
        return "the state to resume from is not one of this model's runs";
      }
      const double* from = options_.resume->mujoco.data();
      for (const auto& [array, n] : StepStateArrays(m_, d_.get())) {
        std::copy(from, from + n, array);
        from += n;
      }
    }
    return "";
  }

  // the channels and the log's columns: every cylinder's commands (its measured signals follow in
  // AddMeasuredColumns)
  std::string PrepareChannels() {
    const ClosedLoopOptions& options = options_;
    out_.comments.push_back("closed-loop rollout: controller " + options.controller + " at " +
                            std::to_string(options.control_rate) + " Hz, commands held between ticks");
    for (size_t i = 0; i < cylinders_.size(); ++i) {
      Channel ch{cylinders_[i], {}, {nullptr, -1}, 0, Stream(options.seed, i, kSensorNoise), {}};
      if (std::string e = DriveOf(m_, ch.info, &ch.drive); !e.empty()) return e;
      if (options.reference) {
        ch.reference = Reference(options.reference, options.reference->FindColumn(ch.info.name, "ref"));
      }
      ch.hold = options.resume ? options.resume->hold[i] : PistonPosition(m_, d_.get(), ch.info);
      if (options.resume && !ch.noise.Load(options.resume->noise[i])) return "the state's noise stream is not one";
      for (const auto& [signal, value] : RestCommands(ch.drive)) {
        int actuator = ch.info.CommandActuator(signal);
        if (actuator < 0) return "cylinder '" + ch.info.name + "' has no actuator '" + ch.info.name + "." + signal + "'";
        ch.command_columns.emplace_back(actuator, static_cast<int>(out_.columns.size()));
        out_.columns.push_back({ch.info.name, signal});
      }
      drives_.push_back(ch.drive);
      auto it = options.cylinder_gains.find(ch.info.name);
      gains_.push_back(it != options.cylinder_gains.end() ? it->second : options.gains);
      if (options.controller == "pid" && gains_.back().pressure_margin > 0) {
        if (std::string e = CheckPressureTargets(ch, gains_.back()); !e.empty()) return e;
      }
      channels_.push_back(std::move(ch));
    }
    return "";
  }

  void AddMeasuredColumns() {
    first_measured_ = out_.columns.size();
    for (const Channel& ch : channels_) {
      for (const char* signal : {"p_P", "p_N", "x", "v", "p_S", "ref"}) out_.columns.push_back({ch.info.name, signal});
    }
    out_.values.assign(out_.columns.size(), {});
    for (auto& column : out_.values) column.reserve(static_cast<size_t>(ticks_));
  }

  // the controller the options name (none for "none"), resumed if the run is
  std::string PrepareController() {
    if (options_.controller == "pid") {
      controller_ = std::make_unique<PositionPid>(drives_, gains_, period_);
    } else if (options_.controller == "custom") {
      std::string why;
      controller_ = options_.make_controller(drives_, period_, &why);
      if (!controller_) return "the controller: " + why;
      if (std::fabs(controller_->Period() - period_) > 1e-12 * period_) {
        return "the controller's period differs from the control rate's";
      }
    }
    if (options_.resume && controller_ && !controller_->SetState(options_.resume->controller)) {
      return "the state's controller state is not this controller's";
    }
    return "";
  }

  void StartSummary() {
    for (const Channel& ch : channels_) {
      CylinderSummary s;
      s.name = ch.info.name;
      s.p_min[0] = s.p_min[1] = 1e300, s.p_max[0] = s.p_max[1] = -1e300;
      summary_.cylinders.push_back(s);
      if (std::string warning = UnreachableReference(ch); !warning.empty()) summary_.warnings.push_back(warning);
    }
    squared_error_.assign(channels_.size(), 0);
  }

  // every chamber's pressure range, sampled after every step (the summary's p_min, p_max)
  void SamplePressures() {
    for (size_t i = 0; i < channels_.size(); ++i) {
      CylinderSummary& s = summary_.cylinders[i];
      for (int chamber = 0; chamber < 2; ++chamber) {
        const double p = ChamberPressure(m_, d_.get(), channels_[i].info, chamber == 0 ? Chamber::kP : Chamber::kN);
        s.p_min[chamber] = std::min(s.p_min[chamber], p), s.p_max[chamber] = std::max(s.p_max[chamber], p);
        s.within_supply_range &= p >= channels_[i].info.p_exhaust - 1 && p <= channels_[i].info.p_supply + 1;
      }
    }
  }

  // the initial pressures sampled, the buffers the ticks reuse, and the observer shown the start
  std::string PrepareLoop() {
    SamplePressures();
    measured_.resize(channels_.size());
    scratch_.reset(mj_makeData(m_));
    if (!scratch_) return "mj_makeData failed";
    commands_.resize(channels_.size());
    arrived_.resize(channels_.size());
    for (size_t i = 0; i < channels_.size(); ++i) arrived_[i] = RestCommands(channels_[i].drive);
    if (options_.observer) {
      if (std::string e = options_.observer(d_.get()); !e.empty()) return e;
    }
    return "";
  }

  // tick k: the sensors read, the controller's commands, the log's row, then the model steps to the
  // next tick with the commands held
  std::string StepOneControlPeriod(long k, bool uses_mobility) {
    const double t = d_->time;
    mjData* present = scratch_.get();
    PresentStages(m_, d_.get(), present);
    if (uses_mobility) Mobilities(m_, present, channels_, &mobility_workspace_, &mobility_);
    ReadSensors(t, present);
    if (controller_) {
      controller_->Update(t, measured_, &commands_);
      if (std::string e = CheckCommands(channels_, commands_); !e.empty()) return e;
    } else {
      for (size_t i = 0; i < channels_.size(); ++i) commands_[i] = RestCommands(channels_[i].drive);
    }
    ApplyCommandsAndWriteRow(t, present);
    return StepToNextTick(k);
  }

  // the measurements at time t (noisy as the options say) and the tracking error of the true state
  void ReadSensors(double t, const mjData* present) {
    const ClosedLoopOptions& options = options_;
    for (size_t i = 0; i < channels_.size(); ++i) {
      Channel& ch = channels_[i];
      CylinderMeasurement& y = measured_[i];
      y.p_P = ChamberPressure(m_, d_.get(), ch.info, Chamber::kP) + options.noise_pressure * ch.noise.Gaussian();
      y.p_N = ChamberPressure(m_, d_.get(), ch.info, Chamber::kN) + options.noise_pressure * ch.noise.Gaussian();
      const double x_noise = options.noise_position * ch.noise.Gaussian();
      y.x = PistonPosition(m_, present, ch.info) + x_noise;
      y.reference = ch.reference.given() ? ch.reference.At(t) : ch.hold;
      y.mobility = mobility_[i];
      // the summary judges the true state, not the noisy sensors
      const double true_x = y.x - x_noise;
      const double error = std::fabs(y.reference - true_x);
      squared_error_[i] += error * error;
      CylinderSummary& s = summary_.cylinders[i];
      s.max_tracking_error = std::max(s.max_tracking_error, error);
    }
  }

  // the commands that reach the valves now (delayed by command_delay_ticks) into ctrl, and the row:
  // this tick's commands and the samples taken before they act
  void ApplyCommandsAndWriteRow(double t, const mjData* present) {
    out_.time.push_back(t);
    if (options_.command_delay_ticks > 0) {
      in_flight_.push_back(commands_);
      if (in_flight_.size() > static_cast<size_t>(options_.command_delay_ticks)) {
        arrived_ = in_flight_.front();
        in_flight_.pop_front();
      }
    }
    const std::vector<CylinderCommands>& applied = options_.command_delay_ticks > 0 ? arrived_ : commands_;
    size_t column = first_measured_;
    for (size_t i = 0; i < channels_.size(); ++i) {
      const Channel& ch = channels_[i];
      for (size_t j = 0; j < ch.command_columns.size(); ++j) {
        const auto [actuator, out_column] = ch.command_columns[j];
        d_->ctrl[actuator] = applied[i][j].second;
        out_.values[static_cast<size_t>(out_column)].push_back(commands_[i][j].second);
      }
      const CylinderMeasurement& y = measured_[i];
      for (double value : {y.p_P, y.p_N, y.x, PistonVelocity(m_, present, ch.info), SupplyPressure(m_, d_.get(), ch.info),
                           y.reference}) {
        out_.values[column++].push_back(value);
      }
    }
  }

  // the control period's model steps, each shown to the observer; an error if the simulation diverged
  std::string StepToNextTick(long k) {
    for (long step = 0; step < steps_per_tick_; ++step) {
      mj_step(m_, d_.get());
      SamplePressures();
      if (options_.observer) {
        if (std::string e = options_.observer(d_.get()); !e.empty()) return e;
      }
    }
    summary_.steps += steps_per_tick_;
    for (int w : {mjWARN_BADQACC, mjWARN_BADQVEL, mjWARN_BADQPOS, mjWARN_BADCTRL}) {
      if (d_->warning[w].number > 0) {
        return "the simulation diverged near t = " + std::to_string(d_->time) + " s (MuJoCo warning " +
               std::to_string(w) + ")";
      }
    }
    if (options_.progress && (k % 100 == 0 || k + 1 == ticks_)) {
      options_.progress(static_cast<double>(k + 1) / static_cast<double>(ticks_));
    }
    return "";
  }

  void FinishSummary(std::chrono::steady_clock::time_point start) {
    ClosedLoopSummary& summary = summary_;
    summary.simulated_s = static_cast<double>(summary.steps) * m_->opt.timestep;
    summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    summary.real_time_factor = summary.wall_s > 0 ? summary.simulated_s / summary.wall_s : 0;
    for (size_t i = 0; i < channels_.size(); ++i) {
      CylinderSummary& s = summary.cylinders[i];
      s.rms_tracking_error = std::sqrt(squared_error_[i] / static_cast<double>(ticks_));
      if (!s.within_supply_range) {
        summary.warnings.push_back("cylinder '" + s.name + "': a chamber pressure left [p_exhaust, p_supply]");
      }
    }
    for (int w = 0; w < mjNWARNING; ++w) {
      if (d_->warning[w].number > 0) {
        summary.warnings.push_back("MuJoCo warning " + std::to_string(w) + " raised " +
                                   std::to_string(d_->warning[w].number) + " times");
      }
    }
  }

  // what a later run needs to go on from here
  void SaveFinalState() {
    ClosedLoopState& state = result_.final_state;
    for (const auto& [array, n] : StepStateArrays(m_, d_.get())) state.mujoco.insert(state.mujoco.end(), array, array + n);
    if (controller_) state.controller = controller_->State();
    for (const Channel& ch : channels_) {
      state.hold.push_back(ch.hold);
      state.noise.push_back(ch.noise.Save());
    }
  }

  const mjModel* m_;
  const ClosedLoopOptions& options_;
  ClosedLoopResult& result_;
  ClosedLoopSummary& summary_;
  std::vector<CylinderInfo> cylinders_;
  double period_ = 0;
  long steps_per_tick_ = 0, ticks_ = 0;
  DataPtr d_{nullptr, mj_deleteData};
  DataPtr scratch_{nullptr, mj_deleteData};  // the present stages at a tick (PresentStages)
  log::Log out_;
  std::vector<Channel> channels_;
  std::vector<ValveDrive> drives_;
  std::vector<PositionPidGains> gains_;
  size_t first_measured_ = 0;  // the log's first measured column
  std::unique_ptr<Controller> controller_;
  std::vector<double> squared_error_;
  std::vector<CylinderMeasurement> measured_;
  std::vector<double> mobility_;
  std::vector<mjtNum> mobility_workspace_;
  std::vector<CylinderCommands> commands_;
  // command_delay_ticks: the commands on their way to the valves, oldest first, and the last to
  // arrive (at rest until the first does)
  std::deque<std::vector<CylinderCommands>> in_flight_;
  std::vector<CylinderCommands> arrived_;
};

}  // namespace

ClosedLoopResult RunClosedLoop(const mjModel* m, const ClosedLoopOptions& options) {
  ClosedLoopResult result;
  ClosedLoopRun run(m, options, &result);
  if (std::string e = run.Run(); !e.empty()) {
    result.error = e;
    result.log.reset();
  }
  return result;
}

}  // namespace pneumatic
