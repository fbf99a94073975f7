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

namespace {

using ModelPtr = std::unique_ptr<mjModel, void (*)(mjModel*)>;
using DataPtr = std::unique_ptr<mjData, void (*)(mjData*)>;

// One run of Rollout: the model it steps, the rows it replays, the command slots and the log being
// written, which its steps share. Every step returns an error, or "" to go on.
class RolloutRun {
 public:
  RolloutRun(const mjModel* model, const log::Log* commands, const RolloutOptions& options, RolloutResult* result)
      : model_(model), commands_(commands), options_(options), result_(*result) {}

  std::string Run() {
    if (std::string e = ChooseModel(); !e.empty()) return e;
    if (std::string problem = AttachedCylinders(m_, &cylinders_); !problem.empty()) return problem;
    if (std::string e = PlanRows(); !e.empty()) return e;
    if (std::string e = MatchCommandSlots(); !e.empty()) return e;
    if (std::string e = CheckLogCommandsUsed(); !e.empty()) return e;
    AddOutputColumns();
    for (const CylinderInfo& c : cylinders_) hinge_sites_ |= c.rod_site >= 0;
    if (std::string e = CheckFollowMotion(); !e.empty()) return e;
    if (std::string e = StartFromFirstRow(); !e.empty()) return e;
    for (size_t row = 0; row < rows_; ++row) {
      if (std::string e = ReplayRow(row); !e.empty()) return e;
    }
    result_.log = std::move(out_);
    return "";
  }

 private:
  // the model, or along a measured motion a private copy that StepAlongPrescribedMotion steps without
  // constraints
  std::string ChooseModel() {
    if (options_.follow_motion) {
      prescribed_ = PrescribedMotionModel(model_);
      if (!prescribed_) return "MuJoCo could not copy the model";
    }
    m_ = options_.follow_motion ? prescribed_.get() : model_;
    timestep_ = m_->opt.timestep;
    return "";
  }

  // rows: from the log, or a constant-command run of `duration`; each a whole number of model steps
  std::string PlanRows() {
    const log::Log* commands = commands_;
    const RolloutOptions& options = options_;
    if (options.duration && !(*options.duration > 0)) return "the duration must be positive";
    if (commands) {
      // a log built in memory gets the checks a file gets; each row holds its commands for one
      // period, so rows must be uniformly spaced (docs/log_format.md)
      if (std::string problem = log::ValidateLog(*commands, /*uniform_time=*/true); !problem.empty()) {
        return "command log: " + problem;
      }
      if (commands->rows() < 2) return "the command log needs at least two rows to define its period";
      if (std::string problem = CheckMeasurements(m_, *commands); !problem.empty()) return problem;
      if (options.period > 0) return "a row period is only chosen without a command log (the log's rows set it)";
      period_ = commands->Period();
      t0_ = commands->time[0];
      rows_ = commands->rows();
      if (options.duration) {
        rows_ = 0;
        while (rows_ < commands->rows() && commands->time[rows_] - t0_ < *options.duration - 1e-9 * period_) ++rows_;
      }
    } else {
      if (!options.duration) return "without a command log, give the duration to simulate";
      period_ = options.period > 0 ? options.period : std::max(1.0, std::round(1e-3 / timestep_)) * timestep_;
      rows_ = static_cast<size_t>(std::ceil(*options.duration / period_ - 1e-9));
    }
    double steps_per_row = period_ / timestep_;
    steps_ = std::lround(steps_per_row);
    if (steps_ < 1 || std::fabs(steps_per_row - static_cast<double>(steps_)) > 1e-6 * steps_per_row) {
      return "the row period " + std::to_string(period_) + " s is not a whole number of model timesteps (" +
             std::to_string(timestep_) + " s)";
    }
    return "";
  }

