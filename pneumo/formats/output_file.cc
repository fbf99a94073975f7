// Writing an output file without ever destroying what is at its path (see output_file.h).

#include "formats/output_file.h"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <iostream>
#include <iterator>
#include <system_error>

namespace pneumatic {
namespace {

namespace fs = std::filesystem;

// the system's text for an errno value
std::string Reason(int error) { return std::strerror(error); }

// The temporaries being written, for the signal handler below: SIGINT, SIGTERM or SIGHUP in the
// middle of a write removes them (unlink is async-signal-safe), then ends the process as the signal
// would have, so that an interrupted tool leaves each output whole or untouched and no temporary
// behind. A path that does not fit a slot is simply not removed.
struct PendingTemporary {
  std::atomic<bool> claimed{false};  // a writer holds this slot
  std::atomic<bool> used{false};     // its path is complete: the handler may remove it
  char path[4096] = "";
};
PendingTemporary pending[64];

void RemovePendingAndRaise(int signal_number) {
  for (PendingTemporary& p : pending) {
    if (p.used.load(std::memory_order_acquire)) ::unlink(p.path);
  }
  ::signal(signal_number, SIG_DFL);
  ::raise(signal_number);
}

// once per process: the handler, for each of the three signals whose disposition is still the
// default (a program's own handler is left alone)
void InstallSignalCleanup() {
  static std::atomic<bool> installed{false};
  if (installed.exchange(true)) return;
  for (int signal_number : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction current {};
    if (::sigaction(signal_number, nullptr, &current) != 0 || current.sa_handler != SIG_DFL) continue;
    struct sigaction action {};
    action.sa_handler = RemovePendingAndRaise;
    sigemptyset(&action.sa_mask);
    ::sigaction(signal_number, &action, nullptr);
  }
}

// registers the temporary at `path`, just created, for the handler; -1 if no slot is free or it is too long
int RegisterTemporary(const std::string& path) {
  InstallSignalCleanup();
  if (path.size() >= sizeof(pending[0].path)) return -1;
  for (int i = 0; i < static_cast<int>(std::size(pending)); ++i) {
    if (pending[i].claimed.exchange(true)) continue;  // another writer's
    std::memcpy(pending[i].path, path.c_str(), path.size() + 1);
    pending[i].used.store(true, std::memory_order_release);
    return i;
  }
  return -1;
}

void UnregisterTemporary(int slot) {
  if (slot < 0) return;
  pending[slot].used.store(false, std::memory_order_release);
  pending[slot].claimed.store(false, std::memory_order_release);
}

// write all of `text` to `fd`, resuming after short writes; 0 or the errno of the failure
int WriteAll(int fd, std::string_view text) {
  while (!text.empty()) {
    const ssize_t written = ::write(fd, text.data(), text.size());
    if (written < 0 && errno == EINTR) continue;
    if (written <= 0) return written < 0 ? errno : EIO;
    text.remove_prefix(static_cast<std::size_t>(written));
  }
  return 0;
}

// write the source's text to `fd`, then close it; 0 or the errno of the first failure
int WriteAndClose(int fd, const TextSource& source, bool sync) {
  int error = 0;
  source([&](std::string_view text) { return (error = WriteAll(fd, text)) == 0; });
  if (!error && sync && ::fsync(fd) != 0) error = errno;
  if (::close(fd) != 0 && !error) error = errno;
  return error;
}

// true for entries of /dev and /proc and links into them (/dev/stdout -> /proc/self/fd/1): they
// stand for devices and open files, so they are written in place and never replaced
bool IsSystemPath(const std::string& path) {
  std::error_code ec;
  const fs::path absolute = fs::absolute(path, ec).lexically_normal();
  fs::path link = absolute;
  if (fs::is_symlink(fs::symlink_status(absolute, ec))) {
    link = (absolute.parent_path() / fs::read_symlink(absolute, ec)).lexically_normal();
  }
  for (const fs::path& p : {absolute, link}) {
    const std::string s = p.string();
    if (s.rfind("/dev/", 0) == 0 || s.rfind("/proc/", 0) == 0) return true;
  }
  return false;
}

// a device, FIFO or socket: open and write it as it is (O_TRUNC empties regular files only)
std::string WriteInPlace(const std::string& path, const TextSource& source) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_TRUNC | O_NOCTTY | O_CLOEXEC);
  if (fd < 0) return path + ": cannot open for writing: " + Reason(errno);
  const int error = WriteAndClose(fd, source, false);
  return error ? path + ": writing failed: " + Reason(error) : "";
}

