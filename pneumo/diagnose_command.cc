#include "diagnose_command.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "log_csv.h"
#include "output_file.h"
#include "report_files.h"

namespace pneumatic {
namespace {

namespace dg = diagnosis;

// JSON has no NaN: a value not computed is null
nlohmann::json Number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

nlohmann::json ParametersJson(const std::vector<dg::ParameterResult>& parameters) {
  nlohmann::json out = nlohmann::json::object();
  for (const dg::ParameterResult& p : parameters) {
    out[p.name] = {{"value", p.value}, {"standard_error", Number(p.standard_error)}, {"unit", p.unit}};
    if (!p.poorly_determined.empty()) out[p.name]["poorly_determined"] = p.poorly_determined;
  }
  return out;
}

nlohmann::json CalibrationJson(const dg::Diagnosis& d) {
  nlohmann::json out = {{"status", d.calibration_status}, {"heldout_gap", Number(d.heldout_gap_calibrated)},
                        {"params", nlohmann::json::object()}};
  for (const dg::CalibratedParameter& p : d.calibration) {
    out["params"][p.name] = {{"nominal", p.nominal}, {"value", p.value}, {"standard_error", Number(p.standard_error)},
                             {"unit", p.unit}, {"at_bound", p.at_bound}};
  }
  return out;
}

nlohmann::json NoiseFloorJson(const dg::Diagnosis& d) {
  const dg::NoiseFloor& f = d.noise_floor;
  nlohmann::json out = {{"gap", f.floor}, {"discretisation_gap", f.discretisation_gap}, {"signals", nlohmann::json::object()}};
  for (size_t s = 0; s < d.signal_labels.size() && s < f.signal_floor.size(); ++s) {
    out["signals"][d.signal_labels[s]] = {{"sensor_noise", f.sensor_noise[s]}, {"carried", f.carried[s]}, {"floor", f.signal_floor[s]}};
  }
  if (!f.error.empty()) out["error"] = f.error;
  return out;
}

nlohmann::json UnexplainedJson(const dg::Unexplained& u) {
  nlohmann::json out = {{"present", u.present}, {"gap", u.gap}, {"floor", u.floor}, {"ratio_to_floor", Number(u.gap / u.floor)},
                        {"side", u.side.empty() ? nlohmann::json(nullptr) : nlohmann::json(u.side)},
                        {"mechanical_side_ratio", Number(u.mechanical_ratio)}, {"pneumatic_side_ratio", Number(u.pneumatic_ratio)},
                        {"full_ratio", Number(u.full_ratio)}, {"summary", u.summary}};
  out["regimes"] = nlohmann::json::object();
  for (const auto& [name, ratio] : u.regimes) out["regimes"][name] = ratio;
  out["signals"] = nlohmann::json::object();
  for (const dg::ResidualStructure& r : u.signals) {
    nlohmann::json states = nlohmann::json::array();
    for (const dg::StateDependence& dep : r.dependences) {
      states.push_back({{"state", dep.state}, {"lag_s", dep.lag_s}, {"eta2", dep.eta2}, {"excess", dep.excess},
                        {"bin_centre", dep.bins.centre}, {"bin_mean_residual", dep.bins.mean}, {"bin_count", dep.bins.count}});
    }
    out["signals"][r.signal] = {{"gap", r.gap}, {"floor", r.floor}, {"rms", r.rms}, {"mean", r.mean},
                                {"systematic", r.systematic}, {"structured", r.structured},
                                {"effective_samples", r.effective_samples}, {"states", states}};
  }
  return out;
}

nlohmann::json AssessmentJson(const dg::Diagnosis& d, const dg::Assessment& a) {
  nlohmann::json j;
  j["gap"] = Number(a.full.gap);
  for (size_t s = 0; s < d.signal_labels.size(); ++s) {
    const std::string& label = d.signal_labels[s];
    j["signals"][label] = {{"full_gap", Number(a.full.signal_gap[s])},
                           {"full_rms", Number(a.full.signal_rms[s])},
                           {"pneumatic_side_gap", Number(a.pneumatic_gap[s])},
                           {"mechanical_side_gap", Number(a.mechanical_gap[s])},
                           {"ljung_box_q", Number(a.whiteness[s].q)},
                           {"ljung_box_p", Number(a.whiteness[s].p_value)},
                           {"lag1_autocorrelation", Number(a.whiteness[s].lag1)},
                           {"max_input_correlation", Number(a.input_correlation[s])}};
  }
  for (size_t k = 0; k < d.regimes.names.size(); ++k) j["regimes"][d.regimes.names[k]] = Number(a.regime_gap[k]);
  return j;
}

// per held-out row: time, each signal measured / before / after, the regimes (0/1)
std::string SeriesCsv(const dg::Diagnosis& d) {
  std::ostringstream out;
  out.precision(9);
  out << "time";
  for (const std::string& label : d.signal_labels) out << "," << label << ".measured," << label << ".before," << label << ".after";
  for (const std::string& name : d.regimes.names) out << ",regime:" << name;
  out << "\n";
  for (int row = 0; row < d.heldout.rows(); ++row) {
    out << d.heldout.time[row];
    for (size_t s = 0; s < d.signal_labels.size(); ++s) {
      out << "," << d.heldout.Signal(static_cast<int>(s))[row];
      for (const dg::Assessment* a : {&d.before, &d.after}) {
        const double v = a->full.prediction.simulated[s][row];
        out << ",";
        if (std::isfinite(v)) out << v;
      }
    }
    for (const auto& member : d.regimes.member) out << "," << static_cast<int>(member[row]);
    out << "\n";
  }
  return out.str();
}

std::string Escape(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '<' ? std::string("&lt;") : c == '>' ? std::string("&gt;") : c == '&' ? std::string("&amp;") : std::string(1, c);
  return out;
}

std::string Format(const char* format, double v) {
  if (!std::isfinite(v)) return "&ndash;";
  char text[64];
  std::snprintf(text, sizeof(text), format, v);
  return text;
}

std::string Html(const dg::Diagnosis& d, const DiagnoseCommandOptions& o) {
  std::ostringstream h;
  const std::string verdict = d.verdict;
  std::string all;
  for (const std::string& e : d.effects) all += (all.empty() ? "" : ", ") + e;
  if (all.empty()) all = d.verdict;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>pneumo diagnose: " << Escape(verdict)
    << "</title>\n<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}"
       "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:4px 8px;text-align:right}"
       "th{background:#f3f3f3}td:first-child,th:first-child{text-align:left}.verdict{font-size:1.4em;padding:.6em 1em;"
       "background:#eef5ff;border-left:6px solid #3a76d8}img{max-width:100%;border:1px solid #ddd;margin:.5em 0}"
       ".yes{color:#167a16;font-weight:bold}.failed{color:#b00}td.text{text-align:left}</style></head><body>\n";
  h << "<h1>Sim-to-real diagnosis</h1>\n<p>Model <code>" << Escape(o.model_path) << "</code>; " << Escape(d.split) << " ("
    << d.train_rows << " training rows, " << d.heldout_rows << " held-out rows; " << Format("%.1f", d.seconds) << " s).</p>\n";
  h << "<div class=\"verdict\">Verdict: <b>" << Escape(all) << "</b><br>Held-out gap "
    << Format("%.4f", d.heldout_gap_before) << " &rarr; " << Format("%.4f", d.heldout_gap_after) << " ("
    << Format("%.1f", 100 * (d.heldout_gap_before - d.heldout_gap_after) / d.heldout_gap_before) << " % smaller)</div>\n";
  h << "<p>The gap is the normalised RMS of short-horizon predictions (" << Format("%.3g", o.diagnose.horizon_s)
    << " s windows restarted from the measured state) over the pressure and position signals, each divided by its "
       "standard deviation in the training log (README, &ldquo;Diagnosis&rdquo;). "
    << (std::isnan(d.discretisation_gap)
            ? std::string("The model's own discretisation error is not known (its prediction at a quarter of its timestep failed).")
            : "The model's own discretisation error (its prediction at its timestep against a quarter of it) is a gap of " +
                  Format("%.2g", d.discretisation_gap) + ": an effect must remove more than " +
                  Format("%.3g", o.diagnose.min_discretisation_multiple) + " times that.")
    << "</p>\n";
  if (!d.parameters.empty()) {
    h << "<h2>Fitted effect parameters</h2><table><tr><th>parameter</th><th>value</th><th>standard error</th><th>unit</th></tr>\n";
    for (const dg::ParameterResult& p : d.parameters) {
      h << "<tr><td>" << Escape(p.name) << "</td><td>" << Format("%.4g", p.value) << "</td><td>" << Format("%.2g", p.standard_error)
        << "</td><td>" << Escape(p.unit) << "</td></tr>\n";
    }
    h << "</table>\n";
  }
  h << "<h2>Measured and simulated, before and after</h2><img src=\"signals.png\" alt=\"signals\">\n"
       "<img src=\"closeup.png\" alt=\"close-up of the worst window\">\n";
  h << "<h2>Where the gap lies</h2><img src=\"where.png\" alt=\"gap by regime and over time\">\n<table><tr><th>signal</th>"
       "<th>full model</th><th>pneumatic side (along the measured motion)</th><th>mechanical side (from the measured pressures)</th>"
       "<th>full model after</th></tr>\n";
  for (size_t s = 0; s < d.signal_labels.size(); ++s) {
    h << "<tr><td>" << Escape(d.signal_labels[s]) << "</td><td>" << Format("%.4f", d.before.full.signal_gap[s]) << "</td><td>"
      << Format("%.4f", d.before.pneumatic_gap[s]) << "</td><td>" << Format("%.4f", d.before.mechanical_gap[s]) << "</td><td>"
      << Format("%.4f", d.after.full.signal_gap[s]) << "</td></tr>\n";
  }
  h << "</table>\n";
  for (size_t r = 0; r < d.rounds.size(); ++r) {
    const dg::Round& round = d.rounds[r];
    std::string in_model;
    for (const std::string& e : round.model_effects) in_model += (in_model.empty() ? "" : " + ") + e;
    h << "<h2>Candidates, round " << r + 1 << "</h2><p>Model effects: "
      << Escape(in_model.empty() ? std::string("none (the model as given)") : in_model)
      << "; held-out gap " << Format("%.4f", round.heldout_gap_before) << "; effective samples "
      << Format("%.0f", round.effective_samples) << ". Accepted: <b>" << Escape(round.accepted) << "</b>.";
    if (!round.refit_status.empty()) {
      h << " The found effects' parameters refitted together: " << Escape(round.refit_status) << ", held-out gap "
        << Format("%.4f", round.refit_heldout_gap) << ".";
    }
    if (!round.dropped.empty()) {
      h << " Then <b>" << Escape(round.dropped) << "</b> was dropped: given the other effects it no longer explains the gap "
        << "(&Delta;IC " << Format("%.1f", round.dropped_delta_ic) << ", " << Format("%.1f", 100 * round.dropped_improvement)
        << " % of the held-out gap).";
    }
    h << "</p>\n";
    h << "<img src=\"ranking_" << r + 1 << ".png\" alt=\"ranking\">\n<table><tr><th>effect</th><th>form</th><th>held-out gap</th>"
         "<th>shrink</th><th>&Delta;IC</th><th>explains</th><th>parameters</th><th>status</th></tr>\n";
    for (const dg::CandidateResult& c : round.ranking) {
      std::string params;
      for (const dg::ParameterResult& p : c.parameters) params += Escape(p.name) + " = " + Format("%.3g", p.value) + " " + Escape(p.unit) + "<br>";
      h << "<tr><td>" << c.effect << "</td><td class=\"text\">" << Escape(c.form) << "</td><td>" << Format("%.4f", c.heldout_gap) << "</td><td>"
        << Format("%.1f %%", 100 * c.improvement) << "</td><td>" << Format("%.1f", c.delta_ic) << "</td><td>"
        << (c.explains ? "<span class=\"yes\">yes</span>" : "no") << "</td><td class=\"text\">" << params << "</td><td"
        << (c.status == "fitted" ? " class=\"text\">" : " class=\"text failed\">") << Escape(c.status) << "</td></tr>\n";
    }
    h << "</table>\n";
  }
  h << "<h2>Residual structure</h2><img src=\"whiteness.png\" alt=\"residual autocorrelation\">\n<p>Autocorrelation of the "
       "normalised residuals before and after. Residuals of multi-step predictions are correlated even for a perfect model "
       "(the error of the start state carries through a window); what matters is how much structure the effect removes.</p>\n";
  h << "</body></html>\n";
  return h.str();
}

// "" if the report may go into `dir` (a folder, or nothing there yet), else why not
std::string ReportDirProblem(const std::string& dir) {
  std::error_code ec;
  if (std::filesystem::exists(dir, ec) && !std::filesystem::is_directory(dir, ec)) return dir + ": exists and is not a directory";
  return "";
}

std::string WriteReport(const dg::Diagnosis& d, const nlohmann::json& j, const DiagnoseCommandOptions& o) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (std::string e = ReportDirProblem(o.report_dir); !e.empty()) return e;
  fs::create_directories(o.report_dir, ec);
  if (ec) return o.report_dir + ": " + ec.message();
  if (std::string e = WriteOutput(o.report_dir + "/diagnosis.json", j.dump(2) + "\n", "a JSON file"); !e.empty()) return e;
  if (std::string e = WriteOutput(o.report_dir + "/series.csv", SeriesCsv(d), "a CSV file"); !e.empty()) return e;
  if (std::string e = RunPlotScript("plot_diagnosis.py", {o.report_dir}); !e.empty()) return o.report_dir + ": " + e;
  return WriteOutput(o.report_dir + "/index.html", Html(d, o), "an HTML file");
}

}  // namespace

