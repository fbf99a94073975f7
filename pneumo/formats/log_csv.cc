// Reader and writer for the CSV log format of docs/log_format.md.

#include "formats/log_csv.h"

#include "formats/output_file.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <new>
#include <system_error>

namespace pneumatic::log {
namespace {

constexpr std::size_t kMaxLineLength = 1 << 20;
constexpr std::string_view kByteOrderMark = "\xEF\xBB\xBF";

// quote text found in a file for a message: escape control bytes, shorten long texts
std::string Quote(std::string_view text) {
  constexpr std::size_t kMaxShown = 40;
  std::string out = "\"";
  for (std::size_t i = 0; i < text.size() && i < kMaxShown; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 || c == 0x7f || c == '"' || c == '\\') {
      char escaped[8];
      std::snprintf(escaped, sizeof(escaped), "\\x%02x", c);
      out += escaped;
    } else {
      out += static_cast<char>(c);
    }
  }
  if (text.size() > kMaxShown) out += "...";
  return out + "\"";
}

// shortest decimal text that reads back to the same double; plain unless very long
std::string Format(double value) {
  char buffer[32];
  const auto fixed = std::to_chars(buffer, buffer + 24, value, std::chars_format::fixed);
  if (fixed.ec == std::errc()) return std::string(buffer, fixed.ptr);
  const auto shortest = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, shortest.ptr);
}

std::string_view Trim(std::string_view text) {
  const std::size_t begin = text.find_first_not_of(" \t");
  if (begin == std::string_view::npos) return {};
  return text.substr(begin, text.find_last_not_of(" \t") - begin + 1);
}

// what keeps `cylinder` from standing in a header as the part of a column name before its dot: empty,
// spaces around it, a comma, or a control character (a line break among them); "" if nothing
std::string CylinderNameProblem(std::string_view cylinder) {
  if (cylinder.empty()) return "is empty";
  if (Trim(cylinder) != cylinder) return "has spaces around it";
  for (const char c : cylinder) {
    if (c == ',') return "holds a comma";
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) return "holds a control character";
  }
  return "";
}

// the comma-separated fields of a line, without surrounding spaces
std::vector<std::string_view> SplitFields(std::string_view line) {
  std::vector<std::string_view> fields;
  for (;;) {
    const std::size_t comma = line.find(',');
    fields.push_back(Trim(line.substr(0, comma)));
    if (comma == std::string_view::npos) return fields;
    line.remove_prefix(comma + 1);
  }
}

// parse a whole field as a finite double (locale independent); returns what is wrong
std::string ParseNumber(std::string_view field, double* value) {
  if (field.empty()) return "empty value, expected a number";
  std::string_view digits = field;
  if (digits.size() > 1 && digits[0] == '+' && digits[1] != '+' && digits[1] != '-') {
    digits.remove_prefix(1);
  }
  const char* end = digits.data() + digits.size();
  const auto [last, ec] = std::from_chars(digits.data(), end, *value);
  if (ec == std::errc::result_out_of_range) {
    return "value " + Quote(field) + " is out of the range of a double";
  }
  if (ec != std::errc() || last != end) return "value " + Quote(field) + " is not a number";
  if (!std::isfinite(*value)) return "value " + Quote(field) + " is not finite";
  return "";
}

// read one line without its '\n' or "\r\n"; kEnd when the input is exhausted
enum class LineStatus { kLine, kEnd, kTooLong };
LineStatus ReadLine(std::istream& in, std::string* line) {
  using Traits = std::istream::traits_type;
  line->clear();
  std::streambuf* buffer = in.rdbuf();
  if (!buffer) return LineStatus::kEnd;
  bool any = false;
  for (Traits::int_type c = buffer->sbumpc(); !Traits::eq_int_type(c, Traits::eof());
       c = buffer->sbumpc()) {
    any = true;
    if (c == '\n') break;
    if (line->size() >= kMaxLineLength) return LineStatus::kTooLong;
    line->push_back(Traits::to_char_type(c));
  }
  if (!line->empty() && line->back() == '\r') line->pop_back();
  return any ? LineStatus::kLine : LineStatus::kEnd;
}