  // command columns: every command signal of every cylinder, from the log or constant
  std::string MatchCommandSlots() {
    std::map<std::string, double> unused = options_.constant_commands;
    for (const CylinderInfo& c : cylinders_) {
      for (const auto& [signal, actuator] : c.command_actuators) {
        CommandSlot slot{{c.name, signal}, actuator, -1, 0};
        std::string name = slot.column.name();
        if (auto it = unused.find(name); it != unused.end()) {
          if (log::IsValveState(signal) && it->second != 0 && it->second != 1) {
            return "constant command '" + name + "' is an on/off valve state: 0 or 1, not " + std::to_string(it->second);
          }
          slot.constant = it->second;
          unused.erase(it);
        } else if (commands_) {
          slot.source = commands_->FindColumn(c.name, signal);
          if (slot.source < 0) return "the command log has no column '" + name + "' (cylinder '" + c.name + "' is commanded through it)";
        }
        slots_.push_back(slot);
      }
    }
    if (!unused.empty()) return "'" + unused.begin()->first + "' is not a command of any cylinder in the model";
    return "";
  }

  // every command column of the log drives a slot
  std::string CheckLogCommandsUsed() const {
    if (!commands_) return "";
    for (const log::Column& column : commands_->columns) {
      const log::SignalInfo* info = log::FindSignal(column.signal);
      if (info->kind != log::SignalKind::kCommand) continue;
      bool used = false;
      for (const CommandSlot& s : slots_) used |= s.column.name() == column.name();
      if (!used) return "log column '" + column.name() + "' is not a command of cylinder '" + column.cylinder + "'";
    }
    return "";
  }

  // output columns: commands, then the measured signals of each cylinder
  void AddOutputColumns() {
    out_.comments.push_back("simulated by pneumo rollout");
    for (const CommandSlot& s : slots_) out_.columns.push_back(s.column);
    const char* measured[] = {"p_P", "p_N", "x", "v", "p_S"};
    for (const CylinderInfo& c : cylinders_) {
      for (const char* signal : measured) out_.columns.push_back({c.name, signal});
    }
    out_.values.assign(out_.columns.size(), {});
  }

  std::string CheckFollowMotion() const {
    if (!options_.follow_motion) return "";
    if (!commands_) return "following the measured motion needs a log";
    for (const CylinderInfo& c : cylinders_) {
      if (commands_->FindColumn(c.name, "x") < 0 || commands_->FindColumn(c.name, "v") < 0) {
        return "following the measured motion needs columns '" + c.name + ".x' and '" + c.name + ".v'";
      }
    }
    return "";
  }

  // the measured motion of the pistons, written into qpos and qvel. With `step` >= 0 the piston is
  // placed on the cubic Hermite curve through the row's and the next row's x and v, at model step
  // `step` of the row, with the velocity that takes it to the curve's next point: through its joint, or
  // a mount=hinge_sites piston through its hinge (PistonJointState), all solved on the present pose
  // before any is set
  std::string SetMotion(mjData* data, size_t row, long step) const {
    const log::Log* commands = commands_;
    if (hinge_sites_) mj_kinematics(m_, data);
    JointState state;
    for (const CylinderInfo& c : cylinders_) {
      int x = commands->FindColumn(c.name, "x"), v = commands->FindColumn(c.name, "v");
      std::optional<double> position, velocity, next;  // next: the curve's point at the next model step
      if (x >= 0) position = commands->values[x][row];
      if (v >= 0) velocity = commands->values[v][row];
      if (step >= 0 && x >= 0 && v >= 0 && row + 1 < commands->rows()) {
        double x0 = *position, v0 = *velocity, x1 = commands->values[x][row + 1], v1 = commands->values[v][row + 1];
        double s0 = static_cast<double>(step) / static_cast<double>(steps_);
        double s1 = static_cast<double>(step + 1) / static_cast<double>(steps_);
        position = HermitePosition(x0, v0, x1, v1, period_, s0);
        next = HermitePosition(x0, v0, x1, v1, period_, s1);
        velocity = (*next - *position) / timestep_;
      }
      if (std::string e = PistonJointState(m_, data, c, position, velocity, next, timestep_, &state); !e.empty()) {
        const double time = commands->time[row] + (step >= 0 ? static_cast<double>(step) * timestep_ : 0.0);
        return e + " (t = " + std::to_string(time) + " s)";
      }
    }
    state.WriteTo(data);
    return "";
  }

