// A cylinder on each kind of mounting: a tendon between two sites across a
// hinge, a slider-crank on a hinge, and a rotary vane cylinder on a hinge.
// With the valves closed, each chamber must follow p V^n = const with V from
// the mounting's geometry, and the limb must settle where the chamber forces
// balance (equal areas: p_P = p_N).
#include <cmath>
#include <functional>
#include <string>

#include <gtest/gtest.h>

#include "test_util.h"

namespace pneumatic {
namespace {

using testing::AttachedModel;
using testing::MujocoTest;

// actuators and configuration of a sealed on/off cylinder on `target` (e.g. tendon="line")
std::string Cylinder(const std::string& target, const std::string& config) {
  std::string actuators;
  for (const char* valve : {"u1", "u2", "u3", "u4"}) {
    actuators += "<general name=\"cyl." + std::string(valve) + "\" " + target + " gaintype=\"user\"/>\n";
  }
  actuators += "<general name=\"cyl.P\" " + target + " dyntype=\"user\" gaintype=\"user\"/>\n";
  actuators += "<general name=\"cyl.N\" " + target + " dyntype=\"user\" gaintype=\"user\"/>\n";
  return "<actuator>" + actuators + "</actuator><custom><text name=\"pneumatic:cyl\" data=\"valve=onoff " +
         config + " p_supply=6e5 p_exhaust=1e5 polytropic_index=1.4\"/></custom>";
}

// a forearm on an elbow hinge about z, no gravity, damping near critical for these cylinders
std::string Arm(const std::string& sites, const std::string& cylinder) {
  return R"(<mujoco><size nuser_actuator="128"/><option timestep="0.0002" gravity="0 0 0"/><worldbody>
    <site name="base" pos="0 -0.1 0"/>
    <body name="forearm"><joint name="elbow" type="hinge" axis="0 0 1" damping="0.5"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="0.5"/>)" +
         sites + "</body></worldbody>" + cylinder + "</mujoco>";
}

class Transmission : public MujocoTest {
 protected:
  // runs 3 s sealed from p_P = 2e5, p_N = 1e5; returns the worst relative drift of p V^1.4 with the
  // chamber volumes computed by `volume(m, d, chamber)` from the geometry
  double RunSealed(const std::string& xml, const std::function<double(const mjModel*, const mjData*, int)>& volume) {
    AttachedModel arm;
    EXPECT_TRUE(arm.Load(xml)) << arm.error();
    if (!arm.m()) return 1;
    const mjModel* m = arm.m();
    mjData* d = arm.d();
    CylinderInfo cyl = arm.cylinder();
    SetChamberPressure(m, d, cyl, Chamber::kP, 2e5);
    SetChamberPressure(m, d, cyl, Chamber::kN, 1e5);
    mj_forward(m, d);
    double invariant[2], worst = 0;
    for (int k = 0; k < 2; ++k) {
      invariant[k] = ChamberPressure(m, d, cyl, static_cast<Chamber>(k)) * std::pow(volume(m, d, k), 1.4);
    }
    double start = d->qpos[0];
    while (d->time < 3) {
      mj_step(m, d);
      mj_forward(m, d);
      for (int k = 0; k < 2; ++k) {
        double now = ChamberPressure(m, d, cyl, static_cast<Chamber>(k)) * std::pow(volume(m, d, k), 1.4);
        worst = std::max(worst, std::fabs(now / invariant[k] - 1));
      }
    }
    // the higher pressure in P extends the cylinder: the limb moved, and settled where p_P = p_N
    EXPECT_GT(std::fabs(d->qpos[0] - start), 0.05);
    EXPECT_NEAR(ChamberPressure(m, d, cyl, Chamber::kP), ChamberPressure(m, d, cyl, Chamber::kN), 10.0);
    EXPECT_LT(std::fabs(d->qvel[0]), 1e-3);
    return worst;
  }
};

constexpr double kArea = 2e-4, kStroke = 0.1, kDead = 2e-6;

// volume of chamber k at piston position x (m): P grows with x
double Volume(int k, double x) { return kArea * (kStroke / 2 + (k == 0 ? x : -x)) + kDead; }

TEST_F(Transmission, TendonBetweenTwoSitesFollowsTheSiteDistance) {
  // the cylinder spans from a site below the elbow to one on the forearm; x is the distance
  // between them minus its value at mid-stroke (elbow at 0: |(0.1, 0.1)| = 0.1414214 m)
  const double mid = std::hypot(0.1, 0.1);
  std::string xml = Arm(R"(<site name="insertion" pos="0.1 0 0"/>)",
                        R"(<tendon><spatial name="line"><site site="base"/><site site="insertion"/></spatial></tendon>)" +
                            Cylinder(R"(tendon="line")", "stroke=0.1 area=2e-4 dead_volume=2e-6 x_mid=" + std::to_string(mid)));
  auto geometric = [&](const mjModel* m, const mjData* d, int k) {
    const double* a = d->site_xpos + 3 * mj_name2id(m, mjOBJ_SITE, "base");
    const double* b = d->site_xpos + 3 * mj_name2id(m, mjOBJ_SITE, "insertion");
    return Volume(k, mju_dist3(a, b) - mid);
  };
  EXPECT_LT(RunSealed(xml, geometric), 1e-3);
}

TEST_F(Transmission, RotaryVaneOnAHingeFollowsTheAngle) {
  // a vane cylinder: "area" is its displacement per radian (m^3/rad), x the joint angle
  std::string xml = Arm("", Cylinder(R"(joint="elbow")", "stroke=2 area=1e-5 dead_volume=1e-6"));
  auto angular = [](const mjModel*, const mjData* d, int k) {
    return 1e-5 * (1.0 + (k == 0 ? d->qpos[0] : -d->qpos[0])) + 1e-6;
  };
  EXPECT_LT(RunSealed(xml, angular), 1e-3);
}

TEST_F(Transmission, SliderCrankFollowsTheSliderPosition) {
  // a slider-crank: the cylinder's rod pushes a crank pin on the forearm; MuJoCo's slider-crank
  // length is the slider position, from the crank pin's distance to the slider site along its axis
  std::string xml = Arm(R"(<site name="crank" pos="0 0.1 0"/>)",
                        Cylinder(R"(cranksite="crank" slidersite="slider" cranklength="0.25")",
                                 "stroke=0.1 area=2e-4 dead_volume=2e-6 x_mid=0.0"));
  // the slider site sits on the upper arm, its z axis along the cylinder, level with the crank pin
  xml.replace(xml.find(R"(<site name="base")"), 0, R"(<site name="slider" pos="-0.25 0.1 0" zaxis="1 0 0"/>)");
  AttachedModel probe;
  ASSERT_TRUE(probe.Load(xml)) << probe.error();
  mj_forward(probe.m(), probe.d());
  double mid = probe.d()->actuator_length[probe.actuator("cyl.P")];
  xml.replace(xml.find("x_mid=0.0"), 9, "x_mid=" + std::to_string(mid));
  // geometry by hand: slider at s, axis e; crank pin c; rod length r: length = e.(c-s) - sqrt((e.(c-s))^2 + r^2 - |c-s|^2)
  auto geometric = [mid](const mjModel* m, const mjData* d, int k) {
    const double* s = d->site_xpos + 3 * mj_name2id(m, mjOBJ_SITE, "slider");
    const double* c = d->site_xpos + 3 * mj_name2id(m, mjOBJ_SITE, "crank");
    const double* mat = d->site_xmat + 9 * mj_name2id(m, mjOBJ_SITE, "slider");
    double e[3] = {mat[2], mat[5], mat[8]}, v[3];
    mju_sub3(v, c, s);
    double along = mju_dot3(e, v);
    double length = along - std::sqrt(along * along + 0.25 * 0.25 - mju_dot3(v, v));
    return Volume(k, length - mid);
  };
  EXPECT_LT(RunSealed(xml, geometric), 1e-3);
}

}  // namespace
}  // namespace pneumatic