std::string SignalNames() {
  std::string names;
  for (const SignalInfo& signal : KnownSignals()) {
    names += (names.empty() ? "" : ", ") + std::string(signal.name);
  }
  return names;
}

// the columns named by a header; on error returns the message and sets *column
std::string ParseHeader(const std::vector<std::string_view>& fields,
                        const ReadOptions& options, std::vector<Column>* columns,
                        std::size_t* column) {
  const auto time = std::find(fields.begin(), fields.end(), "time");
  if (time != fields.begin()) {
    *column = time == fields.end() ? 1 : static_cast<std::size_t>(time - fields.begin()) + 1;
    return time == fields.end()
               ? "first column is " + Quote(fields[0]) + ", expected \"time\""
               : std::string("column \"time\" must be the first column");
  }
  std::map<std::string_view, std::size_t> seen;
  for (std::size_t i = 1; i < fields.size(); ++i) {
    const std::string_view field = fields[i];
    const std::size_t dot = field.rfind('.');
    *column = i + 1;
    if (field == "time") return "duplicate column \"time\"";
    if (dot == std::string_view::npos || dot == 0 || dot + 1 == field.size()) {
      return "column name " + Quote(field) + " is not <cylinder>.<signal>";
    }
    const std::string cylinder(field.substr(0, dot));
    const std::string signal(field.substr(dot + 1));
    if (std::string problem = CylinderNameProblem(cylinder); !problem.empty()) {
      return "cylinder name " + Quote(cylinder) + " in column " + Quote(field) + " " + problem;
    }
    if (!FindSignal(signal)) {
      return "unknown signal " + Quote(signal) + " in column " + Quote(field) +
             ", expected one of " + SignalNames();
    }
    if (!options.cylinders.empty() && !options.cylinders.count(cylinder)) {
      std::string names;
      for (const std::string& name : options.cylinders) names += (names.empty() ? "" : ", ") + name;
      return "cylinder " + Quote(cylinder) + " in column " + Quote(field) +
             " is not in the model, expected one of " + names;
    }
    const auto [previous, inserted] = seen.emplace(field, i + 1);
    if (!inserted) {
      return "duplicate column " + Quote(field) + ", first in column " +
             std::to_string(previous->second);
    }
    columns->push_back({cylinder, signal});
  }
  return "";
}

// the first i whose step time[i+1] - time[i] differs from the median step (relative 1e-6 plus
// 1e-9 s), or -1; *median is set when there are at least three rows
long NonUniformStep(const std::vector<double>& time, double* median) {
  if (time.size() < 3) return -1;
  std::vector<double> steps(time.size() - 1);
  for (std::size_t i = 0; i < steps.size(); ++i) steps[i] = time[i + 1] - time[i];
  std::vector<double> sorted = steps;
  const auto middle = sorted.begin() + static_cast<std::ptrdiff_t>((sorted.size() - 1) / 2);
  std::nth_element(sorted.begin(), middle, sorted.end());
  *median = *middle;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    if (std::fabs(steps[i] - *median) > 1e-6 * *median + 1e-9) return static_cast<long>(i);
  }
  return -1;
}

// the text of a comment line after its '#' and one space; an error if it holds a carriage return
std::string ParseComment(const std::string& text, std::string* comment) {
  *comment = text.substr(text.find('#') + 1);
  if (!comment->empty() && (*comment)[0] == ' ') comment->erase(0, 1);
  if (comment->find('\r') != std::string::npos) {
    // a line break the writer could not write back (a file with carriage-return line endings?)
    return "carriage return inside a comment line, expected line feeds between lines";
  }
  return "";
}

