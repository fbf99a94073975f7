// `pneumo reproduce hodgson2012`: paper 002's comparison of its 7-mode sliding controller with the
// 3-mode one of its ref. [17] (controllers/sliding_mode.h), rerun closed loop on rig A
// (models_mjcf/rig_onoff.xml, docs/rigs.md) with the paper's parameters (Section V:
// w = 100 rad/s, xi = 0.5, tau = 40 ms, beta = 3 mm, e_min = 1 mm; (25): kappa = 2,
// y_d_dot_min = 20 mm/s) at the paper's controller rate, 500 Hz (Section VI; rig A's 2 ms).
//
// References (paper 002, Section V.A), each a function of the time t from the start of the run:
//   square      (28): y_d = +20 mm for the first half of each period, -20 mm for the second, f = 0.5 Hz
//                     (the paper gives no frequency for it: our choice, 1 s per level)
//   sine_<f>Hz  (26): y_d = 20 mm sin(2 pi f t), f = 0.1 .. 3 Hz (Fig. 7a, Fig. 10a)
//   multisine   (27): y_d = 30 mm / m sum_{i=1..m} sin(2 pi (f_i / m) t), m = 8, f_i = i f, f = 1 Hz
//                     (the paper's "f = 1 Hz" read as f_i = i f: components at 1/8 .. 1 Hz)
// Every run starts from rig A's reset state (x = 0, both chambers at atmosphere) and is judged
// after a 1 s warm-up, over whole periods of its reference (at least 4 s):
//   rms_error_mm    the RMS over the control ticks of y_d - x
//   switches_per_s  valve state changes per second, summed over the four valves: every tick at which
//                   a valve's command differs from the tick before counts one (an opening and a
//                   closing are two), which is how we read the paper's "aggregated occurrence of
//                   switches in all 4 solenoid valves" (V.B)
// The valves are rig A's ideal valves (instant switching), the paper's simulation has a 2 ms valve
// response time (V.B); that and the other differences are listed under "disagreement".
#ifndef PNEUMATIC_REPRODUCE_HODGSON2012_H_
#define PNEUMATIC_REPRODUCE_HODGSON2012_H_

#include <optional>
#include <string>

#include <mujoco/mujoco.h>
#include <nlohmann/json.hpp>

#include "formats/log_csv.h"
#include "simulation/closed_loop.h"
#include "sliding_mode.h"

namespace pneumatic {

// One reference of paper 002 (names above) as a log with a "cyl.ref" column, exact at every tick
// t_k = k period for k T < duration; nullopt and *error for an unknown name.
std::optional<log::Log> Hodgson2012Reference(const std::string& signal, double duration, double period,
                                             std::string* error);

// What a closed-loop log of rig A shows from `from_time` on (see above for the definitions).
struct Hodgson2012Metrics {
  double rms_error_mm = 0;
  double max_error_mm = 0;
  double switches_per_s = 0;           // all four valves
  double p_chamber_switches_per_s = 0;  // u1 and u2 only (the paper's Figs. 7-11 plot chamber P's)
  double mode_changes_per_s = 0;       // changes of Table I's mode
  long bypass_ticks = 0;               // ticks with u1 = u2 = 1 or u3 = u4 = 1 (over the whole log)
  double window_s = 0;
};
Hodgson2012Metrics Hodgson2012Measure(const log::Log& log, double from_time);

// The length of a run of `signal` (warm-up included) and the start of its judged window.
struct Hodgson2012Window {
  double duration = 0, from_time = 0;
};
Hodgson2012Window Hodgson2012WindowOf(const std::string& signal);

// Runs one reference under the sliding controller `params` on m (rig A, attached) at 500 Hz.
ClosedLoopResult RunHodgson2012(const mjModel* m, const std::string& signal, const SlidingModeParams& params,
                                double duration);

// Every experiment above on models_dir/rig_onoff.xml, as JSON:
//   square, sine_1.5Hz, multisine: {mode3: {rms_error_mm, switches_per_s, ...}, mode7: {...},
//                                   (square only: mode7_fixed_epsilon, Fig. 5, and overshoot_pct)
//                                   switch_reduction_pct, rms_change_mm (7-mode minus 3-mode)}
//   sines: [{frequency_hz, mode3, mode7, ...}, ...] (0.1 .. 3 Hz)   paper: the paper's figures   comparison: ours against
//   them, each with its difference   disagreement: a sentence for each that differs   done_when:
//   issue 16's criterion   setup: parameters, rates, definitions.
// With a non-empty out_dir, also writes there hodgson2012.json, the logs hodgson2012_<signal>_mode<3|7>.csv
// and hodgson2012_tracking.png, hodgson2012_sines.png (scripts/plot_hodgson2012.py, /usr/bin/python3).
// An empty JSON (null) and *error if the model does not load or a run fails.
nlohmann::json ReproduceHodgson2012(const std::string& models_dir, const std::string& out_dir, std::string* error);

}  // namespace pneumatic

#endif  // PNEUMATIC_REPRODUCE_HODGSON2012_H_
