#include "socketsmith/pipeline/shape_comparison.h"

#include <chrono>
#include <cmath>
#include <fstream>
#include <numbers>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/report/html.h"
#include "socketsmith/report/nice_number.h"
#include "socketsmith/report/vtk_writer.h"

namespace socketsmith::pipeline {
namespace {

namespace fs = std::filesystem;
using geometry::Vec3;

nlohmann::json mm_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v * 1e3) : nlohmann::json(nullptr); }

double automatic_range_m(const geometry::DeviationStats& s) {
  const double big = std::max({std::abs(s.p05_m), std::abs(s.p95_m), 1e-4});
  return report::nice_ceil(1.25 * big * 1e3) * 1e-3;
}

std::string mm_text(double m, int digits = 3) { return report::format_number(m * 1e3, digits) + " mm"; }

}  // namespace

std::vector<geometry::NamedPoint> read_landmark_file(const fs::path& path, units::LengthUnit unit, double scale) {
  std::ifstream in(path);
  require<IoError>(in.good(), "cannot open landmark file '{}' (check the path)", path.string());
  nlohmann::json j;
  try {
    in >> j;
  } catch (const nlohmann::json::exception& e) {
    fail("landmark file '{}' is not valid JSON ({}); expected {{\"PT\": [x, y, z], ...}}", path.string(), e.what());
  }
  require(j.is_object() && !j.empty(), "landmark file '{}' is not an object of points (expected {{\"PT\": [x, y, z], ...}})",
          path.string());
  std::vector<geometry::NamedPoint> out;
  for (const auto& [code, p] : j.items()) {
    require(p.is_array() && p.size() == 3 && p[0].is_number() && p[1].is_number() && p[2].is_number(),
            "landmark file '{}': '{}' is not a point [x, y, z]", path.string(), code);
    const Vec3 v(p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
    require(v.allFinite(), "landmark file '{}': '{}' is not finite", path.string(), code);
    out.emplace_back(code, v * units::to_metres(unit) * scale);
  }
  return out;
}

report::CompareReportData compare_report_data(const geometry::ShapeComparison& r, const std::string& a_label,
                                              const std::string& b_label, double range_m) {
  report::CompareReportData d;
  d.generated = "socketsmith 0.1.0";
  d.a_file = a_label;
  d.b_file = b_label + (r.b_kind == geometry::ShapeKind::Socket ? " (socket: its cavity)" : "");
  const double angle_deg = r.transform.angle_rad() * 180 / std::numbers::pi;
  d.alignment = {{"seed", r.seed},
                 {"rigid motion of B", fmt::format("rotation {}°, translation {} mm", report::format_number(angle_deg),
                                                   report::format_number(r.transform.translation.norm() * 1e3))},
                 {"ICP", r.icp.iterations > 0 ? fmt::format("{} iterations, {} pairs; {}", r.icp.iterations, r.icp.pairs,
                                                            r.icp.message)
                                              : std::string("not run")},
                 {"residual (RMS about the uniform offset)", mm_text(r.icp.rms_m)},
                 {"uniform normal offset of B", mm_text(r.icp.offset_m)},
                 {"crop height (above A's distal end)", mm_text(r.crop_height_m, 4)}};
  const auto& s = r.stats;
  d.deviation = {{"points of A below the crop", std::to_string(s.points)},
                 {"where B was found", fmt::format("{} ({} %)", s.covered,
                                                   report::format_number(s.points ? 100.0 * s.covered / s.points : 0))},
                 {"mean (area-weighted)", mm_text(s.mean_m)},
                 {"standard deviation", mm_text(s.sd_m)},
                 {"RMS", mm_text(s.rms_m)},
                 {"min / max", mm_text(s.min_m) + " / " + mm_text(s.max_m)},
                 {"5th / 95th percentile", mm_text(s.p05_m) + " / " + mm_text(s.p95_m)}};
  d.volumes = {{"A below the crop", report::format_number(r.volume_a_m3 * 1e6, 4) + " cm³"},
               {"B below the crop", report::format_number(r.volume_b_m3 * 1e6, 4) + " cm³"},
               {"change (B − A)", report::format_number((r.volume_b_m3 - r.volume_a_m3) * 1e6, 4) + " cm³ (" +
                                      report::format_number(report::percent_change(r.volume_a_m3, r.volume_b_m3)) + " %)"}};
  d.map.surface = &r.a;
  for (double v : r.deviation_m) d.map.values.push_back(v * 1e3);
  const double range = range_m > 0 ? range_m : automatic_range_m(s);
  d.map.value_min = -range * 1e3;
  d.map.value_max = range * 1e3;
  d.map.value_label = "mm";
  d.map.colormap = report::Colormap::Diverging;
  d.map.title = "Deviation of B from A [mm]";
  d.map.frame = report::surface_frame(r.frame);
  d.map_caption = fmt::format("Signed distance from A to B at each point of A: red where B lies outside A (larger), blue "
                              "inside (smaller); colour range ±{} mm; grey above the crop or where B does not cover A. "
                              "Views from A's limb frame (anterior estimated).",
                              report::format_number(range * 1e3));
  d.slices.title = "Slices (B against A)";
  d.slices.a_label = "A";
  d.slices.b_label = "B";
  d.slices.step_m = r.slices.size() > 1 ? r.slices[1].h_m - r.slices[0].h_m : r.slices.front().h_m;
  d.slices.csv_file = "slices.csv";
  for (const auto& sl : r.slices)
    d.slices.rows.push_back({sl.h_m,
                             {sl.a.circumference_m, sl.a.area_m2, sl.a.slab_volume_m3},
                             {sl.b.circumference_m, sl.b.area_m2, sl.b.slab_volume_m3}});
  d.notes = r.notes;
  return d;
}

namespace {

/// The map (PNG, and A with the field for ParaView), B aligned, the slices and the page, into @p out.
void write_compare_files(const geometry::ShapeComparison& r, const report::CompareReportData& page,
                         const fs::path& out) {
  report::write_pressure_map(out / "deviation_map.png", page.map);
  std::vector<double> dev(r.deviation_m.size()), covered(r.deviation_m.size());
  for (size_t v = 0; v < dev.size(); ++v) {
    covered[v] = std::isfinite(r.deviation_m[v]) ? 1.0 : 0.0;
    dev[v] = covered[v] > 0 ? r.deviation_m[v] * 1e3 : 0.0;
  }
  report::write_vtp(out / "deviation.vtp", r.a, {{"deviation_mm", 1, dev}, {"covered", 1, covered}});
  geometry::write_mesh(out / "b_aligned.stl", r.b);
  report::write_slice_csv(out / "slices.csv", page.slices);
  report::write_compare_html(out / "compare.html", page);
}

/// compare.json's slices: per height both shapes' circumference, area and slab volume, and the changes.
nlohmann::json slices_json(const geometry::ShapeComparison& r) {
  nlohmann::json slices = nlohmann::json::array();
  for (const auto& sl : r.slices)
    slices.push_back({{"h_mm", sl.h_m * 1e3},
                      {"a_circumference_mm", sl.a.circumference_m * 1e3},
                      {"b_circumference_mm", sl.b.circumference_m * 1e3},
                      {"a_area_cm2", sl.a.area_m2 * 1e4},
                      {"b_area_cm2", sl.b.area_m2 * 1e4},
                      {"a_slab_volume_cm3", sl.a.slab_volume_m3 * 1e6},
                      {"b_slab_volume_cm3", sl.b.slab_volume_m3 * 1e6},
                      {"circumference_change_mm", (sl.b.circumference_m - sl.a.circumference_m) * 1e3},
                      {"volume_change_cm3", (sl.b.slab_volume_m3 - sl.a.slab_volume_m3) * 1e6}});
  return slices;
}

/// compare.json's transform_b_to_a: the rigid motion that aligns B on A.
nlohmann::json transform_json(const geometry::ShapeComparison& r) {
  nlohmann::json rot = nlohmann::json::array();
  for (int i = 0; i < 3; ++i) rot.push_back({r.transform.rotation(i, 0), r.transform.rotation(i, 1), r.transform.rotation(i, 2)});
  return {{"rotation", rot},
          {"translation_mm", {r.transform.translation.x() * 1e3, r.transform.translation.y() * 1e3, r.transform.translation.z() * 1e3}},
          {"angle_deg", r.transform.angle_rad() * 180 / std::numbers::pi}};
}

/// compare.json but for its time: the inputs, the alignment, the deviation statistics with the map's
/// colour range @p range_m, the volumes, the slices and the outputs.
nlohmann::json compare_summary(const geometry::ShapeComparison& r, const fs::path& a_path, const fs::path& b_path,
                               const fs::path& out, double range_m) {
  const auto& s = r.stats;
  return {
      {"a", a_path.string()},
      {"b", b_path.string()},
      {"b_kind", geometry::to_string(r.b_kind)},
      {"seed", r.seed},
      {"transform_b_to_a", transform_json(r)},
      {"icp",
       {{"rms_mm", r.icp.rms_m * 1e3},
        {"rms_distance_mm", r.icp.rms_distance_m * 1e3},
        {"uniform_offset_mm", r.icp.offset_m * 1e3},
        {"pairs", r.icp.pairs},
        {"iterations", r.icp.iterations},
        {"converged", r.icp.converged},
        {"message", r.icp.message}}},
      {"crop_height_mm", r.crop_height_m * 1e3},
      {"frame",
       {{"origin_mm", {r.frame.origin.x() * 1e3, r.frame.origin.y() * 1e3, r.frame.origin.z() * 1e3}},
        {"axis", {r.frame.axis.x(), r.frame.axis.y(), r.frame.axis.z()}}}},
      {"deviation",
       {{"points", s.points},
        {"covered", s.covered},
        {"mean_mm", s.mean_m * 1e3},
        {"sd_mm", s.sd_m * 1e3},
        {"rms_mm", s.rms_m * 1e3},
        {"min_mm", mm_or_null(s.covered ? s.min_m : NAN)},
        {"max_mm", mm_or_null(s.covered ? s.max_m : NAN)},
        {"p05_mm", mm_or_null(s.p05_m)},
        {"p95_mm", mm_or_null(s.p95_m)},
        {"colour_range_mm", range_m * 1e3}}},
      {"volume",
       {{"a_cm3", r.volume_a_m3 * 1e6},
        {"b_cm3", r.volume_b_m3 * 1e6},
        {"change_cm3", (r.volume_b_m3 - r.volume_a_m3) * 1e6},
        {"change_percent", report::percent_change(r.volume_a_m3, r.volume_b_m3)}}},
      {"slices", slices_json(r)},
      {"notes", r.notes},
      {"out", out.string()},
      {"outputs", {"compare.html", "compare.json", "deviation_map.png", "deviation.vtp", "b_aligned.stl", "slices.csv"}}};
}

}  // namespace

nlohmann::json run_compare(const fs::path& a_path, const fs::path& b_path, const fs::path& out,
                           const CompareRunOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  require(std::isfinite(o.scale) && o.scale > 0, "compare: scale {} must be positive", o.scale);
  require(std::isfinite(o.range_m) && o.range_m >= 0, "compare: colour range {} mm must be positive (0: automatic)",
          o.range_m * 1e3);
  require(o.landmarks_a.empty() == o.landmarks_b.empty(),
          "compare: give landmarks for both shapes (--landmarks-a and --landmarks-b), or for neither");
  geometry::MeshReadOptions ro;
  ro.unit = o.units;
  geometry::MeshReadInfo ia, ib;
  geometry::TriMesh a = geometry::read_mesh(a_path, ro, &ia);
  geometry::TriMesh b = geometry::read_mesh(b_path, ro, &ib);
  if (o.scale != 1.0) {
    geometry::scale(a, o.scale);
    geometry::scale(b, o.scale);
  }
  geometry::ShapeCompareOptions co = o.compare;
  if (!o.landmarks_a.empty()) {
    co.landmarks_a = read_landmark_file(o.landmarks_a, ia.unit, o.scale);
    co.landmarks_b = read_landmark_file(o.landmarks_b, ib.unit, o.scale);
  }
  ensure_directory(out);
  const geometry::ShapeComparison r = geometry::compare_shapes(a, b, co);
  for (const auto& n : r.notes) log::info("compare: {}", n);

  const report::CompareReportData page = compare_report_data(r, a_path.string(), b_path.string(), o.range_m);
  write_compare_files(r, page, out);
  const double range = std::abs(page.map.value_max) * 1e-3;
  nlohmann::json j = compare_summary(r, a_path, b_path, out, range);
  j["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  write_text_atomically(out / "compare.json", j.dump(2) + "\n");
  return j;
}

}  // namespace socketsmith::pipeline
