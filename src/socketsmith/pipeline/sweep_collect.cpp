// Collecting a sweep: every case's design.json into one CSV (radar, peak ratios, volumes, timings,
// failures) and a summary plot (sweep_detail.h says why this is apart).
#include "socketsmith/pipeline/sweep.h"
#include "socketsmith/pipeline/sweep_detail.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

#include <fmt/format.h>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/exit_status.h"
#include "socketsmith/core/json_input.h"
#include "socketsmith/core/log.h"
#include "socketsmith/design/case_file.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/report/plot_raster.h"
#include "socketsmith/report/svg_plot.h"

extern char** environ;

namespace socketsmith::pipeline {
using namespace sweep_detail;

namespace {

std::string csv_cell(const std::string& t) {
  if (t.find_first_of(",\"\n\r") == std::string::npos && (t.empty() || (t.front() != ' ' && t.back() != ' '))) return t;
  std::string q = "\"";
  for (char c : t) q += c == '"' ? std::string("\"\"") : std::string(1, c == '\n' || c == '\r' ? ' ' : c);
  return q + "\"";
}

std::string number_cell(const json& v) {
  if (v.is_number()) {
    const double d = v.get<double>();
    return std::isfinite(d) ? fmt::format("{:.10g}", d) : std::string();
  }
  if (v.is_boolean()) return v.get<bool>() ? "1" : "0";
  return {};
}

/// A result's cell: a number or a flag as number_cell, a list of phrases joined by "; " (quoted).
std::string result_cell(const json& v) {
  if (!v.is_array()) return number_cell(v);
  std::string t;
  for (const auto& e : v)
    if (e.is_string()) t += (t.empty() ? "" : "; ") + e.get<std::string>();
  return csv_cell(t);
}

/// A parameter's value as a cell: numbers and strings as they are, a limb as its file name or
/// "generated <type>".
std::string parameter_cell(const std::string& column, const json& v) {
  if (column == "limb" && v.is_object()) {
    if (v.contains("file") && v["file"].is_string()) return fs::path(v["file"].get<std::string>()).filename().string();
    // A generated limb: its type and whatever else the sweep set ("generated transtibial side=left").
    std::string label = "generated " + (v.contains("type") && v["type"].is_string() ? v["type"].get<std::string>()
                                                                                      : std::string("transtibial"));
    for (const auto& [k, x] : v.items())
      if (k != "type") label += " " + k + "=" + (x.is_string() ? x.get<std::string>() : x.dump());
    return label;
  }
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number() || v.is_boolean()) return number_cell(v);
  return v.dump();
}

const json& at_path(const json& j, const std::vector<std::string>& keys) {
  static const json null;
  const json* p = &j;
  for (const auto& k : keys) {
    if (!p->is_object() || !p->contains(k)) return null;
    p = &(*p)[k];
  }
  return *p;
}

/// A result column of results.csv: its name and where it is in design.json.
struct ResultColumn {
  const char* name;
  std::vector<std::string> path;  ///< keys into design.json
};

const std::vector<ResultColumn>& result_columns() {
  static const std::vector<ResultColumn> cols = {
      {"nodes", {"nodes"}},
      {"fx_n", {"radar", "fx_n"}},
      {"fy_n", {"radar", "fy_n"}},
      {"fz_n", {"radar", "fz_n"}},
      {"tx_nm", {"radar", "tx_nm"}},
      {"ty_nm", {"radar", "ty_nm"}},
      {"tz_nm", {"radar", "tz_nm"}},
      {"stability_n", {"radar", "stability_n"}},
      {"target_fz_n", {"targets", "fz_n"}},
      {"stability_min_n", {"targets", "stability_min_n"}},
      {"constraints_met", {"constraints_met"}},
      {"max_pressure_ratio", {"max_pressure_ratio"}},
      {"max_pressure_kpa", {"max_pressure_kpa"}},
      {"max_displacement_mm", {"max_displacement_mm"}},
      {"cavity_volume_cm3", {"socket", "cavity_volume_cm3"}},
      {"limb_volume_below_brim_cm3", {"socket", "limb_volume_below_brim_cm3"}},
      {"volume_reduction_percent", {"socket", "volume_reduction_percent"}},
      {"min_thickness_mm", {"socket", "min_thickness_mm"}},
      {"design_seconds", {"seconds"}},
      {"optimiser_seconds", {"optimiser_seconds"}},
      // The closed loop's kept socket, donned and stood on, against the design below the brim
      // (empty when the case ran no loop); delivery_bar_met: report/delivery_bar.h.
      {"closed_loop_donnings", {"closed_loop", "donnings"}},
      // Donnings that failed and were run again on a path of half the steps (design.md, loop step 1).
      {"closed_loop_retried_donnings", {"closed_loop", "retried_donnings"}},
      // 1 when the design was solved again with the drag band and kept, 0 when not kept, empty
      // when it was not tried (design.md, "The design again with a drag band").
      {"closed_loop_drag_band_kept", {"closed_loop", "drag_band", "kept"}},
      // 1 when the loop met its tolerances, 0 when it stopped short (its donnings spent, a corrected
      // socket not buildable): the kept socket is then its best, which `design` warns of.
      {"closed_loop_converged", {"closed_loop", "converged"}},
      {"closed_loop_mae_kpa", {"closed_loop", "regions", "below_brim", "closed_loop", "mae_kpa"}},
      {"closed_loop_p99_kpa", {"closed_loop", "regions", "below_brim", "closed_loop", "p99_kpa"}},
      {"closed_loop_r", {"closed_loop", "regions", "below_brim", "closed_loop", "r"}},
      {"closed_loop_landmark_deviation", {"closed_loop", "bar", "worst_landmark_deviation"}},
      {"closed_loop_dragged_out_nodes", {"closed_loop", "dragged_out_nodes"}},
      // The kept wall's node-scale roughness (pipeline::wall_roughness): its RMS and its share of
      // the correction's spread (over pipeline::kRoughWallShare the report advises a CalculiX check).
      {"closed_loop_roughness_rms_mm", {"closed_loop", "wall_roughness_rms_mm"}},
      {"closed_loop_roughness_share", {"closed_loop", "wall_roughness_share"}},
      {"delivery_bar_met", {"closed_loop", "bar", "met"}},
      {"delivery_bar_missed", {"closed_loop", "bar", "failing"}},  // its items missed, "; "-joined
      {"closed_loop_seconds", {"closed_loop", "seconds"}},
  };
  return cols;
}

/// design.json of an ok or unmet case (null otherwise, or when it cannot be read).
json case_design(const fs::path& dir, const std::string& id, const SweepCaseStatus& s) {
  json d;
  if (s.status == "ok" || s.status == "unmet") {
    const fs::path p = case_dir(dir, id) / "out" / "design.json";
    try {
      if (fs::exists(p)) d = read_json_file(p, "design summary");
    } catch (const Error&) {
      d = json();
    }
  }
  return d;
}

/// The case's row of results.csv: id, status, exit code, message, parameters, failing, results, time.
std::string case_row(const std::string& id, const SweepCaseStatus& s, const json& c, const json& d,
                     const std::vector<std::string>& params, const std::vector<ResultColumn>& cols) {
  std::string row = csv_cell(id) + "," + s.status + "," + (s.status == "missing" ? "" : std::to_string(s.exit_code)) +
                    "," + csv_cell(s.status == "missing" && s.message.empty()
                                       ? "not run yet (or still running): run the sweep again to finish it"
                                       : s.message);
  for (const auto& p : params) {
    row += ',';
    row += csv_cell(c["parameters"].contains(p) ? parameter_cell(p, c["parameters"][p]) : std::string());
  }
  row += "," + csv_cell(d.is_object() ? d.value("failing", std::string()) : std::string());
  for (const auto& col : cols) {
    row += ',';
    row += result_cell(at_path(d, col.path));
  }
  row += "," + (s.status == "missing" ? std::string() : fmt::format("{:.3f}", s.seconds));
  return row;
}

/// The parameter columns of results.csv: the swept ones, in axis order.
std::vector<std::string> swept_columns(const json& manifest) {
  std::vector<std::string> params;
  for (const auto& a : kAxes)
    for (const auto& c : manifest["cases"])
      if (c["parameters"].contains(a.column)) {
        params.emplace_back(a.column);
        break;
      }
  return params;
}

/// results.csv's first line: id, status, exit code, message, parameters, failing, results, time.
std::string csv_header(const std::vector<std::string>& params, const std::vector<ResultColumn>& cols) {
  std::string text = "id,status,exit_code,message";
  for (const auto& p : params) text += "," + p;
  text += ",failing";
  for (const auto& c : cols) text += std::string(",") + c.name;
  text += ",case_seconds\n";
  return text;
}

/// The summary figure's points, x = the case's index: peak ratio by status (a failed or missing
/// case at 0), the ok cases' cavity volume, every run case's time.
struct SummaryPoints {
  std::vector<double> x_ok, ratio_ok, x_unmet, ratio_unmet, x_failed, zero_failed, x_vol, vol, x_t, t;

