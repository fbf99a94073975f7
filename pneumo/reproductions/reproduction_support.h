// What the reproductions of the papers (reproduce_*.cc) share: the numbers' text and rounding in
// their reports, and the start and end of a run of one (its output directory, its failure, its
// report written with the plots).
#ifndef PNEUMATIC_REPRODUCTION_SUPPORT_H_
#define PNEUMATIC_REPRODUCTION_SUPPORT_H_

#include <string>

#include <nlohmann/json.hpp>

namespace pneumatic::reproductions {

// v with `digits` significant digits (printf's %g)
std::string Format(double v, int digits = 3);

// rounded for the report: the run's numbers are exact, the JSON need not carry 17 digits
double Round(double v, int decimals = 3);

// out_dir and its parents made unless out_dir is "" (no files): an error, or ""
std::string CreateOutputDirectory(const std::string& out_dir);

// a reproduction's failure: the message into *error (if given) and the null report
nlohmann::json Failed(const std::string& message, std::string* error);

// the report, written with its plots into out_dir as NAME.json (WriteReportAndPlots) unless out_dir
// is "": the report, or Failed's null report
nlohmann::json Finish(const std::string& out_dir, const std::string& name, nlohmann::json report, std::string* error);

}  // namespace pneumatic::reproductions

#endif  // PNEUMATIC_REPRODUCTION_SUPPORT_H_
