// `pneumo study` (pneumo/studies/, docs/study.md): plans refused with the file and key named, grid and
// seeded random points, and studies of rig C run on 1 and 2 threads, with a failing point, resumed after
// a point was lost or the run was interrupted (SIGINT), all giving the same bytes. The Dask driver:
// tests/study_dask_test.py.
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "simulation/model_edits.h"
#include "studies/plan.h"
#include "test_util.h"

namespace pneumatic {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;
using testing::ReadText;
using testing::ShippedModel;

std::string Quote(const std::string& s) { return "'" + s + "'"; }

// a file's bytes, "" if it is empty or missing
std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

void WriteText(const fs::path& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

// every file under `dir` but the plots, by its path inside it, with its bytes
std::map<std::string, std::string> Files(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    const std::string inside = fs::relative(entry.path(), dir).string();
    if (entry.is_regular_file() && inside.rfind("plots", 0) != 0) files[inside] = ReadText(entry.path().string());
  }
  return files;
}

// rig C under PID for 0.5 s at 4 points: the supply pressure on a grid, the piston's mass and the
// joint's damping drawn; `extra` adds grid values
std::string RigPlan(const std::string& supplies = "[500000, 600000]", double duration = 0.5, int draws = 2) {
  return "{\n  \"model\": \"" + ShippedModel("rig_per_chamber.xml") +
         "\",\n  \"what\": {\"kind\": \"rollout\", \"controller\": \"pid\", \"duration\": " + std::to_string(duration) +
         ", \"seed\": 1, \"noise_position\": 1e-4},\n  \"points\": {\n    \"grid\": {\"cyl:p_supply\": " + supplies +
         "},\n    \"random\": {\"count\": " + std::to_string(draws) +
         ", \"seed\": 7, \"parameters\": {\"body:piston:mass\": {\"log_uniform\": [0.5, 2]}, "
         "\"joint:x:damping\": {\"uniform\": [5, 40]}}}\n  }\n}\n";
}

class StudyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) / ("study_test_" + std::string(info->name()) + "_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    ASSERT_TRUE(fs::create_directories(dir_));
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  // runs pneumo with `args`; its exit code, stderr in *err
  int Pneumo(const std::string& args, std::string* err = nullptr) const {
    const std::string err_path = Path("stderr.txt");
    const int status = std::system((Quote(PNEUMO_BINARY) + " " + args + " >" + Quote(Path("stdout.txt")) + " 2>" +
                                    Quote(err_path)).c_str());
    if (err) *err = ReadAll(err_path);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  std::string ReadPlanError(const std::string& text) const {
    WriteText(Path("plan.json"), text);
    study::Plan plan;
    return study::ReadPlan(Path("plan.json"), &plan);
  }
  fs::path dir_;
};

TEST_F(StudyTest, PlanErrorsNameTheFileAndTheKey) {
  const std::string file = Path("plan.json");
  const std::string model = "\"model\": \"rig.xml\", ";
  const std::string rollout = "\"what\": {\"kind\": \"rollout\", \"duration\": 1}, ";
  const std::pair<std::string, std::string> cases[] = {
      {"{", file + ": [json.exception.parse_error"},
      {"{" + rollout + "\"points\": {\"grid\": {\"cyl:p_supply\": [5e5]}}}", file + ": model: required"},
      {"{" + model + "\"points\": {}}", file + ": what: required"},
      {"{" + model + "\"what\": {\"kind\": \"fly\"}, \"points\": {}}", file + ": what.kind: 'fly' is not rollout"},
      {"{" + model + "\"what\": {\"kind\": \"rollout\"}, \"points\": {}}", file + ": what.duration: required"},
      {"{" + model + "\"what\": {\"kind\": \"rollout\", \"duration\": 1, \"gain\": 2}, \"points\": {}}",
       file + ": what.gain: unknown key"},
      {"{" + model + rollout + "\"points\": {\"grid\": {\"cyl:p_supply\": []}}}",
       file + ": points.grid.cyl:p_supply: expected a non-empty array of numbers"},
      {"{" + model + rollout + "\"points\": {\"grid\": {\"body:piston:volume\": [1]}}}",
       file + ": points.grid.body:piston:volume: 'body:piston:volume' is not <cylinder>:<key>, body:<name>:mass"},
      {"{" + model + rollout + "\"points\": {\"random\": {\"count\": 2, \"parameters\": {\"cyl:p_supply\": {\"uniform\": [1, 2]}}}}}",
       file + ": points.random.seed: required"},
      {"{" + model + rollout +
           "\"points\": {\"random\": {\"count\": 2, \"seed\": 1, \"parameters\": {\"joint:x:damping\": {\"log_uniform\": [0, 2]}}}}}",
       file + ": points.random.parameters.joint:x:damping: log_uniform needs 0 < low < high"},
      {"{" + model + rollout + "\"points\": {\"logs\": [\"a.csv\"]}}", file + ": points.logs: a rollout study's points are"},
      {"{" + model + "\"what\": {\"kind\": \"identify\"}, \"points\": {\"grid\": {\"cyl:p_supply\": [5e5]}}}",
       file + ": points.logs: required"},
      {"{" + model + rollout + "\"points\": {\"grid\": {\"cyl:p_supply\": [5e5]}}, \"scheduler\": \"host\"}",
       file + ": scheduler: expected a Dask scheduler's address"},
      // 2 grid values times a million draws: 2,000,001 > kMaxPoints, refused before any point is made
      {"{" + model + rollout +
           "\"points\": {\"grid\": {\"cyl:p_supply\": [5e5, 6e5]}, \"random\": {\"count\": 1000000, \"seed\": 1, "
           "\"parameters\": {\"joint:x:damping\": {\"uniform\": [0, 2]}}}}}",
       file + ": points: the grid times the random draws make more than 1000000 points"},
  };
  for (const auto& [text, message] : cases) {
    SCOPED_TRACE(text);
    EXPECT_THAT(ReadPlanError(text), HasSubstr(message));
  }
  study::Plan plan;
  EXPECT_EQ(study::ReadPlan(Path("missing.json"), &plan), Path("missing.json") + ": cannot read");
  // the controller's keys are checked when the study opens, before any point runs
  std::string text = RigPlan();
  text.replace(text.find("\"seed\": 1,"), 10, "\"controller_config\": {\"kq\": 1},");
  WriteText(Path("plan.json"), text);
  std::string err;
  EXPECT_EQ(Pneumo("study " + Quote(Path("plan.json")) + " --out " + Quote(Path("out")), &err), 1);
  EXPECT_THAT(err, HasSubstr(Path("plan.json") + ": the plan's what.controller_config: unknown key 'kq'"));
  EXPECT_FALSE(fs::exists(Path("out")));
}

// the grid's points, the last key fastest, with every random draw each; draws are the same bits on
// every machine and run (a SplitMix64-seeded mt19937_64 per draw and parameter)
TEST_F(StudyTest, GridAndRandomPointsAreExactAndReproducible) {
  WriteText(Path("plan.json"),
            "{\"model\": \"rig.xml\", \"what\": {\"kind\": \"rollout\", \"duration\": 1}, \"points\": {\"grid\": "
            "{\"cyl:p_supply\": [5e5, 6e5], \"joint:x:frictionloss\": [0, 1, 2]}}}");
  study::Plan plan;
  ASSERT_EQ(study::ReadPlan(Path("plan.json"), &plan), "");
  EXPECT_EQ(plan.model, Path("rig.xml"));  // relative to the plan's folder
  std::vector<study::Point> points = study::ExpandPoints(plan);
  ASSERT_EQ(points.size(), 6u);
  const double expected[6][2] = {{5e5, 0}, {5e5, 1}, {5e5, 2}, {6e5, 0}, {6e5, 1}, {6e5, 2}};
  for (size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(points[i].index, i);
    ASSERT_EQ(points[i].values.size(), 2u);
    EXPECT_EQ(points[i].values[0], std::make_pair(std::string("cyl:p_supply"), expected[i][0]));
    EXPECT_EQ(points[i].values[1], std::make_pair(std::string("joint:x:frictionloss"), expected[i][1]));
  }

  WriteText(Path("plan.json"), RigPlan());
  ASSERT_EQ(study::ReadPlan(Path("plan.json"), &plan), "");
  points = study::ExpandPoints(plan);
  ASSERT_EQ(points.size(), 4u);
  EXPECT_EQ(study::ParameterKeys(plan), (std::vector<std::string>{"cyl:p_supply", "body:piston:mass", "joint:x:damping"}));
  // the draws of seed 7, the same for each grid point
  const double mass[2] = {0.5252859052767606, 1.9849345455469272}, damping[2] = {28.03991936204531, 36.649741849839515};
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(points[i].values[0].second, i < 2 ? 5e5 : 6e5);
    EXPECT_EQ(points[i].values[1].second, mass[i % 2]);
    EXPECT_EQ(points[i].values[2].second, damping[i % 2]);
  }
  // many draws stay in their ranges; another seed draws other values
  WriteText(Path("plan.json"), RigPlan("[500000]", 0.5, 200));
  ASSERT_EQ(study::ReadPlan(Path("plan.json"), &plan), "");
  for (const study::Point& p : study::ExpandPoints(plan)) {
    EXPECT_TRUE(p.values[1].second >= 0.5 && p.values[1].second < 2) << p.values[1].second;
    EXPECT_TRUE(p.values[2].second >= 5 && p.values[2].second < 40) << p.values[2].second;
  }
  std::string text = RigPlan();
  text.replace(text.find("\"seed\": 7"), 9, "\"seed\": 8");
  WriteText(Path("plan.json"), text);
  ASSERT_EQ(study::ReadPlan(Path("plan.json"), &plan), "");
  EXPECT_NE(study::ExpandPoints(plan)[0].values[1].second, mass[0]);
}

