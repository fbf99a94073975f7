// A cylinder on each kind of mounting: a tendon between two sites across a
// hinge, the same two sites with mount=hinge_sites (the extension's own
// geometry, no MuJoCo tendon), a slider-crank on a hinge, and a rotary vane
// cylinder on a hinge.
// With the valves closed, each chamber must follow p V^n = const with V from
// the mounting's geometry, and the limb must settle where the chamber forces
// balance (equal areas: p_P = p_N).
#include <cmath>
#include <functional>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

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


// ---------------------------------------------------------------------------------------------
// mount=hinge_sites: the cylinder of TendonBetweenTwoSitesFollowsTheSiteDistance, its sites named
// cyl.cap (on the world, the parent of the forearm) and cyl.rod (on the forearm), no tendon

const double kMid = std::hypot(0.1, 0.1);  // |rod - cap| with the elbow at 0
const char* const kMidText = "0.14142135623730951";  // kMid, to the last bit

std::string HingeSitesArm(const std::string& config = "") {
  std::string xml = Arm(R"(<site name="cyl.rod" pos="0.1 0 0"/>)",
                        Cylinder(R"(joint="elbow")", "mount=hinge_sites stroke=0.1 area=2e-4 dead_volume=2e-6 x_mid=" +
                                                         std::string(kMidText) + " " + config));
  return testing::ReplaceAll(xml, R"(<site name="base")", R"(<site name="cyl.cap")");
}

// the same cylinder on a spatial tendon over the same two sites
std::string TendonArm() {
  std::string xml = Arm(R"(<site name="cyl.rod" pos="0.1 0 0"/>)",
                        R"(<tendon><spatial name="line"><site site="cyl.cap"/><site site="cyl.rod"/></spatial>)"
                        R"(</tendon>)" +
                            Cylinder(R"(tendon="line")",
                                     "stroke=0.1 area=2e-4 dead_volume=2e-6 x_mid=" + std::string(kMidText)));
  return testing::ReplaceAll(xml, R"(<site name="base")", R"(<site name="cyl.cap")");
}

TEST_F(Transmission, HingeSitesFollowTheSiteDistance) {
  auto geometric = [&](const mjModel* m, const mjData* d, int k) {
    const double* a = d->site_xpos + 3 * mj_name2id(m, mjOBJ_SITE, "cyl.cap");
    const double* b = d->site_xpos + 3 * mj_name2id(m, mjOBJ_SITE, "cyl.rod");
    return Volume(k, mju_dist3(a, b) - kMid);
  };
  EXPECT_LT(RunSealed(HingeSitesArm(), geometric), 1e-3);
}

TEST_F(Transmission, HingeSitesGiveTheLengthLeverArmAndTorqueWorkedOutByHand) {
  // cap (0, -0.1, 0) on the world, rod 0.1 m out on the forearm at elbow angle q, rod at
  // (0.1 cos q, 0.1 sin q, 0): L^2 = 0.02 (1 + sin q), dL/dq = 0.01 cos q / L
  ASSERT_EQ(std::stod(kMidText), kMid);
  AttachedModel arm;
  ASSERT_TRUE(arm.Load(HingeSitesArm())) << arm.error();
  const mjModel* m = arm.m();
  mjData* d = arm.d();
  const CylinderInfo cyl = arm.cylinder();
  EXPECT_EQ(cyl.cap_site, mj_name2id(m, mjOBJ_SITE, "cyl.cap"));
  EXPECT_EQ(cyl.rod_site, mj_name2id(m, mjOBJ_SITE, "cyl.rod"));
  EXPECT_EQ(cyl.hinge, mj_name2id(m, mjOBJ_JOINT, "elbow"));
  EXPECT_EQ(DrivenJoint(m, cyl), -1) << "x is not proportional to the elbow angle";
  const double q = 0.3, qdot = -0.7;
  d->qpos[0] = q, d->qvel[0] = qdot;
  SetChamberPressure(m, d, cyl, Chamber::kP, 3e5);
  SetChamberPressure(m, d, cyl, Chamber::kN, 1.5e5);
  mj_forward(m, d);
  const double length = 0.1 * std::sqrt(2 * (1 + std::sin(q)));
  const double lever = 0.01 * std::cos(q) / length;
  EXPECT_NEAR(PistonPosition(m, d, cyl), length - kMid, 1e-15);
  EXPECT_NEAR(PistonVelocity(m, d, cyl), lever * qdot, 1e-15);
  std::vector<mjtNum> jacobian(m->nv);
  PistonJacobian(m, d, cyl, jacobian.data());
  EXPECT_NEAR(jacobian[0], lever, 1e-15);
  // the chambers push with A (p_P - p_N) = 2e-4 * 1.5e5 = 30 N along the cylinder: 30 N * dL/dq on the elbow
  EXPECT_NEAR(d->qfrc_actuator[0], 30 * lever, 1e-12);
  EXPECT_NEAR(d->actuator_force[arm.actuator("cyl.P")], 2e-4 * (3e5 - cyl.p_atm) * lever, 1e-12);
  EXPECT_NEAR(d->actuator_force[arm.actuator("cyl.N")], -2e-4 * (1.5e5 - cyl.p_atm) * lever, 1e-12);
}

