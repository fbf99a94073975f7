// `pneumo reproduce laib2021`: paper 003 (Laib et al., JDSMC 2021) rerun on rig A with its four
// on/off valves on PWM (input=pwm, models_mjcf/rig_onoff.xml with the four valve commands replaced
// by one duty, docs/rigs.md).
//
//   nrmsod_pct[f]  eq. (16), f = 10 .. 200 Hz: the switched model (pwm_frequency = f) against the
//                  averaged model (pwm_frequency = 0, eq. 14), open loop, the same duty signal
//                  u(t) = 0.3 sin(2 pi 10 t) for 1 s (Section 4.2's 10 Hz sine; its "10 mm
//                  amplitude" cannot be a duty, and 0.3 swings rig A's piston by about that),
//                  from mid-stroke with both chambers at 2 bar abs; x sampled every 1 ms. The
//                  duty follows the sine at every model step (the PWM compares it with the carrier
//                  as it goes), each pulse centred in its period (pwm_alignment=center, the
//                  default). Reported too: the same with edge-aligned pulses
//                  (nrmsod_pct_leading_edge: each pulse shifted by up to half a period against the
//                  averaged model, an error of first order in the period; at carriers that are odd
//                  multiples of the 10 Hz signal the pulses sample its two half-waves unevenly, a
//                  net push the open loop integrates), and with the duty latched once per carrier
//                  period on both models (nrmsod_pct_latched_duty).
//                  NRMSOD = RMS(y - y_a) / (max y_a - min y_a): eq. (16) divides sqrt(e'e) by
//                  max|e|, which is >= 1 for any signal and grows with the sample count, so cannot be
//                  the paper's "about 1 %"; we read it as the usual normalised RMS deviation.
//   closed_loop.{high_gain, sliding}: the sliding-mode controller (18-20) with observer (22) or (23)
//                  (controllers/laib_smc.h, the paper's gains, the model on rig A's parameters) at
//                  500 Hz, PWM carrier 100 Hz, y_d = 0.04 sin(pi t) for 6 s from rig A's reset
//                  state; judged from t = 2 s:
//                  nrmste_pct = RMS(y_d - y) / (max y_d - min y_d) (eq. 25, read as eq. 16),
//                  pN_error_rms_kPa, v_error_rms_mm_s: RMS of the observer's p_N = psi(X^) and
//                  x2^ against the simulated p_N and v.
#ifndef PNEUMATIC_REPRODUCE_LAIB2021_H_
#define PNEUMATIC_REPRODUCE_LAIB2021_H_

#include <string>
#include <vector>

#include <mujoco/mujoco.h>
#include <nlohmann/json.hpp>

#include "laib_smc.h"

namespace pneumatic {

// rig A's MJCF text (rig_onoff.xml's) with input=pwm at `frequency` Hz (0: averaged) and
// pwm_alignment `alignment` (center or leading), one actuator "cyl.duty"; "" and *error if the text
// is not rig A's.
std::string Laib2021PwmRig(const std::string& rig_onoff_xml, double frequency, std::string* error,
                           const std::string& alignment = "center");

// Loads MJCF text and attaches the extension; null and *error on failure.
mjModel* Laib2021LoadModel(const std::string& xml, std::string* error);

// The open-loop piston trajectory (every 1 ms, 1 s) under the duty signal above. With
// hold_frequency > 0 the duty is sampled at the start of every period 1/hold_frequency and held (a
// digital PWM that latches its duty once per carrier period); 0: the duty follows the sine at every
// model step (natural sampling).
std::vector<double> Laib2021OpenLoop(const mjModel* m, double hold_frequency = 0);

// NRMSOD (%) of `switched` against `averaged` (see above).
double Laib2021Nrmsod(const std::vector<double>& switched, const std::vector<double>& averaged);

// The controller's parameters on the rig (from the attached model m's cylinder).
LaibSmcParams Laib2021Params(const mjModel* m, int observer);

struct Laib2021ClosedLoop {
  double nrmste_pct = 0, rms_error_mm = 0, max_error_mm = 0, pN_error_rms_kPa = 0, v_error_rms_mm_s = 0;
  std::string error;
};
// One closed-loop run of y_d = amplitude sin(omega t) (a step if omega = 0) on m, judged from
// `from_time`; with `log_path` the log is written there (time, x, ref, v, p_P, p_N, estimates).
Laib2021ClosedLoop RunLaib2021(const mjModel* m, const LaibSmcParams& params, double amplitude, double omega,
                               double duration, double from_time, const std::string& log_path = "");

// Every experiment above as JSON (paper values, disagreement notes, done_when, setup); with a
// non-empty out_dir also laib2021.json, laib2021_<observer>.csv and laib2021_nrmsod.png,
// laib2021_tracking.png (scripts/plot_laib2021.py). Null and *error on failure.
nlohmann::json ReproduceLaib2021(const std::string& models_dir, const std::string& out_dir, std::string* error);

}  // namespace pneumatic

#endif  // PNEUMATIC_REPRODUCE_LAIB2021_H_
