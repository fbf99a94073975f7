// Closed-loop rollouts on threads, as `pneumo rollout --jobs` runs them (pneumo/cli/rollout_command.cc):
// ParallelFor over the runs, each run on its own mj_copyModel of one attached model, some copies
// edited by key (SetParameter) before they run. Every run's log must be the serial run's, bit for
// bit. scripts/tsan runs this test under ThreadSanitizer, where any data race between the runs (in
// the extension's registry of attached models, its per-model caches, or the rollout code) fails it.
#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "formats/log_csv.h"
#include "pneumatic/pneumatic.h"
#include "simulation/closed_loop.h"
#include "simulation/parallel_for.h"
#include "test_util.h"

namespace pneumatic {
namespace {

using testing::AttachedModel;
using testing::ShippedModel;

struct RunSpec {
  std::uint64_t seed;
  double supply_pressure;  // Pa abs, the key p_supply; 0: the model's own
};

// one run as the command line makes it: a copy of the model, edited, then run closed loop
ClosedLoopResult RunOnCopy(const mjModel* model, const RunSpec& spec, const log::Log* reference) {
  std::unique_ptr<mjModel, void (*)(mjModel*)> copy(mj_copyModel(nullptr, model), mj_deleteModel);
  std::string error;
  if (spec.supply_pressure > 0 && !SetParameter(copy.get(), "cyl", "p_supply", spec.supply_pressure, &error)) {
    ClosedLoopResult failed;
    failed.error = error;
    return failed;
  }
  ClosedLoopOptions options;
  options.duration = 0.4;
  options.reference = reference;
  options.seed = spec.seed;
  options.noise_position = 1e-4;
  options.noise_pressure = 300;
  return RunClosedLoop(copy.get(), options);
}

TEST(ParallelRollouts, RunsOnCopiesOnTwoThreadsGiveTheSerialRunsBits) {
  AttachedModel model;
  ASSERT_TRUE(model.Load(ShippedModel("rig_per_chamber.xml"), true)) << model.error();
  log::Log reference;
  reference.columns = {{"cyl", "ref"}};
  reference.time = {0, 0.1, 0.1001, 10};
  reference.values = {{0, 0, 0.01, 0.01}};
  // four seeds, two of them on a copy whose supply pressure was changed by key (rig C: 6 bar)
  const std::vector<RunSpec> runs = {{1, 0}, {2, 0}, {1, 5e5}, {2, 7e5}};
  std::vector<ClosedLoopResult> serial(runs.size()), threaded(runs.size());
  for (size_t i = 0; i < runs.size(); ++i) serial[i] = RunOnCopy(model.m(), runs[i], &reference);
  ParallelFor(runs.size(), 2, [&](size_t i) { threaded[i] = RunOnCopy(model.m(), runs[i], &reference); });
  for (size_t i = 0; i < runs.size(); ++i) {
    SCOPED_TRACE("run " + std::to_string(i));
    ASSERT_TRUE(serial[i].log) << serial[i].error;
    ASSERT_TRUE(threaded[i].log) << threaded[i].error;
    EXPECT_TRUE(testing::SameBits(serial[i].log->time, threaded[i].log->time));
    ASSERT_EQ(serial[i].log->values.size(), threaded[i].log->values.size());
    for (size_t c = 0; c < serial[i].log->values.size(); ++c) {
      EXPECT_TRUE(testing::SameBits(serial[i].log->values[c], threaded[i].log->values[c])) << "column " << c;
    }
  }
  // the edit took effect: the run at 5 bar and the one at 7 bar differ from the model's own
  const int p_P = serial[0].log->FindColumn("cyl", "p_P");
  ASSERT_GE(p_P, 0);
  EXPECT_NE(serial[0].log->values[static_cast<size_t>(p_P)], serial[2].log->values[static_cast<size_t>(p_P)]);
  EXPECT_NE(serial[1].log->values[static_cast<size_t>(p_P)], serial[3].log->values[static_cast<size_t>(p_P)]);
}

// ParallelForInOrder (the diagnosis fits its simpler forms side by side with it): then(i) runs once
// per index, in index order, and only after f(i) has returned, also when the later indices finish
// first (each f(i) sleeps less than the one before it)
TEST(ParallelForInOrder, TakesEachResultInIndexOrderOnceItIsDone) {
  constexpr size_t kJobs = 6;
  std::vector<int> results(kJobs, -1), taken;
  ParallelForInOrder(
      kJobs, 2,
      [&](size_t i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5 * (kJobs - i)));
        results[i] = static_cast<int>(10 * i);
      },
      [&](size_t i) {
        EXPECT_EQ(results[i], static_cast<int>(10 * i)) << "then(" << i << ") before f(" << i << ") returned";
        taken.push_back(static_cast<int>(i));
      });
  EXPECT_EQ(taken, (std::vector<int>{0, 1, 2, 3, 4, 5}));
}

}  // namespace
}  // namespace pneumatic