TEST_F(Transmission, HingeAngleAtSolvesTheSiteDistanceForTheAngle) {
  // L^2 = 0.02 (1 + sin q) (above): from the elbow at 0, the x of q = 0.3 gives back 0.3 and dL/dq there.
  // The other root, pi - 0.3, is the farther turn
  AttachedModel arm;
  ASSERT_TRUE(arm.Load(HingeSitesArm())) << arm.error();
  const mjModel* m = arm.m();
  mjData* d = arm.d();
  const CylinderInfo cyl = arm.cylinder();
  const double q = 0.3, length = 0.1 * std::sqrt(2 * (1 + std::sin(q)));
  mj_kinematics(m, d);
  double lever = 0;
  std::string error;
  std::optional<double> angle = HingeAngleAt(m, d, cyl, length - kMid, &lever, &error);
  ASSERT_TRUE(angle) << error;
  EXPECT_NEAR(*angle, q, 1e-14);
  EXPECT_NEAR(lever, 0.01 * std::cos(q) / length, 1e-14);
  // from the elbow at 2.5 rad the nearer root is pi - 0.3
  d->qpos[0] = 2.5;
  mj_kinematics(m, d);
  angle = HingeAngleAt(m, d, cyl, length - kMid, &lever, &error);
  ASSERT_TRUE(angle) << error;
  EXPECT_NEAR(*angle, mjPI - q, 1e-14);
  EXPECT_NEAR(lever, -0.01 * std::cos(q) / length, 1e-14);
  // no angle puts the sites 0.3 m apart (at most 0.2 m), nor is a cylinder on its joint solved
  EXPECT_FALSE(HingeAngleAt(m, d, cyl, 0.3 - kMid, &lever, &error));
  EXPECT_NE(error.find("no angle of hinge 'elbow'"), std::string::npos) << error;
  AttachedModel vane;
  ASSERT_TRUE(vane.Load(Arm("", Cylinder(R"(joint="elbow")", "stroke=2 area=1e-5 dead_volume=1e-6")))) << vane.error();
  EXPECT_FALSE(HingeAngleAt(vane.m(), vane.d(), vane.cylinder(), 0.1, &lever, &error));
  EXPECT_NE(error.find("not mounted between sites"), std::string::npos) << error;
}

// runs the valve pattern of test_util.h for `steps` steps and returns (qpos, qvel, p_P, p_N) after each
std::vector<double> PatternRun(const std::string& xml, int steps) {
  AttachedModel arm;
  EXPECT_TRUE(arm.Load(xml)) << arm.error();
  if (!arm.m()) return {};
  std::vector<double> out;
  const CylinderInfo cyl = arm.cylinder();
  for (int i = 0; i < steps; ++i) {
    testing::PatternCommand(cyl, arm.d(), i);
    mj_step(arm.m(), arm.d());
    out.insert(out.end(), {arm.d()->qpos[0], arm.d()->qvel[0], ChamberPressure(arm.m(), arm.d(), cyl, Chamber::kP),
                           ChamberPressure(arm.m(), arm.d(), cyl, Chamber::kN)});
  }
  return out;
}

