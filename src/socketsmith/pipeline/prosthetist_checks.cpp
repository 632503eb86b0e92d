#include "socketsmith/pipeline/prosthetist_checks.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/shape_compare.h"
#include "socketsmith/geometry/slices.h"
#include "socketsmith/geometry/socket_cavity.h"
#include "socketsmith/geometry/surface_query.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/report/html.h"
#include "socketsmith/report/nice_number.h"

namespace socketsmith::pipeline {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
using Vec3 = Eigen::Vector3d;
constexpr double kSliceStep = 0.01;  // [m] every 10 mm, as a prosthetist tapes

}  // namespace

Rectification compute_rectification(const geometry::TriMesh& limb, const geometry::TriMesh& wall,
                                     const geometry::LimbFrame& frame, const design::BrimLine& brim,
                                     const std::vector<volume::Landmark>& landmarks) {
  require(!limb.empty() && !wall.empty(), "rectification: the {} surface has no triangles",
          limb.empty() ? "limb" : "socket");
  const geometry::SurfaceQuery qw(wall), ql(limb);
  const Vec3 axis = frame.axis.normalized();
  // Socket minus limb at skin point p of outward normal n: along the ray from the axis where the
  // skin faces sideways; along the axis where it faces down (the distal end, where a horizontal
  // ray grazes the skin and a radial difference means nothing): the wall's distance below p.
  const auto at = [&](const Vec3& p, const Vec3& n, bool& axial) -> double {
    const auto c = frame.to_cylindrical(p);
    axial = std::abs(n.dot(axis)) > std::abs(n.dot(frame.radial(c.theta)));
    if (!axial) {
      const auto rho = geometry::radius_at(qw, frame, c.theta, c.h);
      return rho ? *rho - c.rho : kNaN;
    }
    constexpr double kInside = 0.02;  // [m] the ray starts this far up inside the limb
    const auto hit = qw.first_hit(p + kInside * axis, -axis);
    return hit ? hit->distance - kInside : kNaN;
  };
  const auto normals = geometry::vertex_normals(limb);
  Rectification r;
  r.vertex_m.assign(limb.vertices.size(), kNaN);
  std::vector<char> below(limb.vertices.size(), 0);
  for (size_t v = 0; v < limb.vertices.size(); ++v) {
    const auto c = frame.to_cylindrical(limb.vertices[v]);
    if (c.h >= brim.height(c.theta)) continue;
    below[v] = 1;
    bool axial = false;
    r.vertex_m[v] = at(limb.vertices[v], normals[v], axial);
  }
  const geometry::DeviationStats s = geometry::deviation_stats(limb, r.vertex_m, below);
  r.min_m = s.min_m;
  r.max_m = s.max_m;
  r.mean_m = s.mean_m;
  for (const auto& l : landmarks) {
    LandmarkRectification lr;
    lr.code = l.code;
    lr.name = l.name;
    lr.theta_rad = l.cylindrical.theta;
    lr.h_m = l.cylindrical.h;
    const geometry::SurfaceHit on = ql.closest_point(l.position);
    lr.rectification_m = kNaN;
    if (lr.h_m < brim.height(lr.theta_rad))
      lr.rectification_m = at(on.point, geometry::triangle_normal(limb, on.triangle), lr.is_axial);
    r.landmarks.push_back(lr);
  }
  return r;
}

const char* rectification_kind(double socket_minus_limb_m) {
  return !std::isfinite(socket_minus_limb_m) ? "above the brim" : socket_minus_limb_m < 0 ? "indentation" : "relief";
}

double rectification_span_mm(const Rectification& r) {
  return report::nice_ceil(std::max({std::abs(r.min_m), std::abs(r.max_m), 1e-4}) * 1e3);
}

