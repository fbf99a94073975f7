// The candidate effects a diagnosis tries (issue 14, "Which"): for each name of
// docs/effects.md, the form the diagnosis adds to the user's model and the parameters it
// fits. The forms are deliberately simple (a Coulomb friction for whatever the seals do, one wall
// heat conductance, an orifice leak): a real effect will not follow any one form, and a simple
// form that captures its signature generalises to held-out data better than a rich one. Where one
// simple form leaves much unexplained, a second form of the effect is tried in the rounds where the
// effect is the best with richer forms or the runner-up that explains the gap (Candidate::refinement: a dead time, laminar
// leaks, leaks both laminar and orifice, a supply tank, ...; diagnose.cc). Each effect's forms are
// declared in a file of diagnosis/effects/ and registered in effects/registry.cc
// (docs/effect_forms.md).
//
// A candidate changes the model in up to three ways: keys of a cylinder's "pneumatic:" text
// (SetParameter), fields of mjModel (a joint's frictionloss, a body's mass), and the signal model
// (offset and gain of one measured signal, a delay of the logged commands, the history estimate of
// the unmeasured states: prediction.h). Forms with their own states (a gas temperature) also need
// the state's actuator in the MJCF: the candidate lists it as a ModelEdit, and the model is
// reloaded from its file with the edit (LoadEditedModel).
#ifndef PNEUMATIC_DIAGNOSIS_CANDIDATES_H_
#define PNEUMATIC_DIAGNOSIS_CANDIDATES_H_

#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <mujoco/mujoco.h>

#include "diagnosis/measurements.h"
#include "diagnosis/prediction.h"

