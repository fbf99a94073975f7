// Tests of the log reader and writer against docs/log_format.md.

#include "formats/log_csv.h"
#include "formats/output_file.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>
#include <cfloat>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace pneumatic::log {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::StartsWith;

// a rig A log in the shape of the example of docs/log_format.md
constexpr char kExample[] =
    "time,cyl.u1,cyl.u2,cyl.u3,cyl.u4,cyl.p_P,cyl.p_N,cyl.x\n"
    "0.000,1,0,0,1,100000.0,100000.0,0.0\n"
    "0.002,1,0,0,1,131250.4,97010.2,0.000012\n";

// parse text as if it were the file "bad.csv"
ReadResult Parse(const std::string& text, const ReadOptions& options = {}) {
  std::istringstream in(text);
  return ParseLog(in, "bad.csv", options);
}

// expect text to be rejected with an error starting "bad.csv:LINE:COLUMN: "
void ExpectRejected(const std::string& text, int line, int column,
                    const std::string& message_part, const ReadOptions& options = {}) {
  SCOPED_TRACE(text);
  const ReadResult result = Parse(text, options);
  EXPECT_FALSE(result.log.has_value());
  EXPECT_THAT(result.error, StartsWith("bad.csv:" + std::to_string(line) + ":" +
                                       std::to_string(column) + ": "));
  EXPECT_THAT(result.error, HasSubstr(message_part));
}