// the keys a study sets: a cylinder's parameter (checked), a body's mass with its inertia scaled, a
// joint's damping and frictionloss; a value that would leave the model unsteppable is refused and undone
TEST_F(StudyTest, ModelValuesAreSetByKeyAndBadOnesRefused) {
  testing::AttachedModel rig;
  ASSERT_TRUE(rig.Load(ShippedModel("rig_proportional_full.xml"), true)) << rig.error();
  mjModel* m = rig.m();
  const int body = mj_name2id(m, mjOBJ_BODY, "piston"), joint = mj_name2id(m, mjOBJ_JOINT, "x");
  ASSERT_GE(body, 0);
  ASSERT_GE(joint, 0);
  const double mass = m->body_mass[body], inertia = m->body_inertia[3 * body];
  EXPECT_EQ(SetModelValue(m, "body:piston:mass", 2 * mass), "");
  EXPECT_EQ(m->body_mass[body], 2 * mass);
  EXPECT_DOUBLE_EQ(m->body_inertia[3 * body], 2 * inertia);
  EXPECT_EQ(SetModelValue(m, "joint:x:damping", 12.5), "");
  EXPECT_EQ(m->dof_damping[m->jnt_dofadr[joint]], 12.5);
  EXPECT_EQ(SetModelValue(m, "joint:x:frictionloss", 45), "");
  EXPECT_EQ(m->dof_frictionloss[m->jnt_dofadr[joint]], 45);
  EXPECT_EQ(SetModelValue(m, "cyl:p_supply", 5.5e5), "");
  std::string error;
  EXPECT_EQ(GetParameter(m, "cyl", "p_supply", &error), 5.5e5);
  // refused, m unchanged
  EXPECT_THAT(SetModelValue(m, "joint:x:frictionloss", 10), HasSubstr("10 leaves the model unsteppable"));
  EXPECT_EQ(m->dof_frictionloss[m->jnt_dofadr[joint]], 45);
  EXPECT_THAT(SetModelValue(m, "body:piston:mass", 0), HasSubstr("a mass must be positive"));
  EXPECT_THAT(SetModelValue(m, "body:arm:mass", 1), HasSubstr("the model has no body 'arm'"));
  EXPECT_THAT(SetModelValue(m, "joint:x:stiffness", 1), HasSubstr("is not <cylinder>:<key>"));
  EXPECT_THAT(SetModelValue(m, "cyl:p_supply", 5e4), HasSubstr("'cyl:p_supply': cylinder 'cyl'"));
  EXPECT_EQ(GetParameter(m, "cyl", "p_supply", &error), 5.5e5);
}

