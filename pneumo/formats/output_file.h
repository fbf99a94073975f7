// Writing an output file (a log, a JSON report, a model) without ever destroying what is at its
// path, shared by every tool that writes one:
//  - "-" is standard output;
//  - an existing path that is not a regular file once symlinks are followed (a device such as
//    /dev/null or /dev/full, a FIFO, a socket), or any existing path in /dev or /proc or linked
//    into them (/dev/stdout), is opened and written in place, never replaced;
//  - otherwise (a regular file, a new file) the text goes to a temporary file of its own in the
//    target's directory, which is renamed over the target once completely written, so the
//    target is either untouched or the whole new text, concurrent writers never share a
//    temporary, and a symlink to the target keeps pointing to the new file. On failure the
//    temporary is removed and nothing is created at the target. A SIGINT, SIGTERM or SIGHUP that
//    ends the process while it writes removes the temporary too (a handler installed at the first
//    write, for each of those signals still at its default; it then ends the process as the signal
//    would have), so an interrupted tool leaves each output whole or untouched and nothing beside it.
// A directory is refused.
#ifndef PNEUMATIC_OUTPUT_FILE_H_
#define PNEUMATIC_OUTPUT_FILE_H_

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>

namespace pneumatic {

// Produces an output's text in pieces, handing each to `emit` until it returns false; returns
// false if `emit` did.
using TextSource = std::function<bool(const std::function<bool(std::string_view)>& emit)>;

// Writes the source's text to `path` as above. `kind` names what is expected in messages ("a
// log file"). Returns "" on success, or a one-line message starting with `path`, e.g.
// "/dev/full: writing failed: No space left on device".
std::string WriteOutput(const std::string& path, const TextSource& source, const std::string& kind);
std::string WriteOutput(const std::string& path, std::string_view text, const std::string& kind);

// Checked before long work, so that a run is not lost to its output path at the end: "" if
// WriteOutput may write `path` ("-", a device, an existing or a new file in an existing directory
// it may write to), else the message it would give (a directory; no directory to create the file
// in). Writing can still fail later (a full disk).
std::string CheckOutputPath(const std::string& path, const std::string& kind);

}  // namespace pneumatic

#endif  // PNEUMATIC_OUTPUT_FILE_H_