// a fresh directory for the files of one test
class LogFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) / (std::string("log_csv_test_") + info->name());
    fs::remove_all(dir_);
    ASSERT_TRUE(fs::create_directories(dir_));
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  std::string WriteText(const std::string& name, const std::string& text) const {
    std::ofstream(Path(name), std::ios::binary) << text;
    return Path(name);
  }

  std::string ReadText(const std::string& path) const {
    std::ifstream in(path, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }

  // names of the entries of `dir`, sorted; hidden temporaries included
  static std::vector<std::string> Entries(const fs::path& dir) {
    std::vector<std::string> names;
    for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
      names.push_back(entry.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
  }

  fs::path dir_;
};

// a small valid log with one column of each kind of value
Log SmallLog() {
  Log log;
  log.comments = {"rig: models_mjcf/rig_onoff.xml", ""};
  log.columns = {{"cyl", "u1"}, {"cyl", "p_P"}, {"cyl", "x"}};
  log.time = {0.0, 0.002, 0.004};
  log.values = {{1, 0, 1}, {1e5, 1.3e5, 1.2e5}, {0, 1e-5, 2e-5}};
  return log;
}

// SmallLog() as WriteLog() prints it
constexpr char kSmallLogText[] =
    "# rig: models_mjcf/rig_onoff.xml\n#\ntime,cyl.u1,cyl.p_P,cyl.x\n"
    "0,1,100000,0\n0.002,0,130000,0.00001\n0.004,1,120000,0.00002\n";

// a log of some 500 KB, written in many pieces; `scale` tells two of them apart
Log LongLog(double scale) {
  Log log;
  log.comments = {"scale " + std::to_string(scale)};
  log.columns = {{"cyl", "p_P"}, {"cyl", "x"}};
  log.values.resize(2);
  for (int r = 0; r < 20000; ++r) {
    log.time.push_back(r * 0.001);
    log.values[0].push_back(1e5 + scale * r);
    log.values[1].push_back(scale * r / 3.0);
  }
  return log;
}

bool SameLog(const Log& a, const Log& b) {
  auto names = [](const Log& log) {
    std::vector<std::string> names;
    for (const Column& column : log.columns) names.push_back(column.name());
    return names;
  };
  return a.comments == b.comments && names(a) == names(b) && a.time == b.time &&
         a.values == b.values;
}

// accepted input

TEST(LogCsvTest, ParsesSpecExample) {
  const ReadResult result = Parse(kExample);
  ASSERT_TRUE(result.log.has_value()) << result.error;
  EXPECT_EQ(result.error, "");
  const Log& log = *result.log;
  EXPECT_TRUE(log.comments.empty());
  ASSERT_EQ(log.columns.size(), 7u);
  const char* signals[] = {"u1", "u2", "u3", "u4", "p_P", "p_N", "x"};
  for (std::size_t j = 0; j < 7; ++j) {
    EXPECT_EQ(log.columns[j].cylinder, "cyl");
    EXPECT_EQ(log.columns[j].signal, signals[j]);
  }
  EXPECT_EQ(log.columns[4].name(), "cyl.p_P");
  ASSERT_EQ(log.rows(), 2u);
  EXPECT_EQ(log.time, (std::vector<double>{0.0, 0.002}));
  EXPECT_EQ(log.values[0], (std::vector<double>{1, 1}));
  EXPECT_EQ(log.values[1], (std::vector<double>{0, 0}));
  EXPECT_EQ(log.values[4], (std::vector<double>{100000.0, 131250.4}));
  EXPECT_EQ(log.values[5], (std::vector<double>{100000.0, 97010.2}));
  EXPECT_EQ(log.values[6], (std::vector<double>{0.0, 0.000012}));
  EXPECT_DOUBLE_EQ(log.Period(), 0.002);
  EXPECT_EQ(log.FindColumn("cyl", "p_N"), 5);
  EXPECT_EQ(log.FindColumn("cyl", "v"), -1);
  EXPECT_EQ(log.FindColumn("other", "x"), -1);
}

TEST(LogCsvTest, ParsesSpecExampleWithModelCylinders) {
  ReadOptions options;
  options.cylinders = {"cyl", "cyl2"};
  EXPECT_TRUE(Parse(kExample, options).log.has_value());
}

TEST(LogCsvTest, KnownSignalsAreThoseOfTheSpec) {
  std::vector<std::string> names;
  for (const SignalInfo& signal : KnownSignals()) names.push_back(signal.name);
  EXPECT_EQ(names, (std::vector<std::string>{"u", "uP", "uN", "u1", "u2", "u3", "u4", "duty",
                                             "p_P", "p_N", "x", "v", "p_S", "ref"}));
  EXPECT_EQ(FindSignal("u3")->kind, SignalKind::kCommand);
  EXPECT_EQ(FindSignal("p_S")->kind, SignalKind::kMeasured);
  EXPECT_EQ(FindSignal("ref")->kind, SignalKind::kReference);
  EXPECT_STREQ(FindSignal("p_P")->unit, "Pa");
  EXPECT_EQ(FindSignal("pressure"), nullptr);
  EXPECT_TRUE(IsValveState("u4"));
  EXPECT_FALSE(IsValveState("u"));
}

TEST(LogCsvTest, KeepsCommentsBeforeHeader) {
  const ReadResult result = Parse(
      "# rig: models_mjcf/rig_onoff.xml\n#no space\n#\n#  two spaces \n"
      "time,cyl.x\n0,1\n0.5,2\n");
  ASSERT_TRUE(result.log.has_value()) << result.error;
  EXPECT_EQ(result.log->comments, (std::vector<std::string>{
                                      "rig: models_mjcf/rig_onoff.xml", "no space", "",
                                      " two spaces "}));
}

TEST(LogCsvTest, AcceptsCrlfBomSpacesAndTrailingBlankLines) {
  const ReadResult result = Parse(
      "\xEF\xBB\xBF# exported\r\n\r\n time , cyl.x ,\tcyl.u1\r\n0, -1.5e-3 ,1\r\n"
      "0.1,+2,0\r\n\r\n  \n\n");
  ASSERT_TRUE(result.log.has_value()) << result.error;
  EXPECT_EQ(result.log->comments, (std::vector<std::string>{"exported"}));
  EXPECT_EQ(result.log->columns[0].name(), "cyl.x");
  EXPECT_EQ(result.log->time, (std::vector<double>{0, 0.1}));
  EXPECT_EQ(result.log->values[0], (std::vector<double>{-1.5e-3, 2}));
  EXPECT_EQ(result.log->values[1], (std::vector<double>{1, 0}));
}

TEST(LogCsvTest, AcceptsBomBeforeHeader) {
  const ReadResult result = Parse(std::string("\xEF\xBB\xBF") + kExample);
  EXPECT_TRUE(result.log.has_value()) << result.error;
}

TEST(LogCsvTest, AcceptsLastLineWithoutNewline) {
  const ReadResult result = Parse("time,cyl.x\n0,1\n1,2");
  ASSERT_TRUE(result.log.has_value()) << result.error;
  EXPECT_EQ(result.log->rows(), 2u);
}

TEST(LogCsvTest, AcceptsCylinderNamesWithDots) {
  const ReadResult result = Parse("time,arm.cyl.p_P\n0,1e5\n");
  ASSERT_TRUE(result.log.has_value()) << result.error;
  EXPECT_EQ(result.log->columns[0].cylinder, "arm.cyl");
  EXPECT_EQ(result.log->columns[0].signal, "p_P");
}

TEST(LogCsvTest, AcceptsTimeJitterWithinTolerance) {
  // steps of 0.1 accumulate rounding errors of a few ulps
  std::string text = "time,cyl.x\n";
  double t = 0;
  for (int i = 0; i < 100; ++i, t += 0.1) {
    std::ostringstream row;
    row.precision(17);
    row << t << ",0\n";
    text += row.str();
  }
  EXPECT_TRUE(Parse(text).log.has_value());
  EXPECT_TRUE(Parse("time,cyl.x\n0,0\n0.0020000005,0\n0.004,0\n").log.has_value());
}

TEST(LogCsvTest, AcceptsNonUniformTimeWhenAllowed) {
  ReadOptions options;
  options.uniform_time = false;
  const ReadResult result = Parse("time,cyl.x\n0,0\n0.002,0\n0.005,0\n", options);
  ASSERT_TRUE(result.log.has_value()) << result.error;
  EXPECT_DOUBLE_EQ(result.log->Period(), 0.0025);
}

TEST(LogCsvTest, AcceptsValveStatesWrittenAsDecimals) {
  const ReadResult result = Parse("time,cyl.u1,cyl.u2\n0,1.0,0e0\n1,1e0,-0\n");
  ASSERT_TRUE(result.log.has_value()) << result.error;
  EXPECT_EQ(result.log->values[0], (std::vector<double>{1, 1}));
}

// rejected input: each names file, line and column

TEST(LogCsvTest, RejectsEmptyFile) {
  ExpectRejected("", 1, 1, "empty file");
  ExpectRejected("\xEF\xBB\xBF", 2, 1, "expected a header");
}

TEST(LogCsvTest, RejectsFileWithoutHeader) {
  ExpectRejected("# only a comment\n\n", 3, 1, "expected a header line");
}

TEST(LogCsvTest, RejectsMissingTimeColumn) {
  ExpectRejected("cyl.x,cyl.p_P\n1,2\n", 1, 1, "first column is \"cyl.x\", expected \"time\"");
  ExpectRejected("# c\nt,cyl.x\n1,2\n", 2, 1, "expected \"time\"");
}

TEST(LogCsvTest, RejectsTimeNotFirst) {
  ExpectRejected("cyl.x,time\n1,2\n", 1, 2, "\"time\" must be the first column");
}

TEST(LogCsvTest, RejectsColumnNameNotCylinderDotSignal) {
  ExpectRejected("time,cyl.x,pressure\n0,1,2\n", 1, 3, "\"pressure\" is not <cylinder>.<signal>");
  ExpectRejected("time,cyl.\n0,1\n", 1, 2, "is not <cylinder>.<signal>");
  ExpectRejected("time,.x\n0,1\n", 1, 2, "is not <cylinder>.<signal>");
  ExpectRejected("time,cyl.x,\n0,1,2\n", 1, 3, "\"\" is not <cylinder>.<signal>");
}

// a name the writer could not write back: a carriage return or another control character inside it
// (found by tests/fuzz/fuzz_log_csv: the reader accepted it, and its own check of the log refused it)
TEST(LogCsvTest, RejectsCylinderNameWithAControlCharacter) {
  ExpectRejected(std::string("time,cy\rl.x\n0,1\n"), 1, 2, "holds a control character");
  ExpectRejected(std::string("time,cyl.x,a") + '\0' + "b.p_P\n0,1,2\n", 1, 3, "holds a control character");
  ExpectRejected("time,cyl.x,a\tb.p_P\n0,1,2\n", 1, 3, "holds a control character");
}

// found by tests/fuzz/fuzz_log_csv: the reader kept the comment, and its own check of the log refused it
TEST(LogCsvTest, RejectsCarriageReturnInsideAComment) {
  ExpectRejected("# made by\rsomething\ntime,cyl.x\n0,1\n", 1, 1, "carriage return inside a comment line");
}

TEST(LogCsvTest, RejectsUnknownSignal) {
  ExpectRejected("time,cyl.x,cyl.p_A\n0,1,2\n", 1, 3, "unknown signal \"p_A\"");
  ExpectRejected("time,cyl.X\n0,1\n", 1, 2, "unknown signal \"X\"");
}

TEST(LogCsvTest, RejectsCylinderNotInModel) {
  ReadOptions options;
  options.cylinders = {"cyl"};
  ExpectRejected("time,cyl.x,arm.p_P\n0,1,2\n", 1, 3,
                 "cylinder \"arm\" in column \"arm.p_P\" is not in the model, expected one of cyl",
                 options);
}

TEST(LogCsvTest, RejectsDuplicateColumn) {
  ExpectRejected("time,cyl.x,cyl.p_P,cyl.x\n0,1,2,3\n", 1, 4,
                 "duplicate column \"cyl.x\", first in column 2");
  ExpectRejected("time, cyl.x,cyl.x \n0,1,2\n", 1, 3, "duplicate column");
  ExpectRejected("time,cyl.x,time\n0,1,2\n", 1, 3, "duplicate column \"time\"");
}

TEST(LogCsvTest, RejectsRowWithWrongNumberOfFields) {
  ExpectRejected("time,cyl.x,cyl.v\n0,1,2\n0.1,1\n", 3, 3, "row has 2 fields, expected 3");
  ExpectRejected("time,cyl.x,cyl.v\n0,1,2\n0.1,1,2,3\n", 3, 4, "row has 4 fields, expected 3");
  ExpectRejected("time,cyl.x,cyl.v\n0,1,2,\n", 2, 4, "row has 4 fields");
}

TEST(LogCsvTest, RejectsNonNumericValue) {
  ExpectRejected("time,cyl.x,cyl.v\n0,1,2\n0.1,1,abc\n", 3, 3, "value \"abc\" is not a number");
  // the exact message, as promised by the header
  const ReadResult result = Parse("time,cyl.x,cyl.v\n0,1,2\n0.1,1,abc\n");
  EXPECT_EQ(result.error, "bad.csv:3:3: value \"abc\" is not a number");
}

TEST(LogCsvTest, RejectsMalformedNumbers) {
  const std::vector<std::string> bad = {"1.0abc", "0x10", "1e", "\"1\"", "1 2", "--1",
                                        "+", "+-1", ".", "1..2", "1e5e5", "1,5e0"};
  for (const std::string& value : bad) {
    if (value == "1,5e0") continue;  // a decimal comma splits the field: see below
    ExpectRejected("time,cyl.x,cyl.v\n0,1,2\n1,1," + value + "\n", 3, 3, "is not a number");
  }
  ExpectRejected("time,cyl.x,cyl.v\n0,1,2\n1,1,1,5e0\n", 3, 4, "row has 4 fields");
}

TEST(LogCsvTest, RejectsEmptyField) {
  ExpectRejected("time,cyl.x,cyl.v\n0,,2\n", 2, 2, "empty value, expected a number");
  ExpectRejected("time,cyl.x,cyl.v\n0,1,  \n", 2, 3, "empty value");
  ExpectRejected("time,cyl.x\n,1\n", 2, 1, "empty value");
}

TEST(LogCsvTest, RejectsNonFiniteValues) {
  for (const std::string value : {"nan", "NaN", "inf", "-inf", "+Infinity", "nan(0x1)"}) {
    ExpectRejected("time,cyl.x\n0,1\n1," + value + "\n", 3, 2, "is not finite");
  }
  ExpectRejected("time,cyl.x\ninf,1\n", 2, 1, "\"inf\" is not finite");
  ExpectRejected("time,cyl.x\n0,1e400\n", 2, 2, "\"1e400\" is out of the range of a double");
}

TEST(LogCsvTest, RejectsTimeNotIncreasing) {
  ExpectRejected("time,cyl.x\n0,1\n0.002,1\n0.002,1\n", 4, 1,
                 "time 0.002 is not greater than the previous row's 0.002");
  ExpectRejected("time,cyl.x\n0,1\n0.002,1\n0.001,1\n", 4, 1, "expected strictly increasing");
}

TEST(LogCsvTest, RejectsNonUniformSpacing) {
  ExpectRejected("time,cyl.x\n0,1\n0.002,1\n0.004,1\n0.007,1\n0.009,1\n", 5, 1,
                 "differs from the median step 0.002 s");
  ExpectRejected("# c\ntime,cyl.x\n0,1\n0.003,1\n0.005,1\n0.007,1\n", 4, 1,
                 "differs from the median step");
  ExpectRejected("time,cyl.x\n0,0\n0.002,0\n0.004001,0\n", 4, 1, "uniformly spaced");
}

TEST(LogCsvTest, RejectsValveStateOtherThanZeroOrOne) {
  ExpectRejected("time,cyl.u1,cyl.u2,cyl.u3\n0,1,0,0\n1,1,0,0.5\n", 3, 4,
                 "valve state \"0.5\" in column \"cyl.u3\" is not 0 or 1");
  ExpectRejected("time,cyl.x,cyl.u4\n0,0,2\n", 2, 3, "is not 0 or 1");
  ExpectRejected("time,cyl.u2\n0,-1\n", 2, 2, "is not 0 or 1");
  ExpectRejected("time,cyl.u1\n0,0.9999999999\n", 2, 2, "is not 0 or 1");
}

TEST(LogCsvTest, RejectsHeaderWithoutDataRows) {
  ExpectRejected("# c\ntime,cyl.x\n", 2, 1, "header has no data rows");
  ExpectRejected("time,cyl.x\n\n\n", 1, 1, "header has no data rows");
}

TEST(LogCsvTest, RejectsCommentAfterHeader) {
  ExpectRejected("time,cyl.x\n0,1\n# late comment\n1,1\n", 3, 1, "comment line after the header");
  ExpectRejected("time,cyl.x\n#\n0,1\n", 2, 1, "comment line after the header");
}

TEST(LogCsvTest, RejectsBlankLineAmongRows) {
  ExpectRejected("time,cyl.x\n0,1\n\n1,1\n", 3, 1, "blank line among the data rows");
}

TEST(LogCsvTest, RejectsOverlongLine) {
  ExpectRejected("time,cyl.x\n0," + std::string(3 << 20, '1') + "\n", 2, 1,
                 "line is longer than");
}

TEST(LogCsvTest, QuotesJunkSafelyInMessages) {
  const ReadResult result = Parse("time,cyl.x\n0,1\x01\x7f\"" + std::string(100, 'z') + "\n");
  ASSERT_FALSE(result.log.has_value());
  EXPECT_THAT(result.error, StartsWith("bad.csv:2:2: value \"1\\x01\\x7f\\x22zzz"));
  EXPECT_THAT(result.error, HasSubstr("...\" is not a number"));
  EXPECT_LT(result.error.size(), 120u);
}

TEST(LogCsvTest, NeverCrashesOnJunk) {
  // every prefix of a valid file, and random bytes
  const std::string valid = std::string("\xEF\xBB\xBF# c\r\n") + kExample;
  for (std::size_t n = 0; n <= valid.size(); ++n) {
    const ReadResult result = Parse(valid.substr(0, n));
    EXPECT_NE(result.log.has_value(), !result.error.empty());
  }
  std::mt19937 random(42);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int trial = 0; trial < 2000; ++trial) {
    std::string text = trial % 2 ? "time,cyl.x\n" : "";
    const int size = trial % 300;
    for (int i = 0; i < size; ++i) {
      const int b = byte(random);
      text += static_cast<char>(b < 64 ? "0123456789.,\n\r#e-+ \t"[b % 21] : b);
    }
    const ReadResult result = Parse(text);
    EXPECT_NE(result.log.has_value(), !result.error.empty());
  }
}

