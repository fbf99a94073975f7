// The cylinder configuration of a shipped rig model ("pneumatic:cyl"), for the tests of the
// extension's internals (they see plugin/src).
#ifndef PNEUMATIC_TESTS_SHIPPED_CONFIG_H_
#define PNEUMATIC_TESTS_SHIPPED_CONFIG_H_

#include <optional>
#include <string>

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "config.h"
#include "test_util.h"

namespace pneumatic {

inline CylinderConfig ShippedConfig(const std::string& file) {
  char error[1000] = "";
  mjModel* m = mj_loadXML(testing::ShippedModel(file).c_str(), nullptr, error, sizeof(error));
  EXPECT_NE(m, nullptr) << error;
  int id = mj_name2id(m, mjOBJ_TEXT, "pneumatic:cyl");
  std::string parse_error;
  std::optional<CylinderConfig> c = ParseCylinderConfig("cyl", m->text_data + m->text_adr[id], &parse_error);
  mj_deleteModel(m);
  EXPECT_TRUE(c) << parse_error;
  return *c;
}

}  // namespace pneumatic

#endif  // PNEUMATIC_TESTS_SHIPPED_CONFIG_H_