  /// Case @p k's points, and its count in @p r.
  void add(size_t k, const SweepCaseStatus& s, const json& d, SweepCollectResult& r) {
    const double x = static_cast<double>(k);
    const json& ratio = at_path(d, {"max_pressure_ratio"});
    if (s.status == "ok") {
      ++r.ok;
      if (ratio.is_number()) x_ok.push_back(x), ratio_ok.push_back(ratio.get<double>());
      if (const json& v = at_path(d, {"socket", "cavity_volume_cm3"}); v.is_number()) x_vol.push_back(x), vol.push_back(v.get<double>());
    } else if (s.status == "unmet") {
      ++r.unmet;
      if (ratio.is_number()) x_unmet.push_back(x), ratio_unmet.push_back(ratio.get<double>());
    } else {
      s.status == "missing" ? ++r.missing : ++r.failed;
      x_failed.push_back(x), zero_failed.push_back(0.0);
    }
    if (s.status != "missing") x_t.push_back(x), t.push_back(s.seconds);
  }
};

/// A panel of the summary figure over @p cases cases.
report::Plot case_panel(const std::string& title, const std::string& y_label, double cases) {
  report::Plot p;
  p.title = title;
  p.x_label = "case";
  p.y_label = y_label;
  p.x_min = -0.5;
  p.x_max = cases - 0.5;
  p.width_px = 900;
  p.height_px = 300;
  return p;
}

report::PlotSeries scatter(const std::string& name, std::vector<double> x, std::vector<double> y, const char* color) {
  report::PlotSeries s;
  s.name = name;
  s.x = std::move(x);
  s.y = std::move(y);
  s.color = color;
  s.markers = true;
  s.line_width = 0;
  return s;
}

/// Summary figure: peak pressure ratio, cavity volume and time per case.
std::vector<report::Plot> summary_panels(const json& m, const SweepCollectResult& r, const SummaryPoints& pts) {
  const double n = static_cast<double>(std::max<size_t>(1, m["cases"].size()));
  std::vector<report::Plot> panels;
  {
    auto p = case_panel(fmt::format("{}: {} ok, {} constraints not met, {} failed, {} not run",
                                    m.value("name", std::string()), r.ok, r.unmet, r.failed, r.missing),
                        "peak pressure / threshold", n);
    p.series.push_back(scatter("ok", pts.x_ok, pts.ratio_ok, "#0072B2"));
    p.series.push_back(scatter("constraints not met", pts.x_unmet, pts.ratio_unmet, "#E69F00"));
    p.series.push_back(scatter("failed or not run (at 0)", pts.x_failed, pts.zero_failed, "#D55E00"));
    p.y_min = 0.0;
    if (pts.ratio_ok.empty() && pts.ratio_unmet.empty()) p.y_max = 1.0;
    panels.push_back(p);
  }
  {
    auto p = case_panel("socket cavity", "volume [cm^3]", n);
    p.series.push_back(scatter("ok", pts.x_vol, pts.vol, "#0072B2"));
    if (pts.vol.empty()) p.y_min = 0.0, p.y_max = 1.0;
    p.legend = report::LegendPosition::None;
    panels.push_back(p);
  }
  {
    auto p = case_panel("time per case", "wall time [s]", n);
    p.series.push_back(scatter("", pts.x_t, pts.t, "#009E73"));
    p.y_min = 0.0;
    if (pts.t.empty()) p.y_max = 1.0;
    p.legend = report::LegendPosition::None;
    panels.push_back(p);
  }
  return panels;
}

}  // namespace