// files

TEST_F(LogFileTest, ReadsExampleFile) {
  const ReadResult result = ReadLog(WriteText("example.csv", kExample), {});
  ASSERT_TRUE(result.log.has_value()) << result.error;
  EXPECT_EQ(result.log->rows(), 2u);
}

TEST_F(LogFileTest, RejectionNamesThePath) {
  const std::string path = WriteText("log.csv", "time,cyl.x\n0,1\n1,2\n2,abc\n");
  const ReadResult result = ReadLog(path, {});
  EXPECT_EQ(result.error, path + ":4:2: value \"abc\" is not a number");
}

TEST_F(LogFileTest, RejectsMissingFile) {
  const ReadResult result = ReadLog(Path("absent.csv"), {});
  EXPECT_FALSE(result.log.has_value());
  EXPECT_THAT(result.error, StartsWith(Path("absent.csv") + ": cannot open"));
}

TEST_F(LogFileTest, RejectsDirectory) {
  const ReadResult result = ReadLog(dir_.string(), {});
  EXPECT_FALSE(result.log.has_value());
  EXPECT_THAT(result.error, HasSubstr("is a directory"));
}

TEST_F(LogFileTest, RoundTripIsBitIdentical) {
  Log log = SmallLog();
  log.columns.push_back({"arm.cyl2", "ref"});
  log.values.push_back({-0.0, DBL_MIN, 4.9e-324});
  log.columns.push_back({"cyl2", "p_S"});
  log.values.push_back({DBL_MAX, -DBL_MAX, 1.0 / 3.0});
  log.columns.push_back({"cyl2", "v"});
  log.values.push_back({0.1 + 0.2, 1e-300, 123456789012345678.0});
  // random bit patterns
  std::mt19937_64 random(7);
  Log noise;
  noise.columns = {{"cyl", "u"}, {"cyl", "p_N"}};
  noise.values.resize(2);
  for (int r = 0; r < 1000; ++r) {
    noise.time.push_back(r * 0.001);
    for (auto& column : noise.values) {
      double value;
      do {
        const std::uint64_t bits = random();
        std::memcpy(&value, &bits, sizeof(value));
      } while (!std::isfinite(value));
      column.push_back(value);
    }
  }
  for (const Log* original : {&log, &noise}) {
    const std::string path = Path("round_trip.csv");
    ASSERT_EQ(WriteLog(path, *original), "");
    EXPECT_EQ(Entries(dir_), std::vector<std::string>{"round_trip.csv"});
    const ReadResult result = ReadLog(path, {});
    ASSERT_TRUE(result.log.has_value()) << result.error;
    const Log& read = *result.log;
    EXPECT_EQ(read.comments, original->comments);
    ASSERT_EQ(read.columns.size(), original->columns.size());
    for (std::size_t j = 0; j < read.columns.size(); ++j) {
      EXPECT_EQ(read.columns[j].name(), original->columns[j].name());
      EXPECT_EQ(read.columns[j].cylinder, original->columns[j].cylinder);
    }
    ASSERT_EQ(read.rows(), original->rows());
    EXPECT_EQ(std::memcmp(read.time.data(), original->time.data(),
                          read.rows() * sizeof(double)),
              0);
    for (std::size_t j = 0; j < read.values.size(); ++j) {
      ASSERT_EQ(read.values[j].size(), original->values[j].size());
      EXPECT_EQ(std::memcmp(read.values[j].data(), original->values[j].data(),
                            read.rows() * sizeof(double)),
                0)
          << read.columns[j].name();
    }
  }
}