// a data row's fields appended to log's time and values; on error returns the message and sets
// *column
std::string ParseRow(const std::vector<std::string_view>& fields, const std::vector<bool>& is_valve,
                     Log* log, std::size_t* column) {
  if (fields.size() != log->columns.size() + 1) {
    *column = std::min(fields.size(), log->columns.size() + 1) + 1;
    return "row has " + std::to_string(fields.size()) + " fields, expected " +
           std::to_string(log->columns.size() + 1) + " as in the header";
  }
  for (std::size_t i = 0; i < fields.size(); ++i) {
    double value = 0;
    *column = i + 1;
    const std::string problem = ParseNumber(fields[i], &value);
    if (!problem.empty()) return problem;
    if (i == 0) {
      if (!log->time.empty() && !(value > log->time.back())) {
        return "time " + Format(value) + " is not greater than the previous row's " +
               Format(log->time.back()) + ", expected strictly increasing time";
      }
      log->time.push_back(value);
    } else {
      if (is_valve[i - 1] && value != 0 && value != 1) {
        return "valve state " + Quote(fields[i]) + " in column " +
               Quote(log->columns[i - 1].name()) + " is not 0 or 1";
      }
      log->values[i - 1].push_back(value);
    }
  }
  return "";
}

// uniform spacing: every step matches the median step; on error returns the message and sets
// *line to the line of the row that breaks it
std::string SpacingProblem(const Log& log, const std::vector<std::size_t>& row_lines,
                           std::size_t* line) {
  double median = 0;
  if (const long i = NonUniformStep(log.time, &median); i >= 0) {
    const auto k = static_cast<std::size_t>(i);
    *line = row_lines[k + 1];
    return "time step " + Format(log.time[k + 1] - log.time[k]) +
           " s differs from the median step " + Format(median) +
           " s, expected uniformly spaced rows";
  }
  return "";
}

ReadResult Parse(std::istream& in, const std::string& name, const ReadOptions& options) {
  auto fail = [&name](std::size_t line, std::size_t column, const std::string& message) {
    ReadResult result;
    result.error = name + ":" + std::to_string(line) + ":" + std::to_string(column) + ": " +
                   message;
    return result;
  };
  Log log;
  std::string text;
  std::size_t line_number = 0, header_line = 0, blank_line = 0;
  std::vector<std::size_t> row_lines;  // line of each row, for the spacing check
  std::vector<bool> is_valve;
  for (LineStatus status; (status = ReadLine(in, &text)) != LineStatus::kEnd;) {
    ++line_number;
    if (status == LineStatus::kTooLong) {
      return fail(line_number, 1, "line is longer than " + std::to_string(kMaxLineLength) +
                                      " bytes, expected a log line");
    }
    if (line_number == 1 && text.compare(0, kByteOrderMark.size(), kByteOrderMark) == 0) {
      text.erase(0, kByteOrderMark.size());
    }
    const std::string_view line = Trim(text);

    // blank lines: before the header, or trailing
    if (line.empty()) {
      if (header_line && !blank_line) blank_line = line_number;
      continue;
    }
    if (blank_line) return fail(blank_line, 1, "blank line among the data rows");

    // comments: only before the header
    if (line[0] == '#') {
      if (header_line) {
        return fail(line_number, 1, "comment line after the header, expected a data row");
      }
      std::string comment;
      if (std::string problem = ParseComment(text, &comment); !problem.empty()) {
        return fail(line_number, 1, problem);
      }
      log.comments.push_back(std::move(comment));
      continue;
    }
    const std::vector<std::string_view> fields = SplitFields(line);

    // header
    if (!header_line) {
      std::size_t column = 1;
      const std::string problem = ParseHeader(fields, options, &log.columns, &column);
      if (!problem.empty()) return fail(line_number, column, problem);
      header_line = line_number;
      log.values.resize(log.columns.size());
      for (const Column& c : log.columns) is_valve.push_back(IsValveState(c.signal));
      continue;
    }

    // data row
    std::size_t column = 1;
    if (std::string problem = ParseRow(fields, is_valve, &log, &column); !problem.empty()) {
      return fail(line_number, column, problem);
    }
    row_lines.push_back(line_number);
  }
  if (!header_line) {
    return fail(line_number + 1, 1,
                std::string(line_number == 0 ? "empty file" : "end of file") +
                    ", expected a header line starting with \"time\"");
  }
  if (log.time.empty()) return fail(header_line, 1, "header has no data rows");

  if (options.uniform_time) {
    std::size_t line = 0;
    if (std::string problem = SpacingProblem(log, row_lines, &line); !problem.empty()) {
      return fail(line, 1, problem);
    }
  }
  log.source = name;
  log.row_lines = std::move(row_lines);
  return {std::move(log), ""};
}

