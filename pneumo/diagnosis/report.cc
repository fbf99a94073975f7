#include "diagnosis/report.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <sstream>
#include <utility>

#include "formats/log_csv.h"
#include "formats/output_file.h"
#include "formats/report_files.h"

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
  nlohmann::json out = {{"present", u.present}, {"above_floor", u.above_floor}, {"structured", u.structured},
                        {"gap", u.gap}, {"floor", u.floor}, {"ratio_to_floor", Number(u.ratio)},
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

// per held-out row: time, each signal measured / before / after, each cylinder's estimated
// velocity (the residual plot's direction of motion), the regimes (0/1)
std::string SeriesCsv(const dg::Diagnosis& d) {
  std::ostringstream out;
  out.precision(9);
  out << "time";
  for (const std::string& label : d.signal_labels) out << "," << label << ".measured," << label << ".before," << label << ".after";
  for (const dg::CylinderSeries& c : d.heldout.cylinders) out << "," << c.info.name << ".v.estimated";
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
    for (const dg::CylinderSeries& c : d.heldout.cylinders) {
      out << ",";
      if (row < static_cast<int>(c.velocity.size()) && std::isfinite(c.velocity[row])) out << c.velocity[row];
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

// a signal's display unit and its factor from SI, as scripts/plot_diagnosis.py shows it:
// pressures in kPa, positions in mm
std::pair<std::string, double> DisplayUnit(const std::string& signal) {
  return signal.find(".p_") != std::string::npos ? std::pair<std::string, double>{"kPa", 1e-3} : std::pair<std::string, double>{"mm", 1e3};
}

// "1.772 (209 &times; the floor)", ratio the gap over the floor signal by signal (GapOverFloor)
std::string GapAgainstFloor(double gap, double ratio) {
  if (!std::isfinite(gap) || !std::isfinite(ratio)) return Format("%.4f", gap);
  return Format("%.4f", gap) + " <span class=\"ratio\">= " + Format("%.3g", ratio) + " &times; the floor</span>";
}

std::string ParameterList(const std::vector<dg::ParameterResult>& parameters) {
  std::string out;
  for (const dg::ParameterResult& p : parameters) {
    out += Escape(p.name) + " = " + Format("%.3g", p.value) +
           (std::isfinite(p.standard_error) ? " &plusmn; " + Format("%.2g", p.standard_error) : "") + " " + Escape(p.unit) +
           (p.poorly_determined.empty() ? "" : " <span class=\"warn\">(" + Escape(p.poorly_determined) + ")</span>") + "<br>";
  }
  return out;
}

// the calibration is in the verdict's model ("fitted", or "fitted; ..." with some parameters left at
// the model's values)
bool Calibrated(const dg::Diagnosis& d) { return d.calibration_status.rfind("fitted", 0) == 0 && !d.calibration.empty(); }

// the verdict's model, the report's "after": "calibrated, with friction", "no effect added"
std::string AfterModel(const dg::Diagnosis& d) {
  std::string effects;
  for (const std::string& e : d.effects) effects += (effects.empty() ? "" : ", ") + e;
  return std::string(Calibrated(d) ? "calibrated, " : "") + (effects.empty() ? "no effect added" : "with " + effects);
}

// the verdict first: in words, the held-out gaps against the noise floor, what is left, and the
// alternatives the diagnosis does not pick between
void VerdictBox(const dg::Diagnosis& d, const DiagnoseLogOptions& o, std::ostringstream& h) {
  const dg::Unexplained& u = d.unexplained;
  const double floor = d.noise_floor.floor;
  auto ratio = [&](const std::vector<double>& signal_gap) { return dg::GapOverFloor(signal_gap, d.noise_floor); };
  std::string effects;
  for (const std::string& e : d.effects) effects += (effects.empty() ? "" : " and ") + e;
  std::string kind, headline, explanation;
  if (d.verdict == "unexplained") {
    kind = "unexplained";
    headline = "Not explained by any effect in the library";
    explanation = u.present ? "What the model leaves is well above the noise floor and depends on the states, but no candidate effect "
                              "removes it by the rules (or only with values it cannot trust). The missing physics is outside the library: "
                              "&ldquo;What is left unexplained&rdquo; below shows where it lies."
                            : "What the model leaves is well above the noise floor, but depends on no state, command or lag beyond noise, "
                              "and no candidate effect removes it: something that varies with time (a drift), a disturbance, or noise "
                              "the floor does not count. &ldquo;Where the gap lies&rdquo; shows it over time.";
  } else if (d.verdict == "none") {
    kind = "none";
    headline = "No unmodelled effect found";
    explanation = !d.not_searched.empty()
                      ? "What the model leaves is within the noise floor's margin and depends on no state, so no effect was searched "
                        "(<code>--search-unstructured</code> searches all the same)."
                      : std::string("No candidate effect improves the held-out fit") +
                            (u.present ? ", yet what is left is structured and above the floor (below)."
                                       : "; what is left is within the noise floor or does not depend on the states.");
  } else {
    kind = u.present ? "partial" : "effect";
    headline = "Effect found: " + effects;
    explanation = u.present ? "The effect explains part of the gap, but what it leaves is still structured and well above the noise floor: "
                              "something else is missing too (below)."
                            : "With it, what is left is within the noise floor or does not depend on the states.";
  }
  h << "<div class=\"verdict " << kind << "\"><div class=\"headline\">" << Escape(headline) << "</div>\n<p>Verdict <code>"
    << Escape(d.verdict) << "</code>. " << explanation << "</p>\n";
  // the held-out gaps against the noise floor
  h << "<table class=\"gaps\"><tr><th>held-out gap of</th><th>gap</th><th>against the noise floor " << Format("%.4f", floor) << "</th></tr>\n";
  h << "<tr><td>the model as given</td><td>" << Format("%.4f", d.heldout_gap_before) << "</td><td>" << Format("%.3g", ratio(d.before.full.signal_gap))
    << " &times;</td></tr>\n";
  if (Calibrated(d)) {
    h << "<tr><td>the calibrated model (its nominal parameters refitted)</td><td>" << Format("%.4f", d.heldout_gap_calibrated) << "</td><td>"
      << Format("%.3g", ratio(d.heldout_signal_gap_calibrated)) << " &times;</td></tr>\n";
  } else {
    h << "<tr><td>the calibrated model</td><td colspan=\"2\" class=\"text note\">calibration " << Escape(d.calibration_status) << "</td></tr>\n";
  }
  h << "<tr><td>the verdict's model (" << Escape(AfterModel(d)) << ")</td><td>" << Format("%.4f", d.heldout_gap_after) << "</td><td><b>"
    << Format("%.3g", ratio(d.after.full.signal_gap)) << " &times;</b> ("
    << Format("%.0f", 100 * (d.heldout_gap_before - d.heldout_gap_after) / d.heldout_gap_before) << " % smaller than as given)</td></tr>\n</table>\n";
  h << "<p class=\"note\">A gap within " << Format("%.3g", o.diagnose.floor_multiple)
    << " &times; the noise floor is explained: the floor is the gap a perfect model would still leave on this log (sensor noise and the "
       "model's own discretisation, table below). Each signal's gap is weighed against its own floor.</p>\n";
  if (!u.summary.empty()) h << "<p class=\"summary\"><b>What is left, in words:</b> " << Escape(u.summary) << "</p>\n";
  if (!d.alternatives.empty()) {
    h << "<p><b>Ambiguous: " << d.alternatives.size() << " explanations fit the held-out log about equally well</b> (their &Delta;IC "
      << "differ by less than " << Format("%.3g", o.diagnose.alternative_delta_ic)
      << "). The diagnosis does not pick between them: an experiment on the rig tells them apart.</p>\n"
      << "<table><tr><th>explanation</th><th class=\"text\">parameters</th><th>held-out gap</th><th>&Delta;IC against the verdict</th>"
         "<th class=\"text\">the experiment that would tell it apart</th></tr>\n";
    for (const dg::Alternative& a : d.alternatives) {
      const bool verdict = a.effect == d.verdict;
      h << "<tr><td class=\"text\"><b>" << Escape(a.effect) << "</b>" << (verdict ? " (the verdict)" : "") << "<br><small>" << Escape(a.form)
        << "</small></td><td class=\"text\">" << ParameterList(a.parameters) << "</td><td>" << Format("%.4f", a.heldout_gap) << "</td><td>"
        << Format("%+.1f", a.delta_ic) << "</td><td class=\"text\">" << Escape(a.experiment.empty() ? std::string("(none known)") : a.experiment)
        << "</td></tr>\n";
    }
    h << "</table>\n";
  }
  h << "</div>\n";
}

// what the verdict's model leaves: which side fails, per signal its size and the states it
// depends on, the regimes, and the plots of residual.png and residual_regimes.png
void UnexplainedSection(const dg::Diagnosis& d, const DiagnoseLogOptions& o, std::ostringstream& h) {
  const dg::Unexplained& u = d.unexplained;
  const double multiple = o.diagnose.floor_multiple;
  h << "<h2 id=\"unexplained\">What is left unexplained</h2>\n<p>The residual (simulated &minus; measured) of the verdict's model on the held-out "
       "log: its gap " << GapAgainstFloor(u.gap, u.ratio) << " (noise floor " << Format("%.4f", u.floor) << ")"
    << (u.present ? ", structured: physics is missing." : ", not structured beyond noise.") << "</p>\n";
  // which side of the model fails
  auto side = [&](const char* name, const char* what, double ratio) {
    const bool fails = ratio > multiple;
    h << "<tr><td>" << name << "</td><td class=\"text\">" << what << "</td><td>" << Format("%.3g &times;", ratio) << "</td><td class=\"text "
      << (!std::isfinite(ratio) ? "" : fails ? "failed" : "yes") << "\">" << (!std::isfinite(ratio) ? "not predicted" : fails ? "fails" : "within")
      << "</td></tr>\n";
  };
  h << "<h3>Which side of the model fails</h3><table><tr><th>side</th><th class=\"text\">what is predicted</th>"
       "<th>worst signal's gap over its floor</th><th class=\"text\">above " << Format("%.3g", multiple) << " &times;?</th></tr>\n";
  side("mechanical", "the motion (x) from the measured pressures", u.mechanical_ratio);
  side("pneumatic", "the pressures (p_P, p_N) along the measured motion", u.pneumatic_ratio);
  side("full model", "every signal from the measured state at each window's start", u.full_ratio);
  h << "</table>\n<p>";
  if (!u.present) {
    h << (u.above_floor ? "What is left does not depend on the states beyond noise"
                        : "What is left is within " + Format("%.3g", multiple) + " &times; the noise floor")
      << ", so this split does not point at missing physics.";
  } else if (u.side == "mechanical") {
    h << "It looks <b>mechanical</b>: the forces on the moving parts miss something (a load, a spring, friction, a mechanism), "
         "while the pneumatics follow the measured motion.";
  } else if (u.side == "pneumatic") {
    h << "It looks <b>pneumatic</b>: the flows or the volumes miss something (valves, leaks, lines, the gas), while the mechanics "
         "follow the measured pressures.";
  } else if (u.side == "mechanical and pneumatic") {
    h << "Both the <b>mechanical and the pneumatic</b> side fail: each misses its own signals even when the other side's are "
         "taken from the log. Start with the side whose ratio is larger.";
  } else if (u.side == "sensors") {
    h << "It looks like the <b>sensors</b>: each side predicts well from the other side's measurements, but the full prediction "
         "misses the measured signals (offsets, gains, the sensors' own dynamics or filtering).";
  } else {
    h << "Every side is within " << Format("%.3g", multiple) << " &times; its floor.";
  }
  h << "</p>\n";
  // per signal
  h << "<h3>Per signal</h3><table><tr><th>signal</th><th>gap over its floor</th><th>residual RMS</th><th>residual mean</th>"
       "<th>systematic part over its floor</th><th class=\"text\">structured</th><th class=\"text\">depends most on (&eta;&sup2;, lag)</th></tr>\n";
  for (const dg::ResidualStructure& r : u.signals) {
    const auto [unit, factor] = DisplayUnit(r.signal);
    std::string states;
    int listed = 0;
    for (const dg::StateDependence& dep : r.dependences) {
      if (dep.excess <= 0 || listed == 3) break;
      states += (listed++ ? ", " : "") + Escape(dep.state) + " (" + Format("%.2f", dep.eta2) + ", " + Format("%.0f ms", 1e3 * dep.lag_s) + ")";
    }
    h << "<tr><td>" << Escape(r.signal) << "</td><td>" << Format("%.3g &times;", r.gap / r.floor) << "</td><td>" << Format("%.3g ", factor * r.rms)
      << unit << "</td><td>" << Format("%.3g ", factor * r.mean) << unit << "</td><td>" << Format("%.3g &times;", r.systematic / r.floor)
      << "</td><td class=\"text\">" << (r.structured ? "<span class=\"failed\">yes</span>" : "no") << "</td><td class=\"text\">"
      << (states.empty() ? std::string("no state beyond chance") : states) << "</td></tr>\n";
  }
  h << "</table>\n<p class=\"note\">&eta;&sup2;: the share of the residual's variance that its mean per bin of the state explains, at the lag "
       "(the state that long before) that explains most; only states above its level by chance are listed. A residual is structured "
       "when its mean and that explained part exceed its floor.</p>\n";
  if (!u.regimes.empty()) {
    h << "<p>Largest in the regimes: ";
    for (size_t k = 0; k < u.regimes.size(); ++k) {
      h << (k ? ", " : "") << "<b>" << Escape(u.regimes[k].first) << "</b> (" << Format("%.2g", u.regimes[k].second)
        << " &times; the whole log's gap)";
    }
    h << ".</p>\n";
  }
  h << "<a href=\"residual.png\"><img src=\"residual.png\" alt=\"the residual against the states it depends on, and over the stroke\"></a>\n"
       "<p class=\"note\">Each "
       "row is a signal whose residual is structured (or, if none is, the two with the largest gap). Left: the mean residual per bin of "
       "the three states it depends on most (dot size: the rows in the bin); a flat line inside the green band (&plusmn; the noise floor) "
       "is what a complete model leaves. Right: every held-out row's residual over the stroke, by the direction of motion: a slope "
       "points to a force or a volume that varies with position, a split between the directions to friction or hysteresis.</p>\n"
       "<a href=\"residual_regimes.png\"><img src=\"residual_regimes.png\" alt=\"the residual's RMS per regime\"></a>\n"
       "<p class=\"note\">The residual's RMS in each regime (a row may be in several; the share of the rows in brackets), of the "
       "verdict's model and, where it differs, of the model as given, against the noise floor and the whole log's RMS.</p>\n";
}

void CalibrationSection(const dg::Diagnosis& d, std::ostringstream& h) {
  h << "<h2 id=\"calibration\">Calibration of the model's own parameters</h2>\n<p>Before any effect, the model's nominal parameters "
       "(flow coefficient, critical ratio, dead volumes, polytropic index, the joint's damping) are refitted on the training log: a gap "
       "that this removes is a calibration, not an unmodelled effect. Status: <b>"
    << Escape(d.calibration_status) << "</b>";
  if (Calibrated(d)) {
    h << "; held-out gap of the calibrated model "
      << GapAgainstFloor(d.heldout_gap_calibrated, dg::GapOverFloor(d.heldout_signal_gap_calibrated, d.noise_floor));
  }
  h << ".</p>\n";
  if (d.calibration.empty()) return;
  h << "<table><tr><th>parameter</th><th>nominal</th><th>fitted</th><th>change</th><th>standard error</th><th>unit</th><th>at the bound "
       "of its plausible range</th></tr>\n";
  for (const dg::CalibratedParameter& p : d.calibration) {
    h << "<tr><td>" << Escape(p.name) << "</td><td>" << Format("%.4g", p.nominal) << "</td><td>" << Format("%.4g", p.value) << "</td><td>"
      << (p.nominal != 0 ? Format("%+.1f %%", 100 * (p.value - p.nominal) / p.nominal) : std::string("&ndash;")) << "</td><td>"
      << Format("%.2g", p.standard_error) << "</td><td>" << Escape(p.unit) << "</td><td>"
      << (p.at_bound ? "<span class=\"failed\">&#9888; at the bound</span>" : "") << "</td></tr>\n";
  }
  h << "</table>\n";
}

void NoiseFloorSection(const dg::Diagnosis& d, std::ostringstream& h) {
  const dg::NoiseFloor& f = d.noise_floor;
  h << "<h2 id=\"floor\">Noise floor</h2>\n<p>The gap a model without any error would still leave on this log: <b>" << Format("%.4f", f.floor)
    << "</b> (the signals' floors below and the model's discretisation gap " << Format("%.2g", f.discretisation_gap) << ").";
  if (!f.error.empty()) h << " <span class=\"failed\">" << Escape(f.error) << "</span>";
  h << "</p>\n<table><tr><th>signal</th><th>sensor noise (from the log)</th><th>carried through the prediction windows</th><th>floor</th>"
       "<th>floor, normalised</th></tr>\n";
  for (size_t s = 0; s < d.signal_labels.size() && s < f.signal_floor.size(); ++s) {
    const auto [unit, factor] = DisplayUnit(d.signal_labels[s]);
    const double scale = s < d.signal_scale.size() ? d.signal_scale[s] : dg::kNotComputed;
    h << "<tr><td>" << Escape(d.signal_labels[s]) << "</td><td>" << Format("%.3g ", factor * f.sensor_noise[s]) << unit << "</td><td>"
      << Format("%.3g ", factor * f.carried[s]) << unit << "</td><td>" << Format("%.3g ", factor * f.signal_floor[s] * scale) << unit
      << "</td><td>" << Format("%.4f", f.signal_floor[s]) << "</td></tr>\n";
  }
  h << "</table>\n";
}

// the page's head (title, style) and its first lines: the model and the logs
void Head(const dg::Diagnosis& d, const DiagnoseLogOptions& o, std::ostringstream& h) {
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>pneumo diagnose: " << Escape(d.verdict)
    << "</title>\n<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}"
       "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:4px 8px;text-align:right}"
       "td{white-space:nowrap}td.text{white-space:normal}th{background:#f3f3f3}td:first-child,th:first-child,th.text{text-align:left}"
       "img{max-width:100%;border:1px solid #ddd;margin:.5em 0}"
       ".verdict{padding:.4em 1.2em .2em;margin:1em 0 1.5em;background:#eef5ff;border-left:8px solid #3a76d8}"
       ".verdict.unexplained,.verdict.partial{background:#fff4e5;border-color:#e08a00}.verdict.none{background:#eef8ee;border-color:#2e9a2e}"
       ".verdict .headline{font-size:1.6em;font-weight:bold;margin:.3em 0}.verdict table{background:#fff}"
       ".ratio{color:#555}.note,.summary{color:#555;font-size:.9em}.warn{color:#a05a00}nav{font-size:.9em;color:#555}"
       ".yes{color:#167a16;font-weight:bold}.failed{color:#b00}.rejected{color:#a05a00}td.text{text-align:left}</style></head><body>\n";
  h << "<h1>Sim-to-real diagnosis</h1>\n<p>Model <code>" << Escape(o.model_path) << "</code>; " << Escape(d.split) << " ("
    << d.train_rows << " training rows, " << d.heldout_rows << " held-out rows; " << Format("%.1f", d.seconds) << " s).</p>\n";
}

// links to the sections, in their order on the page
void Navigation(const dg::Diagnosis& d, bool left_first, std::ostringstream& h) {
  h << "<nav>Sections: " << (left_first ? "<a href=\"#unexplained\">what is left unexplained</a> &middot; " : "")
    << (d.parameters.empty() ? "" : "<a href=\"#effect\">fitted effect</a> &middot; ")
    << "<a href=\"#calibration\">calibration</a> &middot; <a href=\"#floor\">noise floor</a> &middot; <a href=\"#signals\">signals</a> "
       "&middot; <a href=\"#where\">where the gap lies</a> &middot; "
    << (left_first ? "" : "<a href=\"#unexplained\">what is left</a> &middot; ") << "<a href=\"#rounds\">candidates</a> &middot; "
    << "<a href=\"#whiteness\">residual whiteness</a></nav>\n";
}

void FittedEffectSection(const dg::Diagnosis& d, std::ostringstream& h) {
  h << "<h2 id=\"effect\">Fitted effect parameters</h2><table><tr><th>parameter</th><th>value</th><th>standard error</th><th>unit</th>"
       "<th>note</th></tr>\n";
  for (const dg::ParameterResult& p : d.parameters) {
    h << "<tr><td>" << Escape(p.name) << "</td><td>" << Format("%.4g", p.value) << "</td><td>" << Format("%.2g", p.standard_error)
      << "</td><td>" << Escape(p.unit) << "</td><td class=\"text warn\">" << Escape(p.poorly_determined) << "</td></tr>\n";
  }
  h << "</table>\n";
}

void SignalsSection(const dg::Diagnosis& d, const DiagnoseLogOptions& o, std::ostringstream& h) {
  h << "<h2 id=\"signals\">Measured and simulated, before and after</h2>\n<p>The gap is the normalised RMS of short-horizon predictions ("
    << Format("%.3g", o.diagnose.horizon_s)
    << " s windows restarted from the measured state) over the pressure and position signals, each divided by its "
       "standard deviation in the training log (README, &ldquo;Diagnosis&rdquo;). &ldquo;After&rdquo; is the verdict's model ("
    << Escape(AfterModel(d)) << "). "
    << (std::isnan(d.discretisation_gap)
            ? std::string("The model's own discretisation error is not known (its prediction at a quarter of its timestep failed).")
            : "The model's own discretisation error (its prediction at its timestep against a quarter of it) is a gap of " +
                  Format("%.2g", d.discretisation_gap) + ": an effect must remove more than " +
                  Format("%.3g", o.diagnose.min_discretisation_multiple) + " times that.")
    << "</p>\n<img src=\"signals.png\" alt=\"signals\">\n<img src=\"closeup.png\" alt=\"close-up of the worst window\">\n";
}

void WhereSection(const dg::Diagnosis& d, std::ostringstream& h) {
  h << "<h2 id=\"where\">Where the gap lies</h2><img src=\"where.png\" alt=\"gap by regime and over time\">\n<table><tr><th>signal</th>"
       "<th>full model</th><th>pneumatic side (along the measured motion)</th><th>mechanical side (from the measured pressures)</th>"
       "<th>full model after</th></tr>\n";
  for (size_t s = 0; s < d.signal_labels.size(); ++s) {
    h << "<tr><td>" << Escape(d.signal_labels[s]) << "</td><td>" << Format("%.4f", d.before.full.signal_gap[s]) << "</td><td>"
      << Format("%.4f", d.before.pneumatic_gap[s]) << "</td><td>" << Format("%.4f", d.before.mechanical_gap[s]) << "</td><td>"
      << Format("%.4f", d.after.full.signal_gap[s]) << "</td></tr>\n";
  }
  h << "</table>\n";
}

// round r of the search: the effects in the model, what it accepted, refitted and dropped, and
// every candidate's figures
void RoundSection(const dg::Diagnosis& d, size_t r, std::ostringstream& h) {
  const dg::Round& round = d.rounds[r];
  std::string in_model;
  for (const std::string& e : round.model_effects) in_model += (in_model.empty() ? "" : " + ") + e;
  h << "<h2" << (r == 0 ? " id=\"rounds\"" : "") << ">Candidates, round " << r + 1 << "</h2><p>Model effects: "
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
  if (!round.richer_forms_skipped.empty()) h << " Richer forms not fitted: " << Escape(round.richer_forms_skipped) << ".";
  if (!round.search_ends.empty()) h << " No further round: " << Escape(round.search_ends) << ".";
  h << "</p>\n";
  h << "<img src=\"ranking_" << r + 1 << ".png\" alt=\"ranking\">\n<table><tr><th>effect</th><th>form</th><th>held-out gap</th>"
       "<th>shrink</th><th>&Delta;IC</th><th>explains</th><th>parameters</th><th>status</th></tr>\n";
  for (const dg::CandidateResult& c : round.ranking) {
    std::string params;
    for (const dg::ParameterResult& p : c.parameters) params += Escape(p.name) + " = " + Format("%.3g", p.value) + " " + Escape(p.unit) + "<br>";
    const char* status_class = c.status != "fitted" ? "text failed" : !c.rejected.empty() ? "text rejected" : "text";
    h << "<tr><td>" << Escape(c.effect) << "</td><td class=\"text\">" << Escape(c.form) << "</td><td>" << Format("%.4f", c.heldout_gap)
      << "</td><td>" << Format("%.1f %%", 100 * c.improvement) << "</td><td>" << Format("%.1f", c.delta_ic) << "</td><td>"
      << (c.explains ? "<span class=\"yes\">yes</span>" : "no") << "</td><td class=\"text\">" << params << "</td><td class=\"" << status_class
      << "\">" << Escape(c.status) << (c.rejected.empty() ? "" : "; <b>rejected</b>: " + Escape(c.rejected)) << "</td></tr>\n";
  }
  h << "</table>\n";
}

void WhitenessSection(std::ostringstream& h) {
  h << "<h2 id=\"whiteness\">Residual whiteness</h2><img src=\"whiteness.png\" alt=\"residual autocorrelation\">\n<p>Autocorrelation of the "
       "normalised residuals before and after. Residuals of multi-step predictions are correlated even for a perfect model "
       "(the error of the start state carries through a window); what matters is how much structure the effect removes.</p>\n";
}

std::string Html(const dg::Diagnosis& d, const DiagnoseLogOptions& o) {
  std::ostringstream h;
  // what is left comes first where it is the answer
  const bool left_first = d.verdict == "unexplained" || d.unexplained.present;
  Head(d, o, h);
  VerdictBox(d, o, h);
  Navigation(d, left_first, h);
  if (left_first) UnexplainedSection(d, o, h);
  if (!d.parameters.empty()) FittedEffectSection(d, h);
  CalibrationSection(d, h);
  NoiseFloorSection(d, h);
  SignalsSection(d, o, h);
  WhereSection(d, h);
  if (!left_first) UnexplainedSection(d, o, h);
  for (size_t r = 0; r < d.rounds.size(); ++r) RoundSection(d, r, h);
  if (d.rounds.empty()) {
    h << "<h2 id=\"rounds\">Candidates</h2><p>Effects not searched" << (d.not_searched.empty() ? "" : ": " + Escape(d.not_searched)) << ".</p>\n";
  }
  WhitenessSection(h);
  h << "</body></html>\n";
  return h.str();
}

}  // namespace

std::string ReportDirProblem(const std::string& dir) {
  std::error_code ec;
  if (std::filesystem::exists(dir, ec) && !std::filesystem::is_directory(dir, ec)) return dir + ": exists and is not a directory";
  return "";
}

std::string WriteReport(const dg::Diagnosis& d, const nlohmann::json& j, const DiagnoseLogOptions& o) {
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

nlohmann::json DiagnosisJson(const dg::Diagnosis& d) {
  nlohmann::json j;
  j["verdict"] = {{"effect", d.verdict},
                  {"effects", d.effects},
                  {"params", ParametersJson(d.parameters)},
                  {"calibration", CalibrationJson(d)},
                  {"noise_floor", NoiseFloorJson(d)},
                  {"unexplained", UnexplainedJson(d.unexplained)},
                  {"alternatives", nlohmann::json::array()},
                  {"search", d.not_searched.empty() ? std::string("searched") : "not searched: " + d.not_searched},
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
  j["rounds"] = nlohmann::json::array();
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
    if (!r.richer_forms_skipped.empty()) round["richer_forms_skipped"] = r.richer_forms_skipped;
    if (!r.search_ends.empty()) round["search_ends"] = r.search_ends;
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
                                  {"on_model_as_given", c.on_model_as_given},
                                  {"leaves_nothing_to_explain", c.leaves_nothing_to_explain},
                                  {"evaluations", c.evaluations},
                                  {"seconds", c.seconds}});
    }
    j["rounds"].push_back(round);
  }
  j["ranking"] = j["rounds"].empty() ? nlohmann::json::array() : j["rounds"][0]["ranking"];
  return j;
}