TEST_F(LogFileTest, WritesPlainReadableNumbers) {
  const std::string path = Path("plain.csv");
  ASSERT_EQ(WriteLog(path, SmallLog()), "");
  EXPECT_EQ(ReadText(path), kSmallLogText);
}

TEST_F(LogFileTest, WriteRefusesLogsTheReaderWouldReject) {
  const std::string path = Path("refused.csv");
  auto expect_refused = [&](const Log& log, const std::string& message_part) {
    EXPECT_THAT(WriteLog(path, log), HasSubstr(message_part));
    EXPECT_TRUE(fs::is_empty(dir_));
  };
  Log log = SmallLog();
  log.values[1].pop_back();
  expect_refused(log, "has 2 values, expected one per row (3)");
  log = SmallLog();
  log.values[2][1] = std::numeric_limits<double>::quiet_NaN();
  expect_refused(log, "expected a finite number");
  log = SmallLog();
  log.values[0][1] = 0.5;
  expect_refused(log, "0 or 1 for valve states");
  log = SmallLog();
  log.columns[1].signal = "pressure";
  expect_refused(log, "unknown signal \"pressure\"");
  log = SmallLog();
  log.columns[1] = log.columns[2];
  expect_refused(log, "duplicate column \"cyl.x\"");
  log = SmallLog();
  log.columns[1].cylinder = "a,b";
  expect_refused(log, "cannot be written in a header");
  log = SmallLog();
  log.time[2] = log.time[1];
  expect_refused(log, "not greater than the previous row's");
  log = SmallLog();
  log.comments.push_back("two\nlines");
  expect_refused(log, "contains a line break");
  log = SmallLog();
  log.values.pop_back();
  expect_refused(log, "3 columns but 2 value vectors");
  expect_refused(Log{}, "log has no rows");
}

