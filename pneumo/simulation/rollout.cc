#include "simulation/rollout.h"

#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "pneumatic/pneumatic.h"
#include "simulation/prescribed_motion.h"

namespace pneumatic {
namespace {

// a command column of the output and the actuator whose ctrl it drives
struct CommandSlot {
  log::Column column;
  int actuator = -1;
  int source = -1;        // column index in the command log, -1 if constant
  double constant = 0;
};

}  // namespace

std::string AttachedCylinders(const mjModel* m, std::vector<CylinderInfo>* cylinders) {
  *cylinders = Cylinders(m);
  if (!cylinders->empty()) return "";
  for (int i = 0; i < m->ntext; ++i) {
    if (std::string(m->names + m->name_textadr[i]).rfind("pneumatic:", 0) == 0) {
      return "the model is not attached to the pneumatic extension (pneumatic::Attach)";
    }
  }
  return "the model has no pneumatic cylinder (no <text name=\"pneumatic:...\">)";
}

log::ReadResult ReadModelLog(const mjModel* m, const std::string& path, bool uniform_time) {
  log::ReadOptions read;
  for (const CylinderInfo& c : Cylinders(m)) read.cylinders.insert(c.name);
  read.uniform_time = uniform_time;
  return log::ReadLog(path, read);
}

std::string CheckMeasurements(const mjModel* m, const log::Log& log) {
  std::vector<CylinderInfo> cylinders;
  if (std::string problem = AttachedCylinders(m, &cylinders); !problem.empty()) return problem;
  char text[200];
  for (size_t c = 0; c < log.columns.size(); ++c) {
    const log::Column& column = log.columns[c];
    const CylinderInfo* cylinder = nullptr;
    for (const CylinderInfo& info : cylinders) cylinder = info.name == column.cylinder ? &info : cylinder;
    if (!cylinder) continue;
    double low = -1e300, high = 1e300;
    bool low_excluded = false;  // absolute pressures: 0 itself is impossible
    std::string what;
    const std::string& s = column.signal;
    if (s == "p_P" || s == "p_N" || s == "p_S") {
      low = 0, low_excluded = true, high = 10 * cylinder->p_supply, what = "an absolute pressure in Pa";
    } else if (s == "x") {
      std::string ignored;
      const double stroke = GetParameter(m, cylinder->name, "stroke", &ignored).value_or(1e300);
      high = 0.6 * stroke, low = -high;
      char stroke_text[64];
      std::snprintf(stroke_text, sizeof(stroke_text), "a position on a stroke of %.9g", stroke);
      what = stroke_text;
    } else {
      if (int id = cylinder->CommandActuator(s); id >= 0 && m->actuator_ctrllimited[id]) {
        low = m->actuator_ctrlrange[2 * id], high = m->actuator_ctrlrange[2 * id + 1], what = "a command";
      }
    }
    for (size_t row = 0; row < log.rows(); ++row) {
      const double v = log.values[c][row];
      if ((low_excluded ? v <= low : v < low) || v > high) {
        std::snprintf(text, sizeof(text), ": %s = %.9g is impossible for %s (valid: %s%.9g, %.9g])", column.name().c_str(), v,
                      what.c_str(), low_excluded ? "(" : "[", low, high);
        return log.Where(row, c) + text;
      }
    }
  }
  return "";
}

RolloutResult Rollout(const mjModel* model, const log::Log* commands, const RolloutOptions& options) {
  RolloutResult result;
  auto fail = [&](const std::string& message) {
    result.error = message;
    return result;
  };
  // along a measured motion, a private copy that StepAlongPrescribedMotion steps without constraints
  std::unique_ptr<mjModel, void (*)(mjModel*)> prescribed(nullptr, mj_deleteModel);
  if (options.follow_motion) {
    prescribed = PrescribedMotionModel(model);
    if (!prescribed) return fail("MuJoCo could not copy the model");
  }
  const mjModel* m = options.follow_motion ? prescribed.get() : model;
  std::vector<CylinderInfo> cylinders;
  if (std::string problem = AttachedCylinders(m, &cylinders); !problem.empty()) return fail(problem);

  // rows: from the log, or a constant-command run of `duration`
  double timestep = m->opt.timestep;
  double period = 0, t0 = 0;
  size_t rows = 0;
  if (options.duration && !(*options.duration > 0)) return fail("the duration must be positive");
  if (commands) {
    // a log built in memory gets the checks a file gets; each row holds its commands for one
    // period, so rows must be uniformly spaced (docs/log_format.md)
    if (std::string problem = log::ValidateLog(*commands, /*uniform_time=*/true); !problem.empty()) {
      return fail("command log: " + problem);
    }
    if (commands->rows() < 2) return fail("the command log needs at least two rows to define its period");
    if (std::string problem = CheckMeasurements(m, *commands); !problem.empty()) return fail(problem);
    if (options.period > 0) return fail("a row period is only chosen without a command log (the log's rows set it)");
    period = commands->Period();
    t0 = commands->time[0];
    rows = commands->rows();
    if (options.duration) {
      rows = 0;
      while (rows < commands->rows() && commands->time[rows] - t0 < *options.duration - 1e-9 * period) ++rows;
    }
  } else {
    if (!options.duration) return fail("without a command log, give the duration to simulate");
    period = options.period > 0 ? options.period : std::max(1.0, std::round(1e-3 / timestep)) * timestep;
    rows = static_cast<size_t>(std::ceil(*options.duration / period - 1e-9));
  }
  double steps_per_row = period / timestep;
  long steps = std::lround(steps_per_row);
  if (steps < 1 || std::fabs(steps_per_row - static_cast<double>(steps)) > 1e-6 * steps_per_row) {
    return fail("the row period " + std::to_string(period) + " s is not a whole number of model timesteps (" +
                std::to_string(timestep) + " s)");
  }

  // command columns: every command signal of every cylinder, from the log or constant
  std::vector<CommandSlot> slots;
  std::map<std::string, double> unused = options.constant_commands;
  for (const CylinderInfo& c : cylinders) {
    for (const auto& [signal, actuator] : c.command_actuators) {
      CommandSlot slot{{c.name, signal}, actuator, -1, 0};
      std::string name = slot.column.name();
      if (auto it = unused.find(name); it != unused.end()) {
        if (log::IsValveState(signal) && it->second != 0 && it->second != 1) {
          return fail("constant command '" + name + "' is an on/off valve state: 0 or 1, not " + std::to_string(it->second));
        }
        slot.constant = it->second;
        unused.erase(it);
      } else if (commands) {
        slot.source = commands->FindColumn(c.name, signal);
        if (slot.source < 0) return fail("the command log has no column '" + name + "' (cylinder '" + c.name + "' is commanded through it)");
      }
      slots.push_back(slot);
    }
  }
  if (!unused.empty()) return fail("'" + unused.begin()->first + "' is not a command of any cylinder in the model");
  if (commands) {
    for (const log::Column& column : commands->columns) {
      const log::SignalInfo* info = log::FindSignal(column.signal);
      if (info->kind != log::SignalKind::kCommand) continue;
      bool used = false;
      for (const CommandSlot& s : slots) used |= s.column.name() == column.name();
      if (!used) return fail("log column '" + column.name() + "' is not a command of cylinder '" + column.cylinder + "'");
    }
  }

  // output columns: commands, then the measured signals of each cylinder
  log::Log out;
  out.comments.push_back("simulated by pneumo rollout");
  for (const CommandSlot& s : slots) out.columns.push_back(s.column);
  const char* measured[] = {"p_P", "p_N", "x", "v", "p_S"};
  for (const CylinderInfo& c : cylinders) {
    for (const char* signal : measured) out.columns.push_back({c.name, signal});
  }
  out.values.assign(out.columns.size(), {});

  // the measured motion of the pistons, written into qpos and qvel. With `step` >= 0 the piston is
  // placed on the cubic Hermite curve through the row's and the next row's x and v, at model step
  // `step` of the row, with the velocity that takes it to the curve's next point: through its joint, or
  // a mount=hinge_sites piston through its hinge (PistonJointState), all solved on the present pose
  // before any is set
  bool hinge_sites = false;
  for (const CylinderInfo& c : cylinders) hinge_sites |= c.rod_site >= 0;
  auto set_motion = [&](mjData* data, size_t row, long step) -> std::string {
    if (hinge_sites) mj_kinematics(m, data);
    JointState state;
    for (const CylinderInfo& c : cylinders) {
      int x = commands->FindColumn(c.name, "x"), v = commands->FindColumn(c.name, "v");
      std::optional<double> position, velocity, next;  // next: the curve's point at the next model step
      if (x >= 0) position = commands->values[x][row];
      if (v >= 0) velocity = commands->values[v][row];
      if (step >= 0 && x >= 0 && v >= 0 && row + 1 < commands->rows()) {
        double x0 = *position, v0 = *velocity, x1 = commands->values[x][row + 1], v1 = commands->values[v][row + 1];
        double s0 = static_cast<double>(step) / static_cast<double>(steps);
        double s1 = static_cast<double>(step + 1) / static_cast<double>(steps);
        position = HermitePosition(x0, v0, x1, v1, period, s0);
        next = HermitePosition(x0, v0, x1, v1, period, s1);
        velocity = (*next - *position) / timestep;
      }
      if (std::string e = PistonJointState(m, data, c, position, velocity, next, timestep, &state); !e.empty()) {
        const double time = commands->time[row] + (step >= 0 ? static_cast<double>(step) * timestep : 0.0);
        return e + " (t = " + std::to_string(time) + " s)";
      }
    }
    state.WriteTo(data);
    return "";
  };
  // with the motion prescribed, each piston moves exactly to the curve's next point
  auto step_along_motion = [&](mjData* data, size_t row, long k) -> std::string {
    if (std::string e = set_motion(data, row, k); !e.empty()) return e;
    StepAlongPrescribedMotion(prescribed.get(), data);
    return "";
  };
  if (options.follow_motion) {
    if (!commands) return fail("following the measured motion needs a log");
    for (const CylinderInfo& c : cylinders) {
      if (commands->FindColumn(c.name, "x") < 0 || commands->FindColumn(c.name, "v") < 0) {
        return fail("following the measured motion needs columns '" + c.name + ".x' and '" + c.name + ".v'");
      }
    }
  }

  // initial state from the first row
  std::unique_ptr<mjData, void (*)(mjData*)> d(mj_makeData(m), mj_deleteData);
  if (!d) return fail("mj_makeData failed");
  d->time = t0;
  if (commands) {
    for (const CylinderInfo& c : cylinders) {
      if (int col = commands->FindColumn(c.name, "p_P"); col >= 0) SetChamberPressure(m, d.get(), c, Chamber::kP, commands->values[col][0]);
      if (int col = commands->FindColumn(c.name, "p_N"); col >= 0) SetChamberPressure(m, d.get(), c, Chamber::kN, commands->values[col][0]);
    }
    if (std::string e = set_motion(d.get(), 0, -1); !e.empty()) return fail(e);
  }

  // replay: set the row's commands (and motion), sample, then hold them for one period
  for (size_t row = 0; row < rows; ++row) {
    if (options.follow_motion) {
      if (std::string e = set_motion(d.get(), row, -1); !e.empty()) return fail(e);
    }
    for (size_t i = 0; i < slots.size(); ++i) {
      const CommandSlot& s = slots[i];
      double u = s.source >= 0 ? commands->values[s.source][row] : s.constant;
      d->ctrl[s.actuator] = u;
      out.values[i].push_back(u);
    }
    mj_forward(m, d.get());
    size_t col = slots.size();
    for (const CylinderInfo& c : cylinders) {
      out.values[col++].push_back(ChamberPressure(m, d.get(), c, Chamber::kP));
      out.values[col++].push_back(ChamberPressure(m, d.get(), c, Chamber::kN));
      out.values[col++].push_back(PistonPosition(m, d.get(), c));
      out.values[col++].push_back(PistonVelocity(m, d.get(), c));
      out.values[col++].push_back(SupplyPressure(m, d.get(), c));
    }
    out.time.push_back(commands ? commands->time[row] : t0 + static_cast<double>(row) * period);
    for (long k = 0; k < steps; ++k) {
      if (options.follow_motion) {
        if (std::string e = step_along_motion(d.get(), row, k); !e.empty()) return fail(e);
      } else {
        mj_step(m, d.get());
      }
    }
    // MuJoCo resets the state after a non-finite one: a replay must not carry on from there
    for (int w : {mjWARN_BADQACC, mjWARN_BADQVEL, mjWARN_BADQPOS, mjWARN_BADCTRL}) {
      if (d->warning[w].number > 0) {
        return fail("the simulation diverged or got a non-finite command near t = " + std::to_string(d->time) +
                    " s (MuJoCo warning " + std::to_string(w) + ")");
      }
    }
  }
  result.log = std::move(out);
  return result;
}

}  // namespace pneumatic