ChecksWall checks_wall(const design::SocketResult* socket, bool closed_loop, const geometry::TriMesh& designed_skin,
                       const design::BrimLine& brim) {
  ChecksWall w;
  if (socket) {
    std::vector<int> inner;
    for (size_t t = 0; t < socket->face_kind.size(); ++t)
      if (socket->face_kind[t] == design::SocketFace::Inner) inner.push_back(static_cast<int>(t));
    w.wall = geometry::submesh(socket->solid, inner);
    geometry::flip_orientation(w.wall);  // the solid's inner wall faces the cavity: turn it to face out of it
    w.source = closed_loop ? "the socket's inner wall (corrected by the closed loop)" : "the socket's inner wall";
    w.closed_below_m = socket->rim_min_h_m;
  } else {
    w.wall = designed_skin;
    w.source = "the designed skin (no socket was built)";
    w.closed_below_m = brim.min_height();
  }
  return w;
}

ChecksWall designed_wall(const geometry::TriMesh& rest_skin, const geometry::TriMesh& designed_skin,
                         bool constraints_met, const geometry::LimbFrame& frame, const design::BrimLine& brim,
                         const design::SocketOptions& socket) {
  if (!constraints_met) return checks_wall(nullptr, false, designed_skin, brim);
  const design::SocketResult built = build_design_socket(designed_skin, rest_skin, frame, brim, socket);
  return checks_wall(&built, false, designed_skin, brim);
}

ProsthetistChecks prosthetist_checks(const DesignSetup& setup, const DesignResult& result) {
  ProsthetistChecks c;
  const auto& frame = setup.model.frame;
  ChecksWall w = checks_wall(result.socket ? &*result.socket : nullptr, result.closed_loop.has_value(),
                             result.deformed_skin, setup.brim);
  c.wall = std::move(w.wall);
  c.wall_source = std::move(w.source);
  c.socket_closed_below_m = w.closed_below_m;
  c.rectification = compute_rectification(result.rest_skin, c.wall, frame, setup.brim, setup.model.landmarks);

  // Slices: the limb up to its cut, the cavity where its section is closed (below the brim's lowest point).
  const double limb_top = geometry::lowest_open_boundary_height(result.rest_skin, frame) - 1e-4;
  const auto heights = geometry::slice_heights(kSliceStep, limb_top);
  const auto limb = geometry::measure_slices(result.rest_skin, frame, heights);
  std::vector<double> closed;
  for (double h : heights)
    if (h < c.socket_closed_below_m) closed.push_back(h);
  const auto cavity = closed.empty() ? std::vector<geometry::SliceLevel>{}
                                     : geometry::measure_slices(c.wall, frame, closed);
  c.slices.title = "Slice measurements (limb and socket cavity)";
  c.slices.a_label = "limb";
  c.slices.b_label = "socket";
  c.slices.step_m = kSliceStep;
  c.slices.csv_file = "slices.csv";
  c.slices.note = fmt::format("Limb: the stump's skin at rest. Socket: {}, a closed section below the brim's lowest "
                              "point ({} mm); above it the socket's values are left out.",
                              c.wall_source, report::format_number(c.socket_closed_below_m * 1e3));
  for (size_t k = 0; k < heights.size(); ++k) {
    report::SliceRow row;
    row.h_m = heights[k];
    row.a = {limb[k].circumference_m, limb[k].area_m2, limb[k].slab_volume_m3};
    row.b = k < cavity.size() ? report::SliceValues{cavity[k].circumference_m, cavity[k].area_m2, cavity[k].slab_volume_m3}
                              : report::SliceValues{kNaN, kNaN, kNaN};
    c.slices.rows.push_back(row);
  }
  return c;
}

