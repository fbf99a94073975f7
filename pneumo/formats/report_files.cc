#include "formats/report_files.h"

#include <sys/wait.h>

#include <cstdlib>

#include "formats/output_file.h"

namespace pneumatic {
namespace {

// 'text' for the shell, single quotes inside escaped
std::string Quote(const std::string& text) {
  std::string quoted = "'";
  for (char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

// the shell command running scripts/<script> with the arguments
std::string ScriptCommand(const std::string& script, const std::vector<std::string>& arguments) {
  std::string command = "/usr/bin/python3 " + Quote(std::string(PNEUMATIC_SCRIPTS_DIR) + "/" + script);
  for (const std::string& argument : arguments) command += " " + Quote(argument);
  return command;
}

}  // namespace

std::string RunPlotScript(const std::string& script, const std::vector<std::string>& arguments) {
  const std::string command = ScriptCommand(script, arguments);
  if (std::system(command.c_str()) != 0) return "the plot failed (" + command + ")";
  return "";
}

int RunScript(const std::string& script, const std::vector<std::string>& arguments) {
  const int status = std::system(ScriptCommand(script, arguments).c_str());
  if (status == -1) return -1;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

std::string WriteReportAndPlots(const std::string& out_dir, const std::string& name, const nlohmann::json& report) {
  if (std::string e = WriteOutput(out_dir + "/" + name + ".json", report.dump(2) + "\n", "a JSON file"); !e.empty()) {
    return e;
  }
  if (std::string e = RunPlotScript("plot_" + name + ".py", {out_dir}); !e.empty()) return out_dir + ": " + e;
  return "";
}

}  // namespace pneumatic