// what would make the reader reject `log` (spacing aside), or ""
std::string CheckContents(const Log& log) {
  if (log.time.empty()) return "log has no rows";
  if (log.values.size() != log.columns.size()) {
    return "log has " + std::to_string(log.columns.size()) + " columns but " +
           std::to_string(log.values.size()) + " value vectors";
  }
  for (const std::string& comment : log.comments) {
    if (comment.find_first_of("\r\n") != std::string::npos) {
      return "comment " + Quote(comment) + " contains a line break";
    }
  }
  for (std::size_t r = 0; r < log.rows(); ++r) {
    if (!std::isfinite(log.time[r]) || (r > 0 && !(log.time[r] > log.time[r - 1]))) {
      return "time " + Format(log.time[r]) + " of row " + std::to_string(r) +
             " is not finite or not greater than the previous row's";
    }
  }
  std::map<std::string, std::size_t> seen;
  for (std::size_t j = 0; j < log.columns.size(); ++j) {
    const Column& column = log.columns[j];
    const std::string name = column.name();
    if (std::string problem = CylinderNameProblem(column.cylinder); !problem.empty()) {
      return "cylinder name " + Quote(column.cylinder) + " cannot be written in a header: it " + problem;
    }
    if (!FindSignal(column.signal)) return "unknown signal " + Quote(column.signal);
    if (!seen.emplace(name, j).second) return "duplicate column " + Quote(name);
    if (log.values[j].size() != log.rows()) {
      return "column " + Quote(name) + " has " + std::to_string(log.values[j].size()) +
             " values, expected one per row (" + std::to_string(log.rows()) + ")";
    }
    for (const double value : log.values[j]) {
      if (!std::isfinite(value) || (IsValveState(column.signal) && value != 0 && value != 1)) {
        return "column " + Quote(name) + " holds " + Format(value) +
               ", expected a finite number (0 or 1 for valve states)";
      }
    }
  }
  return "";
}

// the text of `log` in pieces of about 64 KiB, handed to `emit` until it returns false
bool EmitText(const Log& log, const std::function<bool(std::string_view)>& emit) {
  std::string text;
  for (const std::string& comment : log.comments) {
    text += '#' + std::string(comment.empty() ? "" : " ") + comment + '\n';
  }
  text += "time";
  for (const Column& column : log.columns) text += ',' + column.name();
  text += '\n';
  for (std::size_t r = 0; r < log.rows(); ++r) {
    text += Format(log.time[r]);
    for (const std::vector<double>& values : log.values) text += ',' + Format(values[r]);
    text += '\n';
    if (text.size() >= (1 << 16)) {
      if (!emit(text)) return false;
      text.clear();
    }
  }
  return emit(text);
}

}  // namespace

std::string ValidateLog(const Log& log, bool uniform_time) {
  if (std::string problem = CheckContents(log); !problem.empty()) return problem;
  double median = 0;
  if (const long i = uniform_time ? NonUniformStep(log.time, &median) : -1; i >= 0) {
    const auto k = static_cast<std::size_t>(i);
    return "rows " + std::to_string(k) + " and " + std::to_string(k + 1) + " are " +
           Format(log.time[k + 1] - log.time[k]) + " s apart, not the median step " + Format(median) +
           " s: rows must be uniformly spaced";
  }
  return "";
}

