#include "identification/chamber_series.h"

#include <cmath>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "pneumatic/pneumatic.h"

namespace pneumatic::identification {
namespace {

constexpr const char* kPerChamberValve = "proportional_per_chamber";

std::string Format(double value) {
  std::ostringstream text;
  text.precision(10);
  text << value;
  return text.str();
}

// the series of one chamber; "" or why not
std::string ExtractChamber(const mjModel* m, const log::Log& log, const CylinderInfo& c, Chamber k,
                           ChamberSeries* series) {
  const bool is_p = k == Chamber::kP;
  const std::string command = is_p ? "uP" : "uN";
  const std::string pressure = is_p ? "p_P" : "p_N";
  for (const std::string& signal : {command, pressure, std::string("x")}) {
    if (log.FindColumn(c.name, signal) < 0) {
      return "log has no column '" + c.name + "." + signal + "', needed to identify chamber " + c.name +
             (is_p ? ".P" : ".N");
    }
  }
  const std::vector<double>& u = log.values[static_cast<size_t>(log.FindColumn(c.name, command))];
  const std::vector<double>& p = log.values[static_cast<size_t>(log.FindColumn(c.name, pressure))];
  const std::vector<double>& x = log.values[static_cast<size_t>(log.FindColumn(c.name, "x"))];

  ChamberSeries s;
  s.name = c.name + (is_p ? ".P" : ".N");
  s.period = log.Period();
  s.p_supply = c.p_supply;
  s.p_exhaust = c.p_exhaust;
  int actuator = c.CommandActuator(command);
  if (actuator >= 0 && m->actuator_ctrllimited[actuator]) {
    s.u_min = m->actuator_ctrlrange[2 * actuator];
    s.u_max = m->actuator_ctrlrange[2 * actuator + 1];
  }
  std::string error;
  std::optional<double> stroke = GetParameter(m, c.name, "stroke", &error);
  if (!stroke) return "cylinder '" + c.name + "': " + error;
  s.stroke = *stroke;
  const std::string side = is_p ? "P." : "N.";
  std::optional<double> u_c = GetParameter(m, c.name, side + "u_supply_seal", &error);
  std::optional<double> u_r = GetParameter(m, c.name, side + "u_exhaust_seal", &error);
  if (u_c && u_r) s.u_seal_centre = (*u_c + *u_r) / 2;

  const size_t rows = log.rows();
  for (size_t t = 0; t < rows; ++t) {
    if (u[t] < s.u_min || u[t] > s.u_max) {
      return "column '" + c.name + "." + command + "', row " + std::to_string(t) + ": command " + Format(u[t]) +
             " V is outside the valve's ctrlrange [" + Format(s.u_min) + ", " + Format(s.u_max) + "] V";
    }
  }
  const size_t n = rows - 1;  // the last row has no successor for its forward difference
  s.u.assign(u.begin(), u.begin() + static_cast<std::ptrdiff_t>(n));
  s.p.assign(p.begin(), p.begin() + static_cast<std::ptrdiff_t>(n));
  s.x.assign(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(n));
  s.x_rate.resize(n);
  for (size_t t = 0; t < n; ++t) s.x_rate[t] = (x[t + 1] - x[t]) / s.period;
  *series = std::move(s);
  return "";
}

}  // namespace

std::string CheckSeries(const ChamberSeries& s) {
  const std::string name = "series '" + s.name + "'";
  const size_t n = s.p.size();
  if (s.u.size() != n || s.x.size() != n || s.x_rate.size() != n) {
    return name + ": u, p, x and x_rate differ in length (" + std::to_string(s.u.size()) + ", " +
           std::to_string(n) + ", " + std::to_string(s.x.size()) + ", " + std::to_string(s.x_rate.size()) + ")";
  }
  if (n + 1 < static_cast<size_t>(kMinimumLogRows)) {
    return name + ": " + std::to_string(n) + " samples; identification needs at least " +
           std::to_string(kMinimumLogRows - 1) + " (10 next-step predictions per parameter of paper 000 eq. 10, "
           "plus the first row)";
  }
  if (!(s.period > 0) || !std::isfinite(s.period)) return name + ": period must be positive, is " + Format(s.period);
  if (!(s.p_supply > s.p_exhaust) || !std::isfinite(s.p_supply) || !std::isfinite(s.p_exhaust)) {
    return name + ": p_supply (" + Format(s.p_supply) + " Pa) must exceed p_exhaust (" + Format(s.p_exhaust) + " Pa)";
  }
  for (const auto* v : {&s.u, &s.p, &s.x, &s.x_rate}) {
    for (size_t t = 0; t < n; ++t) {
      if (!std::isfinite((*v)[t])) return name + ": non-finite value at sample " + std::to_string(t);
    }
  }
  return "";
}

std::string ExtractChambers(const mjModel* m, const log::Log& log, std::vector<ChamberSeries>* out) {
  if (!m || !IsAttached(m)) return "the model is not attached (pneumatic::Attach)";
  if (std::string invalid = log::ValidateLog(log, /*uniform_time=*/true); !invalid.empty()) {
    return "invalid log: " + invalid;
  }
  std::vector<ChamberSeries> series;
  for (const CylinderInfo& c : Cylinders(m)) {
    bool in_log = false;
    for (const log::Column& column : log.columns) in_log = in_log || column.cylinder == c.name;
    if (!in_log) continue;
    if (std::string valve = GetChoice(m, c.name, "valve", nullptr).value_or("?"); valve != kPerChamberValve) {
      return "cylinder '" + c.name + "' has valve=" + valve +
             ": identification supports only valve=proportional_per_chamber (paper 000's set-up, one valve "
             "per chamber, columns uP and uN); a 5/3 valve's one command would have to be mapped to each "
             "chamber, which is not done";
    }
    if (log.rows() < static_cast<size_t>(kMinimumLogRows)) {
      return "log has " + std::to_string(log.rows()) + " rows; identification needs at least " +
             std::to_string(kMinimumLogRows) +
             ": 10 next-step predictions per parameter of the 9-parameter model (paper 000 eq. 10), plus the "
             "row that starts the first prediction and the last row, which has no successor for its position rate";
    }
    for (Chamber k : {Chamber::kP, Chamber::kN}) {
      ChamberSeries s;
      if (std::string error = ExtractChamber(m, log, c, k, &s); !error.empty()) return error;
      series.push_back(std::move(s));
    }
  }
  if (series.empty()) return "log has no column of any pneumatic cylinder of the model";
  out->insert(out->end(), series.begin(), series.end());
  return "";
}

}  // namespace pneumatic::identification