  // initial state from the first row
  std::string StartFromFirstRow() {
    d_.reset(mj_makeData(m_));
    if (!d_) return "mj_makeData failed";
    d_->time = t0_;
    if (commands_) {
      for (const CylinderInfo& c : cylinders_) {
        if (int col = commands_->FindColumn(c.name, "p_P"); col >= 0) SetChamberPressure(m_, d_.get(), c, Chamber::kP, commands_->values[col][0]);
        if (int col = commands_->FindColumn(c.name, "p_N"); col >= 0) SetChamberPressure(m_, d_.get(), c, Chamber::kN, commands_->values[col][0]);
      }
      if (std::string e = SetMotion(d_.get(), 0, -1); !e.empty()) return e;
    }
    return "";
  }

  // replay: set the row's commands (and motion), sample, then hold them for one period
  std::string ReplayRow(size_t row) {
    mjData* d = d_.get();
    if (options_.follow_motion) {
      if (std::string e = SetMotion(d, row, -1); !e.empty()) return e;
    }
    for (size_t i = 0; i < slots_.size(); ++i) {
      const CommandSlot& s = slots_[i];
      double u = s.source >= 0 ? commands_->values[s.source][row] : s.constant;
      d->ctrl[s.actuator] = u;
      out_.values[i].push_back(u);
    }
    mj_forward(m_, d);
    size_t col = slots_.size();
    for (const CylinderInfo& c : cylinders_) {
      out_.values[col++].push_back(ChamberPressure(m_, d, c, Chamber::kP));
      out_.values[col++].push_back(ChamberPressure(m_, d, c, Chamber::kN));
      out_.values[col++].push_back(PistonPosition(m_, d, c));
      out_.values[col++].push_back(PistonVelocity(m_, d, c));
      out_.values[col++].push_back(SupplyPressure(m_, d, c));
    }
    out_.time.push_back(commands_ ? commands_->time[row] : t0_ + static_cast<double>(row) * period_);
    for (long k = 0; k < steps_; ++k) {
      if (options_.follow_motion) {
        // with the motion prescribed, each piston moves exactly to the curve's next point
        if (std::string e = SetMotion(d, row, k); !e.empty()) return e;
        StepAlongPrescribedMotion(prescribed_.get(), d);
      } else {
        mj_step(m_, d);
      }
    }
    // MuJoCo resets the state after a non-finite one: a replay must not carry on from there
    for (int w : {mjWARN_BADQACC, mjWARN_BADQVEL, mjWARN_BADQPOS, mjWARN_BADCTRL}) {
      if (d->warning[w].number > 0) {
        return "the simulation diverged or got a non-finite command near t = " + std::to_string(d->time) +
               " s (MuJoCo warning " + std::to_string(w) + ")";
      }
    }
    return "";
  }

  const mjModel* model_;
  const log::Log* commands_;
  const RolloutOptions& options_;
  RolloutResult& result_;
  ModelPtr prescribed_{nullptr, mj_deleteModel};
  const mjModel* m_ = nullptr;  // the model stepped: model_ or prescribed_
  double timestep_ = 0;
  std::vector<CylinderInfo> cylinders_;
  double period_ = 0, t0_ = 0;  // the rows' period and first time
  size_t rows_ = 0;
  long steps_ = 0;  // model steps per row
  std::vector<CommandSlot> slots_;
  log::Log out_;
  bool hinge_sites_ = false;  // some piston is mounted through hinge sites
  DataPtr d_{nullptr, mj_deleteData};
};

}  // namespace

RolloutResult Rollout(const mjModel* model, const log::Log* commands, const RolloutOptions& options) {
  RolloutResult result;
  RolloutRun run(model, commands, options, &result);
  if (std::string e = run.Run(); !e.empty()) result.error = e;
  return result;
}

}  // namespace pneumatic
