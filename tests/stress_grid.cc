// The stress grid: every valve arrangement with every flow law it takes, over timesteps, dead
// volumes, supply pressures and command patterns, each run long enough to reach the stroke's ends
// (and, on the rig with seal friction, to stick). Every step checks that mjData holds no NaN or Inf,
// that MuJoCo did not reset an unstable simulation (mjWARN_BADQACC), and that every chamber pressure
// is positive (its gas mass p V / (r T) never negative) and inside the range the chamber can reach:
// from the lowest of p_exhaust and p_atm expanded polytropically from the dead volume to the largest
// volume, to p_supply compressed from the largest volume to the dead volume, with the largest index
// the configuration allows (1.7; the project's own bound, physics' not the step's).
//
//   build/bin/stress_grid            the full grid (about 4000 runs of 2 s; figures in the README)
//   build/bin/stress_grid --small    the grid ctest runs (256 runs of 0.3 s)
//
// Prints one line per arrangement and law (runs, steps, failures) and the first failures; exits 1 if
// any run failed. Configurations a valve does not take (Attach refuses them) are listed as such.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <regex>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "pneumatic/pneumatic.h"
#include "test_util.h"

namespace {

using pneumatic::Chamber;
using pneumatic::CylinderInfo;

struct Arrangement {
  const char* rig;   // a shipped model
  const char* law;   // its flow law, and the keys that law needs
  const char* keys;
};

// each valve arrangement of the shipped rigs with each flow law (port_area and critical_ratio values
// are the rigs' own or of the same size)
const Arrangement kArrangements[] = {
    {"rig_onoff.xml", "iso6358", "flow=iso6358 sonic_conductance=3.4e-9 critical_ratio=0.433"},
    {"rig_onoff.xml", "sanville", "flow=sanville port_area=2e-6 discharge_coefficient=0.7 critical_ratio=0.3"},
    {"rig_onoff.xml", "thin_plate", "flow=thin_plate port_area=2e-6 discharge_coefficient=0.72"},
    {"rig_proportional.xml", "iso6358", "flow=iso6358 sonic_conductance=3.4e-9 critical_ratio=0.433"},
    {"rig_proportional.xml", "sanville", "flow=sanville discharge_coefficient=0.7 critical_ratio=0.2"},
    {"rig_proportional.xml", "thin_plate", "flow=thin_plate discharge_coefficient=0.7"},
    {"rig_proportional_full.xml", "sanville", "flow=sanville discharge_coefficient=0.7 critical_ratio=0.2"},
    {"rig_per_chamber.xml", "iso6358", "flow=iso6358 sonic_conductance=3.4e-9 critical_ratio=0.433"},
    {"rig_per_chamber.xml", "sanville", "flow=sanville discharge_coefficient=0.72 critical_ratio=0.2"},
    {"rig_per_chamber.xml", "thin_plate", "flow=thin_plate discharge_coefficient=0.72 compressibility=0.99"},
};

enum class Pattern { kConstant, kBangBang, kRandom, kSaturating };
const char* Name(Pattern p) {
  switch (p) {
    case Pattern::kConstant: return "constant";
    case Pattern::kBangBang: return "bang-bang";
    case Pattern::kRandom: return "random";
    case Pattern::kSaturating: return "saturating";
  }
  return "?";
}

// the rig's MJCF with its flow-law keys (and the gas keys only some laws take) replaced by `keys`
std::string WithLaw(const std::string& xml, const std::string& keys) {
  const size_t data = xml.find("data=\"", xml.find("name=\"pneumatic:cyl\"")) + 6;
  const size_t end = xml.find('"', data);
  std::string text = xml.substr(data, end - data);
  text = std::regex_replace(
      text, std::regex("\\b(flow|sonic_conductance|critical_ratio|discharge_coefficient|port_area|heat_capacity_ratio|"
                 "compressibility)=[^ \\n\\t]*"), "");
  return xml.substr(0, data) + text + " " + keys + xml.substr(end);
}

// the command range of actuator id: its ctrlrange, or [0, 1] for an on/off valve's unlimited command
void Range(const mjModel* m, int id, double* lo, double* hi) {
  *lo = 0, *hi = 1;
  if (m->actuator_ctrllimited[id]) *lo = m->actuator_ctrlrange[2 * id], *hi = m->actuator_ctrlrange[2 * id + 1];
}

void Command(const mjModel* m, mjData* d, const CylinderInfo& c, Pattern pattern, int step, std::mt19937* random) {
  const bool phase = static_cast<long>(step * m->opt.timestep / 0.05) % 2 == 0;  // 50 ms one way, 50 ms the other
  for (const auto& [signal, id] : c.command_actuators) {
    double lo, hi;
    Range(m, id, &lo, &hi);
    double u = 0;
    switch (pattern) {
      case Pattern::kConstant: u = lo + 0.6 * (hi - lo); break;
      case Pattern::kBangBang: u = step % 2 ? hi : lo; break;  // switching at the step rate
      case Pattern::kRandom: u = std::uniform_real_distribution<double>(lo, hi)(*random); break;
      case Pattern::kSaturating: u = phase ? hi + 10 * (hi - lo) : lo - 10 * (hi - lo); break;
    }
    // on/off valves: the opposite pair of the push (u1, u4) is the pull (u2, u3)
    if ((signal == "u2" || signal == "u3") && pattern != Pattern::kRandom) u = hi + lo - u;
    d->ctrl[id] = u;
  }
}

struct Bounds {
  double lo[2], hi[2];  // Pa abs, by chamber
};

Bounds Reachable(const mjModel* m, const CylinderInfo& c) {
  std::string error;
  auto get = [&](const std::string& key) { return pneumatic::GetParameter(m, c.name, key, &error).value_or(NAN); };
  constexpr double kLargestIndex = 1.7;  // the range of polytropic_index and heat_capacity_ratio
  const double stroke = get("stroke");
  const double floor_pressure = std::min(c.p_exhaust, c.p_atm);
  Bounds b;
  for (int k = 0; k < 2; ++k) {
    const std::string prefix = k == 0 ? "P." : "N.";
    const double dead = get(prefix + "dead_volume"), largest = dead + get(prefix + "area") * stroke;
    const double ratio = std::pow(largest / dead, kLargestIndex);
    b.lo[k] = floor_pressure / ratio;
    b.hi[k] = c.p_supply * ratio;
  }
  return b;
}

// what is wrong with d after a step, or ""
std::string Problem(const mjModel* m, const mjData* d, const CylinderInfo& c, const Bounds& b) {
  auto finite = [](const mjtNum* x, int n) {
    for (int i = 0; i < n; ++i) {
      if (!std::isfinite(x[i])) return false;
    }
    return true;
  };
  if (!finite(d->qpos, m->nq) || !finite(d->qvel, m->nv) || !finite(d->act, m->na) || !finite(d->qacc, m->nv) ||
      !finite(d->act_dot, m->na) || !finite(d->actuator_force, m->nu)) {
    return "a NaN or Inf in mjData";
  }
  if (d->warning[mjWARN_BADQACC].number > 0) return "MuJoCo reset an unstable simulation (bad qacc)";
  for (int k = 0; k < 2; ++k) {
    const double p = pneumatic::ChamberPressure(m, d, c, k == 0 ? Chamber::kP : Chamber::kN);
    if (!(p > 0) || p < b.lo[k] || p > b.hi[k]) {
      char text[200];
      std::snprintf(text, sizeof(text), "chamber %s at %.6g Pa, outside [%.6g, %.6g]", k == 0 ? "P" : "N", p,
                    b.lo[k], b.hi[k]);
      return text;
    }
  }
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  const bool small = argc > 1 && std::strcmp(argv[1], "--small") == 0;
  const std::vector<double> timesteps = small ? std::vector<double>{1e-4, 1e-2}
                                              : std::vector<double>{1e-4, 3e-4, 1e-3, 3e-3, 1e-2};
  const std::vector<double> dead_volumes = small ? std::vector<double>{1e-8, 1e-4}
                                                 : std::vector<double>{1e-8, 1e-7, 1e-6, 1e-5, 1e-4};
  const std::vector<double> supplies = small ? std::vector<double>{2e5, 1e6}
                                             : std::vector<double>{2e5, 4e5, 6e5, 8e5, 1e6};
  const Pattern patterns[] = {Pattern::kConstant, Pattern::kBangBang, Pattern::kRandom, Pattern::kSaturating};
  const double duration = small ? 0.3 : 2.0;  // s of simulated time per run
  mju_user_warning = [](const char*) {};      // counted in d->warning; checked per step

  std::printf("stress grid (%s): timesteps %zu, dead volumes %zu, supplies %zu, 4 command patterns, %.1f s a run\n\n",
              small ? "small" : "full", timesteps.size(), dead_volumes.size(), supplies.size(), duration);
  std::printf("| valve arrangement (rig) | flow law | runs | steps | failed |\n|---|---|---:|---:|---:|\n");
  int total_runs = 0, total_failed = 0;
  long long total_steps = 0;
  std::vector<std::string> failures;
  for (const Arrangement& a : kArrangements) {
    const std::string xml = WithLaw(pneumatic::testing::ReadText(pneumatic::testing::ShippedModel(a.rig)), a.keys);
    std::string error;
    mjModel* base = pneumatic::testing::LoadModelFromString(xml, &error);
    if (!base || !pneumatic::Attach(base, &error)) {
      std::printf("| %s | %s | not taken: %s | | |\n", a.rig, a.law, error.c_str());
      if (base) mj_deleteModel(base);
      continue;
    }
    int runs = 0, failed = 0;
    long long steps = 0;
    for (double h : timesteps) {
      for (double dead : dead_volumes) {
        for (double supply : supplies) {
          for (Pattern pattern : patterns) {
            mjModel* m = mj_copyModel(nullptr, base);
            m->opt.timestep = h;
            std::string why;
            if (!pneumatic::SetParameter(m, "cyl", "dead_volume", dead, &why) ||
                !pneumatic::SetParameter(m, "cyl", "p_supply", supply, &why)) {
              failures.push_back(std::string(a.rig) + " " + a.law + ": " + why);
              ++failed, ++runs;
              mj_deleteModel(m);
              continue;
            }
            const CylinderInfo c = pneumatic::Cylinders(m).at(0);
            const Bounds bounds = Reachable(m, c);
            mjData* d = mj_makeData(m);
            std::mt19937 random(12345);
            const int n = static_cast<int>(std::lround(duration / h));
            std::string problem;
            int step = 0;
            for (; step < n && problem.empty(); ++step) {
              Command(m, d, c, pattern, step, &random);
              mj_step(m, d);
              problem = Problem(m, d, c, bounds);
            }
            steps += step;
            ++runs;
            if (!problem.empty()) {
              ++failed;
              char where[300];
              std::snprintf(where, sizeof(where), "%s %s h=%g dead_volume=%g p_supply=%g %s, step %d (t=%.4g s): ",
                            a.rig, a.law, h, dead, supply, Name(pattern), step, d->time);
              failures.push_back(where + problem);
            }
            mj_deleteData(d);
            mj_deleteModel(m);
          }
        }
      }
    }
    std::printf("| %s | %s | %d | %lld | %d |\n", a.rig, a.law, runs, steps, failed);
    total_runs += runs, total_steps += steps, total_failed += failed;
    mj_deleteModel(base);
  }
  std::printf("\n%d runs, %lld steps, %d failed\n", total_runs, total_steps, total_failed);
  for (size_t i = 0; i < failures.size() && i < 20; ++i) std::printf("  %s\n", failures[i].c_str());
  if (failures.size() > 20) std::printf("  ... and %zu more\n", failures.size() - 20);
  return total_failed == 0 ? 0 : 1;
}