// --jobs 1 and --jobs 2 write the same bytes: results.csv, each point's log, summary and record; a
// point whose value is refused (a supply below the exhaust) is recorded with its error, and the others run
TEST_F(StudyTest, OneAndTwoThreadsGiveTheSameBytesAndAFailedPointIsRecorded) {
  WriteText(Path("plan.json"), RigPlan("[500000, 50000]"));
  std::string err;
  ASSERT_EQ(Pneumo("study " + Quote(Path("plan.json")) + " --out " + Quote(Path("one")) + " --no-plots", &err), 0) << err;
  EXPECT_THAT(err, HasSubstr("4 of 4 points done, 2 failed"));
  ASSERT_EQ(Pneumo("study " + Quote(Path("plan.json")) + " --out " + Quote(Path("two")) + " --jobs 2 --no-plots", &err), 0)
      << err;
  const std::map<std::string, std::string> one = Files(Path("one")), two = Files(Path("two"));
  EXPECT_EQ(one, two);
  EXPECT_EQ(one.size(), 1 + 1 + 2 * 3 + 2 * 1u);  // plan.json, results.csv, 2 points ok, 2 failed
  EXPECT_EQ(one.at("plan.json"), ReadText(Path("plan.json")));
  const std::string csv = one.at("results.csv");
  EXPECT_THAT(csv, HasSubstr("point,cyl:p_supply,body:piston:mass,joint:x:damping,cyl.rms_tracking_error,"
                             "cyl.max_tracking_error,warnings,status,error\n0,500000.0,0.5252859052767606,28.03991936204531,"));
  EXPECT_THAT(csv, HasSubstr("\n2,50000.0,0.5252859052767606,28.03991936204531,,,,failed,'cyl:p_supply': cylinder 'cyl':"));
  EXPECT_THAT(one.at("points/1/record.json"), HasSubstr("\"status\": \"ok\""));
  EXPECT_THAT(one.at("points/3/record.json"), HasSubstr("\"status\": \"failed\""));
  EXPECT_TRUE(one.count("points/0/rollout.csv") && one.count("points/0/summary.json"));
  EXPECT_THAT(one.at("points/0/summary.json"), Not(HasSubstr("wall_s")));
}