TEST_F(Transmission, HingeSitesStepLikeATendonOverTheSameSites) {
  // the same physics as MuJoCo's spatial tendon, to round-off (measured 1.8e-14): 1 s of switching valves (the arm
  // swings through about 1.3 rad; the sites' geometry is the tendon's, computed another way)
  const std::vector<double> tendon = PatternRun(TendonArm(), 5000);
  const std::vector<double> sites = PatternRun(HingeSitesArm(), 5000);
  ASSERT_EQ(tendon.size(), sites.size());
  double swing = 0;
  for (size_t i = 0; i < tendon.size(); i += 4) swing = std::max(swing, std::fabs(tendon[i]));
  EXPECT_GT(swing, 0.3);
  // the worst difference, in rad, rad/s and units of p_supply (Pa / 6e5)
  double worst = 0;
  size_t at = 0;
  for (size_t i = 0; i < tendon.size(); ++i) {
    const double difference = std::fabs(sites[i] - tendon[i]) / (i % 4 < 2 ? 1.0 : 6e5);
    if (difference > worst) worst = difference, at = i;
  }
  EXPECT_LT(worst, 1e-11) << "step " << at / 4 << ", signal " << at % 4 << " (qpos, qvel, p_P, p_N)";
  std::cout << "hinge_sites against the tendon: worst difference " << worst << " at step " << at / 4 << "\n";
}

TEST_F(Transmission, HingeSitesModelCopyStepsLikeItsOriginal) {
  AttachedModel arm;
  ASSERT_TRUE(arm.Load(HingeSitesArm())) << arm.error();
  mjModel* copy = mj_copyModel(nullptr, arm.m());
  mjData* d = mj_makeData(copy);
  const CylinderInfo cyl = arm.cylinder();
  testing::RunPattern(arm.m(), arm.d(), cyl, 0, 1000);
  testing::RunPattern(copy, d, cyl, 0, 1000);
  EXPECT_TRUE(testing::SameBits(testing::State(arm.m(), arm.d()), testing::State(copy, d)));
  EXPECT_GT(std::fabs(d->qpos[0]), 0.01);
  mj_deleteData(d);
  mj_deleteModel(copy);
}

TEST_F(Transmission, HingeSitesRefuseWhatTheirGeometryCannotTake) {
  struct Case {
    std::string xml;
    std::vector<std::string> expected;  // pieces of the error
  };
  const std::string good = HingeSitesArm();
  const std::vector<Case> cases = {
      {testing::ReplaceAll(good, R"(<site name="cyl.rod")", R"(<site name="cyl.pin")"),
       {"cylinder 'cyl'", "key 'mount'", "site 'cyl.rod' is missing", "'forearm'"}},
      // the cap on the forearm itself: it would turn with the rod
      {testing::ReplaceAll(testing::ReplaceAll(good, R"(<site name="cyl.cap" pos="0 -0.1 0"/>)", ""),
                           R"(<site name="cyl.rod")", R"(<site name="cyl.cap" pos="0 -0.1 0"/><site name="cyl.rod")"),
       {"key 'mount'", "site 'cyl.cap' is on body 'forearm'", "parent of the hinge's body"}},
      {testing::ReplaceAll(good, R"(joint="elbow")", R"(joint="elbow" gear="2")"), {"key 'mount'", "gear=\"1\""}},
      {testing::ReplaceAll(good, R"(type="hinge")", R"(type="slide")"), {"key 'mount'", "hinge"}},
      {testing::ReplaceAll(good, "mount=hinge_sites", "mount=hinge_sites coulomb_friction=5"),
       {"key 'coulomb_friction'", "mount=hinge_sites"}},
      {testing::ReplaceAll(good, R"(<general name="cyl.P" joint="elbow" dyntype="user" gaintype="user"/>)",
                           R"(<general name="cyl.P" joint="elbow" dyntype="user" gainprm="2e-4"/>)"),
       {"actuator 'cyl.P'", "gaintype=\"user\"", "lever arm"}},
      {testing::ReplaceAll(good, "mount=hinge_sites", "mount=hinge"), {"key 'mount'", "transmission hinge_sites"}},
  };
  for (const Case& c : cases) {
    AttachedModel arm;
    EXPECT_FALSE(arm.Load(c.xml));
    for (const std::string& piece : c.expected) EXPECT_NE(arm.error().find(piece), std::string::npos) << arm.error();
  }
}

}  // namespace
}  // namespace pneumatic
