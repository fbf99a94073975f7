// `pneumo generate`: closed-loop identification logs of rig C (paper 000 Section V.C), tested
// through the binary as a user runs it and read back with the log library.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "formats/log_csv.h"
#include "test_util.h"

namespace pneumatic {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::ReadText;
using testing::ShippedModel;

constexpr double kDuration = 20;       // s: 2000 rows, ~0.3 s of simulation per run
constexpr double kPeriod = 0.01;       // s: paper 000's 100 Hz loop
constexpr double kHalfStroke = 0.05;   // m: rig C, x in [-0.05, 0.05] (docs/rigs.md)
constexpr double kSupplyMinusExhaust = 6.2e5 - 1.0e5;  // Pa: rig C

std::string Quote(const std::string& s) { return "'" + s + "'"; }

struct Outcome {
  int exit_code = -1;
  std::string err;
};

// runs of the binary shared by the suite: each log is generated once
class GenerateTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // one directory per process: ctest runs each test in its own process, in parallel
    dir_ = new fs::path(fs::path(::testing::TempDir()) / ("generate_test_" + std::to_string(getpid())));
    fs::remove_all(*dir_);
    fs::create_directories(*dir_);
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(*dir_, ec);
    delete dir_;
    dir_ = nullptr;
  }

  static std::string Path(const std::string& file) { return (*dir_ / file).string(); }

  static Outcome Pneumo(const std::string& args) {
    const std::string err = Path("stderr.txt");
    int status = std::system((Quote(PNEUMO_BINARY) + " " + args + " >/dev/null 2>" + Quote(err)).c_str());
    Outcome run;
    run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    run.err = fs::exists(err) ? ReadText(err) : "";
    return run;
  }

  // generates (once per distinct arguments) rig C's log and returns its path
  static std::string Generate(int seed, const std::string& noise = "", double duration = kDuration) {
    const std::string key = std::to_string(seed) + noise + "_" + std::to_string(duration);
    static std::map<std::string, std::string> made;
    if (auto it = made.find(key); it != made.end()) return it->second;
    std::string out = Path("log" + std::to_string(made.size()) + ".csv");
    Outcome run = Pneumo("generate " + Quote(ShippedModel("rig_per_chamber.xml")) + " --duration " +
                         std::to_string(duration) + " --seed " + std::to_string(seed) + " " + noise + " --out " +
                         Quote(out));
    EXPECT_EQ(run.exit_code, 0) << run.err;
    return made[key] = out;
  }
  static std::string NoiseFree(int seed) { return Generate(seed, "--noise-pressure 0 --noise-position 0"); }

  static log::Log Read(const std::string& path) {
    log::ReadResult r = log::ReadLog(path, {});
    EXPECT_TRUE(r.log) << r.error;
    return r.log ? *r.log : log::Log{};
  }
  static const std::vector<double>& Column(const log::Log& log, const std::string& signal) {
    static const std::vector<double> empty;
    int i = log.FindColumn("cyl", signal);
    EXPECT_GE(i, 0) << "no column cyl." << signal;
    return i >= 0 ? log.values[static_cast<size_t>(i)] : empty;
  }

  static fs::path* dir_;
};
fs::path* GenerateTest::dir_ = nullptr;

double StandardDeviation(const std::vector<double>& a, const std::vector<double>& b) {
  double sum = 0, sum2 = 0;
  for (size_t i = 0; i < a.size(); ++i) sum += a[i] - b[i];
  double mean = sum / static_cast<double>(a.size());
  for (size_t i = 0; i < a.size(); ++i) sum2 += (a[i] - b[i] - mean) * (a[i] - b[i] - mean);
  return std::sqrt(sum2 / static_cast<double>(a.size() - 1));
}

