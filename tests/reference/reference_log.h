// A reference simulation of docs/rigs.md written as a log of docs/log_format.md, so it
// can be replayed through a model exactly as a real robot's log would be.
#ifndef PNEUMATIC_TESTS_REFERENCE_LOG_H_
#define PNEUMATIC_TESTS_REFERENCE_LOG_H_

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "formats/log_csv.h"
#include "rig_reference.h"

namespace pneumatic::reference {

// the shipped model of each rig
inline const char* RigModelFile(Rig rig) {
  switch (rig) {
    case Rig::kOnOff: return "rig_onoff.xml";
    case Rig::kProportional: return "rig_proportional.xml";
    case Rig::kPerChamber: return "rig_per_chamber.xml";
  }
  return "";
}

// samples of Simulate() as a log of cylinder "cyl": the rig's commands, then p_P, p_N, x, v
// the rig's commands by log signal (docs/log_format.md): u1..u4 on rig A, u on B, uP and uN on C
inline std::vector<std::pair<std::string, double>> NamedCommands(Rig rig, const RigCommand& c) {
  switch (rig) {
    case Rig::kOnOff: return {{"u1", c.u1}, {"u2", c.u2}, {"u3", c.u3}, {"u4", c.u4}};
    case Rig::kProportional: return {{"u", c.u}};
    case Rig::kPerChamber: return {{"uP", c.uP}, {"uN", c.uN}};
  }
  return {};
}

inline log::Log ToLog(Rig rig, const std::vector<Sample>& samples) {
  log::Log out;
  out.comments.push_back(std::string("reference: docs/rigs.md, fine-step RK4; rig: models_mjcf/") + RigModelFile(rig));
  for (const auto& [signal, value] : NamedCommands(rig, RigCommand{})) out.columns.push_back({"cyl", signal});
  for (const char* m : {"p_P", "p_N", "x", "v"}) out.columns.push_back({"cyl", m});
  out.values.assign(out.columns.size(), {});
  for (const Sample& s : samples) {
    out.time.push_back(s.time);
    std::vector<double> row;
    for (const auto& [signal, value] : NamedCommands(rig, s.command)) row.push_back(value);
    for (double v : {s.state.p_P, s.state.p_N, s.state.x, s.state.v}) row.push_back(v);
    for (size_t i = 0; i < row.size(); ++i) out.values[i].push_back(row[i]);
  }
  return out;
}

// a position reference for cylinder "cyl" (log signal "ref", every 10 ms): a multi-sine of 4 components
// at 0.2-1.2 Hz with random phases (drawn from `seed`), at 60 % of the half stroke, faded in over the
// first second; what bench_diagnose's closed-loop logs follow, and the diagnosis tests that match them
inline log::Log MultiSinePositionReference(std::uint64_t seed, double duration, double stroke) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> frequency(0.2, 1.2), phase(0, 2 * M_PI);
  double f[4], ph[4];
  for (int i = 0; i < 4; ++i) f[i] = frequency(random), ph[i] = phase(random);
  log::Log ref;
  ref.columns = {{"cyl", "ref"}};
  ref.values.assign(1, {});
  for (double t = 0; t <= duration + 1e-9; t += 0.01) {
    double s = 0;
    for (int i = 0; i < 4; ++i) s += std::sin(2 * M_PI * f[i] * t + ph[i]) / 4;
    const double fade = t < 1 ? std::sin(M_PI * t / 2) * std::sin(M_PI * t / 2) : 1;
    ref.time.push_back(t);
    ref.values[0].push_back(0.6 * 0.5 * stroke * fade * s * 2);
  }
  return ref;
}

}  // namespace pneumatic::reference

#endif  // PNEUMATIC_TESTS_REFERENCE_LOG_H_
