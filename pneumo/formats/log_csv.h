// Reader and writer for the CSV log format of docs/log_format.md.
//
// One format for everything that records or reads a run of a pneumatic system: the
// rollout tool, identification, diagnosis and logs exported from real robots. A log is
// '#' comment lines, one header row `time,<cylinder>.<signal>,...`, then one row per
// sample. The reader validates everything and never guesses: any deviation from the
// format is reported as "FILE:LINE:COLUMN: message".

#ifndef PNEUMATIC_LOG_CSV_H_
#define PNEUMATIC_LOG_CSV_H_

#include <cstddef>
#include <istream>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace pneumatic::log {

// The role of a signal in a log.
enum class SignalKind {
  kCommand,    // applied from this row's time until the next row's (zero-order hold)
  kMeasured,   // sampled at this row's time, before this row's command acts
  kReference,  // the controller's reference for `x`
};

// A signal that may follow the cylinder name in a column name.
struct SignalInfo {
  const char* name;     // e.g. "p_P"
  SignalKind kind;
  const char* unit;     // SI unit, "1" for dimensionless quantities
  const char* meaning;  // one-line description, from docs/log_format.md
};

// Returns the signals of docs/log_format.md: u, uP, uN, u1..u4, duty, p_P, p_N, x, v, p_S, ref.
const std::vector<SignalInfo>& KnownSignals();

// Returns the description of the signal called `name`, or nullptr if there is none.
const SignalInfo* FindSignal(std::string_view name);

// Returns true for the on/off valve states u1..u4, whose values must be exactly 0 or 1.
bool IsValveState(std::string_view signal);

// A data column other than time: "cyl.p_P" is {"cyl", "p_P"}.
struct Column {
  std::string cylinder;  // name of a pneumatic cylinder in the MJCF model
  std::string signal;    // one of KnownSignals()

  // Returns the column name as written in the header, "<cylinder>.<signal>".
  std::string name() const { return cylinder + "." + signal; }
};

// A log held in memory.
struct Log {
  // The '#' lines before the header, without the '#' and at most one space after it.
  std::vector<std::string> comments;

  // Every column except time, in file order.
  std::vector<Column> columns;

  // Time of each row, in seconds, strictly increasing.
  std::vector<double> time;

  // values[column][row], with column indexing `columns` and row indexing `time`.
  std::vector<std::vector<double>> values;

  // Where the log was read from: the name given to the reader, and the 1-based file line of each
  // row. Empty for a log built in memory.
  std::string source;
  std::vector<std::size_t> row_lines;

  // "FILE:LINE:COLUMN" of row `row` (from 0) and data column `column` (index into `columns`), as
  // the reader's messages name a place; "row R, column NAME" for a log built in memory.
  std::string Where(std::size_t row, std::size_t column) const;

  // Returns the index of column `cylinder`.`signal` in `columns`, or -1 if it is absent.
  int FindColumn(const std::string& cylinder, const std::string& signal) const;

  // Returns the number of rows.
  std::size_t rows() const { return time.size(); }

  // Returns the mean spacing of the rows in seconds, or 0 if there are fewer than two.
  double Period() const;
};

// How strictly ParseLog() and ReadLog() check a log.
struct ReadOptions {
  // Names of the cylinders in the model; every column must name one of them. Empty
  // accepts any name.
  std::set<std::string> cylinders;

  // If true, rows must be uniformly spaced in time: every step must match the median step
  // within a relative tolerance of 1e-6 plus an absolute tolerance of 1e-9 s.
  bool uniform_time = true;
};

// The outcome of reading a log: either `log` is set, or `error` says why it is not.
struct ReadResult {
  std::optional<Log> log;
  // "FILE:LINE:COLUMN: message", with LINE the 1-based line of the file and COLUMN the
  // 1-based index of the CSV field (1 for problems with a whole line). Errors opening
  // the file are "FILE: message". Empty when `log` is set.
  std::string error;
};

// Parses a log from `in`; `name` stands for the file in error messages.
//
// Accepted besides the strict format: a UTF-8 byte order mark, CRLF line endings, spaces
// and tabs around fields, blank lines before the header and at the end of the file.
// Rejected, with the line and column at fault: an empty file or no header; a first
// column other than `time`; a column name that is not `<cylinder>.<signal>`, names a
// cylinder not in `options.cylinders` or an unknown signal; a duplicate column; a row
// with the wrong number of fields; an empty, non-numeric or non-finite value; time that
// does not strictly increase or, with `options.uniform_time`, is not uniformly spaced; a
// valve state u1..u4 other than 0 or 1; a comment or blank line among the data rows; a
// header without data rows; lines longer than 1 MiB.
ReadResult ParseLog(std::istream& in, const std::string& name, const ReadOptions& options);

// Reads the log file at `path`, as ParseLog() does.
ReadResult ReadLog(const std::string& path, const ReadOptions& options);

// Checks a log held in memory as the reader checks a file: one value per row in every column,
// known signals, no duplicate columns, finite values, strictly increasing time, valve states
// 0 or 1, and, with `uniform_time`, uniformly spaced rows. Returns "" or what is wrong
// (rows counted from 0).
std::string ValidateLog(const Log& log, bool uniform_time);

// Writes `log` to `path`. Every double is printed with the fewest digits that read back
// to the same bits, so ReadLog() returns exactly the values written. Where it goes:
//  - "-" is standard output;
//  - an existing path that is not a regular file once symlinks are followed (a device such
//    as /dev/null or /dev/full, a FIFO, a socket), or any existing path in /dev or /proc or
//    linked into them (/dev/stdout), is opened and written in place, never replaced;
//  - otherwise (a regular file, a new file) the log goes to a temporary file of its own in
//    the target's directory, which is renamed over the target once completely written, so
//    the target is either untouched or the whole new log, concurrent writers never share a
//    temporary, and a symlink to the target keeps pointing to the new log. On failure the
//    temporary is removed and nothing is created at the target.
// A directory is refused. Refuses logs the reader would reject (except for non-uniform
// time). Returns an empty string on success, or a one-line message starting with `path`,
// e.g. "/dev/full: writing failed: No space left on device".
std::string WriteLog(const std::string& path, const Log& log);

}  // namespace pneumatic::log

#endif  // PNEUMATIC_LOG_CSV_H_
