// Quick start: fill chamber P of rig A from its supply and watch the pressures, the piston and
// the force.
//
// Chamber P is connected to supply (U1) and chamber N to exhaust (U4): paper
// 002's mode M6. Each step the extension advances both chamber pressures
//   dp/dt = n r T Q / V - n p (dV/dt) / V        (paper 002 eq. 1)
// with the ISO 6358 valve flow Q (paper 002 eq. 4), and MuJoCo applies the
// force A (p_P - p_N) to the piston's slide joint.
//
// usage: example_step_rig [models_mjcf/rig_onoff.xml]
#include <cstdio>
#include <string>

#include <mujoco/mujoco.h>

#include "pneumatic/pneumatic.h"

int main(int argc, char** argv) {
  const char* path = argc > 1 ? argv[1] : "models_mjcf/rig_onoff.xml";
  char load_error[1000] = "";
  mjModel* m = mj_loadXML(path, nullptr, load_error, sizeof(load_error));
  if (!m) {
    std::fprintf(stderr, "%s: %s\n", path, load_error);
    return 1;
  }
  std::string error;
  if (!pneumatic::Attach(m, &error)) {
    std::fprintf(stderr, "%s: %s\n", path, error.c_str());
    mj_deleteModel(m);
    return 1;
  }
  mjData* d = mj_makeData(m);
  pneumatic::CylinderInfo cyl = pneumatic::Cylinders(m).at(0);

  // mode M6: U1 (P-supply) and U4 (N-exhaust) open
  for (const auto& [signal, id] : cyl.command_actuators) {
    d->ctrl[id] = (signal == "u1" || signal == "u4") ? 1 : 0;
  }
  std::printf("%8s %12s %12s %10s %9s\n", "t (s)", "p_P (Pa)", "p_N (Pa)", "x (mm)", "F (N)");
  for (int i = 0; d->time < 0.1; ++i) {
    if (i % 40 == 0) {
      mj_forward(m, d);
      // the force on the piston: the two chamber actuators' forces, A_P (p_P - p_atm) - A_N (p_N - p_atm)
      double force = d->actuator_force[cyl.chamber_actuator[0]] + d->actuator_force[cyl.chamber_actuator[1]];
      std::printf("%8.4f %12.1f %12.1f %10.3f %9.2f\n", d->time,
                  pneumatic::ChamberPressure(m, d, cyl, pneumatic::Chamber::kP),
                  pneumatic::ChamberPressure(m, d, cyl, pneumatic::Chamber::kN),
                  1e3 * pneumatic::PistonPosition(m, d, cyl), force);
    }
    mj_step(m, d);
  }
  mj_deleteData(d);
  pneumatic::Detach(m);
  mj_deleteModel(m);
  return 0;
}