SweepCollectResult collect_sweep(const fs::path& dir) {
  const json m = read_manifest(dir);
  const std::vector<std::string> params = swept_columns(m);
  const std::vector<ResultColumn>& cols = result_columns();
  std::string text = csv_header(params, cols);

  SweepCollectResult r;
  SummaryPoints pts;
  for (size_t k = 0; k < m["cases"].size(); ++k) {
    const json& c = m["cases"][k];
    const std::string id = c["id"].get<std::string>();
    const SweepCaseStatus s = read_case_status(dir, id);
    const json d = case_design(dir, id, s);
    text += case_row(id, s, c, d, params, cols) + "\n";
    ++r.rows;
    if (const json& met = at_path(d, {"closed_loop", "bar", "met"}); met.is_boolean()) {
      ++r.delivery_judged;
      r.delivery_met += met.get<bool>() ? 1 : 0;
    }
    pts.add(k, s, d, r);
  }
  r.csv = dir / "results.csv";
  write_text_atomically(r.csv, text);

  const std::vector<report::Plot> panels = summary_panels(m, r, pts);
  r.svg = dir / "summary.svg";
  r.png = dir / "summary.png";
  report::write_svg_grid(r.svg, panels, 1);
  report::write_plot_grid_png(r.png, panels, 1);
  return r;
}

}  // namespace socketsmith::pipeline
