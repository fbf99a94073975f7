// The diagnosis' model edits (pneumo/diagnosis/candidates.cc, LoadEditedModel) made on the MJCF
// document: a model written with single-quoted attributes and spaces inside its tags, or with its
// cylinder's text and actuators in included files (tests/data/candidate_edits/), gets the same edits
// as the shipped rigs; an edited model is the model with the edit written out by hand, bit for bit.
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "diagnosis/candidates.h"
#include "formats/model_loading.h"
#include "pneumatic/pneumatic.h"

namespace pneumatic::diagnosis {
namespace {

const std::string kData = PNEUMATIC_TEST_DATA_DIR;
const std::string kModels = PNEUMATIC_MODELS_DIR;

// heat_transfer's first form on cylinder "cyl" (diagnosis/effects/heat_transfer.cc): the gas
// temperatures' actuators cyl.TP, cyl.TN and two keys of its text
ModelEdit EnergyEdit() {
  return {"cyl", {"TP", "TN"}, {}, {}, {{"thermal_model", "energy"}, {"wall_heat_conductance", "0.02"}}};
}

// the model as mj_saveModel writes it: equal for two models compiled from the same elements
std::vector<char> Bytes(const mjModel* m) {
  std::vector<char> bytes(mj_sizeModel(m));
  mj_saveModel(m, nullptr, bytes.data(), static_cast<int>(bytes.size()));
  return bytes;
}

// qpos, qvel and act after each of 2000 steps, every command swept through its range
std::vector<double> Trajectory(const mjModel* m) {
  mjData* d = mj_makeData(m);
  std::vector<double> states;
  for (int step = 0; step < 2000; ++step) {
    for (int i = 0; i < m->nu; ++i) {
      const double lo = m->actuator_ctrlrange[2 * i], hi = m->actuator_ctrlrange[2 * i + 1];
      d->ctrl[i] = m->actuator_ctrllimited[i] ? lo + (hi - lo) * (0.5 + 0.4 * std::sin(0.004 * step + i)) : 0;
    }
    mj_step(m, d);
    states.insert(states.end(), d->qpos, d->qpos + m->nq);
    states.insert(states.end(), d->qvel, d->qvel + m->nv);
    states.insert(states.end(), d->act, d->act + m->na);
  }
  mj_deleteData(d);
  return states;
}

// true if a and b hold the same bits
bool SameBits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

// a model loaded from its file as LoadEditedModel loads one: attached, its collision detection
// skipped where nothing can collide
ModelPtr LoadAsTheDiagnosisDoes(const std::string& path, std::string* error) {
  ModelPtr m = LoadAttachedModel(path, error);
  if (m) SkipCollisionWhereNothingCollides(m.get());
  return m;
}

std::string ReadFile(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

// A shipped rig's MJCF with EnergyEdit written out by hand, where the diagnosis put it when it edited
// the text: the keys after the cylinder's own, the actuators after every other, on joint x.
std::string WithEnergyEditByHand(std::string xml) {
  const size_t text = xml.find("name=\"pneumatic:cyl\"");
  const size_t data = xml.find("data=\"", text);
  const size_t data_end = data == std::string::npos ? data : xml.find('"', data + 6);
  const size_t actuators_end = xml.rfind("</actuator>");
  if (text == std::string::npos || data_end == std::string::npos || actuators_end == std::string::npos) return "";
  const std::string keys = " thermal_model=energy wall_heat_conductance=0.02";
  const std::string actuators = "<general name=\"cyl.TP\" joint=\"x\" dyntype=\"user\" gaintype=\"user\"/>\n"
                                "<general name=\"cyl.TN\" joint=\"x\" dyntype=\"user\" gaintype=\"user\"/>\n";
  // the later place first, so that the earlier stays where it was found
  if (data_end > actuators_end) {
    xml.insert(data_end, keys);
    xml.insert(actuators_end, actuators);
  } else {
    xml.insert(actuators_end, actuators);
    xml.insert(data_end, keys);
  }
  return xml;
}

TEST(CandidateEditsTest, IncludesResolveAsMuJoCoResolvesThem) {
  std::string error;
  // without edits, the document with its includes resolved is the model MuJoCo compiles from the file
  ModelPtr own = LoadAsTheDiagnosisDoes(kData + "/rig_included.xml", &error);
  ASSERT_TRUE(own) << error;
  ModelPtr resolved = LoadEditedModel(kData + "/rig_included.xml", {}, &error);
  ASSERT_TRUE(resolved) << error;
  EXPECT_EQ(Bytes(own.get()), Bytes(resolved.get()));
  // and the single file with quoted attributes is the same model
  ModelPtr quoted = LoadEditedModel(kData + "/rig_quoted.xml", {}, &error);
  ASSERT_TRUE(quoted) << error;
  EXPECT_EQ(Bytes(quoted.get()), Bytes(resolved.get()));
}

TEST(CandidateEditsTest, EnergyEditThroughQuotesAndIncludes) {
  std::string error;
  ModelPtr by_hand = LoadAsTheDiagnosisDoes(kData + "/rig_energy_by_hand.xml", &error);
  ASSERT_TRUE(by_hand) << error;
  for (const char* file : {"rig_quoted.xml", "rig_included.xml"}) {
    SCOPED_TRACE(file);
    ModelPtr m = LoadEditedModel(kData + "/" + file, {EnergyEdit()}, &error);
    ASSERT_TRUE(m) << error;
    // cyl.TP, cyl.TN after every other actuator, on chamber P's joint, states of the extension
    const int joint = mj_name2id(m.get(), mjOBJ_JOINT, "x");
    const char* const states[] = {"cyl.TP", "cyl.TN"};
    for (int i = 0; i < 2; ++i) {
      const int id = mj_name2id(m.get(), mjOBJ_ACTUATOR, states[i]);
      EXPECT_EQ(id, m->nu - 2 + i) << states[i];
      if (id < 0) continue;
      EXPECT_EQ(m->actuator_trntype[id], mjTRN_JOINT);
      EXPECT_EQ(m->actuator_trnid[2 * id], joint);
      EXPECT_EQ(m->actuator_dyntype[id], mjDYN_USER);  // (Attach fixes the gains of the extension's actuators)
    }
    // the keys, read back through the extension
    EXPECT_EQ(GetChoice(m.get(), "cyl", "thermal_model", &error).value_or(""), "energy") << error;
    EXPECT_EQ(GetParameter(m.get(), "cyl", "P.wall_heat_conductance", &error).value_or(0), 0.02) << error;
    EXPECT_EQ(GetParameter(m.get(), "cyl", "N.wall_heat_conductance", &error).value_or(0), 0.02) << error;
    // the model with the edit written out by hand, bit for bit
    EXPECT_EQ(Bytes(m.get()), Bytes(by_hand.get()));
    EXPECT_TRUE(SameBits(Trajectory(m.get()), Trajectory(by_hand.get())));
  }
}

TEST(CandidateEditsTest, ShippedRigsStepAsWithTheEditWrittenByHand) {
  for (const char* rig : {"rig_per_chamber.xml", "rig_proportional_full.xml"}) {
    SCOPED_TRACE(rig);
    const std::string by_hand_text = WithEnergyEditByHand(ReadFile(kModels + "/" + rig));
    ASSERT_FALSE(by_hand_text.empty()) << "the rig's text or actuators are not where this test writes the edit";
    const std::string by_hand_path = ::testing::TempDir() + "candidate_edits_by_hand_" + rig;
    std::ofstream(by_hand_path, std::ios::binary) << by_hand_text;
    std::string error;
    ModelPtr by_hand = LoadAsTheDiagnosisDoes(by_hand_path, &error);
    ASSERT_TRUE(by_hand) << error;
    ModelPtr edited = LoadEditedModel(kModels + "/" + rig, {EnergyEdit()}, &error);
    ASSERT_TRUE(edited) << error;
    EXPECT_EQ(Bytes(edited.get()), Bytes(by_hand.get()));
    EXPECT_TRUE(SameBits(Trajectory(edited.get()), Trajectory(by_hand.get())));
  }
}

// Collision detection is skipped only where no geom pair can touch, and there it changes nothing:
// every shipped rig (its geoms contype="0" conaffinity="0") gets mjDSBL_CONTACT and steps the same
// to the bit as without it; a geom that may meet another's conaffinity, or an explicit <pair>,
// leaves the model as it is.
TEST(CandidateEditsTest, CollisionSkippedOnlyWhereNothingCanCollide) {
  for (const char* rig : {"rig_onoff.xml", "rig_proportional.xml", "rig_per_chamber.xml", "rig_proportional_full.xml"}) {
    SCOPED_TRACE(rig);
    std::string error;
    ModelPtr as_loaded = LoadAttachedModel(kModels + "/" + rig, &error);
    ModelPtr skipped = LoadEditedModel(kModels + "/" + rig, {}, &error);
    ASSERT_TRUE(as_loaded && skipped) << error;
    EXPECT_EQ(as_loaded->opt.disableflags & mjDSBL_CONTACT, 0);
    EXPECT_NE(skipped->opt.disableflags & mjDSBL_CONTACT, 0);
    EXPECT_TRUE(SameBits(Trajectory(as_loaded.get()), Trajectory(skipped.get())));
  }
  auto loaded = [](const std::string& worldbody, const std::string& extra = "") {
    std::string error;
    ModelPtr m = LoadModelFromText("<mujoco>" + extra + "<worldbody>" + worldbody + "</worldbody></mujoco>",
                                   ::testing::TempDir() + "collision_skip.xml", &error);
    EXPECT_TRUE(m) << error;
    if (m) SkipCollisionWhereNothingCollides(m.get());
    return m;
  };
  const std::string box = "<body><joint type='free'/><geom name='box' type='box' size='.1 .1 .1' contype='2' conaffinity='0'/></body>";
  // the box's contype 2 meets a floor's conaffinity 2: a contact can arise
  ModelPtr touching = loaded("<geom type='plane' size='1 1 1' contype='0' conaffinity='2'/>" + box);
  ASSERT_TRUE(touching);
  EXPECT_EQ(touching->opt.disableflags & mjDSBL_CONTACT, 0);
  // a floor of conaffinity 1 never meets contype 2, and nothing else can touch
  ModelPtr apart = loaded("<geom name='floor' type='plane' size='1 1 1' contype='0' conaffinity='1'/>" + box);
  ASSERT_TRUE(apart);
  EXPECT_NE(apart->opt.disableflags & mjDSBL_CONTACT, 0);
  // the same with an explicit pair between them
  ModelPtr paired = loaded("<geom name='floor' type='plane' size='1 1 1' contype='0' conaffinity='1'/>" + box,
                           "<contact><pair geom1='floor' geom2='box'/></contact>");
  ASSERT_TRUE(paired);
  EXPECT_EQ(paired->opt.disableflags & mjDSBL_CONTACT, 0);
}

// a command given a state, a force actuator and a supply reservoir, in an included file
TEST(CandidateEditsTest, CommandStateForceAndReservoirThroughIncludes) {
  const ModelEdit edit{"cyl",
                       {"z"},
                       {"friction"},
                       {"uP", "uN"},
                       {{"spool_time_constant", "0.002"},
                        {"friction_model", "lugre"},
                        {"coulomb_friction", "1.5"},
                        {"static_friction", "3"},
                        {"stribeck_velocity", "0.005"}},
                       "supply_tank",
                       {{"volume", "0.001"}, {"line_conductance", "1e-7"}}};
  std::string error;
  ModelPtr m = LoadEditedModel(kData + "/rig_included.xml", {edit}, &error);
  ASSERT_TRUE(m) << error;
  const int joint = mj_name2id(m.get(), mjOBJ_JOINT, "x");
  // the force actuator before every other: stateless, its force the extension's bias
  const int friction = mj_name2id(m.get(), mjOBJ_ACTUATOR, "cyl.friction");
  EXPECT_EQ(friction, 0);
  if (friction >= 0) {
    EXPECT_EQ(m->actuator_dyntype[friction], mjDYN_NONE);
    EXPECT_EQ(m->actuator_biastype[friction], mjBIAS_USER);
    EXPECT_EQ(m->actuator_trnid[2 * friction], joint);
  }
  // the commands with their lag's state
  for (const char* command : {"cyl.uP", "cyl.uN"}) {
    const int id = mj_name2id(m.get(), mjOBJ_ACTUATOR, command);
    ASSERT_GE(id, 0) << command;
    EXPECT_EQ(m->actuator_dyntype[id], mjDYN_USER) << command;
  }
  // the bristle state, then the reservoir's pressure, after every other actuator
  EXPECT_EQ(mj_name2id(m.get(), mjOBJ_ACTUATOR, "cyl.z"), m->nu - 2);
  const int pressure = mj_name2id(m.get(), mjOBJ_ACTUATOR, "supply_tank.pressure");
  EXPECT_EQ(pressure, m->nu - 1);
  EXPECT_GE(mj_name2id(m.get(), mjOBJ_TEXT, "pneumatic_reservoir:supply_tank"), 0);
  const std::vector<ReservoirInfo> reservoirs = Reservoirs(m.get());
  ASSERT_EQ(reservoirs.size(), 1u);
  EXPECT_EQ(reservoirs[0].name, "supply_tank");
  EXPECT_EQ(reservoirs[0].volume, 0.001);
  ASSERT_EQ(Cylinders(m.get()).size(), 1u);
  EXPECT_EQ(Cylinders(m.get())[0].supply_actuator, pressure);
  // the keys, read back
  EXPECT_EQ(GetChoice(m.get(), "cyl", "friction_model", &error).value_or(""), "lugre") << error;
  EXPECT_EQ(GetParameter(m.get(), "cyl", "coulomb_friction", &error).value_or(0), 1.5) << error;
  EXPECT_EQ(GetParameter(m.get(), "cyl", "spool_time_constant", &error).value_or(0), 0.002) << error;
  // the single file with quoted attributes gets the same model
  ModelPtr quoted = LoadEditedModel(kData + "/rig_quoted.xml", {edit}, &error);
  ASSERT_TRUE(quoted) << error;
  EXPECT_EQ(Bytes(quoted.get()), Bytes(m.get()));
}

TEST(CandidateEditsTest, RefusesWhatItCannotEdit) {
  std::string error;
  EXPECT_FALSE(LoadEditedModel(kData + "/rig_included.xml", {{"nope", {}, {}, {}, {{"stroke", "0.1"}}}}, &error));
  EXPECT_NE(error.find("pneumatic:nope"), std::string::npos) << error;
  // a command that has a state already
  EXPECT_FALSE(LoadEditedModel(kData + "/rig_included.xml", {{"cyl", {}, {}, {"P"}, {}}}, &error));
  EXPECT_NE(error.find("cannot give actuator 'cyl.P' a state"), std::string::npos) << error;
  // a file included twice, which MuJoCo refuses too
  EXPECT_FALSE(LoadEditedModel(kData + "/twice.xml", {}, &error));
  EXPECT_NE(error.find("already included"), std::string::npos) << error;
  EXPECT_FALSE(LoadEditedModel(kData + "/missing.xml", {}, &error));
  EXPECT_NE(error.find("cannot read the model"), std::string::npos) << error;
}

}  // namespace
}  // namespace pneumatic::diagnosis
