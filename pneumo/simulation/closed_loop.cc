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

}  // namespace

ClosedLoopResult RunClosedLoop(const mjModel* m, const ClosedLoopOptions& options) {
  ClosedLoopResult result;
  auto fail = [&](const std::string& message) {
    result.error = message;
    result.log.reset();
    return result;
  };
  std::vector<CylinderInfo> cylinders;
  if (std::string problem = AttachedCylinders(m, &cylinders); !problem.empty()) return fail(problem);
  if (!(options.duration > 0) || !std::isfinite(options.duration)) return fail("the duration must be positive");
  if (!(options.control_rate > 0) || !std::isfinite(options.control_rate)) return fail("the control rate must be positive");
  if (options.controller != "pid" && options.controller != "none" &&
      !(options.controller == "custom" && options.make_controller)) {
    return fail("unknown controller '" + options.controller + "' (choices: pid none)");
  }
  if (!(options.noise_pressure >= 0) || !(options.noise_position >= 0)) return fail("sensor noise must be >= 0");
  if (options.command_delay_ticks < 0) return fail("the command delay must be >= 0 ticks");
  if (options.command_delay_ticks > 0 && options.resume) return fail("a run with a command delay cannot be resumed");
  const double period = 1 / options.control_rate;
  const long steps_per_tick = std::lround(period / m->opt.timestep);
  if (steps_per_tick < 1 || std::fabs(static_cast<double>(steps_per_tick) * m->opt.timestep - period) > 1e-9 * period) {
    return fail("the control period " + std::to_string(period) + " s is not a whole number of model timesteps (" +
                std::to_string(m->opt.timestep) + " s)");
  }
  const long ticks = std::lround(std::ceil(options.duration * options.control_rate - 1e-9));
  for (const auto& [name, gains] : options.cylinder_gains) {
    bool known = false;
    for (const CylinderInfo& c : cylinders) known |= c.name == name;
    if (!known) return fail("controller gains for '" + name + "', which is not a cylinder of the model");
  }

  std::unique_ptr<mjData, void (*)(mjData*)> d(mj_makeData(m), mj_deleteData);
  if (!d) return fail("mj_makeData failed");
  if (m->nkey > 0) mj_resetDataKeyframe(m, d.get(), 0);
  mj_forward(m, d.get());
  if (options.resume) {
    // the state as the interrupted run left it, after its last mj_step (no forward pass since)
    size_t size = 0;
    for (const auto& [array, n] : StepStateArrays(m, d.get())) size += static_cast<size_t>(n);
    if (options.resume->mujoco.size() != size || options.resume->hold.size() != cylinders.size() ||
        options.resume->noise.size() != cylinders.size()) {
      return fail("the state to resume from is not one of this model's runs");
    }
    const double* from = options.resume->mujoco.data();
    for (const auto& [array, n] : StepStateArrays(m, d.get())) {
      std::copy(from, from + n, array);
      from += n;
    }
  }

  // the channels and the log's columns: every cylinder's commands, then its measured signals
  log::Log out;
  out.comments.push_back("closed-loop rollout: controller " + options.controller + " at " +
                         std::to_string(options.control_rate) + " Hz, commands held between ticks");
  std::vector<Channel> channels;
  std::vector<ValveDrive> drives;
  std::vector<PositionPidGains> gains;
  for (size_t i = 0; i < cylinders.size(); ++i) {
    Channel ch{cylinders[i], {}, {nullptr, -1}, 0, Stream(options.seed, i, kSensorNoise), {}};
    if (std::string e = DriveOf(m, ch.info, &ch.drive); !e.empty()) return fail(e);
    if (options.reference) ch.reference = Reference(options.reference, options.reference->FindColumn(ch.info.name, "ref"));
    ch.hold = options.resume ? options.resume->hold[i] : PistonPosition(m, d.get(), ch.info);
    if (options.resume && !ch.noise.Load(options.resume->noise[i])) return fail("the state's noise stream is not one");
    for (const auto& [signal, value] : RestCommands(ch.drive)) {
      int actuator = ch.info.CommandActuator(signal);
      if (actuator < 0) return fail("cylinder '" + ch.info.name + "' has no actuator '" + ch.info.name + "." + signal + "'");
      ch.command_columns.emplace_back(actuator, static_cast<int>(out.columns.size()));
      out.columns.push_back({ch.info.name, signal});
    }
    drives.push_back(ch.drive);
    auto it = options.cylinder_gains.find(ch.info.name);
    gains.push_back(it != options.cylinder_gains.end() ? it->second : options.gains);
    if (options.controller == "pid" && gains.back().pressure_margin > 0) {
      const ValveDrive& drive = ch.drive;
      if (drive.kind != ValveDrive::Kind::kPerChamber || !drive.pressure_targets) {
        return fail("cylinder '" + ch.info.name + "': pressure_margin needs one proportional valve per chamber, " +
                    "each chamber with the identified pressure model or the physical one with thin-plate flow");
      }
      if (!(2 * gains.back().pressure_margin < drive.p_supply - drive.p_exhaust)) {
        return fail("cylinder '" + ch.info.name + "': pressure_margin " + std::to_string(gains.back().pressure_margin) +
                    " Pa leaves no pressure between p_exhaust + margin and p_supply - margin");
      }
      if (!(gains.back().pressure_step > 0 && gains.back().pressure_step <= 1)) {
        return fail("cylinder '" + ch.info.name + "': pressure_step must be in (0, 1]");
      }
    }
    channels.push_back(std::move(ch));
  }
  const size_t first_measured = out.columns.size();
  for (const Channel& ch : channels) {
    for (const char* signal : {"p_P", "p_N", "x", "v", "p_S", "ref"}) out.columns.push_back({ch.info.name, signal});
  }
  out.values.assign(out.columns.size(), {});
  for (auto& column : out.values) column.reserve(static_cast<size_t>(ticks));
  std::unique_ptr<Controller> controller;
  if (options.controller == "pid") {
    controller = std::make_unique<PositionPid>(drives, gains, period);
  } else if (options.controller == "custom") {
    std::string why;
    controller = options.make_controller(drives, period, &why);
    if (!controller) return fail("the controller: " + why);
    if (std::fabs(controller->Period() - period) > 1e-12 * period) {
      return fail("the controller's period differs from the control rate's");
    }
  }
  if (options.resume && controller && !controller->SetState(options.resume->controller)) {
    return fail("the state's controller state is not this controller's");
  }

  ClosedLoopSummary& summary = result.summary;
  for (const Channel& ch : channels) {
    CylinderSummary s;
    s.name = ch.info.name;
    s.p_min[0] = s.p_min[1] = 1e300, s.p_max[0] = s.p_max[1] = -1e300;
    summary.cylinders.push_back(s);
    // a target the piston cannot reach: x within half the stroke of mid-stroke (m, or rad for a vane)
    if (ch.reference.given()) {
      const double half_stroke = ch.drive.half_stroke;
      const auto [low, high] = std::minmax_element(ch.reference.Rows().begin(), ch.reference.Rows().end());
      if (*low < -half_stroke || *high > half_stroke) {
        char text[300];
        std::snprintf(text, sizeof(text),
                      "cylinder '%s': its reference reaches %.6g, beyond the stroke (x within +-%.6g of mid-stroke): "
                      "the piston cannot follow there",
                      ch.info.name.c_str(), *low < -half_stroke ? *low : *high, half_stroke);
        summary.warnings.push_back(text);
      }
    }
  }
  std::vector<double> squared_error(channels.size(), 0);
  // every chamber's pressure range, sampled after every step (the summary's p_min, p_max)
  auto sample_pressures = [&]() {
    for (size_t i = 0; i < channels.size(); ++i) {
      CylinderSummary& s = summary.cylinders[i];
      for (int chamber = 0; chamber < 2; ++chamber) {
        const double p = ChamberPressure(m, d.get(), channels[i].info, chamber == 0 ? Chamber::kP : Chamber::kN);
        s.p_min[chamber] = std::min(s.p_min[chamber], p), s.p_max[chamber] = std::max(s.p_max[chamber], p);
        s.within_supply_range &= p >= channels[i].info.p_exhaust - 1 && p <= channels[i].info.p_supply + 1;
      }
    }
  };
  sample_pressures();
  std::vector<CylinderMeasurement> measured(channels.size());
  std::unique_ptr<mjData, void (*)(mjData*)> scratch(mj_makeData(m), mj_deleteData);
  if (!scratch) return fail("mj_makeData failed");
  std::vector<double> mobility;
  std::vector<mjtNum> mobility_workspace;
  std::vector<CylinderCommands> commands(channels.size());
  // command_delay_ticks: the commands on their way to the valves, oldest first, and the last to
  // arrive (at rest until the first does)
  std::deque<std::vector<CylinderCommands>> in_flight;
  std::vector<CylinderCommands> arrived(channels.size());
  for (size_t i = 0; i < channels.size(); ++i) arrived[i] = RestCommands(channels[i].drive);
  if (options.observer) {
    if (std::string e = options.observer(d.get()); !e.empty()) return fail(e);
  }
  const auto start = std::chrono::steady_clock::now();
  const bool uses_mobility = controller && controller->UsesMobility();
  mobility.assign(channels.size(), 0.0);
  for (long k = 0; k < ticks; ++k) {
    const double t = d->time;
    mjData* present = scratch.get();
    PresentStages(m, d.get(), present);
    if (uses_mobility) Mobilities(m, present, channels, &mobility_workspace, &mobility);
    for (size_t i = 0; i < channels.size(); ++i) {
      Channel& ch = channels[i];
      CylinderMeasurement& y = measured[i];
      y.p_P = ChamberPressure(m, d.get(), ch.info, Chamber::kP) + options.noise_pressure * ch.noise.Gaussian();
      y.p_N = ChamberPressure(m, d.get(), ch.info, Chamber::kN) + options.noise_pressure * ch.noise.Gaussian();
      const double x_noise = options.noise_position * ch.noise.Gaussian();
      y.x = PistonPosition(m, present, ch.info) + x_noise;
      y.reference = ch.reference.given() ? ch.reference.At(t) : ch.hold;
      y.mobility = mobility[i];
      // the summary judges the true state, not the noisy sensors
      const double true_x = y.x - x_noise;
      const double error = std::fabs(y.reference - true_x);
      squared_error[i] += error * error;
      CylinderSummary& s = summary.cylinders[i];
      s.max_tracking_error = std::max(s.max_tracking_error, error);
    }
    if (controller) {
      controller->Update(t, measured, &commands);
      if (std::string e = CheckCommands(channels, commands); !e.empty()) return fail(e);
    } else {
      for (size_t i = 0; i < channels.size(); ++i) commands[i] = RestCommands(channels[i].drive);
    }

    // the row: this tick's commands and the samples taken before they act
    out.time.push_back(t);
    if (options.command_delay_ticks > 0) {
      in_flight.push_back(commands);
      if (in_flight.size() > static_cast<size_t>(options.command_delay_ticks)) {
        arrived = in_flight.front();
        in_flight.pop_front();
      }
    }
    const std::vector<CylinderCommands>& applied = options.command_delay_ticks > 0 ? arrived : commands;
    size_t column = first_measured;
    for (size_t i = 0; i < channels.size(); ++i) {
      const Channel& ch = channels[i];
      for (size_t j = 0; j < ch.command_columns.size(); ++j) {
        const auto [actuator, out_column] = ch.command_columns[j];
        d->ctrl[actuator] = applied[i][j].second;
        out.values[static_cast<size_t>(out_column)].push_back(commands[i][j].second);
      }
      const CylinderMeasurement& y = measured[i];
      for (double value : {y.p_P, y.p_N, y.x, PistonVelocity(m, present, ch.info), SupplyPressure(m, d.get(), ch.info), y.reference}) {
        out.values[column++].push_back(value);
      }
    }

    for (long step = 0; step < steps_per_tick; ++step) {
      mj_step(m, d.get());
      sample_pressures();
      if (options.observer) {
        if (std::string e = options.observer(d.get()); !e.empty()) return fail(e);
      }
    }
    summary.steps += steps_per_tick;
    for (int w : {mjWARN_BADQACC, mjWARN_BADQVEL, mjWARN_BADQPOS, mjWARN_BADCTRL}) {
      if (d->warning[w].number > 0) {
        return fail("the simulation diverged near t = " + std::to_string(d->time) + " s (MuJoCo warning " +
                    std::to_string(w) + ")");
      }
    }
    if (options.progress && (k % 100 == 0 || k + 1 == ticks)) {
      options.progress(static_cast<double>(k + 1) / static_cast<double>(ticks));
    }
  }

  summary.simulated_s = static_cast<double>(summary.steps) * m->opt.timestep;
  summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  summary.real_time_factor = summary.wall_s > 0 ? summary.simulated_s / summary.wall_s : 0;
  for (size_t i = 0; i < channels.size(); ++i) {
    CylinderSummary& s = summary.cylinders[i];
    s.rms_tracking_error = std::sqrt(squared_error[i] / static_cast<double>(ticks));
    if (!s.within_supply_range) {
      summary.warnings.push_back("cylinder '" + s.name + "': a chamber pressure left [p_exhaust, p_supply]");
    }
  }
  for (int w = 0; w < mjNWARNING; ++w) {
    if (d->warning[w].number > 0) {
      summary.warnings.push_back("MuJoCo warning " + std::to_string(w) + " raised " +
                                 std::to_string(d->warning[w].number) + " times");
    }
  }
  ClosedLoopState& state = result.final_state;
  for (const auto& [array, n] : StepStateArrays(m, d.get())) state.mujoco.insert(state.mujoco.end(), array, array + n);
  if (controller) state.controller = controller->State();
  for (const Channel& ch : channels) {
    state.hold.push_back(ch.hold);
    state.noise.push_back(ch.noise.Save());
  }
  result.log = std::move(out);
  return result;
}

}  // namespace pneumatic