TEST_F(LogFileTest, FailedWriteKeepsPreviousFile) {
  const std::string path = WriteText("kept.csv", kExample);
  Log log = SmallLog();
  log.values[0][0] = 2;
  EXPECT_NE(WriteLog(path, log), "");
  EXPECT_EQ(ReadText(path), kExample);
  // a destination that is a directory is refused, and nothing is left beside it
  fs::create_directory(Path("taken.csv"));
  EXPECT_EQ(WriteLog(Path("taken.csv"), SmallLog()),
            Path("taken.csv") + ": is a directory, expected a log file");
  EXPECT_EQ(Entries(dir_), (std::vector<std::string>{"kept.csv", "taken.csv"}));
  EXPECT_TRUE(fs::is_empty(Path("taken.csv")));
}

TEST_F(LogFileTest, WriteReplacesExistingFileAndLeavesNoTemporary) {
  const std::string path = WriteText("replaced.csv", kExample);
  ASSERT_EQ(WriteLog(path, SmallLog()), "");
  EXPECT_EQ(ReadText(path), kSmallLogText);
  EXPECT_EQ(Entries(dir_), std::vector<std::string>{"replaced.csv"});
}

// A tool stopped by Ctrl-C or `kill` in the middle of writing an output: a child process writes half
// of a text, says so through a pipe and waits; it is then signalled. The output must be the file that
// was there before (or absent), and no temporary may be left beside it.
TEST_F(LogFileTest, SignalDuringAWriteLeavesTheOutputUntouchedAndNoTemporary) {
  for (int signal_number : {SIGINT, SIGTERM}) {
    SCOPED_TRACE(signal_number == SIGINT ? "SIGINT" : "SIGTERM");
    const std::string path = WriteText("kept.csv", kExample);
    int ready[2];
    ASSERT_EQ(::pipe(ready), 0);
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      ::close(ready[0]);
      WriteOutput(path, [&](const std::function<bool(std::string_view)>& emit) {
        if (!emit("time,cyl.x\n0,1\n")) return false;
        const char byte = 1;
        if (::write(ready[1], &byte, 1) != 1) ::_exit(3);
        ::pause();  // half written: wait for the signal
        return emit("1,2\n");
      }, "a log file");
      ::_exit(0);  // not reached: the signal ends the child
    }
    ::close(ready[1]);
    char byte = 0;
    ASSERT_EQ(::read(ready[0], &byte, 1), 1) << "the child did not start writing";
    ::close(ready[0]);
    ASSERT_EQ(::kill(child, signal_number), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == signal_number) << "ended as the signal ends a process";
    EXPECT_EQ(ReadText(path), kExample);
    EXPECT_EQ(Entries(dir_), std::vector<std::string>{"kept.csv"}) << "a temporary was left behind";
  }
}