nlohmann::json write_prosthetist_checks(const DesignSetup& setup, const DesignResult& result, const ProsthetistChecks& c,
                                        const std::filesystem::path& out, report::DesignReportData& rd) {
  const auto& frame = setup.model.frame;
  const auto& rect = c.rectification;
  // Rectification: per landmark (CSV, JSON, report table) and the map on the limb.
  nlohmann::json lms = nlohmann::json::array();
  std::string csv = "code,theta_deg,h_mm,rectification_mm,measured\n";
  for (const auto& l : rect.landmarks) {
    const double d = l.rectification_m;
    lms.push_back({{"code", l.code},
                   {"name", l.name},
                   {"theta_deg", l.theta_rad * 180 / std::numbers::pi},
                   {"h_mm", l.h_m * 1e3},
                   {"measured", l.is_axial ? "along the axis" : "radially"},
                   {"rectification_mm", std::isfinite(d) ? nlohmann::json(d * 1e3) : nullptr},
                   {"kind", rectification_kind(d)}});
    csv += fmt::format("{},{:.3f},{:.3f},{:.4f},{}\n", l.code, l.theta_rad * 180 / std::numbers::pi, l.h_m * 1e3,
                       d * 1e3, l.is_axial ? "axial" : "radial");
  }
  write_text_atomically(out / "rectification.csv", csv);
  report::ReportRectification rr;
  rr.has_rectification = true;
  rr.source = c.wall_source;
  rr.min_m = rect.min_m;
  rr.max_m = rect.max_m;
  rr.mean_m = rect.mean_m;
  for (const auto& l : rect.landmarks)
    rr.landmarks.push_back({l.code, l.name, l.theta_rad, l.h_m, l.rectification_m, l.is_axial});
  report::PressureMapData& m = rr.map;
  m.surface = &result.rest_skin;
  m.value_label = "mm";
  m.colormap = report::Colormap::Diverging;
  m.title = "Rectification: socket minus limb [mm] (radially; along the axis at the distal end)";
  m.frame = report::surface_frame(frame);
  for (const auto& l : setup.model.landmarks) m.landmarks.push_back({l.code, l.position, l.estimated});
  m.brim = brim_on_skin(setup, 180);
  const double span = rectification_span_mm(rect);
  m.value_min = -span;
  m.value_max = span;
  for (double v : rect.vertex_m) m.values.push_back(v * 1e3);
  rr.has_map = true;
  report::write_pressure_map(out / "rectification_map.png", m);
  rd.rectification = rr;
  rd.slices = c.slices;
  report::write_slice_csv(out / c.slices.csv_file, c.slices);

  nlohmann::json levels = nlohmann::json::array();
  const auto fin = [](double v, double s) { return std::isfinite(v) ? nlohmann::json(v * s) : nlohmann::json(nullptr); };
  for (const auto& r : c.slices.rows)
    levels.push_back({{"h_mm", r.h_m * 1e3},
                      {"limb_circumference_mm", r.a.circumference_m * 1e3},
                      {"socket_circumference_mm", fin(r.b.circumference_m, 1e3)},
                      {"limb_area_cm2", r.a.area_m2 * 1e4},
                      {"socket_area_cm2", fin(r.b.area_m2, 1e4)},
                      {"limb_slab_volume_cm3", r.a.slab_volume_m3 * 1e6},
                      {"socket_slab_volume_cm3", fin(r.b.slab_volume_m3, 1e6)},
                      {"circumference_change_percent", fin(report::percent_change(r.a.circumference_m, r.b.circumference_m), 1)},
                      {"volume_change_percent", fin(report::percent_change(r.a.slab_volume_m3, r.b.slab_volume_m3), 1)}});
  return {{"rectification",
           {{"wall", c.wall_source},
            {"min_mm", rect.min_m * 1e3},
            {"max_mm", rect.max_m * 1e3},
            {"mean_mm", rect.mean_m * 1e3},
            {"landmarks", lms},
            {"map", "rectification_map.png"},
            {"csv", "rectification.csv"}}},
          {"slices",
           {{"step_mm", c.slices.step_m * 1e3},
            {"socket_closed_below_mm", c.socket_closed_below_m * 1e3},
            {"csv", c.slices.csv_file},
            {"levels", levels}}}};
}

}  // namespace socketsmith::pipeline
