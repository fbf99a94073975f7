// Fitting MJCF parameters of a model to a measured log (issue 13): the parameters of the nominal
// model a user does not know well (discharge coefficient, polytropic index, dead volume, leakage,
// spool time constant...), and later those of the unmodelled effects a diagnosis adds. The layer
// is generic over MJCF keys: any numeric key of any cylinder, by name.
//
// What is fitted. Given the volume and its rate, the pressure dynamics do not depend on the
// mechanics (paper 000 Section II.5). The fit therefore simulates only the pressures, with the
// pistons following the log's measured motion (pneumo/rollout.h, follow_motion: cubic Hermite
// through each row's x and v, commands held per row, the state starting from the first row's
// p_P, p_N), and minimises
//
//   S(theta) = sum over fitted cylinders c, chambers k in {P, N}, rows i = 1..n-1 of
//              (p_sim,c,k,i(theta) - p_meas,c,k,i)^2          (Pa^2, absolute pressures)
//
// (the project's own formulation of paper 000's multi-step pressure prediction, Section V.D, as a
// least-squares fit). Row 0 is left out: the simulation starts from it, so its residual is 0.
// Weighting: both chambers' pressures in Pa, unweighted. They come from the same kind of sensor, so
// equal weights are the natural choice; and the standard errors do not rely on it, because the
// covariance is the sandwich form with a Newey-West estimate of the residuals' covariance
// (identification/uncertainty.h), consistent for unequal variances between chambers and for
// residuals correlated in time (noise in the measured x and v drives the simulated pressure).
// Only the cylinders with fitted keys contribute residuals: along a prescribed motion the other
// cylinders' pressures do not depend on them.
//
// How. Levenberg-Marquardt (Ceres Solver) on scaled variables z = value / s, s = max(|initial|,
// scale), inside the bounds of pneumatic::Parameters(). The Jacobian is computed by forward
// differences of whole rollouts (backward at an upper bound), step relative_step * s, run on
// `threads` threads, each rollout on its own mj_copyModel copy: the result is bit for bit the
// same whatever the thread count. The standard errors come from the Jacobian at the optimum.
#ifndef PNEUMATIC_IDENTIFICATION_PHYSICAL_FIT_H_
#define PNEUMATIC_IDENTIFICATION_PHYSICAL_FIT_H_

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <mujoco/mujoco.h>

#include "formats/log_csv.h"
#include "identification/uncertainty.h"

namespace pneumatic::identification {

// One fitted parameter: an MJCF key of one cylinder.
struct FitKey {
  std::string cylinder;  // cylinder name in the model, e.g. "cyl"
  // MJCF key: "P.dead_volume", "spool_time_constant"; a chamber key without prefix
  // ("polytropic_index") is one value for both chambers, which must then start equal
  std::string key;
  // typical magnitude in the key's unit, used where the initial value is 0 or tiny: the
  // optimiser's unit and the finite-difference step are relative to max(|initial|, scale).
  // 0: |initial| alone, which must then be nonzero (a leak conductance that defaults to 0
  // needs a scale, e.g. 1e-12 kg/(s Pa))
  double scale = 0;