namespace pneumatic::diagnosis {

using ModelPtr = std::unique_ptr<mjModel, void (*)(mjModel*)>;

// MJCF text added to a model: state actuators "<cylinder>.<suffix>" on the cylinder's
// transmission, and keys appended to its "pneumatic:<cylinder>" text.
struct ModelEdit {
  std::string cylinder;
  std::vector<std::string> state_actuators;                 // suffixes, e.g. "TP", "TN"
  std::vector<std::string> force_actuators;                 // stateless, with a user bias: "friction"
  std::vector<std::string> stateful_commands;               // existing command actuators given dyntype="user"
  std::vector<std::pair<std::string, std::string>> keys;    // e.g. {"thermal_model", "energy"}
  // a supply reservoir that feeds the cylinder (supply_drop): "" or its name, with its keys; added
  // as <text name="pneumatic_reservoir:NAME">, its state actuator NAME.pressure on the cylinder's
  // transmission, and the cylinder's key supply=NAME
  std::string reservoir = "";
  std::vector<std::pair<std::string, std::string>> reservoir_keys = {};
};

// The state actuators (suffixes) of a cylinder's command delay line, which spool_dead_time and
// line_delay share (plugin/src/valves.h, ValveSignal: a (1,2) Pade approximant, two states per
// command channel): "d1", "d2" for valve=proportional_5_3; "dP1", "dP2", "dN1", "dN2" for
// proportional_per_chamber; none for any other valve, which has no delay line.
std::vector<std::string> DelayLineStates(const std::string& valve);

// Loads the MJCF at `path` with `edits` applied and attaches it. The edits are made on its document
// (tinyxml2) after its <include> elements are resolved as MuJoCo resolves them, so the cylinder's
// text and the actuators may sit in an included file; the edited document is loaded through a virtual
// file beside the original, so its assets resolve as before. Where no geom pair of the model can
// touch, its collision detection is skipped (SkipCollisionWhereNothingCollides: the same results,
// sooner). Null and *error on failure.
ModelPtr LoadEditedModel(const std::string& path, const std::vector<ModelEdit>& edits, std::string* error);

// Skips collision detection (mjDSBL_CONTACT) in a model where no contact can ever arise: no explicit
// <pair>, and no geom whose contype meets any geom's conaffinity (MuJoCo's filter: contype_a &
// conaffinity_b or contype_b & conaffinity_a). MuJoCo 2.2.2 still runs its broad phase on such a
// model every step (engine_collision_driver.c, mj_collision) and finds nothing; with contacts
// disabled it returns at once with the same zero contacts, so every result is the same to the bit.
// The benchmark rigs (docs/rigs.md) are such models: on rig A, stepped at 0.05 ms, the broad phase
// was 8.6 % of a diagnosis' time. A model whose geoms can touch is left as it is.
void SkipCollisionWhereNothingCollides(mjModel* m);

// One fitted parameter of a candidate.
struct EffectParameter {
  std::string name;   // as reported, e.g. "cyl:delay_open", "cyl:joint x frictionloss", "cyl.p_P:offset"
  std::string unit;   // SI
  double initial = 0, lower = 0, upper = 0;
  double scale = 1;   // typical magnitude: the fit's unit and finite-difference reference
  // a linear parameter is fitted as z = (value - nominal) / scale, its deviation from the model
  // without the effect (a gain's 1, the rated supply pressure), so that the solver's relative step
  // tolerance (Ceres' parameter_tolerance, relative to |z|) measures a step against the effect's
  // size: at z = value / scale a sensor gain near 1 on a scale of 0.01 sat at z = 100, and on a
  // noise-free rig C log the fit of a p_N sensor's -10 kPa offset stopped at -5 kPa and gain 0.990
  // (the two trade off over the logged pressures) with steps of 3e-5 |z|
  double nominal = 0;
  // the value that is the model without the effect, where it is neither the nominal of a linear
  // parameter fitted as a deviation nor the lower bound (an unrestricted line, an endless tank:
  // their upper bounds); NaN: that one. A fitted value at this end of the range means the effect is
  // absent; at the other end, a magnitude the range cuts short (diagnose.cc, Implausible)
  double absent = std::numeric_limits<double>::quiet_NaN();
  // true for a parameter that is not the effect's size but a nuisance of its form (statistics'
  // nuisance parameter): the logged supply form's p_S sensor offset, where the effect is the logged
  // supply itself. No value of it is the model without the effect, and it may sit anywhere in its
  // range, at 0 or undetermined, without refusing the effect; only a value at a bound of its range
  // does (Implausible). On bench_diagnose's rig A supply tank the logged supply with an offset of
  // 7 +- 14 Pa left the held-out gap at 0.0124 (-97.6 %) and was refused as undetermined, and as
  // "every parameter at the value of the model without the effect" when the offset fitted 0: a
  // leak was named (54.1 %)
  bool nuisance = false;
  // true where both ends of the range are physical limits, not magnitudes a plausible range cuts
  // short: the calibration keeps a value there (the polytropic index at 1, isothermal, or at the gas'
  // ratio of specific heats, adiabatic), where it leaves another parameter at a bound at the model's
  // value (diagnose.cc, Calibrate)
  bool ends_are_physical_limits = false;
  // fitted as z = ln(value / scale) (lower > 0): for magnitudes known only to a decade or two
  // (conductances, volumes), where a linear step either crawls or overshoots
  bool logarithmic = false;
  // false: a logarithmic parameter the coarse scan (FitOptions::scan_points) leaves at its initial
  // value, for a start known to lie in the one basin its range has
  bool scanned = true;
  // > 0 (a linear parameter): before the fit, tried at lower, lower + scan_step, ... up to upper
  // (FitOptions: the grid scan), for a cost with local minima about that far apart, which a
  // Levenberg-Marquardt start outside the true one's basin cannot leave
  double scan_step = 0;
  // > 0: where a form of the same effect fitted earlier in the round has a parameter named seed_from
  // (this parameter's own name where seed_from is empty; the form's best by dIC), the fit starts at
  // seed_factor times that form's value, and without the scans: a richer form that sums two simpler
  // ones, each at half its own fit (factor 0.5, the same names), or a form whose parameter is
  // another's converted (a laminar leak's conductance from an orifice's area)
  double seed_factor = 0;
  std::string seed_from;
  // sets the value on a model (with the candidate's edits) and the signal model: "" or why not
  std::function<std::string(mjModel*, SignalModel*, double)> apply;
};

struct Candidate {
  std::string effect;  // effects.md name
  std::string form;    // what is added, in words
  std::vector<ModelEdit> edits;
  std::vector<EffectParameter> parameters;
  // a richer form of an effect that has a simpler one in the library: fitted only in a round where
  // the effect's simpler forms are the best or second best of the effects with richer forms
  // (the second must explain the gap by itself; refinement.h), as its fit is costly
  // (a state to simulate)
  bool refinement = false;
};

// The candidates for m (attached, loaded from its file) and the measurements: every effect of
// effects.md except `none`, in the forms this model admits (e.g. valve_deadband needs a
// proportional valve); sensor_bias once per measured signal.
std::vector<Candidate> CandidateLibrary(const mjModel* m, const Measurements& meas);

// Recomputes the constants MuJoCo derives from masses at compile time (mj_setConst): after a change
// of body_mass or body_inertia, without which the mass matrix of a "simple" body (e.g. a piston on a
// slide joint) keeps its cached value dof_M0 and the change has no effect. "" or why not.
std::string RefreshMassConstants(mjModel* m);

// Every effect name of effects.md, `none` last.
const std::vector<std::string>& EffectNames();

}  // namespace pneumatic::diagnosis

#endif  // PNEUMATIC_DIAGNOSIS_CANDIDATES_H_
