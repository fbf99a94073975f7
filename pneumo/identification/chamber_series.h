// The data of one valve-chamber system taken from a log: what paper 000 (Section V.C) fits its
// parametric pressure model to, "the voltage u_t, chamber pressure p_t, and joint-potentiometer
// reading v_t", with v_t finite-differenced to a rate.
//
// The position rate is the FORWARD difference x_rate_t = (x_{t+1} - x_t) / h: the mean rate over
// the step [t, t + h] whose end pressure p_{t+1} the model predicts from row t (paper 000 eq. 7
// holds s and r, hence the rate, fixed over that step). A central difference would mix in the
// previous step, and the logged `v` column (optional, an instantaneous rate) is not the rate the
// step sees. The last row has no successor, so it is dropped: a series has rows - 1 entries.
#ifndef PNEUMATIC_IDENTIFICATION_CHAMBER_SERIES_H_
#define PNEUMATIC_IDENTIFICATION_CHAMBER_SERIES_H_

#include <limits>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "formats/log_csv.h"

namespace pneumatic::identification {

struct ChamberSeries {
  std::string name;    // "<cylinder>.P" or "<cylinder>.N"
  double period = 0;   // s: h, the log's row spacing
  // one entry per row kept (all rows but the last), same length:
  std::vector<double> u;       // V: the chamber's valve command, held over [t, t + h]
  std::vector<double> p;       // Pa abs: chamber pressure at t
  std::vector<double> x;       // m (rad for a rotary cylinder): piston position at t, the same for both chambers
  std::vector<double> x_rate;  // m/s: (x_{t+1} - x_t) / h, see above
  double p_supply = 0;         // Pa abs: P_c of paper 000 Table I (c_b, c_s)
  double p_exhaust = 0;        // Pa abs: P_r
  double u_min = -std::numeric_limits<double>::infinity();  // V: the command actuator's ctrlrange
  double u_max = std::numeric_limits<double>::infinity();
  double stroke = 0;           // m: x in [-stroke/2, stroke/2] (for 1 + c6 x > 0)
  // V: (U_c + U_r)/2 of the model's valve for this chamber (paper 000 Table I: c1's meaning),
  // the initial guess of c1; NaN if the model does not give the seal voltages
  double u_seal_centre = std::numeric_limits<double>::quiet_NaN();
};

// 9 parameters of paper 000 eq. 10, 10 next-step predictions each for estimates and standard
// errors worth reporting, plus the row that starts the first prediction and the last row, which
// has no successor for its position rate
constexpr int kMinimumLogRows = 9 * 10 + 2;

// "" if the series is usable by the fit and the drift, else what is wrong with it: vectors of
// one length with at least kMinimumLogRows - 1 entries, finite values, period > 0,
// p_supply > p_exhaust (a series built by hand, not by ExtractChambers, gets the same checks).
std::string CheckSeries(const ChamberSeries& series);

// Appends one series per chamber of every cylinder of m (attached) that has columns in the log:
// "<cyl>.P" (columns <cyl>.uP, <cyl>.p_P, <cyl>.x) then "<cyl>.N" (<cyl>.uN, <cyl>.p_N, <cyl>.x).
// Only valve=proportional_per_chamber (paper 000's set-up) is supported. Returns "" or why not:
// an invalid log, a cylinder with another valve, a missing column (named), a command outside its
// actuator's ctrlrange (column, row from 0 and value), fewer than kMinimumLogRows rows, no column
// of any cylinder of the model. *out is unchanged on error.
std::string ExtractChambers(const mjModel* m, const log::Log& log, std::vector<ChamberSeries>* out);

}  // namespace pneumatic::identification

#endif  // PNEUMATIC_IDENTIFICATION_CHAMBER_SERIES_H_
