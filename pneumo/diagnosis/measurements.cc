#include "diagnosis/measurements.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <Eigen/Dense>

#include "simulation/rollout.h"

namespace pneumatic::diagnosis {

const char* SignalName(int kind) {
  static const char* names[] = {"p_P", "p_N", "x"};
  return names[kind];
}

std::vector<double> EstimateVelocity(const std::vector<double>& x, double period, int half) {
  const int n = static_cast<int>(x.size());
  std::vector<double> v(x.size(), 0.0);
  for (int i = 0; i < n; ++i) {
    const int lo = std::max(0, std::min(i - half, n - 1 - 2 * half)), hi = std::min(n - 1, lo + 2 * half);
    const int degree = std::min(3, hi - lo);
    // least-squares polynomial in tau = (j - i) (rows) over the window; v = its slope at tau = 0
    Eigen::MatrixXd A(hi - lo + 1, degree + 1);
    Eigen::VectorXd b(hi - lo + 1);
    for (int j = lo; j <= hi; ++j) {
      double power = 1;
      for (int d = 0; d <= degree; ++d) A(j - lo, d) = power, power *= static_cast<double>(j - i) / half;
      b(j - lo) = x[j];
    }
    if (degree < 1) continue;
    const Eigen::VectorXd c = A.colPivHouseholderQr().solve(b);
    v[i] = c(1) / (half * period);
  }
  return v;
}

std::optional<Measurements> PrepareMeasurements(const mjModel* m, const log::Log& log, int min_rows,
                                                std::string* error) {
  const std::string where = log.source.empty() ? std::string("log") : log.source;
  auto fail = [&](const std::string& message) -> std::optional<Measurements> {
    *error = where + ": " + message;
    return std::nullopt;
  };
  std::vector<CylinderInfo> cylinders;
  if (std::string problem = AttachedCylinders(m, &cylinders); !problem.empty()) return fail(problem);
  if (std::string problem = log::ValidateLog(log, /*uniform_time=*/true); !problem.empty()) return fail(problem);
  if (std::string problem = CheckMeasurements(m, log); !problem.empty()) {
    *error = problem;
    return std::nullopt;
  }
  for (const log::Column& c : log.columns) {
    bool known = false;
    for (const CylinderInfo& info : cylinders) known |= info.name == c.cylinder;
    if (!known) return fail("column '" + c.name() + "' names no cylinder of the model: the log does not match the model");
  }
  if (log.rows() < static_cast<size_t>(std::max(min_rows, 2))) {
    return fail("too short to fit: " + std::to_string(log.rows()) + " rows; the diagnosis needs at least " +
                std::to_string(min_rows) + " (two prediction windows and their warm-up)");
  }
  Measurements out;
  out.source = where;
  out.time = log.time;
  out.period = log.Period();
  const double steps = out.period / m->opt.timestep;
  out.steps_per_row = static_cast<int>(std::lround(steps));
  if (out.steps_per_row < 1 || std::fabs(steps - out.steps_per_row) > 1e-6 * steps) {
    char text[160];
    std::snprintf(text, sizeof(text), "the row period %.9g s is not a whole number of model timesteps (%.9g s)", out.period,
                  m->opt.timestep);
    return fail(text);
  }
  const int half = VelocityHalfWindow(out.period);
  for (const CylinderInfo& info : cylinders) {
    CylinderSeries c;
    c.info = info;
    const int id = info.chamber_actuator[0];
    c.joint = DrivenJoint(m, info);
    if (c.joint < 0) {
      return fail("cylinder '" + info.name + "' drives a tendon or slider-crank, or is mounted between sites; the "
                  "diagnosis needs joint-driven cylinders");
    }
    c.gear = m->actuator_gear[6 * id];
    std::string ignored;
    c.stroke = GetParameter(m, info.name, "stroke", &ignored).value_or(0);
    for (int k = 0; k < kSignalsPerCylinder; ++k) {
      int column = log.FindColumn(info.name, SignalName(k));
      if (column < 0) return fail("signal missing: column '" + info.name + "." + SignalName(k) + "'");
      c.signal[k] = log.values[column];
    }
    for (const auto& [signal, actuator] : info.command_actuators) {
      int column = log.FindColumn(info.name, signal);
      if (column < 0) return fail("signal missing: command column '" + info.name + "." + signal + "'");
      const std::vector<double>& u = log.values[column];
      if (std::all_of(u.begin(), u.end(), [&](double value) { return value == u[0]; })) {
        return fail("constant excitation: command '" + info.name + "." + signal +
                    "' never changes, so nothing in the log excites the model (a diagnosis needs a log that moves the valves)");
      }
      c.command_actuators.push_back(actuator);
      c.command_names.push_back(signal);
      c.commands.push_back(u);
    }
    if (int column = log.FindColumn(info.name, "p_S"); column >= 0) c.supply = log.values[column];
    c.velocity = EstimateVelocity(c.signal[kPosition], out.period, half);
    out.cylinders.push_back(std::move(c));
  }
  return out;
}

Measurements SliceRows(const Measurements& all, int begin, int end) {
  Measurements out = all;
  auto cut = [&](std::vector<double>& v) { v = std::vector<double>(v.begin() + begin, v.begin() + end); };
  cut(out.time);
  out.first_line_row = all.first_line_row + begin;
  for (CylinderSeries& c : out.cylinders) {
    for (std::vector<double>& s : c.signal) cut(s);
    cut(c.velocity);
    for (std::vector<double>& u : c.commands) cut(u);
    if (!c.supply.empty()) cut(c.supply);
  }
  return out;
}

}  // namespace pneumatic::diagnosis