nlohmann::json DiagnosisJson(const dg::Diagnosis& d) {
  nlohmann::json j;
  j["verdict"] = {{"effect", d.verdict},
                  {"effects", d.effects},
                  {"params", ParametersJson(d.parameters)},
                  {"calibration", CalibrationJson(d)},
                  {"noise_floor", NoiseFloorJson(d)},
                  {"unexplained", UnexplainedJson(d.unexplained)},
                  {"alternatives", nlohmann::json::array()},
                  {"heldout_gap_before", d.heldout_gap_before},
                  {"heldout_gap_after", d.heldout_gap_after},
                  {"shrink_pct", 100 * (d.heldout_gap_before - d.heldout_gap_after) / d.heldout_gap_before}};
  for (const dg::Alternative& a : d.alternatives) {
    j["verdict"]["alternatives"].push_back({{"effect", a.effect}, {"form", a.form}, {"params", ParametersJson(a.parameters)},
                                            {"heldout_gap", Number(a.heldout_gap)}, {"delta_ic_vs_verdict", Number(a.delta_ic)},
                                            {"experiment", a.experiment}});
  }
  j["discretisation_gap"] = Number(d.discretisation_gap);
  j["split"] = d.split;
  j["rows"] = {{"train", d.train_rows}, {"heldout", d.heldout_rows}};
  j["seconds"] = d.seconds;
  for (size_t s = 0; s < d.signal_labels.size(); ++s) j["signal_scale"][d.signal_labels[s]] = d.signal_scale[s];
  j["before"] = AssessmentJson(d, d.before);
  j["after"] = AssessmentJson(d, d.after);
  j["regime_fraction"] = nlohmann::json::object();
  for (size_t k = 0; k < d.regimes.names.size(); ++k) {
    double n = 0;
    for (char c : d.regimes.member[k]) n += c;
    j["regime_fraction"][d.regimes.names[k]] = n / std::max<double>(1, static_cast<double>(d.regimes.member[k].size()));
  }
  j["over_time"] = {{"window_start_s", d.before.window_time}, {"gap_before", d.before.window_gap}, {"gap_after", d.after.window_gap}};
  for (const dg::Round& r : d.rounds) {
    nlohmann::json round = {{"model_effects", r.model_effects},
                            {"heldout_gap_before", r.heldout_gap_before},
                            {"effective_samples", r.effective_samples},
                            {"accepted", r.accepted}};
    if (!r.refit_status.empty()) round["refit"] = {{"status", r.refit_status}, {"heldout_gap", Number(r.refit_heldout_gap)}};
    if (!r.dropped.empty()) {
      round["dropped"] = {{"effect", r.dropped},
                          {"delta_ic", Number(r.dropped_delta_ic)},
                          {"improvement_pct", Number(100 * r.dropped_improvement)}};
    }
    round["ranking"] = nlohmann::json::array();
    for (const dg::CandidateResult& c : r.ranking) {
      round["ranking"].push_back({{"effect", c.effect},
                                  {"form", c.form},
                                  {"status", c.status},
                                  {"params", ParametersJson(c.parameters)},
                                  {"train_gap", Number(c.train_gap)},
                                  {"heldout_gap", Number(c.heldout_gap)},
                                  {"improvement_pct", Number(100 * c.improvement)},
                                  {"delta_ic", Number(c.delta_ic)},
                                  {"score", Number(c.delta_ic)},
                                  {"explains", c.explains},
                                  {"rejected", c.rejected.empty() ? nlohmann::json(nullptr) : nlohmann::json(c.rejected)},
                                  {"refinement", c.refinement},
                                  {"with_found_effects", c.with_found_effects},
                                  {"evaluations", c.evaluations},
                                  {"seconds", c.seconds}});
    }
    j["rounds"].push_back(round);
  }
  j["ranking"] = j["rounds"].empty() ? nlohmann::json::array() : j["rounds"][0]["ranking"];
  return j;
}

