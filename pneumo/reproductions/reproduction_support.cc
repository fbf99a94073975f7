#include "reproductions/reproduction_support.h"

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "formats/report_files.h"

namespace pneumatic::reproductions {

std::string Format(double v, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*g", digits, v);
  return buffer;
}

double Round(double v, int decimals) {
  const double scale = std::pow(10.0, decimals);
  return std::round(v * scale) / scale;
}

std::string CreateOutputDirectory(const std::string& out_dir) {
  std::error_code ec;
  if (!out_dir.empty()) {
    std::filesystem::create_directories(out_dir, ec);
    if (ec) return out_dir + ": " + ec.message();
  }
  return "";
}

nlohmann::json Failed(const std::string& message, std::string* error) {
  if (error) *error = message;
  return nlohmann::json();
}

nlohmann::json Finish(const std::string& out_dir, const std::string& name, nlohmann::json report, std::string* error) {
  if (!out_dir.empty()) {
    if (std::string e = WriteReportAndPlots(out_dir, name, report); !e.empty()) return Failed(e, error);
  }
  return report;
}

}  // namespace pneumatic::reproductions