TEST_F(LogFileTest, NewFileGetsThePermissionsOfTheUmask) {
  const mode_t previous = ::umask(027);
  const std::string error = WriteLog(Path("new.csv"), SmallLog());
  ::umask(previous);
  ASSERT_EQ(error, "");
  EXPECT_EQ(fs::status(Path("new.csv")).permissions(),
            fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
}

TEST_F(LogFileTest, WriteThroughSymlinkReplacesTheFileAndKeepsTheLink) {
  const std::string target = WriteText("target.csv", kExample);
  fs::create_symlink("target.csv", Path("link.csv"));
  ASSERT_EQ(WriteLog(Path("link.csv"), SmallLog()), "");
  EXPECT_TRUE(fs::is_symlink(Path("link.csv")));
  EXPECT_EQ(ReadText(target), kSmallLogText);
  EXPECT_EQ(Entries(dir_), (std::vector<std::string>{"link.csv", "target.csv"}));
}

TEST_F(LogFileTest, WriteIntoMissingDirectoryFailsAndCreatesNothing) {
  const std::string path = Path("missing/dir/out.csv");
  EXPECT_EQ(WriteLog(path, SmallLog()), path + ": cannot create a temporary file in " +
                                            Path("missing/dir") + ": " + std::strerror(ENOENT));
  EXPECT_TRUE(fs::is_empty(dir_));
}

TEST_F(LogFileTest, WriteIntoUnwritableDirectoryFailsAndCreatesNothing) {
  if (::geteuid() == 0) GTEST_SKIP() << "root can write into any directory";
  const std::string locked = Path("locked"), path = Path("locked/out.csv");
  ASSERT_TRUE(fs::create_directory(locked));
  fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec);
  const std::string error = WriteLog(path, SmallLog());
  fs::permissions(locked, fs::perms::owner_all);
  EXPECT_EQ(error,
            path + ": cannot create a temporary file in " + locked + ": " + std::strerror(EACCES));
  EXPECT_TRUE(fs::is_empty(locked));
}