  // "cyl:P.dead_volume": how the fit names it in messages and flags
  std::string name() const { return cylinder + ":" + key; }
};

// "cyl:P.dead_volume" -> {"cyl", "P.dead_volume"}; nullopt and *error if it is not
// "<cylinder>:<key>" (the key itself is checked by FitPhysical against the model).
std::optional<FitKey> ParseFitKey(const std::string& text, std::string* error);

// The physical parameters of `cylinder` that a user typically does not know well and that a
// follow-motion fit of the pressures can determine together, for its valve and flow law (empty
// and *error if m is not attached or has no such cylinder):
//   flow=thin_plate or sanville: P./N.discharge_coefficient (C of paper 000 eq. 1 multiplies the
//     whole port opening; area_gain B, port_area and orifice_gradient multiply it again, so
//     fitting them together is degenerate: they are left out), and for sanville also
//     critical_ratio (one value for both chambers: the same valve's ports);
//   flow=iso6358: P./N.sonic_conductance and critical_ratio (both chambers);
//   every chamber: P./N.dead_volume (tubes and ports differ per chamber), and polytropic_index
//     (the same gas and walls: one value for both chambers);
//   valve=proportional_5_3 with a spool lag: spool_time_constant.
// Leakage keys are not defaults: the valve leak areas trade off against the seal voltages and
// the discharge coefficient near the sealed band, and the laminar conductances default to 0
// (they need a scale); a diagnosis adds them with FitKey when the residuals ask for them.
std::vector<FitKey> DefaultPhysicalKeys(const mjModel* m, const std::string& cylinder, std::string* error);

struct PhysicalFitOptions {
  std::vector<FitKey> keys;  // what to fit (DefaultPhysicalKeys for the usual set)
  int threads = 2;           // rollouts run at once for the Jacobian (>= 1)
  int max_iterations = 30;   // Levenberg-Marquardt iterations
  // forward-difference step as a fraction of s = max(|value|, scale): large enough that the
  // change of the simulated pressures dominates the chamber step's adaptive switching (which
  // makes the rollout piecewise smooth in the parameters), small enough for a 1e-3 relative bias
  double relative_step = 1e-3;
  // standard errors: lag_window < 0 (default) chooses the Newey-West window from the residuals,
  // 0 is the textbook covariance; thresholds of the poorly-determined flag
  UncertaintyOptions uncertainty;
  // called with one line per iteration (and one at the start), for a progress display
  std::function<void(const std::string&)> progress;
};

struct FittedParameter {
  std::string cylinder, key;  // as in FitKey
  std::string unit;           // SI unit of the key, from pneumatic::Parameters()
  double initial = 0;         // the model's value
  double value = 0;           // fitted
  double standard_error = 0;  // linearised at the optimum; +inf if not determined
  // "" if well determined, else why not: "standard error 62 % of its value" or
  // "correlated with cyl:N.area_gain (-0.99)"
  std::string poorly_determined;
};

struct PhysicalFit {
  std::vector<FittedParameter> parameters;  // in the order of options.keys
  Eigen::MatrixXd correlation;              // of the estimates, in that order
  double rms_before_pa = 0;                 // RMS pressure residual at the initial values (Pa)
  double rms_after_pa = 0;                  // ... at the fitted values
  int residuals = 0;                        // number of pressure residuals (both chambers)
  // at the fitted values, for residual analysis and other covariance estimates: the residuals
  // p_sim - p_meas (Pa), one series per fitted chamber signal (rows 1..n-1 of cylinder c's p_P,
  // then its p_N, c in model order) starting at series_starts, and the Jacobian (Pa per unit of
  // each key, residuals x keys)
  Eigen::VectorXd final_residuals;
  std::vector<int> series_starts;
  Eigen::MatrixXd jacobian;
  int lag_window = 0;                       // Newey-West window used (rows)
  int iterations = 0;
  int rollouts = 0;                         // follow-motion simulations run
  bool converged = false;                   // Ceres reported convergence (not just the iteration limit)
  std::vector<std::string> warnings;        // e.g. a velocity built from x, a parameter at a bound
  std::string error;                        // non-empty: nothing was fitted, parameters is empty
};

// Fits options.keys of m (attached; not modified) to `log`, which needs for every cylinder of m
// its command columns and x, and for every cylinder with fitted keys p_P and p_N. A log without
// a cylinder's v gets one by central differences of x (one-sided at the ends; a warning says
// so); noisy x makes that v noisy too, which the standard errors account for.
PhysicalFit FitPhysical(const mjModel* m, const log::Log& log, const PhysicalFitOptions& options);

// Sets every fitted value on m (an attached model, e.g. an mj_copyModel copy of the one fitted):
// "" or the first error, naming cylinder and key. m is unchanged on error.
std::string ApplyPhysicalFit(mjModel* m, const PhysicalFit& fit);

}  // namespace pneumatic::identification

#endif  // PNEUMATIC_IDENTIFICATION_PHYSICAL_FIT_H_