TEST_F(GenerateTest, LogReadsBackWith100HzRowsForTheDuration) {
  log::Log log = Read(Generate(1));
  // 20 s at 100 Hz: rows at 0, 0.01, ..., 19.99 (each command held until the next row)
  ASSERT_EQ(log.rows(), 2000u);
  EXPECT_DOUBLE_EQ(log.time.front(), 0);
  EXPECT_NEAR(log.Period(), kPeriod, 1e-12);
  EXPECT_NEAR(log.time.back(), kDuration - kPeriod, 1e-9);
  // the columns docs/log_format.md asks of a per-chamber rig, the velocity and the controller's reference
  for (const char* signal : {"uP", "uN", "p_P", "p_N", "x", "v", "ref"}) EXPECT_GE(log.FindColumn("cyl", signal), 0) << signal;
  // the log says which sampling convention it follows (samples at the row's time, not 10 ms averages)
  std::string comments;
  for (const std::string& c : log.comments) comments += c + "\n";
  EXPECT_THAT(comments, HasSubstr("instantaneous samples at the row's time")) << comments;
}

TEST_F(GenerateTest, CommandsStayWithinThreeToSevenVolts) {
  for (int seed : {1, 2, 3}) {
    log::Log log = Read(NoiseFree(seed));
    for (const char* signal : {"uP", "uN"}) {
      const std::vector<double>& u = Column(log, signal);
      ASSERT_FALSE(u.empty());
      // paper 000 Section V: "we used 3 < u < 7 Volts"
      EXPECT_GE(*std::min_element(u.begin(), u.end()), 3.0) << "seed " << seed << " " << signal;
      EXPECT_LE(*std::max_element(u.begin(), u.end()), 7.0) << "seed " << seed << " " << signal;
    }
    // both chambers are driven: the co-contraction uP + uN varies, not only the difference
    const std::vector<double>& uP = Column(log, "uP");
    const std::vector<double>& uN = Column(log, "uN");
    double lo = 1e9, hi = -1e9;
    for (size_t i = 0; i < uP.size(); ++i) lo = std::min(lo, uP[i] + uN[i]), hi = std::max(hi, uP[i] + uN[i]);
    EXPECT_GT(hi - lo, 1.0) << "seed " << seed << ": uP + uN spans only " << hi - lo << " V";
  }
}

TEST_F(GenerateTest, PistonExploresTheStrokeWithoutTouchingTheLimits) {
  for (int seed : {1, 2, 3}) {
    log::Log log = Read(NoiseFree(seed));
    const std::vector<double>& x = Column(log, "x");
    ASSERT_FALSE(x.empty());
    double lo = *std::min_element(x.begin(), x.end()), hi = *std::max_element(x.begin(), x.end());
    // explores: beyond half the half stroke on both sides
    EXPECT_LT(lo, -0.5 * kHalfStroke) << "seed " << seed;
    EXPECT_GT(hi, 0.5 * kHalfStroke) << "seed " << seed;
    // never reaches the joint limits, between rows either: within a row the piston moves at most
    // |v| T + a T^2 / 2 past the sampled x, with a <= (P_c - P_r) A_P / M = 81.7 m/s^2, the
    // largest pressure force on the 0.5 kg piston (damping only slows it): 4.1 mm + |v| T
    const double a_max = kSupplyMinusExhaust * 7.854e-5 / 0.5;
    const std::vector<double>& v = Column(log, "v");
    ASSERT_EQ(v.size(), x.size());
    double reach = 0;
    for (size_t i = 0; i < x.size(); ++i) {
      reach = std::max(reach, std::fabs(x[i]) + std::fabs(v[i]) * kPeriod + 0.5 * a_max * kPeriod * kPeriod);
    }
    EXPECT_LT(reach, kHalfStroke) << "seed " << seed;
  }
}

TEST_F(GenerateTest, SameSeedGivesIdenticalBytesAndAnotherSeedAnotherLog) {
  const std::string first = ReadText(Generate(1));
  // a second run with the same arguments, to another file
  const std::string again = Path("again.csv");
  Outcome run = Pneumo("generate " + Quote(ShippedModel("rig_per_chamber.xml")) + " --duration " +
                       std::to_string(kDuration) + " --seed 1 --out " + Quote(again));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  // the file names only the model: same arguments, same bytes
  EXPECT_TRUE(ReadText(again) == first);
  // another seed: another reference, co-contraction and noise (held-out data)
  log::Log a = Read(Generate(1)), b = Read(Generate(2));
  EXPECT_NE(ReadText(Generate(2)), first);
  EXPECT_NE(Column(a, "ref"), Column(b, "ref"));
  EXPECT_NE(Column(a, "uP"), Column(b, "uP"));
}