// CheckOutputPath, run before long work, refuses what the write would refuse, with the write's own
// message, and lets through what it would write (a new or existing file, a device, standard output)
TEST_F(LogFileTest, OutputCheckGivesTheWritesOwnVerdictBeforehand) {
  for (const std::string& bad : {dir_.string(), Path("missing/dir/out.csv")}) {
    SCOPED_TRACE(bad);
    const std::string checked = CheckOutputPath(bad, "a log file");
    EXPECT_NE(checked, "");
    EXPECT_EQ(checked, WriteLog(bad, SmallLog()));
  }
  for (const std::string& good : {Path("new.csv"), WriteText("old.csv", "x"), std::string("/dev/null"), std::string("-")}) {
    EXPECT_EQ(CheckOutputPath(good, "a log file"), "") << good;
  }
  EXPECT_EQ(ReadText(Path("old.csv")), "x") << "checking writes nothing";
  EXPECT_EQ(Entries(dir_), std::vector<std::string>{"old.csv"});
}

TEST_F(LogFileTest, ConcurrentWritersOfOneTargetBothSucceedAndLeaveOneCompleteLog) {
  const Log a = LongLog(1), b = LongLog(2);
  const std::string path = Path("shared.csv");
  for (int round = 0; round < 10; ++round) {
    std::string error_a = "not run", error_b = "not run";
    std::thread writer_a([&] { error_a = WriteLog(path, a); });
    std::thread writer_b([&] { error_b = WriteLog(path, b); });
    writer_a.join();
    writer_b.join();
    EXPECT_EQ(error_a, "");
    EXPECT_EQ(error_b, "");
    const ReadResult read = ReadLog(path, {});
    ASSERT_TRUE(read.log.has_value()) << read.error;
    EXPECT_TRUE(SameLog(*read.log, a) || SameLog(*read.log, b)) << "round " << round;
    EXPECT_EQ(Entries(dir_), std::vector<std::string>{"shared.csv"});
  }
}

