// Closed-loop identification logs of a rig with one proportional valve per chamber (rig C),
// recorded as paper 000 Section V.C describes: "controlled movement ... by a simple PID
// controller W.R.T the potentiometer reading ... designed to explore the state space as
// violently as possible, without hitting any joint limits", valves used in 3 <= u <= 7 V
// (Section V), a 100 Hz loop (Section V), both chambers driven so that the co-contraction
// (stiffness) varies as well as the position.
//
// The law, for every cylinder, at each row k (t_k = k T, T = 10 ms, commands held for T):
//
//   r(t)  = 0.7 (l/2) F(t) S(t) / max_k |F(t_k) S(t_k)|,  S(t) = sum_{i=1..4} (1/f_i) sin(2 pi f_i t + phi_i),
//           f_i uniform in [0.1, 0.8] Hz (amplitude 1/f_i: equal peak speed per component), phi_i uniform
//           in [0, 2 pi), F(t) = sin^2(pi t / 2 s) for t < 1 s, else 1 (starts from rest): a smooth
//           reference reaching 70 % of the half stroke l/2 at its extreme row and never beyond (at 80 %,
//           while tuning, the PID's overshoot reached the end stops on some seeds)
//   d_k   = PID(r(t_k), x(t_k)): kp = 60 V/m, ki = 60 V/(m s), kd = 1.5 V s/m, output in [-4, 4] V
//           (controllers/pid.h: derivative on the measurement, anti-windup)
//   c(t)  = 0.25 V + 0.75 V C(t),  C(t) = (sin(2 pi g_1 t + psi_1) + sin(2 pi g_2 t + psi_2)) / 2,
//           g_j uniform in [0.03, 0.15] Hz: a co-contraction in [-0.5, 1] V varying slowly (wider
//           ranges pinned uN at 7 V and left uP in the valve's sealed band near 5 V: poor tracking)
//   uP_k  = clamp(5 V + c(t_k) + d_k, 3 V, 7 V),  uN_k = clamp(5 V + c(t_k) - d_k, 3 V, 7 V)
//
// Everything random comes from `seed` (mt19937_64 streams per cylinder and purpose), so the
// same options give the same log bit for bit, and the noise draws do not depend on the noise
// levels: a run with noise and one without differ only by noise.
//
// Sampling: every measured column is the instantaneous value at the row's time, before the
// row's command acts (docs/log_format.md), NOT paper 000's average of 200 samples over
// the preceding 10 ms period (Section V). The controller uses the same instantaneous but
// noise-free position: the noise stands for the logging sensors; paper 000's controller sees
// 200-sample averages, whose white noise is sqrt(200) ~ 14 times smaller.
#ifndef PNEUMATIC_GENERATE_H_
#define PNEUMATIC_GENERATE_H_

#include <cstdint>
#include <optional>
#include <string>

#include <mujoco/mujoco.h>

#include "formats/log_csv.h"

namespace pneumatic {

struct GenerateOptions {
  double duration = 0;           // s, > 0; rows: ceil(duration / period)
  std::uint64_t seed = 1;
  // standard deviations of the Gaussian sensor noise added to the logged p_P, p_N (Pa) and
  // x (m); v gets sqrt(2) noise_position / period, the noise of a finite difference of two
  // position samples (paper 000 finite-differences its potentiometers)
  double noise_pressure = 500;   // Pa: 0.1 % of supply - exhaust on rig C
  double noise_position = 1e-4;  // m: 0.1 % of rig C's 0.1 m stroke
  double period = 0.01;          // s: paper 000's 100 Hz loop
};

struct GenerateResult {
  std::optional<log::Log> log;  // time, cyl.uP, cyl.uN, cyl.p_P, cyl.p_N, cyl.x, cyl.v, cyl.ref per cylinder
  std::string error;
};

// Simulates m (attached; every cylinder valve=proportional_per_chamber) closed loop as above,
// from the model's reset state (atmospheric chambers, qpos0).
GenerateResult Generate(const mjModel* m, const GenerateOptions& options);

}  // namespace pneumatic

#endif  // PNEUMATIC_GENERATE_H_
