#include "diagnosis/prediction.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <limits>
#include <memory>
#include <mutex>
#include <thread>

#include <Eigen/Dense>

#include "simulation/prescribed_motion.h"
#include "simulation/step_state.h"

namespace pneumatic::diagnosis {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Copies what mj_step advances from, and nothing else: StepStateArrays, the mocap poses and userdata (together
// the state MuJoCo's later releases name mjSTATE_INTEGRATION), and the warnings Diverged reads. Everything else
// in mjData is computed from these by the next mj_forward before it is read. mj_copyData copies every array of
// mjData, the constraint arrays sized by njmax included (efc_AR alone is njmax^2 numbers): on rig C about
// 0.2 ms a copy, as long as the whole warm-up run it restores (measured; 0.6 us a step).
void CopyState(const mjModel* m, mjData* to, const mjData* from) {
  const auto source = StepStateArrays(m, from);
  const auto target = StepStateArrays(m, to);
  for (size_t i = 0; i < source.size(); ++i) mju_copy(target[i].first, source[i].first, source[i].second);
  mju_copy(to->mocap_pos, from->mocap_pos, 3 * m->nmocap);
  mju_copy(to->mocap_quat, from->mocap_quat, 4 * m->nmocap);
  mju_copy(to->userdata, from->userdata, m->nuserdata);
  std::copy(from->warning, from->warning + mjNWARNING, to->warning);
}

// the true value behind a measurement, through the inverse of the signal model's sensors
double TrueValue(const Measurements& meas, const SignalModel& sensors, int signal, int row) {
  return sensors.Truth(signal, meas.Signal(signal)[row]);
}

class WindowRunner {
 public:
  // along the measured motion (the pneumatic side), on a private copy of m (PrescribedMotionModel)
  WindowRunner(const mjModel* m, const Measurements& meas, const SignalModel& signals, PredictionKind kind)
      : prescribed_(kind == PredictionKind::kPneumatic ? PrescribedMotionModel(m)
                                                       : std::unique_ptr<mjModel, void (*)(mjModel*)>(nullptr, mj_deleteModel)),
        m_(prescribed_ ? prescribed_.get() : m), meas_(meas), signals_(signals), kind_(kind), d_(mj_makeData(m_), mj_deleteData),
        snapshot_(mj_makeData(m_), mj_deleteData) {
    // the cylinders as the model being predicted has them (its lines, the reservoir that feeds each),
    // in the log's order
    const std::vector<CylinderInfo> cylinders = Cylinders(m_);
    for (const CylinderSeries& cyl : meas_.cylinders) {
      auto same = [&](const CylinderInfo& c) { return c.name == cyl.info.name; };
      auto found = std::find_if(cylinders.begin(), cylinders.end(), same);
      cylinders_.push_back(found != cylinders.end() ? *found : cyl.info);  // an edit keeps every cylinder
      // the command actuators in this model, by log signal: an edit that adds a stateless actuator
      // (a seal friction's force) puts it before the others (MuJoCo 2.2 wants stateless actuators
      // first), so the ids of the model the log was prepared on point one actuator off here
      std::vector<int> ids;
      for (size_t j = 0; j < cyl.command_names.size(); ++j) {
        int id = cylinders_.back().CommandActuator(cyl.command_names[j]);
        ids.push_back(id >= 0 ? id : cyl.command_actuators[j]);
      }
      command_ids_.push_back(std::move(ids));
    }
  }

  // predicts rows start+1 .. start+horizon into `out`, from `act` at the warm-up's first row if
  // given (the history estimate), else from the model's reset state; "" or why not
  std::string Run(int start, const Windows& w, const std::vector<mjtNum>* act, std::vector<std::vector<double>>* out) {
    mjData* d = d_.get();
    mj_resetData(m_, d);
    const int first = start - w.warmup_rows;
    d->time = meas_.time[first];
    if (act) {
      std::copy(act->begin(), act->end(), d->act);
    } else {
      StartLinesAtTheChambers(first);
    }
    // the warm-up; where the window simulates the motion, its rows also give the start's velocity
    auto diverged = [&] { return "the simulation diverged in the warm-up of the window starting at t = " + std::to_string(meas_.time[start]) + " s"; };
    std::vector<double> velocity;
    if (kind_ == PredictionKind::kPneumatic) {
      for (int row = first; row < start; ++row) {
        StepMeasuredRow(row);
        if (Diverged()) return diverged();
      }
    } else if (!FitStartVelocity(first, start, &velocity)) {
      return diverged();
    }
    SetMeasuredState(start);
    for (size_t c = 0; c < velocity.size(); ++c) {
      const CylinderSeries& cyl = meas_.cylinders[c];
      d->qvel[m_->jnt_dofadr[cyl.joint]] = velocity[c] / cyl.gear;
    }
    for (int row = start; row < start + w.horizon_rows; ++row) {
      for (int k = 0; k < meas_.steps_per_row; ++k) {
        SetCommands(row, k);
        SetLoggedSupply(row, k);
        if (kind_ == PredictionKind::kMechanical) HoldMeasuredPressures(row, static_cast<double>(k) / meas_.steps_per_row);
        if (kind_ == PredictionKind::kPneumatic) {
          FollowMeasuredMotion(row, k);
        } else {
          mj_step(m_, d);
        }
      }
      if (Diverged()) return "the simulation diverged in the window starting at t = " + std::to_string(meas_.time[start]) + " s";
      Record(row + 1, out);
    }
    return "";
  }

  // The history estimate: runs the log from its first row up to the last window's warm-up as the
  // warm-up does (the measured pressures and motion set at every row), and hands d->act at each
  // window's warm-up row to `ready(window, act)` in window order; "" or why not
  template <typename Ready>
  std::string Observe(const Windows& w, Ready ready) {
    mjData* d = d_.get();
    mj_resetData(m_, d);
    d->time = meas_.time[0];
    StartLinesAtTheChambers(0);
    int row = 0;
    for (size_t i = 0; i < w.starts.size(); ++i) {
      for (const int first = w.starts[i] - w.warmup_rows; row < first; ++row) {
        StepMeasuredRow(row);
        if (Diverged()) return "the simulation diverged in the history estimate at t = " + std::to_string(meas_.time[row]) + " s";
      }
      ready(i, std::vector<mjtNum>(d->act, d->act + m_->na));
    }
    return "";
  }

 private:
  // one row of the warm-up and of the history estimate: the measured pressures and motion set, the
  // row's commands, the row's steps
  void StepMeasuredRow(int row) {
    SetMeasuredState(row);
    for (int k = 0; k < meas_.steps_per_row; ++k) {
      SetCommands(row, k);
      SetLoggedSupply(row, k);
      mj_step(m_, d_.get());
    }
  }

  // The velocity at the window's start, x' (m/s or rad/s) per cylinder, fitted to the measured
  // positions of the warm-up's rows [first, start]: the project's own form of what prediction-error
  // methods do with a predictor's unknown initial state, estimate it from the data (Ljung, System
  // Identification, 2nd ed., 1999). The model runs those rows with the measured pressures set at
  // every row and the motion free from (x, v) at `first`, and (x, v) of every cylinder are the
  // least-squares fit of the simulated positions to the measured ones: one Gauss-Newton step from
  // the measured x and the velocity estimated from x, its Jacobian from one run per perturbed value,
  // exact where the mechanics is linear in the state (a mass with viscous damping, driven by the
  // chambers). The velocity estimated from x alone (EstimateVelocity) cannot follow motion faster
  // than the rows resolve: on rig C at paper 000's 100 Hz, under its closed loop (pneumo generate),
  // it erred by about 4 % of the velocity's spread on a noise-free log, and on that log of the
  // nominal model a heavier payload took the resulting error up as an effect (a held-out shrink of
  // 12.7 %). The model resolves the motion between the rows: its pressures there follow its own
  // chamber dynamics from the measured ones. Leaves d at `start` as the warm-up would (the measured
  // pressures set at every row, the motion from the fit's start); false if a run diverged
  bool FitStartVelocity(int first, int start, std::vector<double>* velocity) {
    const int cylinders = static_cast<int>(meas_.cylinders.size()), unknowns = 2 * cylinders, rows = start - first + 1;
    mjData* d = d_.get();
    CopyState(m_, snapshot_.get(), d);
    // run j perturbs unknown j - 1 (x, then v, of each cylinder in turn); run 0, the last to run, none
    Eigen::MatrixXd x(rows * cylinders, unknowns + 1), v(cylinders, unknowns + 1);
    Eigen::VectorXd measured(rows * cylinders);
    std::vector<double> step(unknowns);
    for (int c = 0; c < cylinders; ++c) {
      const double stroke = meas_.cylinders[c].stroke > 0 ? meas_.cylinders[c].stroke : 1.0;
      step[2 * c] = 1e-3 * stroke, step[2 * c + 1] = 1e-2 * stroke;  // m or rad, m/s or rad/s
    }
    for (int run = unknowns; run >= 0; --run) {
      CopyState(m_, d, snapshot_.get());
      SetMeasuredState(first);
      if (run > 0) {
        const CylinderSeries& cyl = meas_.cylinders[(run - 1) / 2];
        (run - 1) % 2 == 0 ? d->qpos[m_->jnt_qposadr[cyl.joint]] += step[run - 1] / cyl.gear
                           : d->qvel[m_->jnt_dofadr[cyl.joint]] += step[run - 1] / cyl.gear;
      }
      for (int row = first;; ++row) {
        for (int c = 0; c < cylinders; ++c) {
          const CylinderSeries& cyl = meas_.cylinders[c];
          x(c * rows + row - first, run) = cyl.gear * d->qpos[m_->jnt_qposadr[cyl.joint]] - cyl.info.x_mid;
          if (run == unknowns) measured(c * rows + row - first) = TrueValue(meas_, signals_, kSignalsPerCylinder * c + kPosition, row);
        }
        if (row == start) break;
        if (row > first) SetMeasuredPressures(row);
        for (int k = 0; k < meas_.steps_per_row; ++k) {
          SetCommands(row, k);
          SetLoggedSupply(row, k);
          mj_step(m_, d);
        }
        if (Diverged()) return false;
      }
      for (int c = 0; c < cylinders; ++c) {
        v(c, run) = meas_.cylinders[c].gear * d->qvel[m_->jnt_dofadr[meas_.cylinders[c].joint]];
      }
    }
    Eigen::MatrixXd dx(rows * cylinders, unknowns), dv(cylinders, unknowns);
    for (int j = 0; j < unknowns; ++j) {
      dx.col(j) = (x.col(j + 1) - x.col(0)) / step[j];
      dv.col(j) = (v.col(j + 1) - v.col(0)) / step[j];
    }
    const Eigen::VectorXd correction = dx.colPivHouseholderQr().solve(measured - x.col(0));
    const Eigen::VectorXd fitted = v.col(0) + dv * correction;
    velocity->resize(cylinders);
    for (int c = 0; c < cylinders; ++c) {
      // where the fit has nothing to go on (a piston held at an end stop), the estimate from x
      (*velocity)[c] = std::isfinite(fitted(c)) ? fitted(c) : meas_.cylinders[c].velocity[start] / signals_.gain[kSignalsPerCylinder * c + kPosition];
    }
    return true;
  }

  // the measured chamber pressures of `row`, the motion left as it is
  void SetMeasuredPressures(int row) {
    for (size_t c = 0; c < meas_.cylinders.size(); ++c) {
      const int base = kSignalsPerCylinder * static_cast<int>(c);
      SetChamberPressure(m_, d_.get(), cylinders_[c], Chamber::kP, TrueValue(meas_, signals_, base + kPressureP, row));
      SetChamberPressure(m_, d_.get(), cylinders_[c], Chamber::kN, TrueValue(meas_, signals_, base + kPressureN, row));
    }
  }

  // A line's pressure (line_volume > 0), which no sensor gives, starts at its chamber's measured
  // pressure, the level it holds at rest behind its restriction, and the warm-up's rows take it on
  // from there. From the reset's atmosphere it would come to its level only by a part of the way
  // per row, as the chamber it fills from is set back to the measured pressure at each row: on a
  // 100 Hz log 20 ms are two rows, and a rig C line model predicting its own log erred 4.4 kPa RMS
  // on p_P against the 0.5 kPa sensor noise; on rig B's slower line (23 ms) 20 ms fell short at
  // 500 Hz too (bench_diagnose's line case: held-out shrink 63 %, 91 % from the chamber's pressure)
  void StartLinesAtTheChambers(int row) {
    for (size_t c = 0; c < meas_.cylinders.size(); ++c) {
      const int base = kSignalsPerCylinder * static_cast<int>(c);
      for (int k : {0, 1}) {
        SetLinePressure(m_, d_.get(), cylinders_[c], static_cast<Chamber>(k),
                        TrueValue(meas_, signals_, base + (k == 0 ? kPressureP : kPressureN), row));
      }
    }
  }

  // the commands of step k of the row as the valves get them (SignalModel): the logged ones, or
  // with a command delay their mean over the step [a, b], in rows, command_delay earlier, which
  // meets at most two rows (a step is at most a row); before the log's first row, its commands
  void SetCommands(int row, int k) {
    const int rows = meas_.rows();
    for (size_t c = 0; c < meas_.cylinders.size(); ++c) {
      const CylinderSeries& cyl = meas_.cylinders[c];
      const double delay = signals_.command_delay[c];
      if (delay == 0) {
        for (size_t j = 0; j < cyl.command_actuators.size(); ++j) d_->ctrl[command_ids_[c][j]] = cyl.commands[j][row];
        continue;
      }
      const double step = 1.0 / meas_.steps_per_row;
      const double a = row + k * step - delay / meas_.period, b = a + step;
      const double boundary = std::floor(a) + 1;  // the first row boundary after a
      const double later = std::max(0.0, b - boundary) / step;  // the part of the step in the next row
      const int first = std::clamp(static_cast<int>(std::floor(a)), 0, rows - 1), next = std::clamp(first + 1, 0, rows - 1);
      for (size_t j = 0; j < cyl.command_actuators.size(); ++j) {
        const std::vector<double>& u = cyl.commands[j];
        d_->ctrl[command_ids_[c][j]] = (1 - later) * u[first] + later * u[next];
      }
    }
  }

  // with the logged supply, each fed cylinder's reservoir at the logged p_S (less the sensor's
  // offset) at the start of step k of the row, on the straight line between the row's and the next
  // row's values
  void SetLoggedSupply(int row, int k) {
    if (!signals_.logged_supply) return;
    const double s = static_cast<double>(k) / meas_.steps_per_row;
    const int next = std::min(row + 1, meas_.rows() - 1);
    for (size_t c = 0; c < meas_.cylinders.size(); ++c) {
      const std::vector<double>& p_s = meas_.cylinders[c].supply;
      if (p_s.empty()) continue;
      SetSupplyPressure(m_, d_.get(), cylinders_[c], (1 - s) * p_s[row] + s * p_s[next] - signals_.supply_offset);
    }
  }

  bool Diverged() const {
    for (int warning : {mjWARN_BADQACC, mjWARN_BADQVEL, mjWARN_BADQPOS}) {
      if (d_->warning[warning].number > 0) return true;
    }
    return false;
  }

  void SetMeasuredState(int row) {
    SetMeasuredPressures(row);
    mjData* d = d_.get();
    for (size_t c = 0; c < meas_.cylinders.size(); ++c) {
      const CylinderSeries& cyl = meas_.cylinders[c];
      const int base = kSignalsPerCylinder * static_cast<int>(c);
      const double x = TrueValue(meas_, signals_, base + kPosition, row);
      d->qpos[m_->jnt_qposadr[cyl.joint]] = (x + cyl.info.x_mid) / cyl.gear;
      d->qvel[m_->jnt_dofadr[cyl.joint]] = cyl.velocity[row] / signals_.gain[base + kPosition] / cyl.gear;
    }
  }

  // chamber pressures on the straight line between the row's and the next row's measurements
  void HoldMeasuredPressures(int row, double s) {
    for (size_t c = 0; c < meas_.cylinders.size(); ++c) {
      const int base = kSignalsPerCylinder * static_cast<int>(c);
      for (int k : {kPressureP, kPressureN}) {
        const int next = std::min(row + 1, meas_.rows() - 1);
        const double p = (1 - s) * TrueValue(meas_, signals_, base + k, row) + s * TrueValue(meas_, signals_, base + k, next);
        SetChamberPressure(m_, d_.get(), cylinders_[c], k == kPressureP ? Chamber::kP : Chamber::kN, p);
      }
    }
  }

  // the piston on the cubic Hermite curve through the row's and the next row's measured x and
  // estimated v (prescribed_motion.h, as pneumo rollout --follow-motion)
  void FollowMeasuredMotion(int row, int k) {
    mjData* d = d_.get();
    const double period = meas_.period, h = m_->opt.timestep;
    const int next = std::min(row + 1, meas_.rows() - 1);
    for (size_t c = 0; c < meas_.cylinders.size(); ++c) {
      const CylinderSeries& cyl = meas_.cylinders[c];
      const int base = kSignalsPerCylinder * static_cast<int>(c);
      const double gain = signals_.gain[base + kPosition];
      const double x0 = TrueValue(meas_, signals_, base + kPosition, row), x1 = TrueValue(meas_, signals_, base + kPosition, next);
      const double v0 = cyl.velocity[row] / gain, v1 = cyl.velocity[next] / gain;
      const double a = HermitePosition(x0, v0, x1, v1, period, static_cast<double>(k) / meas_.steps_per_row);
      const double b = HermitePosition(x0, v0, x1, v1, period, static_cast<double>(k + 1) / meas_.steps_per_row);
      d->qpos[m_->jnt_qposadr[cyl.joint]] = (a + cyl.info.x_mid) / cyl.gear;
      d->qvel[m_->jnt_dofadr[cyl.joint]] = (b - a) / h / cyl.gear;
    }
    StepAlongPrescribedMotion(prescribed_.get(), d);
  }

  void Record(int row, std::vector<std::vector<double>>* out) {
    if (row >= meas_.rows()) return;
    const mjData* d = d_.get();
    for (size_t c = 0; c < meas_.cylinders.size(); ++c) {
      const CylinderSeries& cyl = meas_.cylinders[c];
      const int base = kSignalsPerCylinder * static_cast<int>(c);
      const double truth[3] = {ChamberPressure(m_, d, cylinders_[c], Chamber::kP), ChamberPressure(m_, d, cylinders_[c], Chamber::kN),
                               cyl.gear * d->qpos[m_->jnt_qposadr[cyl.joint]] - cyl.info.x_mid};
      for (int k = 0; k < kSignalsPerCylinder; ++k) {
        const bool predicted = kind_ == PredictionKind::kFull || (kind_ == PredictionKind::kPneumatic && k != kPosition) ||
                               (kind_ == PredictionKind::kMechanical && k == kPosition);
        (*out)[base + k][row] = predicted ? signals_.Measured(base + k, truth[k]) : kNaN;
      }
    }
  }

  std::unique_ptr<mjModel, void (*)(mjModel*)> prescribed_;
  const mjModel* m_;
  const Measurements& meas_;
  const SignalModel& signals_;
  PredictionKind kind_;
  std::unique_ptr<mjData, void (*)(mjData*)> d_;
  std::unique_ptr<mjData, void (*)(mjData*)> snapshot_;  // d_ at the warm-up's start (FitStartVelocity)
  std::vector<CylinderInfo> cylinders_;  // per cylinder of the log: its actuators in m_ (chambers, lines, supply)
  std::vector<std::vector<int>> command_ids_;  // per cylinder of the log: its command actuators in m_, in the order of its command_names
};

}  // namespace

SignalModel SignalModel::Identity(const Measurements& meas) {
  SignalModel s{std::vector<double>(meas.signals(), 0.0), std::vector<double>(meas.signals(), 1.0),
                std::vector<double>(meas.signals(), 0.0), std::vector<double>(meas.cylinders.size(), 0.0)};
  for (int i = 0; i < meas.signals(); ++i) {
    if (i % kSignalsPerCylinder != kPosition) s.reference[i] = meas.cylinders[i / kSignalsPerCylinder].info.p_atm;
  }
  return s;
}

const char* PredictionKindName(PredictionKind kind) {
  switch (kind) {
    case PredictionKind::kFull: return "full";
    case PredictionKind::kPneumatic: return "pneumatic";
    case PredictionKind::kMechanical: return "mechanical";
  }
  return "";
}

Windows MakeWindows(int rows, int horizon_rows, int warmup_rows) {
  Windows w;
  w.horizon_rows = horizon_rows;
  w.warmup_rows = warmup_rows;
  for (int start = warmup_rows; start + horizon_rows < rows; start += horizon_rows) w.starts.push_back(start);
  return w;
}

Windows EveryNthWindow(const Windows& w, int stride, int max_windows) {
  const int windows = static_cast<int>(w.starts.size());
  stride = std::max(stride, 1);
  if (max_windows > 0) stride = std::max(stride, (windows + max_windows - 1) / max_windows);
  Windows kept = w;
  kept.starts.clear();
  for (int i = 0; i < windows; i += stride) kept.starts.push_back(w.starts[i]);
  return kept;
}

bool EstimatesOverTheHistory(const mjModel* m, const SignalModel& signals) {
  return signals.history_estimate || (!Reservoirs(m).empty() && !signals.logged_supply);
}

Prediction Predict(const mjModel* m, const Measurements& meas, const SignalModel& sensors, const Windows& windows,
                   PredictionKind kind, int threads) {
  Prediction p;
  p.simulated.assign(meas.signals(), std::vector<double>(meas.rows(), kNaN));
  const size_t n = windows.starts.size();
  std::vector<std::string> errors(n);

  // the history estimate, handed from the observer to the windows as it reaches each one
  const bool history = EstimatesOverTheHistory(m, sensors);
  std::vector<std::vector<mjtNum>> start_act(history ? n : 0);
  std::mutex mutex;
  std::condition_variable reached;
  size_t observed = 0;
  std::string observe_error;
  auto observe = [&] {
    WindowRunner runner(m, meas, sensors, kind);
    const std::string error = runner.Observe(windows, [&](size_t i, std::vector<mjtNum> act) {
      std::lock_guard<std::mutex> lock(mutex);
      start_act[i] = std::move(act);
      observed = i + 1;
      reached.notify_all();
    });
    std::lock_guard<std::mutex> lock(mutex);
    observe_error = error;
    observed = n;
    reached.notify_all();
  };

  std::atomic<size_t> next{0};
  auto work = [&] {
    WindowRunner runner(m, meas, sensors, kind);
    for (size_t i = next++; i < n; i = next++) {
      if (history) {
        std::unique_lock<std::mutex> lock(mutex);
        reached.wait(lock, [&] { return observed > i; });
        if (!observe_error.empty()) {
          errors[i] = observe_error;
          continue;
        }
      }
      errors[i] = runner.Run(windows.starts[i], windows, history ? &start_act[i] : nullptr, &p.simulated);
    }
  };

  // threads: the observer on one of them when there are two or more, else before the windows
  std::vector<std::thread> pool;
  int workers = std::min<int>(std::max(threads, 1), static_cast<int>(n));
  if (history && threads >= 2) {
    pool.emplace_back(observe);
    workers = std::max(1, std::min(threads - 1, static_cast<int>(n)));
  } else if (history) {
    observe();
  }
  for (int t = 1; t < workers; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  for (const std::string& e : errors) {
    if (!e.empty()) {
      p.error = e;
      break;
    }
  }
  return p;
}

}  // namespace pneumatic::diagnosis