std::string DiagnoseLog(const DiagnoseLogOptions& options, dg::Diagnosis* result, nlohmann::json* document) {
  // the report's folder, checked before the diagnosis (a minute or more) rather than after
  if (!options.report_dir.empty()) {
    if (std::string e = ReportDirProblem(options.report_dir); !e.empty()) return e;
  }
  log::ReadOptions read;
  log::ReadResult train = log::ReadLog(options.train_path, read);
  if (!train.log) return train.error;
  std::optional<log::Log> heldout;
  if (!options.heldout_path.empty()) {
    log::ReadResult h = log::ReadLog(options.heldout_path, read);
    if (!h.log) return h.error;
    heldout = std::move(h.log);
  }
  std::optional<log::Log> test;
  if (!options.test_path.empty()) {
    log::ReadResult t = log::ReadLog(options.test_path, read);
    if (!t.log) return t.error;
    test = std::move(t.log);
  }
  const dg::DiagnoseOptions& o = options.diagnose;
  dg::Diagnosis d = dg::Diagnose(options.model_path, *train.log, heldout ? &*heldout : nullptr, o);
  if (!d.error.empty()) return d.error;
  nlohmann::json j = DiagnosisJson(d);
  if (test) {
    const dg::Graded g = dg::GradeOnLog(options.model_path, d, *test, o);
    if (!g.error.empty()) return options.test_path + ": " + g.error;
    j["test"] = {{"log", options.test_path}, {"gap_before", g.gap_before}, {"gap_calibrated", g.gap_calibrated}, {"gap_after", g.gap_after},
                 {"shrink_pct", 100 * (g.gap_before - g.gap_after) / g.gap_before}};
  }
  if (!options.report_dir.empty()) {
    if (std::string e = WriteReport(d, j, options); !e.empty()) return e;
  }
  *result = std::move(d);
  *document = std::move(j);
  return "";
}

}  // namespace pneumatic
