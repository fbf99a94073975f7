// Seal friction of rig_proportional_full.xml (paper 001: 40 N static, 20 N
// Coulomb) and the identified pressure model of paper 000 inside MuJoCo.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "test_util.h"

namespace pneumatic {
namespace {

using testing::AttachedModel;
using testing::MujocoTest;
using testing::ShippedModel;

class SealFriction : public MujocoTest {
 protected:
  void SetUp() override {
    MujocoTest::SetUp();
    ASSERT_TRUE(rig_.Load(ShippedModel("rig_proportional_full.xml"), true)) << rig_.error();
  }
  AttachedModel rig_;
};

TEST_F(SealFriction, HoldsThePistonBelowTheStaticLevel) {
  // 30 N pushing on the rod, below the 40 N breakaway: over 0.5 s the piston only creeps as the
  // rig's stiff friction constraint allows, (R/A) a / b = 0.0101 * 15.7 m/s^2 / 1001 /s = 0.16 mm/s
  mjData* d = rig_.d();
  d->qfrc_applied[0] = 30;
  while (d->time < 0.5) mj_step(rig_.m(), d);
  EXPECT_LT(std::fabs(d->qpos[0]), 1e-4);
}

TEST_F(SealFriction, SlidingFrictionIsTheCoulombLevel) {
  // sliding at 0.5 m/s: the frictionloss constraint gives the 40 N static level against the motion,
  // cyl.friction gives back (40 - 20) tanh(0.5 / 0.01) = 20 N: 20 N in all
  const mjModel* m = rig_.m();
  mjData* d = rig_.d();
  d->qvel[0] = 0.5;
  mj_forward(m, d);
  double seal = d->qfrc_constraint[0] + d->actuator_force[rig_.actuator("cyl.friction")];
  EXPECT_NEAR(seal, -20.0, 0.5);
  d->qvel[0] = -0.5;
  mj_forward(m, d);
  EXPECT_NEAR(d->qfrc_constraint[0] + d->actuator_force[rig_.actuator("cyl.friction")], 20.0, 0.5);
}

TEST_F(SealFriction, BreaksAwayAboveTheStaticLevel) {
  // 60 N on the rod moves the piston; sealed chambers then push back as it moves
  mjData* d = rig_.d();
  d->qfrc_applied[0] = 60;
  while (d->time < 0.05) mj_step(rig_.m(), d);
  EXPECT_GT(d->qpos[0], 1e-4);
}

class IdentifiedInMujoco : public MujocoTest {};

TEST_F(IdentifiedInMujoco, ChamberFollowsTheExactStepOfEq7) {
  // at u = 6 V: u_hat = 1, s = c_b + c_s g(1.7) with c_b = 3.6e5, c_s = 2.6e5, g(y) = y / sqrt(y^2 + 1);
  // r = c7 (sqrt(1 + 0.01) - 0.1 + c9 + c8) = 40 * 1.0549876; p(t) = s + (p0 - s) e^(-r t) at every step
  AttachedModel rig;
  ASSERT_TRUE(rig.Load(testing::IdentifiedRig())) << rig.error();
  const mjModel* m = rig.m();
  mjData* d = rig.d();
  CylinderInfo cyl = rig.cylinder();
  d->ctrl[rig.actuator("cyl.uP")] = 6;
  d->ctrl[rig.actuator("cyl.uN")] = 6;
  const double s = 3.6e5 + 2.6e5 * 1.7 / std::sqrt(1.7 * 1.7 + 1);
  const double r = 40 * (std::sqrt(1.01) - 0.1 + 0.05 + 0.1);
  for (int i = 1; i <= 100; ++i) {
    mj_step(m, d);
    double expected = s + (1e5 - s) * std::exp(-r * i * 1e-3);
    ASSERT_NEAR(ChamberPressure(m, d, cyl, Chamber::kP), expected, 1e-6 * s) << "step " << i;
  }
}

}  // namespace
}  // namespace pneumatic
