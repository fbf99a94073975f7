// A supply reservoir: a model-level state shared by the cylinders it feeds.
//
// MJCF: <text name="pneumatic_reservoir:<name>" data="volume=... line_conductance=..."/>, one
// actuator "<name>.pressure" (dyntype="user", no force) whose act is the reservoir pressure
// minus the compressor pressure, and supply=<name> in each cylinder it feeds. The compressor
// behind the reservoir is the fed cylinders' p_supply (and their gas, temperature and
// gas_constant: one reservoir holds one gas, so they must agree); it fills the reservoir through
// a line restriction (ISO 6358, the law of paper 002 eq. 4 in flow.h). The valves' supply ports
// see the reservoir's pressure instead of p_supply.
#ifndef PNEUMATIC_RESERVOIR_H_
#define PNEUMATIC_RESERVOIR_H_

#include <optional>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "flow.h"
#include "pneumatic/pneumatic.h"

namespace pneumatic {

struct ReservoirConfig {
  std::string name;
  double volume = 0;               // m^3
  double line_conductance = 0;     // kg/(s Pa): sonic conductance C rho0 of the line from the compressor; 0 = sealed
  double line_critical_ratio = 0;  // b of the line's ISO 6358 law
};

// "key=value ..." of "pneumatic_reservoir:<name>", checked against the reservoir table
// (ReservoirParameters()); nullopt and *error ("reservoir 'tank': key 'volume': ...") on failure
std::optional<ReservoirConfig> ParseReservoirConfig(const std::string& name, const std::string& text,
                                                    std::string* error);
std::string FormatReservoirConfig(const ReservoirConfig& c);
// as numbers, one per table row, for the model's storage; back through the parser
int PackedReservoirSize();
void PackReservoirConfig(const ReservoirConfig& c, double* out);
std::optional<ReservoirConfig> UnpackReservoirConfig(const std::string& name, const double* values, std::string* error);

// the suffix of the reservoir's state actuator: "<name>.pressure"
extern const char kReservoirStateRole[];

// what a step needs, fixed when the reservoir is linked to its cylinders
struct ReservoirModel {
  double p_source = 0;  // Pa abs: the compressor, the fed cylinders' p_supply
  double gas_rt = 0;    // r T of the fed cylinders' gas, J/kg
  double volume = 0;    // m^3
  double line_conductance = 0;
  FlowLawConstants line;  // ISO 6358 with the line's critical ratio
};

// A reservoir bound to its actuator in a compiled model.
struct BoundReservoir {
  ReservoirConfig config;
  int actuator = -1;  // "<name>.pressure": act = p - p_source
  ReservoirModel model;  // set by the engine when it links the cylinders
  std::vector<int> cylinders;  // indices of the cylinders it feeds, in the model's order
};

// checks "<name>.pressure" in m (a state role of the role table); nullopt and *error on failure
std::optional<BoundReservoir> BindReservoir(const mjModel* m, ReservoirConfig config, std::string* error);

// The reservoir's pressure (Pa abs) at the end of a step of length h from p0, while the chambers
// it feeds draw `drawn` kg through their supply ports over the step (evenly: a constant draw
// D = drawn / h). Mass balance of an isothermal reservoir, p V = m r T:
//   dp/dt = (r T / V) (Q_line(p) - D),  Q_line = ISO 6358 from p_source to p (signed)
// The line flow is linearized at p0 (its slope; the chord to p_source where the pressure is
// closer to it than the step moves it, where the law's slope is unbounded) and the linear ODE
// solved exactly: p0 + h phi1(-k G h) k (Q_line(p0) - D), k = r T / V (exponential
// Rosenbrock-Euler, as the chamber step; exact while the line is choked, Q = C p_source).
double ReservoirPressureStep(const ReservoirModel& r, double p0, double drawn, double h);

}  // namespace pneumatic

#endif  // PNEUMATIC_RESERVOIR_H_