int RunDiagnose(const DiagnoseCommandOptions& options) {
  auto fail = [](const std::string& message) {
    std::fprintf(stderr, "pneumo diagnose: %s\n", message.c_str());
    return 1;
  };
  // the report's folder, checked before the diagnosis (a minute or more) rather than after
  if (!options.report_dir.empty()) {
    if (std::string e = ReportDirProblem(options.report_dir); !e.empty()) return fail(e);
  }
  log::ReadOptions read;
  log::ReadResult train = log::ReadLog(options.train_path, read);
  if (!train.log) return fail(train.error);
  std::optional<log::Log> heldout;
  if (!options.heldout_path.empty()) {
    log::ReadResult h = log::ReadLog(options.heldout_path, read);
    if (!h.log) return fail(h.error);
    heldout = std::move(h.log);
  }
  dg::DiagnoseOptions o = options.diagnose;
  if (!options.quiet) o.progress = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  dg::Diagnosis d = dg::Diagnose(options.model_path, *train.log, heldout ? &*heldout : nullptr, o);
  if (!d.error.empty()) return fail(d.error);
  nlohmann::json j = DiagnosisJson(d);
  if (!options.report_dir.empty()) {
    if (std::string e = WriteReport(d, j, options); !e.empty()) return fail(e);
    if (!options.quiet) std::fprintf(stderr, "report: %s/index.html\n", options.report_dir.c_str());
  }
  std::printf("%s\n", j.dump(2).c_str());
  return 0;
}

}  // namespace pneumatic
