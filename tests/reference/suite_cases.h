// The graded diagnosis suite of issue 55 (item 3): its cases and their logs, simulated by the
// independent "real rig" of real_rig.h.
//
// Each case is one rig of docs/rigs.md with its parameters drawn around the nominal ones
// (valve discharge coefficient or sonic conductance, critical ratio and polytropic index within
// +-20 %, the index clamped to [1.0, 1.4]; each chamber's dead volume and the viscous damping
// within +-30 %; the moving mass as nominal), at most one effect switched on, sensors with noise
// (a factor in [0.5, 2] of 500 Pa and 0.05 mm), a 30-100 us pressure-sensor lag and a 5 um position
// quantum. Its truth is an effect's name of docs/effects.md, `none` (parameters only), or
// `unexplained` (an effect no library holds). The diagnosis gets the nominal model
// (models_mjcf/<RigModelFile>) and three logs made with different excitations: training, selection
// and test. Everything is deterministic: the case list is fixed and each log depends only on its
// case and seed.
#ifndef PNEUMATIC_TESTS_REFERENCE_SUITE_CASES_H_
#define PNEUMATIC_TESTS_REFERENCE_SUITE_CASES_H_

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "formats/log_csv.h"
#include "real_rig.h"

namespace pneumatic::reference {

// the parameters a case's real rig was drawn with, against docs/rigs.md's
struct Perturbation {
  double flow = 1;            // factor on C_val (A) or the discharge coefficient (B, C)
  double critical_ratio = 1;  // factor on b_crit (A) or P_cr (B); 1 on C (no critical ratio)
  double polytropic_index = 0;  // the value used, in [1.0, 1.4]
  double dead_volume_P = 1, dead_volume_N = 1;  // factors on V0, per chamber
  double damping = 1;         // factor on the viscous b
};

struct SuiteCase {
  std::string id;          // e.g. "B07-valve_deadband"
  Rig rig = Rig::kOnOff;
  double rate = 500;       // Hz: the log's and the excitation's rate
  double noise = 1;        // the sensors' noise as a factor of 500 Pa and 0.05 mm
  std::string truth;       // docs/effects.md name, "none" or "unexplained"
  std::string description;
  Perturbation perturbation;
  RealRigParams params;    // the real rig: perturbed, with its effect
  Sensors sensors;
  std::array<uint32_t, 3> seeds{};  // excitation and noise of the train, selection and test logs
};

// the logs of a case, by `which`
enum LogPart { kTrainLog = 0, kSelectionLog = 1, kTestLog = 2 };
inline const char* LogPartName(int which) {
  return which == kTrainLog ? "train" : which == kSelectionLog ? "selection" : "test";
}
// their default durations, s
inline constexpr double kDefaultDurations[3] = {10, 6, 6};

// the real rig's RK4 step, s (tests/real_rig_test checks its convergence)
inline constexpr double kSuiteFineStep = 5e-6;

// every case, in a fixed order
std::vector<SuiteCase> SuiteCases();

// A log of the case (docs/log_format.md, cylinder "cyl"): the rig's commands, p_P, p_N, x, v (a finite
// difference of the logged x) and p_S, one row per 1 / rate s over `duration` s, the excitation of
// seeds[which] closed on the logged (noisy) measurements. `source` names the case and the part.
log::Log SimulateCase(const SuiteCase& c, int which, double duration);

// The commands of a log of SimulateCase(), row by row.
std::vector<RigCommand> LogCommands(Rig rig, const log::Log& log);

// The case's real rig driven open loop by `commands` (one per 1 / rate s) at RK4 step `fine_step`,
// logged as SimulateCase() logs but read without noise and without the position's quantisation
// (the sensors' lag and bias kept): what a finer step changes, free of the closed loop's reaction.
log::Log ReplayCase(const SuiteCase& c, const std::vector<RigCommand>& commands, double fine_step);

// "A", "B" or "C"
const char* RigLetter(Rig rig);

}  // namespace pneumatic::reference

#endif  // PNEUMATIC_TESTS_REFERENCE_SUITE_CASES_H_
