// Fitting a candidate effect's parameters to a measured log (issue 14, "Which"), with the fitting
// layer of identification: Levenberg-Marquardt (Ceres Solver) on the normalised residuals of the
// short-horizon full-model predictions (diagnosis/prediction.h), standard errors from the
// sandwich covariance with a Newey-West estimate (identification/uncertainty.h), since residuals
// of multi-step predictions are correlated within a window.
//
// The residuals and the gap. For signal s (p_P, p_N or x of a cylinder) and predicted row i,
//   r_s,i = (y_sim,s,i - y_meas,s,i) / scale_s,
// scale_s the standard deviation of the measured signal in the training log, and
//   gap = sqrt( mean over signals s of mean over rows i of r_s,i^2 )
// the normalised RMS gap the diagnosis reports (README, "Diagnosis"): 0 for a perfect prediction
// of noise-free data, about 1 for a prediction no better than the signal's mean.
#ifndef PNEUMATIC_DIAGNOSIS_EFFECT_FIT_H_
#define PNEUMATIC_DIAGNOSIS_EFFECT_FIT_H_

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "diagnosis/candidates.h"
#include "diagnosis/measurements.h"
#include "diagnosis/prediction.h"

namespace pneumatic::diagnosis {

// A model as a diagnosis builds it: the user's model with effects' edits, fitted values and the
// signal model.
struct Scenario {
  std::vector<ModelEdit> edits;  // MJCF edits of every effect added so far
  // (apply, value) of every fitted parameter added so far, applied in order
  std::vector<std::pair<std::function<std::string(mjModel*, SignalModel*, double)>, double>> values;
};

// The scenario's model and signal model; null model and *error on failure.
ModelPtr BuildScenario(const std::string& model_path, const Scenario& s, const Measurements& meas, SignalModel* sensors,
                       std::string* error);

struct GapOptions {
  std::vector<double> signal_scale;  // per signal (SignalScales of the training log)
  Windows windows;
  int threads = 2;
};

// scale_s: the standard deviation of each measured signal (at least 1e-9 of its mean magnitude)
std::vector<double> SignalScales(const Measurements& meas);

struct Evaluated {
  Prediction prediction;
  std::vector<double> signal_gap;  // RMS of r_s per signal (normalised)
  std::vector<double> signal_rms;  // RMS of y_sim - y_meas per signal, in its unit (Pa, m)
  double gap = 0;
  Eigen::VectorXd residuals;       // r over every predicted row, signal by signal
  std::vector<int> series_starts;  // where each window of each signal starts in `residuals`
  std::string error;
};

Evaluated Evaluate(const mjModel* m, const SignalModel& sensors, const Measurements& meas, const GapOptions& options);

struct CandidateFit {
  std::vector<double> values, standard_errors;  // per parameter, in its unit
  std::vector<std::string> poorly_determined;   // per parameter, "" if well determined
  // per parameter, its standard error with the others held at their fitted values (the same
  // estimate on its Jacobian column alone): how well the data determine it given the others. Two
  // parameters that trade off (a sensor's offset and gain) have large standard errors and small
  // conditional ones; a parameter the data ignore has both large
  std::vector<double> conditional_standard_errors;
  double train_gap_before = 0, train_gap_after = 0;
  int iterations = 0, evaluations = 0;  // Levenberg-Marquardt steps taken (refused ones too); simulations of the log
  bool converged = false;
  std::string error;  // non-empty: the fit failed (the candidate is reported as failed)
};

struct FitOptions {
  GapOptions gap;
  int max_iterations = 12;
  // forward-difference step of the optimiser's variable: a fraction of the parameter's scale, or of
  // its value for a logarithmic parameter. Not smaller: a prediction error over a window is not
  // smooth at fine scales (valve regimes, stroke ends), and a small step overstates the slope, so
  // that Levenberg-Marquardt crawls
  double relative_step = 5e-2;
  // before Levenberg-Marquardt, the logarithmic parameters (magnitudes known only to a decade or
  // two, so their initial values may be decades off) are scanned at points spread evenly over
  // their ranges on their log scales, and the fit starts from the best point: those of one unit
  // together, at scan_points; parameters of different units (a volume and a conductance) on a
  // grid of scan_grid_points per unit; then each parameter of a unit that several share, alone
  // (three leak areas: one place may leak, the others not). Then the grid scan: the parameters with a scan_step
  // (EffectParameter) together on the first one's grid. 0: neither scan
  int scan_points = 6;
  int scan_grid_points = 4;
  // Jacobians in a row that Broyden's secant update of the last one may stand for (a
  // finite-difference Jacobian costs a simulation of the log per parameter, the update none);
  // 0: every Jacobian by finite differences. A fit converges only on a finite-difference one
  // (one that runs out of iterations may stop on a secant one)
  int secant_updates = 2;
  std::function<void(const std::string&)> progress;
};

// Fits c's parameters on `meas` with the scenario `base` plus c's edits.
CandidateFit FitCandidate(const std::string& model_path, const Scenario& base, const Candidate& c, const Measurements& meas,
                          const FitOptions& options);

// `base` plus candidate c at `values`
Scenario WithCandidate(const Scenario& base, const Candidate& c, const std::vector<double>& values);

}  // namespace pneumatic::diagnosis

#endif  // PNEUMATIC_DIAGNOSIS_EFFECT_FIT_H_
