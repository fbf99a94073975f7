// The files a reproduction or a fit hands a person: its JSON report, written whole or not at
// all (output_file.h), and the PNG plots a project script draws from it.
#ifndef PNEUMATIC_REPORT_FILES_H_
#define PNEUMATIC_REPORT_FILES_H_

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace pneumatic {

// Runs scripts/<script> with Debian's /usr/bin/python3 (which python3-matplotlib serves; a python3
// earlier on PATH, e.g. pyenv's, may lack it) and the arguments, each quoted for the shell.
// "" or the failing command.
std::string RunPlotScript(const std::string& script, const std::vector<std::string>& arguments);

// The same for any of the project's scripts (scripts/<script>), its exit status returned: the
// status it exited with, 128 + the signal that ended it, or -1 if it could not be started.
int RunScript(const std::string& script, const std::vector<std::string>& arguments);

// Writes OUT_DIR/<name>.json, then runs scripts/plot_<name>.py OUT_DIR. "" or the error.
std::string WriteReportAndPlots(const std::string& out_dir, const std::string& name, const nlohmann::json& report);

}  // namespace pneumatic

#endif  // PNEUMATIC_REPORT_FILES_H_