struct stat Stat(const std::string& path) {
  struct stat s {};
  ::stat(path.c_str(), &s);
  return s;
}

// a point lost (its folder removed) is run again and only it; results.csv is the uninterrupted run's
// bytes; another plan on the folder is refused; --point, --unfinished and --collect as a Dask worker
// and driver use them
TEST_F(StudyTest, ResumeRunsOnlyTheUnfinishedPointsAndGivesTheSameBytes) {
  WriteText(Path("plan.json"), RigPlan());
  const std::string plan = Quote(Path("plan.json"));
  std::string err;
  ASSERT_EQ(Pneumo("study " + plan + " --out " + Quote(Path("whole")) + " --no-plots", &err), 0) << err;
  const std::map<std::string, std::string> whole = Files(Path("whole"));
  fs::remove_all(Path("whole/points/2"));
  const struct stat before = Stat(Path("whole/points/1/record.json"));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_EQ(Pneumo("study " + plan + " --out " + Quote(Path("whole")) + " --unfinished", &err), 0) << err;
  EXPECT_EQ(ReadAll(Path("stdout.txt")), "2\n");
  ASSERT_EQ(Pneumo("study " + plan + " --out " + Quote(Path("whole")) + " --collect --no-plots", &err), 1);
  EXPECT_THAT(err, HasSubstr("point 2 is not finished"));
  ASSERT_EQ(Pneumo("study " + plan + " --out " + Quote(Path("whole")) + " --no-plots", &err), 0) << err;
  EXPECT_THAT(err, HasSubstr("3 of 4 points already finished"));
  EXPECT_EQ(Files(Path("whole")), whole);
  const struct stat after = Stat(Path("whole/points/1/record.json"));
  EXPECT_EQ(after.st_mtim.tv_sec, before.st_mtim.tv_sec);
  EXPECT_EQ(after.st_mtim.tv_nsec, before.st_mtim.tv_nsec);
  EXPECT_EQ(after.st_ino, before.st_ino);  // not rewritten

  // point by point, as the Dask workers run them, then collected
  for (int k : {3, 0, 2, 1}) {
    ASSERT_EQ(Pneumo("study " + plan + " --out " + Quote(Path("pointwise")) + " --point " + std::to_string(k), &err), 0) << err;
  }
  ASSERT_EQ(Pneumo("study " + plan + " --out " + Quote(Path("pointwise")) + " --collect --no-plots", &err), 0) << err;
  EXPECT_EQ(Files(Path("pointwise")), whole);
  EXPECT_EQ(Pneumo("study " + plan + " --out " + Quote(Path("pointwise")) + " --point 4", &err), 1);
  EXPECT_THAT(err, HasSubstr("--point 4: the plan has 4 points (0 to 3)"));

  WriteText(Path("other.json"), RigPlan("[500000, 700000]"));
  EXPECT_EQ(Pneumo("study " + Quote(Path("other.json")) + " --out " + Quote(Path("whole")), &err), 1);
  EXPECT_THAT(err, HasSubstr(Path("whole") + " holds the study of another plan"));
}

