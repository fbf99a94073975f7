// The discrete PID of controllers/ against values computed by hand.
#include <gtest/gtest.h>

#include "pid.h"

namespace pneumatic {
namespace {

TEST(Pid, ProportionalAndIntegralTermsMatchHandComputation) {
  // paper 001's QFT gains: K_p = 10 V/m, K_i = 26 V/(m s); 1 kHz; error 0.1 m held
  Pid pid({10, 26, 0, 0}, 1e-3);
  // u = 10 * 0.1 + 26 * (0.1 * 1e-3) = 1.0026 V; then the integral holds 1e-4 m s
  EXPECT_DOUBLE_EQ(pid.Update(0.1, 0), 1.0 + 26 * 1e-4);
  EXPECT_DOUBLE_EQ(pid.Update(0.1, 0), 1.0 + 26 * 2e-4);
}

TEST(Pid, DerivativeActsOnMeasurementNotOnReferenceSteps) {
  Pid pid({0, 0, 2, 5}, 1e-3);
  EXPECT_DOUBLE_EQ(pid.Update(0, 0), 5.0);       // no previous sample: no derivative
  EXPECT_DOUBLE_EQ(pid.Update(1, 0), 5.0);       // a reference step does not kick
  EXPECT_DOUBLE_EQ(pid.Update(1, 1e-3), 3.0);    // x moved 1 mm in 1 ms: -2 V s/m * 1 m/s
}

TEST(Pid, IntegralDoesNotWindUpWhileSaturated) {
  Pid pid({10, 1000, 0, 0, -1, 1}, 1e-3);
  for (int i = 0; i < 100; ++i) EXPECT_DOUBLE_EQ(pid.Update(1, 0), 1.0);  // saturated at u_max
  // back inside the range: the output is the proportional term alone, no stored integral
  EXPECT_NEAR(pid.Update(0.05, 0), 10 * 0.05 + 1000 * 0.05 * 1e-3, 1e-12);
}

}  // namespace
}  // namespace pneumatic
