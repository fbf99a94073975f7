// One pneumatic cylinder bound to the actuators of a compiled mjModel: the
// validated configuration, the actuator ids of its roles, and the pure
// functions of (m, d) that the callbacks return for each role.
#ifndef PNEUMATIC_CYLINDER_H_
#define PNEUMATIC_CYLINDER_H_

#include <optional>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "chamber.h"
#include "chamber_batch.h"
#include "config.h"
#include "pneumatic/pneumatic.h"
#include "roles.h"
#include "valves.h"

namespace pneumatic {

// mju_clip, inlined for the pass: lo below lo, hi above hi, else x (NaN stays NaN)
inline double Clip(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

// what the whole model's pass computes once for every cylinder
struct PassInputs {
  bool zero_commands = false;         // a bad control: MuJoCo zeroes every control this pass
  const mjtNum* end_velocity = nullptr;  // predicted qvel(t + h), nv numbers (null: not needed)
};

// mount=hinge_sites: the length |rod - cap| (m) of a cylinder spanning the sites of c, and its lever
// arm dL/dq (m/rad) about c's hinge, from d's kinematics (site_xpos, xaxis, xanchor)
struct HingeGeometry {
  double length = 0;
  double arm = 0;
};
HingeGeometry HingeSitesGeometry(const mjData* d, const CylinderInfo& c);

class Cylinder {
 public:
  // Binds the configuration to m's actuators named "<name>.<role>", checks
  // their types and transmissions; nullopt with *error on failure. With
  // gains_written (m was attached before), chamber gains may be fixed.
  static std::optional<Cylinder> FromModel(const mjModel* m, CylinderConfig config, bool gains_written,
                                           std::string* error);

  const CylinderConfig& config() const { return config_; }
  const CylinderInfo& info() const { return info_; }
  // (actuator id, role) of every actuator of this cylinder
  const std::vector<std::pair<int, ActuatorRole>>& actuators() const { return actuators_; }
  // true if a step of this cylinder follows the piston's predicted end-of-step velocity (its chambers
  // or its LuGre bristles)
  bool NeedsEndVelocity() const;
  // extra-state slots of the role table (roles.cc): index of each Role::kState row
  // (spool_dead_time: the delay line of command channel ch, states x1, x2, is at slots kDelay + 2 ch + 0, 1 for
  // the 5/3 valve's d1, d2, and kDelayPerChamber + 2 ch + 0, 1 for dP1, dP2, dN1, dN2)
  enum ExtraState {
    kBristle = 0, kTemperatureP = 1, kTemperatureN = 2, kLineP = 3, kLineN = 4, kDelay = 5, kDelayPerChamber = 7,
    kExtraStateCount = 11
  };

  // Advances the chambers and valve states over the step: writes the act_dot of the
  // chamber actuators ((p(t + h) - p(t)) / h with the configured chamber step) and of
  // the valve-state actuators. A cylinder fed by a reservoir gets its pressure at the start
  // of the step (Pa abs), which its supply ports see for the whole step instead of p_supply,
  // and adds the mass its supply ports draw over the step (kg) to *supply_drawn.
  void Step(const mjModel* m, mjData* d, const PassInputs& pass, const double* supply_pressure = nullptr,
            double* supply_drawn = nullptr) const;
  // Step in two halves around LinearizedChambers, for a cylinder whose chambers it takes (Batched(); not
  // fed by a reservoir): BeginStep does what Step does before the chambers' step and fills their inputs;
  // EndStep, after LinearizedChambers ran on them, writes their act_dot, with the adaptive step where the
  // linearized one asked for it. The act_dot written are Step's, bit for bit.
  bool Batched() const { return batched_; }
  void BeginStep(const mjModel* m, mjData* d, const PassInputs& pass, BatchedChamber chambers[2]) const;
  void EndStep(const mjModel* m, mjData* d, const PassInputs& pass, const BatchedChamber chambers[2]) const;
  // largest total volume of the two chambers (m^3): a reservoir feeding the cylinder must exceed it
  double LargestVolume() const;
  // Makes the force of each actuator a fixed gain on its act or ctrl: +A_P, -A_N on
  // the chamber gauge pressures, 0 for valve commands and friction.
  void WriteGains(mjModel* m) const;
  // seal friction (bias of "<cyl>.friction"), on top of the transmission's frictionloss
  double FrictionBias(const mjModel* m, const mjData* d) const;
  // mount=hinge_sites: the gain of chamber 0 (P) or 1 (N), +A_P or -A_N times the lever arm dx/dq, so
  // that MuJoCo's force gain * act is the cylinder's torque on its hinge (the gain callback's value)
  double ChamberGain(const mjData* d, int chamber) const;

 private:
  // FromModel's steps, in its order: each binds one group of the cylinder's actuators and returns "" or
  // the error (cylinder.cc says what each checks)
  std::string BindChambers(const mjModel* m, bool gains_written);
  std::string BindTransmission(const mjModel* m);
  std::string BindValves(const mjModel* m);
  std::string BindFriction(const mjModel* m);
  std::string BindExtraStates(const mjModel* m);
  std::string RefuseOtherActuators(const mjModel* m) const;
  // after the checks: the info, the chambers' models and the path each step takes
  void PrepareSteps();

  ValveInputs ReadValves(const mjModel* m, const mjData* d, bool zero_commands) const;
  // the piston over one step, read once (with mount=hinge_sites, one evaluation of the sites' geometry)
  struct PistonMotion {
    double x = 0;         // position at the step's start (m or rad)
    double velocity = 0;  // dx/dt at the step's start
    double end_rate = 0;  // dx/dt at the predicted end of the step (velocity without a prediction)
  };
  // `end_velocity`: the predicted joint velocities at the step's end, or null
  PistonMotion Motion(const mjModel* m, const mjData* d, const mjtNum* end_velocity) const;
  // the start of every step: reads the valves (*valves) and writes the act_dot of the valve states, the
  // delay lines and the LuGre bristles; the chambers' pressures p0 (Pa abs); returns the piston's motion,
  // and in *x_rate the rate that moves the chambers' volumes over the step
  PistonMotion StartStep(const mjModel* m, mjData* d, const PassInputs& pass, ValveInputs* valves, double p0[2],
                         double* x_rate) const;
  // the chambers' pressures at the start of the step (Pa abs)
  void ReadChamberPressures(const mjModel* m, const mjData* d, double p0[2]) const;
  // the extra-state slot of state x1 (x2: the next) of command channel ch's dead-time delay line
  int DelaySlot(int channel) const;
  // chamber's volume over the step from piston position x, moving at x_rate
  VolumePath Volume(int chamber, double x, double x_rate) const;
  // Step's stages (cylinder.cc): the energy equation's step of both chambers (thermal_model=energy), which
  // writes their act_dot; the physical chambers' rates otherwise, from the lines' step, the linearized,
  // explicit or adaptive chamber steps and the leaks across the piston, and the supply's mass over the step
  void StepEnergy(const mjModel* m, mjData* d, const ChamberModel models[2], const ValveInputs& valves,
                  const PistonMotion& motion, double x_rate, const double p0[2], double* supply_drawn) const;
  void PhysicalRates(const mjModel* m, mjData* d, const ChamberModel models[2], const ValveInputs& valves,
                     const PistonMotion& motion, double x_rate, const double p0[2], double rate[2],
                     double* supply_drawn) const;
  double StepLines(const mjModel* m, mjData* d, const ChamberModel models[2], const PortSchedule ports[2],
                   const VolumePath volume[2], const bool line[2], const double pin[2], bool count_supply,
                   double p1[2], bool done[2]) const;
  void ExplicitRates(const ChamberModel models[2], const PortSchedule ports[2], const VolumePath volume[2],
                     const double p0[2], double rate[2]) const;
  void AddSupplyDrawn(const ChamberModel models[2], const PortSchedule ports[2], const VolumePath volume[2],
                      const bool line[2], double line_drawn, const double p0[2], const double p_start[2],
                      const double p_end[2], double h, double* supply_drawn) const;

  CylinderConfig config_;
  CylinderInfo info_;
  ChamberModel chamber_model_[2];
  int command_id_[4] = {-1, -1, -1, -1};  // ctrl sources, in ValveInputs::command order
  int state_id_[4] = {-1, -1, -1, -1};    // act sources, in ValveInputs::state order
  // true if the chambers' volume path follows the predicted end-of-step velocity
  bool ChambersFollowEndVelocity() const;
  // LuGre (friction_model=lugre): the bristle deflection's mean rate over a step of length h at velocity v,
  // from z (closed form, see cylinder.cc)
  double BristleMeanRate(double z, double v, double h) const;

  static constexpr int kMaxExtraStates = 12;
  int extra_state_id_[kMaxExtraStates] = {-1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1};  // role table rows of Role::kState
  bool has_extra_states_ = false;
  bool batched_ = false;                  // see Batched()
  bool held_voltage_ = false;             // valve per chamber, openings held over a step (BeginStep)
  bool voltages_only_ = false;            // held_voltage_ and nothing else to read or step (BeginStep)
  int dof_ = -1;                          // the joint's dof when the transmission is a slide or hinge joint
  double static_friction_ = 0;            // transmission frictionloss in actuator units
  std::vector<std::pair<int, ActuatorRole>> actuators_;
};

}  // namespace pneumatic

#endif  // PNEUMATIC_CYLINDER_H_