// SIGINT while points run: the process stops starting points, the point under way ends unrecorded,
// it exits 130; run again, the study finishes with the uninterrupted run's bytes and no temporary left
TEST_F(StudyTest, InterruptedBySigintThenResumedGivesTheSameBytes) {
  WriteText(Path("plan.json"), RigPlan("[500000, 600000]", 1.0));
  const std::string plan = Quote(Path("plan.json"));
  std::string err;
  ASSERT_EQ(Pneumo("study " + plan + " --out " + Quote(Path("whole")) + " --no-plots", &err), 0) << err;
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    if (!freopen("/dev/null", "w", stderr)) _exit(126);
    execl(PNEUMO_BINARY, PNEUMO_BINARY, "study", Path("plan.json").c_str(), "--out", Path("cut").c_str(), "--no-plots",
          static_cast<char*>(nullptr));
    _exit(127);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!fs::exists(Path("cut/points/0/record.json")) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ::kill(child, SIGINT);
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  size_t finished = 0;
  for (size_t k = 0; k < 4; ++k) finished += fs::exists(Path("cut/points/" + std::to_string(k) + "/record.json"));
  if (finished < 4) EXPECT_EQ(WEXITSTATUS(status), 130);  // (a slow signal may have found the study done)
  EXPECT_GE(finished, 1u);
  EXPECT_FALSE(fs::exists(Path("cut/results.csv")) && finished < 4);
  for (const auto& entry : fs::recursive_directory_iterator(Path("cut"))) {
    EXPECT_NE(entry.path().filename().string()[0], '.') << "a temporary left: " << entry.path();
  }
  ASSERT_EQ(Pneumo("study " + plan + " --out " + Quote(Path("cut")) + " --no-plots", &err), 0) << err;
  EXPECT_EQ(Files(Path("cut")), Files(Path("whole")));
}

// the plots: one PNG per figure of merit, a panel per parameter (scripts/plot_study.py)
TEST_F(StudyTest, PlotsEachFigureOfMerit) {
  WriteText(Path("plan.json"), RigPlan("[500000]", 0.2));
  std::string err;
  ASSERT_EQ(Pneumo("study " + Quote(Path("plan.json")) + " --out " + Quote(Path("s")) + " --jobs 2", &err), 0) << err;
  for (const char* figure : {"cyl.rms_tracking_error", "cyl.max_tracking_error", "warnings"}) {
    EXPECT_GT(fs::file_size(Path(std::string("s/plots/") + figure + ".png")), 1000u) << figure;
  }
}

}  // namespace
}  // namespace pneumatic
