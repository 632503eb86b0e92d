#include "socketsmith/report/slice_table.h"

#include <cmath>
#include <limits>

#include "socketsmith/core/errors.h"
#include "socketsmith/report/csv.h"
#include "socketsmith/report/svg_plot.h"

namespace socketsmith::report {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string cell(double v, double scale, int digits = 4) { return std::isfinite(v) ? format_number(v * scale, digits) : "—"; }

}  // namespace

double percent_change(double a, double b) {
  if (!std::isfinite(a) || !std::isfinite(b) || a == 0) return kNaN;
  return 100 * (b - a) / a;
}

std::vector<Plot> slice_plots(const SliceTable& t) {
  require(!t.rows.empty(), "slice_plots: '{}' has no levels", t.title);
  Plot circ;
  circ.title = "Circumference along the limb";
  circ.x_label = "height above the distal end [mm]";
  circ.y_label = "circumference [mm]";
  circ.width_px = 640;
  circ.height_px = 360;
  circ.y_min = 0.0;
  PlotSeries a{t.a_label, {}, {}, "#0072B2", false, true, 2};
  PlotSeries b{t.b_label, {}, {}, "#D55E00", true, true, 2};
  Plot change = circ;
  change.title = "Change, " + t.b_label + " against " + t.a_label;
  change.y_label = "change [%]";
  change.y_min.reset();
  PlotSeries dc{"circumference", {}, {}, "#0072B2", false, true, 2};
  PlotSeries dv{"slab volume", {}, {}, "#009E73", true, true, 2};
  for (const auto& r : t.rows) {
    const double h = r.h_m * 1e3;
    a.x.push_back(h);
    a.y.push_back(r.a.circumference_m * 1e3);
    b.x.push_back(h);
    b.y.push_back(r.b.circumference_m * 1e3);
    dc.x.push_back(h);
    dc.y.push_back(percent_change(r.a.circumference_m, r.b.circumference_m));
    dv.x.push_back(h);
    dv.y.push_back(percent_change(r.a.slab_volume_m3, r.b.slab_volume_m3));
  }
  circ.series = {a, b};
  change.series = {dc, dv};
  return {circ, change};
}

void write_slice_csv(const std::filesystem::path& path, const SliceTable& t) {
  const std::string a = t.a_label, b = t.b_label;
  std::vector<std::string> header{"h_mm",
                                  a + "_circumference_mm", a + "_area_cm2", a + "_slab_volume_cm3",
                                  b + "_circumference_mm", b + "_area_cm2", b + "_slab_volume_cm3",
                                  "circumference_change_percent", "area_change_percent", "volume_change_percent"};
  std::vector<std::vector<double>> rows;
  for (const auto& r : t.rows)
    rows.push_back({r.h_m * 1e3, r.a.circumference_m * 1e3, r.a.area_m2 * 1e4, r.a.slab_volume_m3 * 1e6,
                    r.b.circumference_m * 1e3, r.b.area_m2 * 1e4, r.b.slab_volume_m3 * 1e6,
                    percent_change(r.a.circumference_m, r.b.circumference_m), percent_change(r.a.area_m2, r.b.area_m2),
                    percent_change(r.a.slab_volume_m3, r.b.slab_volume_m3)});
  write_csv(path, header, rows, 8);
}

void append_slice_section(HtmlWriter& h, const SliceTable& t) {
  h.heading(t.title);
  const std::string a = t.a_label, b = t.b_label;
  h.paragraph(fmt::format("Every {} mm along the limb axis, h above the distal end. Circumference and cross-section at "
                          "the level; volume of the slab between the level below (or the distal end) and this one.{}",
                          format_number(t.step_m * 1e3), t.csv_file.empty() ? "" : " The table: " + t.csv_file + "."));
  std::vector<std::vector<std::string>> rows;
  double va = 0, vb = 0;
  bool b_complete = true;
  for (const auto& r : t.rows) {
    va += r.a.slab_volume_m3;
    if (std::isfinite(r.b.slab_volume_m3)) vb += r.b.slab_volume_m3;
    else b_complete = false;
    rows.push_back({format_number(r.h_m * 1e3, 4), cell(r.a.circumference_m, 1e3), cell(r.b.circumference_m, 1e3),
                    cell(percent_change(r.a.circumference_m, r.b.circumference_m), 1, 2), cell(r.a.area_m2, 1e4),
                    cell(r.b.area_m2, 1e4), cell(r.a.slab_volume_m3, 1e6), cell(r.b.slab_volume_m3, 1e6),
                    cell(percent_change(r.a.slab_volume_m3, r.b.slab_volume_m3), 1, 2)});
  }
  rows.push_back({"total", "", "", "", "", "", format_number(va * 1e6, 4),
                  b_complete ? format_number(vb * 1e6, 4) : format_number(vb * 1e6, 4) + " (closed levels)",
                  b_complete ? cell(percent_change(va, vb), 1, 2) : "—"});
  h.table({"h [mm]", a + " circumference [mm]", b + " circumference [mm]", "change [%]", a + " area [cm²]",
           b + " area [cm²]", a + " slab volume [cm³]", b + " slab volume [cm³]", "volume change [%]"},
          rows);
  if (!t.note.empty()) h.paragraph(t.note);
  for (const auto& p : slice_plots(t)) h.image(svg_data_uri(render_svg(p)), p.title);
}

}  // namespace socketsmith::report
