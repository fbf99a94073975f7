// `pneumo reproduce karpenko2006`: paper 001's nonlinear PI position controller
// (controllers/karpenko_pid.h) rerun closed loop on rig B with the paper's deadband (12 % of the
// spool range) and seal friction (40 N static, 20 N Coulomb): models_mjcf/rig_proportional_full.xml,
// at rig B's control rate, 1 kHz (docs/rigs.md; the paper gives none). The paper's gains
// throughout (K_p = 10 V/m, K_i = 26 V/(m s)); nothing below is tuned to its figures.
//
// Experiments (each from rig B's reset state: x = 0, both chambers at atmosphere, valve centred):
//   step      Fig. 5 / Fig. 6: the reference holds 0 for kStepTime = 0.5 s, then steps to +100 mm
//             (the paper gives no step size: ours, a fifth of the stroke) and holds for 5 s.
//             linear_pi  the linear PI (reset off)               - Fig. 5a
//             reset_pi   the resetting PI (13), eps = 1 mm        - Fig. 5b (simulation), Fig. 6 (experiment)
//   s_curve   Figs. 7-9: S-curve moves (cycloidal: x_d = x0 + D (s - sin(2 pi s) / (2 pi)), s = t / t_move,
//             velocity and acceleration continuous, peak speed 2 D / t_move) over 60 % of the stroke:
//             0 -> -150 mm (3 s), hold 2 s, -150 -> +150 mm (6 s), hold 3 s, +150 -> 0 (3 s), hold 3 s,
//             then a small slow move 0 -> +20 mm (2 s), hold 2 s ("small low velocity" moves). Peak speed 0.1 m/s.
//             plain              resetting PI, eps = 1 mm, reset only while x_d' = 0     - Fig. 7
//             augmented          + velocity-error-triggered integral augmentation (14-15)  - Fig. 8
//             augmented_braking  + braking acceleration (16-17), eps = 4 mm               - Fig. 9
// Metrics (over the control ticks of the log):
//   step: overshoot_pct   100 max(x - x_target, 0) / step after the step
//         rise_time_s     from the step to the first tick with x >= 90 % of the step (the paper's "90 % rise time")
//         steady_error_mm max |x_d - x| over the last 0.5 s of the run
//   s_curve: peak_error_mm   max |x_d - x| over the run
//            final_error_mm  |x_d - x| at the last tick
//            max_hold_error_mm  max over the holds of |x_d - x| at the end of the hold (the paper's "steady errors")
//            overshoot_mm    max over the holds of how far x passes the hold's target in the move's direction
//            deadtime_s      from the start of the first move to the piston moving 1 mm
//   sines     (not in the paper) 50 mm at 0.05 Hz and 100 mm at 0.1 Hz under reset_pi and augmented_braking:
//             max and RMS |x_d - x| after the first 2 s, over 1.5 periods
#ifndef PNEUMATIC_REPRODUCE_KARPENKO2006_H_
#define PNEUMATIC_REPRODUCE_KARPENKO2006_H_

#include <optional>
#include <string>

#include <mujoco/mujoco.h>
#include <nlohmann/json.hpp>

#include "formats/log_csv.h"
#include "karpenko_pid.h"
#include "simulation/closed_loop.h"

namespace pneumatic {

constexpr double kKarpenko2006ControlRate = 1000;  // Hz: rig B's 1 ms
constexpr double kKarpenko2006StepTime = 0.5;      // s
constexpr double kKarpenko2006Step = 0.100;        // m

// The controller of one of the runs above by name (linear_pi, reset_pi, plain, augmented,
// augmented_braking): paper 001's parameters with its switches; nullopt for an unknown name.
std::optional<KarpenkoPidParams> Karpenko2006Controller(const std::string& name);

// A reference log with a "cyl.ref" column at every tick k / kKarpenko2006ControlRate:
// "step" (above, size `step`) or "s_curve" (above). *duration is the run's length. nullopt and
// *error for an unknown name.
std::optional<log::Log> Karpenko2006Reference(const std::string& name, double step, double* duration,
                                              std::string* error);

// x_d = amplitude sin(2 pi frequency t) at every tick, for `duration` s (the slow sines below, and the tests).
log::Log Karpenko2006SineReference(double amplitude, double frequency, double duration);

// Runs `reference` under KarpenkoPid(params) on m (rig B, attached) at 1 kHz.
ClosedLoopResult RunKarpenko2006(const mjModel* m, const log::Log& reference, double duration,
                                 const KarpenkoPidParams& params);

struct Karpenko2006StepMetrics {
  double overshoot_pct = 0;
  double rise_time_s = -1;  // -1: never reached 90 %
  double steady_error_mm = 0;
};
Karpenko2006StepMetrics Karpenko2006MeasureStep(const log::Log& log, double step_time, double step);

struct Karpenko2006TrackingMetrics {
  double peak_error_mm = 0, final_error_mm = 0, max_hold_error_mm = 0, overshoot_mm = 0, rms_error_mm = 0;
  double deadtime_s = -1;  // -1: the piston never moved 1 mm
};
Karpenko2006TrackingMetrics Karpenko2006MeasureTracking(const log::Log& log);

// Every experiment above on models_dir/rig_proportional_full.xml, as JSON:
//   step.{linear_pi, reset_pi}.{overshoot_pct, rise_time_s, steady_error_mm}
//   s_curve.{plain, augmented, augmented_braking}.{peak_error_mm, final_error_mm, max_hold_error_mm, overshoot_mm,
//            rms_error_mm, deadtime_s}
//   step_nominal.{linear_pi, reset_pi}: the step on the nominal rig B (rig_proportional.xml, no deadband or
//            friction), the closer analogue of Fig. 5's simulation
//   sines: [{amplitude_mm, frequency_hz, peak_speed_mm_s, reset_pi: {max_error_mm, rms_error_mm}, augmented_braking}]
//   paper: the paper's figures; comparison: ours against them with differences; disagreement: a sentence for
//   each that differs and the set-up differences; done_when: the resetting PI overshoots less than the linear PI;
//   setup: parameters, rates, definitions.
// With a non-empty out_dir, also writes there karpenko2006.json, the logs karpenko2006_<experiment>_<run>.csv
// and karpenko2006_step.png, karpenko2006_s_curve.png (scripts/plot_karpenko2006.py, /usr/bin/python3).
// null and *error if the model does not load or a run fails.
nlohmann::json ReproduceKarpenko2006(const std::string& models_dir, const std::string& out_dir, std::string* error);

}  // namespace pneumatic

#endif  // PNEUMATIC_REPRODUCE_KARPENKO2006_H_