// special files are written in place and stay what they are

TEST_F(LogFileTest, WriteToDevFullFailsAndKeepsTheDevice) {
  if (!fs::is_character_file("/dev/full")) GTEST_SKIP() << "no /dev/full";
  EXPECT_EQ(WriteLog("/dev/full", SmallLog()),
            std::string("/dev/full: writing failed: ") + std::strerror(ENOSPC));
  EXPECT_TRUE(fs::is_character_file(fs::symlink_status("/dev/full")));
}

TEST_F(LogFileTest, WriteToFifoDeliversTheLogAndKeepsTheFifo) {
  const std::string path = Path("pipe");
  ASSERT_EQ(::mkfifo(path.c_str(), 0600), 0) << std::strerror(errno);
  // a read end, and a spare write end so that the reader sees the end only after WriteLog
  const int reader = ::open(path.c_str(), O_RDONLY | O_NONBLOCK);
  ASSERT_GE(reader, 0) << std::strerror(errno);
  const int spare = ::open(path.c_str(), O_WRONLY);
  ASSERT_GE(spare, 0) << std::strerror(errno);
  ASSERT_EQ(::fcntl(reader, F_SETFL, 0), 0);
  std::string received;
  std::thread read_all([&] {
    char buffer[4096];
    for (ssize_t n; (n = ::read(reader, buffer, sizeof(buffer))) > 0;) {
      received.append(buffer, static_cast<std::size_t>(n));
    }
  });
  const Log log = LongLog(1);  // more than a pipe holds: needs the reader
  const std::string error = WriteLog(path, log);
  ::close(spare);
  read_all.join();
  ::close(reader);
  EXPECT_EQ(error, "");
  std::istringstream in(received);
  const ReadResult read = ParseLog(in, path, {});
  ASSERT_TRUE(read.log.has_value()) << read.error;
  EXPECT_TRUE(SameLog(*read.log, log));
  EXPECT_TRUE(fs::is_fifo(fs::symlink_status(path)));
  EXPECT_EQ(Entries(dir_), std::vector<std::string>{"pipe"});
}

TEST_F(LogFileTest, WriteToDashWritesStandardOutput) {
  ::testing::internal::CaptureStdout();
  const std::string error = WriteLog("-", SmallLog());
  EXPECT_EQ(::testing::internal::GetCapturedStdout(), kSmallLogText);
  EXPECT_EQ(error, "");
  EXPECT_FALSE(fs::exists("-"));
}

TEST_F(LogFileTest, WriteToDevStdoutWritesInPlaceAndKeepsTheLink) {
  if (!fs::is_symlink(fs::symlink_status("/dev/stdout"))) GTEST_SKIP() << "no /dev/stdout link";
  const fs::path link = fs::read_symlink("/dev/stdout");
  ::testing::internal::CaptureStdout();  // stdout becomes a regular file
  const std::string error = WriteLog("/dev/stdout", SmallLog());
  EXPECT_EQ(::testing::internal::GetCapturedStdout(), kSmallLogText);
  EXPECT_EQ(error, "");
  EXPECT_TRUE(fs::is_symlink(fs::symlink_status("/dev/stdout")));
  std::error_code ec;
  EXPECT_EQ(fs::read_symlink("/dev/stdout", ec), link);
}

}  // namespace
}  // namespace pneumatic::log
