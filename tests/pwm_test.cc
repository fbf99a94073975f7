// Switched PWM against paper 003's averaged model (eq. 14): the piston
// trajectories converge as the carrier frequency rises (paper 003 Fig. 5).
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "test_util.h"

namespace pneumatic {
namespace {

using testing::AttachedModel;
using testing::MujocoTest;

// piston position every 1 ms over 1 s of duty u(t) = 0.3 sin(2 pi 10 t), from mid-stroke with both
// chambers at 2e5 Pa (the open-loop test signal of paper 003 Section 4.2, scaled to rig A)
std::vector<double> Trajectory(double frequency) {
  AttachedModel rig;
  EXPECT_TRUE(rig.Load(testing::RigAOnPwm(frequency))) << rig.error();
  const mjModel* m = rig.m();
  mjData* d = rig.d();
  CylinderInfo cyl = rig.cylinder();
  SetChamberPressure(m, d, cyl, Chamber::kP, 2e5);
  SetChamberPressure(m, d, cyl, Chamber::kN, 2e5);
  std::vector<double> x;
  for (int i = 0; i < 4000; ++i) {
    d->ctrl[0] = 0.3 * std::sin(2 * M_PI * 10 * d->time);
    mj_step(m, d);
    if (i % 4 == 3) x.push_back(d->qpos[0]);
  }
  return x;
}

double MaxDifference(const std::vector<double>& a, const std::vector<double>& b) {
  double worst = 0;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::fabs(a[i] - b[i]));
  return worst;
}

class Pwm : public MujocoTest {};

TEST_F(Pwm, SwitchedModelConvergesToTheAveragedModel) {
  std::vector<double> averaged = Trajectory(0);
  double swing = 0;
  for (double x : averaged) swing = std::max(swing, std::fabs(x));
  ASSERT_GT(swing, 5e-3);   // the piston moves...
  ASSERT_LT(swing, 0.045);  // ...and stays off the end stops
  double at_50 = MaxDifference(Trajectory(50), averaged);
  double at_200 = MaxDifference(Trajectory(200), averaged);
  double at_1000 = MaxDifference(Trajectory(1000), averaged);
  // the switched trajectory differs from the averaged one by an error that shrinks with the carrier
  // period; from 1 kHz on, below 2 % of the swing (paper 003 Fig. 5: about 1 % at 100 Hz on its rig)
  EXPECT_LT(at_200, at_50 / 2);
  EXPECT_LT(at_1000, at_200 / 2);
  EXPECT_LT(at_1000, 0.02 * swing);
  RecordProperty("swing_m", std::to_string(swing));
  RecordProperty("difference_50_200_1000_Hz_m",
                 std::to_string(at_50) + " " + std::to_string(at_200) + " " + std::to_string(at_1000));
}

}  // namespace
}  // namespace pneumatic