const std::vector<SignalInfo>& KnownSignals() {
  static const std::vector<SignalInfo> signals = {
      {"u", SignalKind::kCommand, "V",
       "proportional valve command (rig B: relative to the valve centre, in [-5, 5])"},
      {"uP", SignalKind::kCommand, "V", "proportional valve command of chamber P"},
      {"uN", SignalKind::kCommand, "V", "proportional valve command of chamber N"},
      {"u1", SignalKind::kCommand, "1", "on/off valve U1, P-supply: 0 closed, 1 open"},
      {"u2", SignalKind::kCommand, "1", "on/off valve U2, P-exhaust: 0 closed, 1 open"},
      {"u3", SignalKind::kCommand, "1", "on/off valve U3, N-supply: 0 closed, 1 open"},
      {"u4", SignalKind::kCommand, "1", "on/off valve U4, N-exhaust: 0 closed, 1 open"},
      {"duty", SignalKind::kCommand, "1", "averaged PWM command in [-1, 1] (paper 003)"},
      {"p_P", SignalKind::kMeasured, "Pa", "absolute pressure of chamber P"},
      {"p_N", SignalKind::kMeasured, "Pa", "absolute pressure of chamber N"},
      {"x", SignalKind::kMeasured, "m or rad", "rod position or angle of the driven joint"},
      {"v", SignalKind::kMeasured, "m/s or rad/s", "velocity of x (optional)"},
      {"p_S", SignalKind::kMeasured, "Pa", "absolute supply pressure (optional)"},
      {"ref", SignalKind::kReference, "m or rad", "the controller's reference for x (optional)"},
  };
  return signals;
}

const SignalInfo* FindSignal(std::string_view name) {
  for (const SignalInfo& signal : KnownSignals()) {
    if (name == signal.name) return &signal;
  }
  return nullptr;
}

bool IsValveState(std::string_view signal) {
  return signal == "u1" || signal == "u2" || signal == "u3" || signal == "u4";
}

int Log::FindColumn(const std::string& cylinder, const std::string& signal) const {
  for (std::size_t j = 0; j < columns.size(); ++j) {
    if (columns[j].cylinder == cylinder && columns[j].signal == signal) {
      return static_cast<int>(j);
    }
  }
  return -1;
}

std::string Log::Where(std::size_t row, std::size_t column) const {
  if (row < row_lines.size() && column < columns.size()) {
    // the file's columns count time as column 1
    return source + ":" + std::to_string(row_lines[row]) + ":" + std::to_string(column + 2);
  }
  return "row " + std::to_string(row) + ", column " + (column < columns.size() ? columns[column].name() : "?");
}

double Log::Period() const {
  if (time.size() < 2) return 0;
  return (time.back() - time.front()) / static_cast<double>(time.size() - 1);
}

ReadResult ParseLog(std::istream& in, const std::string& name, const ReadOptions& options) {
  try {
    return Parse(in, name, options);
  } catch (const std::bad_alloc&) {
    return {std::nullopt, name + ": out of memory while reading the log"};
  }
}

ReadResult ReadLog(const std::string& path, const ReadOptions& options) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    return {std::nullopt, path + ": is a directory, expected a log file"};
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return {std::nullopt, path + ": cannot open the file for reading"};
  return ParseLog(in, path, options);
}

std::string WriteLog(const std::string& path, const Log& log) {
  const std::string problem = CheckContents(log);
  if (!problem.empty()) return path + ": " + problem;
  return WriteOutput(path, [&](const std::function<bool(std::string_view)>& emit) { return EmitText(log, emit); },
                     "a log file");
}

}  // namespace pneumatic::log
