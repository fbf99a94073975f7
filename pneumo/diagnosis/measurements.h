// The measured log of a diagnosis (issue 14), checked against its model and put in the form the
// predictions read: per cylinder the measured chamber pressures and position, a velocity estimated
// from the position (closed-loop logs of real robots have no velocity column), and the commands.
#ifndef PNEUMATIC_DIAGNOSIS_MEASUREMENTS_H_
#define PNEUMATIC_DIAGNOSIS_MEASUREMENTS_H_

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "formats/log_csv.h"
#include "pneumatic/pneumatic.h"

namespace pneumatic::diagnosis {

// The signals a diagnosis compares, per cylinder, in this order: signal index 3 c + kind.
enum SignalKind { kPressureP = 0, kPressureN = 1, kPosition = 2 };
constexpr int kSignalsPerCylinder = 3;
const char* SignalName(int kind);  // "p_P", "p_N", "x"

struct CylinderSeries {
  CylinderInfo info;
  int joint = -1;      // the joint the cylinder drives (diagnosis needs joint-driven cylinders)
  double gear = 1;     // x = gear qpos - x_mid
  double stroke = 0;   // m or rad
  std::vector<double> signal[kSignalsPerCylinder];  // measured p_P, p_N (Pa abs), x (m or rad), per row
  std::vector<double> velocity;                     // estimated dx/dt per row (m/s or rad/s)
  std::vector<int> command_actuators;               // actuator ids ...
  std::vector<std::string> command_names;           // ... and their log signals ("uP", "u1", ...)
  std::vector<std::vector<double>> commands;        // [command][row]
  std::vector<double> supply;                       // measured p_S (Pa abs) per row; empty when the log has none
};

struct Measurements {
  std::string source;          // the log's file, for messages
  std::vector<double> time;    // s, uniform
  double period = 0;           // s
  int steps_per_row = 1;       // model timesteps per row
  int first_line_row = 0;      // row of the source log that row 0 is (after a split)
  std::vector<CylinderSeries> cylinders;

  int rows() const { return static_cast<int>(time.size()); }
  int signals() const { return kSignalsPerCylinder * static_cast<int>(cylinders.size()); }
  const std::vector<double>& Signal(int s) const { return cylinders[s / 3].signal[s % 3]; }
  std::string SignalLabel(int s) const { return cylinders[s / 3].info.name + "." + SignalName(s % 3); }
};

// Checks `log` against m (attached) and prepares it: every cylinder needs its command columns and
// p_P, p_N, x; rows uniformly spaced by a whole number of model timesteps; at least `min_rows`
// rows; no command constant over the whole log (nothing would excite the model); no impossible
// value (rollout.h CheckMeasurements, with FILE:LINE:COLUMN). A v column, if present, is ignored:
// the velocity is always estimated from x, as it must be on a real robot. A p_S column, if
// present, is kept (CylinderSeries::supply) for supply_drop's logged form. nullopt and *error
// naming the file and what is wrong.
std::optional<Measurements> PrepareMeasurements(const mjModel* m, const log::Log& log, int min_rows,
                                                std::string* error);

// Rows [begin, end) of `all`, with the velocity estimate kept from the whole log.
Measurements SliceRows(const Measurements& all, int begin, int end);

// dx/dt by a local least-squares cubic over +-half rows (Savitzky and Golay, Anal. Chem. 36, 1964:
// the first-derivative filter of degree 3), windows shifted inside the log at its ends. A cubic,
// not a line: a closed loop's fast oscillations (a limit cycle of a few tens of Hz) would bias the
// slope of a line fitted over the same window.
std::vector<double> EstimateVelocity(const std::vector<double>& x, double period, int half);

// EstimateVelocity's half window for rows `period` apart: +-10 ms, at least 2 rows (short against
// the motion of the rigs' closed loops, bandwidths of a few Hz; long enough to average position noise)
inline int VelocityHalfWindow(double period) { return std::max(2, static_cast<int>(std::lround(0.01 / period))); }

}  // namespace pneumatic::diagnosis

#endif  // PNEUMATIC_DIAGNOSIS_MEASUREMENTS_H_