TEST_F(GenerateTest, NoiseHasTheRequestedStandardDeviation) {
  // the same seed with and without noise: the same run (the controller sees the noise-free
  // position), so the difference is the noise alone; 2000 samples estimate a standard
  // deviation within about 1.6 % (1 / sqrt(2 n)), far inside the 10 % asked
  const double sigma_p = 2000, sigma_x = 5e-4;
  char noise[100];
  std::snprintf(noise, sizeof(noise), "--noise-pressure %g --noise-position %g", sigma_p, sigma_x);
  log::Log noisy = Read(Generate(1, noise)), exact = Read(NoiseFree(1));
  ASSERT_EQ(noisy.rows(), exact.rows());
  ASSERT_GE(noisy.rows(), 1000u);
  EXPECT_EQ(Column(noisy, "uP"), Column(exact, "uP"));  // commands are not measured: no noise
  struct Expected {
    const char* signal;
    double sigma;
  };
  // v: sqrt(2) sigma_x / period, the noise of a finite difference of two position samples
  for (Expected e : {Expected{"p_P", sigma_p}, Expected{"p_N", sigma_p}, Expected{"x", sigma_x},
                     Expected{"v", std::sqrt(2.0) * sigma_x / kPeriod}}) {
    double sd = StandardDeviation(Column(noisy, e.signal), Column(exact, e.signal));
    EXPECT_NEAR(sd, e.sigma, 0.1 * e.sigma) << e.signal;
  }
}

TEST_F(GenerateTest, NoiseFreeLogReplaysOpenLoopToItsOwnPressures) {
  // pneumo rollout holds the log's commands from its first row's measured state: the closed loop
  // and the open-loop replay step the same model with the same commands
  const std::string log_path = NoiseFree(1), replay = Path("replay.csv");
  Outcome run = Pneumo("rollout " + Quote(ShippedModel("rig_per_chamber.xml")) + " --commands " + Quote(log_path) +
                       " --out " + Quote(replay));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  log::Log generated = Read(log_path), replayed = Read(replay);
  ASSERT_EQ(generated.rows(), replayed.rows());
  for (const char* signal : {"p_P", "p_N"}) {
    const std::vector<double>& a = Column(generated, signal);
    const std::vector<double>& b = Column(replayed, signal);
    double worst = 0;
    for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::fabs(a[i] - b[i]));
    EXPECT_LE(worst, 1e-3 * kSupplyMinusExhaust) << signal;
  }
}

TEST_F(GenerateTest, RefusesAModelWithoutOneValvePerChamber) {
  const std::string out = Path("rig_a.csv");
  Outcome run = Pneumo("generate " + Quote(ShippedModel("rig_onoff.xml")) + " --duration 1 --seed 1 --out " + Quote(out));
  EXPECT_NE(run.exit_code, 0);
  // names the cylinder, its valve and the valve it needs
  EXPECT_THAT(run.err, HasSubstr("cylinder 'cyl'"));
  EXPECT_THAT(run.err, HasSubstr("valve=onoff"));
  EXPECT_THAT(run.err, HasSubstr("proportional_per_chamber"));
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(GenerateTest, RefusesAMissingModelAndABadDuration) {
  const std::string out = Path("bad.csv");
  Outcome missing = Pneumo("generate " + Quote(Path("no_such_model.xml")) + " --duration 1 --seed 1 --out " + Quote(out));
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_THAT(missing.err, HasSubstr("no_such_model.xml"));
  EXPECT_FALSE(fs::exists(out));
  for (const char* duration : {"0", "-1", "nan", "abc"}) {
    Outcome bad = Pneumo("generate " + Quote(ShippedModel("rig_per_chamber.xml")) + " --duration " + duration +
                         " --seed 1 --out " + Quote(out));
    EXPECT_NE(bad.exit_code, 0) << duration;
    EXPECT_THAT(bad.err, HasSubstr("duration")) << duration;
    EXPECT_FALSE(fs::exists(out)) << duration;
  }
}

}  // namespace
}  // namespace pneumatic