// write a new temporary file beside `target`, then rename it over `target`; on failure the
// temporary is removed and `target` is left as it was. `path` names the output in messages.
std::string WriteReplacing(const std::string& path, const fs::path& target, const TextSource& source) {
  // a temporary of our own: O_EXCL never shares one, mode 0666 gets the umask as any new file
  static std::atomic<unsigned> counter{0};
  const fs::path directory = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::string temporary;
  int fd = -1;
  for (int attempt = 0; fd < 0 && attempt < 100; ++attempt) {
    const std::string name = "." + target.filename().string() + "." +
                             std::to_string(::getpid()) + "." + std::to_string(counter++);
    temporary = (directory / name).string();
    fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0 && errno != EEXIST) break;
  }
  if (fd < 0) {
    return path + ": cannot create a temporary file in " + directory.string() + ": " +
           Reason(errno);
  }
  // ours from here on: a signal removes it (one that arrives before this line leaves it empty)
  const int slot = RegisterTemporary(temporary);

  // write, sync and close, then replace the target in one step
  std::string problem;
  if (const int error = WriteAndClose(fd, source, true)) {
    ::unlink(temporary.c_str());
    problem = path + ": writing failed: " + Reason(error);
  } else if (::rename(temporary.c_str(), target.c_str()) != 0) {
    const int rename_error = errno;
    ::unlink(temporary.c_str());
    problem = path + ": cannot replace the file: " + Reason(rename_error);
  }
  UnregisterTemporary(slot);
  return problem;
}

}  // namespace

std::string WriteOutput(const std::string& path, const TextSource& source, const std::string& kind) {
  // "-": standard output
  if (path == "-") {
    errno = 0;
    source([](std::string_view text) {
      return bool(std::cout.write(text.data(), static_cast<std::streamsize>(text.size())));
    });
    if (std::cout.flush()) return "";
    std::cout.clear();
    return path + ": writing to standard output failed" + (errno ? ": " + Reason(errno) : "");
  }

  // what the path stands for, after following symlinks
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec && status.type() != fs::file_type::not_found) {
    return path + ": cannot examine the output: " + ec.message();
  }
  if (fs::is_directory(status)) return path + ": is a directory, expected " + kind;
  if (fs::exists(status) && (!fs::is_regular_file(status) || IsSystemPath(path))) {
    return WriteInPlace(path, source);
  }

  // a regular file or a new one: replaced in one step (a symlink keeps pointing to the new file)
  const bool linked = fs::exists(status) && fs::is_symlink(fs::symlink_status(path, ec));
  const std::string target = linked ? fs::canonical(path, ec).string() : path;
  if (linked && ec) return path + ": cannot resolve the symbolic link: " + ec.message();
  return WriteReplacing(path, target, source);
}

std::string WriteOutput(const std::string& path, std::string_view text, const std::string& kind) {
  return WriteOutput(path, [text](const std::function<bool(std::string_view)>& emit) { return emit(text); }, kind);
}

std::string CheckOutputPath(const std::string& path, const std::string& kind) {
  if (path == "-") return "";
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec && status.type() != fs::file_type::not_found) {
    return path + ": cannot examine the output: " + ec.message();
  }
  if (fs::is_directory(status)) return path + ": is a directory, expected " + kind;
  if (fs::exists(status) && (!fs::is_regular_file(status) || IsSystemPath(path))) return "";
  // a regular file or a new one: WriteReplacing creates its temporary in the target's directory
  const bool linked = fs::exists(status) && fs::is_symlink(fs::symlink_status(path, ec));
  const fs::path target = linked ? fs::canonical(path, ec) : fs::path(path);
  const fs::path directory = target.has_parent_path() ? target.parent_path() : fs::path(".");
  if (::access(directory.c_str(), W_OK | X_OK) != 0) {
    return path + ": cannot create a temporary file in " + directory.string() + ": " + Reason(errno);
  }
  return "";
}

}  // namespace pneumatic
