#include "socketsmith/report/design_report.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/report/design_report_detail.h"
#include "socketsmith/report/draw_2d.h"
#include "socketsmith/report/html.h"
#include "socketsmith/report/nice_number.h"

// GCC 12 warns -Wrestrict on std::string copies it inlines into the radar's label code (GCC bug
// 105329, a false positive: no overlapping copy is made); this file alone inlines them since the
// paths and the page moved out.
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ == 12
#pragma GCC diagnostic ignored "-Wrestrict"
#endif

namespace socketsmith::report {
using namespace design_report_detail;
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr Rgb kWhite{255, 255, 255};
constexpr Rgb kInk{30, 30, 30};
constexpr Rgb kGrid{200, 200, 200};
constexpr Rgb kTargetColour{30, 60, 150};
constexpr Rgb kPolygonColour{70, 130, 220};


// ---- radar layout --------------------------------------------------------------------------

constexpr int kRadarTitleScale = 3, kRadarLabelScale = 2;
constexpr int kRadarSideRoom = 140;  // label room left and right of the outer ring [px]
constexpr int kRadarVertRoom = 60;   // label room above and below the outer ring [px]
constexpr int kRadarLegendRows = 2;

struct RadarLayout {
  int width = 0, height = 0;
  int title_h = 0;
  Vector2d centre;
  double r_out = 0;  // [px] of kRadarMaxRadius
};

void validate_radar(const RadarChart& chart) {
  const auto n = chart.axes.size();
  require(n >= 3 && n <= 12, "render_radar_chart: {} axes (expected 3..12; 7 for the design tool)",
          n);
  require(chart.size_px >= 80 && chart.size_px <= 2000,
          "render_radar_chart: size {} px (expected 80..2000)", chart.size_px);
  for (const auto& a : chart.axes) {
    require(std::isfinite(a.value) && std::isfinite(a.target),
            "render_radar_chart: axis '{}' value {} / target {} (expected finite numbers)", a.name,
            a.value, a.target);
    require(std::isfinite(a.tolerance) && a.tolerance >= 0,
            "render_radar_chart: axis '{}' tolerance {} (expected ≥ 0)", a.name, a.tolerance);
    require(std::isfinite(a.scale) && a.scale > 0,
            "render_radar_chart: axis '{}' scale {} (expected a positive reference, e.g. M g / 2)",
            a.name, a.scale);
  }
}

RadarLayout radar_layout(const RadarChart& chart) {
  RadarLayout l;
  l.r_out = chart.size_px;
  l.title_h = 12 + text_height("X", kRadarTitleScale) + 8;
  const int legend_h = kRadarLegendRows * text_height("X", kRadarLabelScale) + 24;
  l.width = 2 * chart.size_px + 2 * kRadarSideRoom;
  l.height = l.title_h + 2 * (chart.size_px + kRadarVertRoom) + legend_h;
  l.centre = Vector2d(0.5 * l.width, l.title_h + kRadarVertRoom + chart.size_px);
  return l;
}

Vector2d radar_direction(int k, int n) {
  const double a = -0.5 * kPi + 2 * kPi * k / n;
  return {std::cos(a), std::sin(a)};
}


std::string radar_value_text(const RadarAxis& a) {
  return a.unit.empty() ? num(a.value) : num(a.value) + " " + a.unit;
}

// ---- frame checks --------------------------------------------------------------------------



/// A dark tube of 6 sides along the closed polyline @p pts.
geometry::TriMesh brim_tube(const std::vector<Vector3d>& pts, double radius) {
  geometry::TriMesh m;
  const std::size_t n = pts.size();
  if (n < 2) return m;
  constexpr int kSides = 6;
  const std::size_t segments = n == 2 ? 1 : n;
  for (std::size_t i = 0; i < segments; ++i) {
    const Vector3d& a = pts[i];
    const Vector3d& b = pts[(i + 1) % n];
    const Vector3d d = b - a;
    if (d.norm() <= 0) continue;
    const Vector3d t = d.normalized();
    Vector3d u = t.unitOrthogonal();
    const Vector3d v = t.cross(u);
    const int base = m.num_vertices();
    for (int k = 0; k < kSides; ++k) {
      const double ang = 2 * kPi * k / kSides;
      const Vector3d off = radius * (std::cos(ang) * u + std::sin(ang) * v);
      m.vertices.push_back(a + off);
      m.vertices.push_back(b + off);
    }
    for (int k = 0; k < kSides; ++k) {
      const int k1 = (k + 1) % kSides;
      const int a0 = base + 2 * k, b0 = a0 + 1, a1 = base + 2 * k1, b1 = a1 + 1;
      m.triangles.push_back({a0, a1, b1});
      m.triangles.push_back({a0, b1, b0});
    }
  }
  return m;
}

}  // namespace


// ---- shared with the paths and the HTML report (design_report_detail.h) ---------------------

void design_report_detail::validate_frame(const SurfaceFrame& f, const char* fn) {
  const bool finite = f.origin.allFinite() && f.axis.allFinite() && f.anterior.allFinite() &&
                      f.medial.allFinite();
  require(finite, "{}: the frame has a non-finite origin or direction", fn);
  constexpr double tol = 1e-4;
  const bool ortho = std::abs(f.axis.norm() - 1) < tol && std::abs(f.anterior.norm() - 1) < tol &&
                     std::abs(f.medial.norm() - 1) < tol && std::abs(f.axis.dot(f.anterior)) < tol &&
                     std::abs(f.axis.dot(f.medial)) < tol && std::abs(f.anterior.dot(f.medial)) < tol;
  require(ortho,
          "{}: the frame's axis, anterior and medial are not orthonormal (|a|={:.4g}, |ant|={:.4g}, "
          "|med|={:.4g}; use surface_frame() of a LimbFrame)",
          fn, f.axis.norm(), f.anterior.norm(), f.medial.norm());
}

double design_report_detail::wrap_pi(double a) {
  a = std::remainder(a, 2 * kPi);  // [-π, π]
  return a <= -kPi ? a + 2 * kPi : a;
}

double design_report_detail::radar_radius(const RadarAxis& a) { return 1 + (a.value - a.target) / a.scale; }

// ==== radar =================================================================================

std::vector<RadarAxis> seven_radar_axes(const RadarInputs& in) {
  require(std::isfinite(in.body_mass_kg) && in.body_mass_kg > 0,
          "seven_radar_axes: body mass {} kg (expected > 0)", in.body_mass_kg);
  require(std::isfinite(in.prosthesis_mass_kg) && in.prosthesis_mass_kg >= 0,
          "seven_radar_axes: prosthesis mass {} kg (expected ≥ 0)", in.prosthesis_mass_kg);
  require(std::isfinite(in.stump_length_m) && in.stump_length_m > 0,
          "seven_radar_axes: stump length {} m (expected > 0)", in.stump_length_m);
  require(std::isfinite(in.force_tolerance) && in.force_tolerance >= 0 &&
              std::isfinite(in.torque_tolerance) && in.torque_tolerance >= 0,
          "seven_radar_axes: tolerances {} / {} (expected fractions ≥ 0)", in.force_tolerance,
          in.torque_tolerance);
  require(std::isfinite(in.gravity) && in.gravity > 0, "seven_radar_axes: g = {} (expected > 0)",
          in.gravity);
  require(in.force_n.allFinite() && in.torque_nm.allFinite() && std::isfinite(in.stability_n),
          "seven_radar_axes: a force, torque or stability value is not finite");
  const double half_weight = 0.5 * in.body_mass_kg * in.gravity;
  const double torque_scale = half_weight * in.stump_length_m;
  const double force_tol = in.force_tolerance * half_weight;
  const double torque_tol = in.torque_tolerance * torque_scale;
  std::vector<RadarAxis> axes;
  const char* fnames[3] = {"F_x", "F_y", "F_z"};
  const char* tnames[3] = {"T_x", "T_y", "T_z"};
  for (int i = 0; i < 3; ++i) {
    RadarAxis a;
    a.name = fnames[i];
    a.unit = "N";
    a.value = in.force_n[i];
    a.target = i == 2 ? half_weight : 0.0;
    a.tolerance = force_tol;
    a.scale = half_weight;
    a.is_ok = std::abs(a.value - a.target) <= a.tolerance;
    axes.push_back(a);
  }
  for (int i = 0; i < 3; ++i) {
    RadarAxis a;
    a.name = tnames[i];
    a.unit = "N·m";
    a.value = in.torque_nm[i];
    a.target = 0;
    a.tolerance = torque_tol;
    a.scale = torque_scale;
    a.is_ok = std::abs(a.value) <= a.tolerance;
    axes.push_back(a);
  }
  RadarAxis s;
  s.name = "stability";
  s.unit = "N";
  s.value = in.stability_n;
  s.target = in.prosthesis_mass_kg * in.gravity;
  s.is_lower_bound = true;
  s.scale = half_weight;
  s.is_ok = s.value >= s.target;
  axes.push_back(s);
  return axes;
}

int radar_axes_met(const std::vector<RadarAxis>& axes) {
  return static_cast<int>(std::count_if(axes.begin(), axes.end(), [](const RadarAxis& a) { return a.is_ok; }));
}

Eigen::Vector2d radar_axis_pixel(const RadarChart& chart, int axis, double r) {
  validate_radar(chart);
  const int n = static_cast<int>(chart.axes.size());
  require(axis >= 0 && axis < n, "radar_axis_pixel: axis {} (expected 0..{})", axis, n - 1);
  const RadarLayout l = radar_layout(chart);
  return l.centre + (r / kRadarMaxRadius) * l.r_out * radar_direction(axis, n);
}

namespace {

/// The pixel at radius @p r (1 = on target) along axis @p k of @p n.
Vector2d radar_point(const RadarLayout& l, int k, int n, double r) {
  const double px_per_r = l.r_out / kRadarMaxRadius;
  return l.centre + r * px_per_r * radar_direction(k, n);
}

Rgb radar_axis_colour(const RadarAxis& a) { return a.is_ok ? kRadarOkColour : kRadarFailColour; }

/// Ticks across each axis at its tolerance band's ends (a lower bound: at the target only).
void draw_radar_tolerance_ticks(Image& img, const RadarChart& chart, const RadarLayout& l) {
  const int n = static_cast<int>(chart.axes.size());
  for (int k = 0; k < n; ++k) {
    const RadarAxis& a = chart.axes[k];
    const Vector2d d = radar_direction(k, n), perp(-d.y(), d.x());
    const double lo = a.is_lower_bound ? 1.0 : 1 - a.tolerance / a.scale;
    const double hi = a.is_lower_bound ? kRadarMaxRadius : 1 + a.tolerance / a.scale;
    for (double r : {lo, hi}) {
      if (r < 0 || r > kRadarMaxRadius) continue;
      const Vector2d p = radar_point(l, k, n, r);
      draw2d::stroke_segment(img, p - 7 * perp, p + 7 * perp, 2.0, kInk);
    }
  }
}

/// The value points: filled, or a ring when the value lies off the chart (clamped to its edge).
void draw_radar_points(Image& img, const RadarChart& chart, const std::vector<Vector2d>& poly,
                       const std::vector<double>& radii) {
  for (std::size_t k = 0; k < poly.size(); ++k) {
    const Rgb c = radar_axis_colour(chart.axes[k]);
    const bool clamped = radii[k] < 0 || radii[k] > kRadarMaxRadius;
    draw2d::fill_disc(img, poly[k].x(), poly[k].y(), 7.5, kInk, draw2d::whole(img));
    if (clamped) {
      draw2d::fill_disc(img, poly[k].x(), poly[k].y(), 5.5, kWhite, draw2d::whole(img));
      draw2d::stroke_circle(img, poly[k], 4.0, 2.5, c);
    } else {
      draw2d::fill_disc(img, poly[k].x(), poly[k].y(), 6.0, c, draw2d::whole(img));
    }
  }
}

/// Labels outside the outer ring: "name" over "value unit".
void draw_radar_labels(Image& img, const RadarChart& chart, const RadarLayout& l) {
  const int n = static_cast<int>(chart.axes.size());
  for (int k = 0; k < n; ++k) {
    const RadarAxis& a = chart.axes[k];
    const std::string text = to_ascii(a.name) + "\n" + to_ascii(radar_value_text(a));
    const int w = text_width(text, kRadarLabelScale), h = text_height(text, kRadarLabelScale);
    const Vector2d d = radar_direction(k, n);
    const Vector2d p = radar_point(l, k, n, kRadarMaxRadius) + 14 * d;
    const double x = d.x() > 0.3 ? p.x() : (d.x() < -0.3 ? p.x() - w : p.x() - 0.5 * w);
    const double y = d.y() < -0.3 ? p.y() - h : (d.y() > 0.3 ? p.y() : p.y() - 0.5 * h);
    draw_text(img, static_cast<int>(std::lround(x)), static_cast<int>(std::lround(y)), text,
              radar_axis_colour(a), kRadarLabelScale);
  }
}

/// The legend (how many constraints are met, which fail) and the key to the chart.
void draw_radar_legend(Image& img, const RadarChart& chart, const RadarLayout& l) {
  const int n = static_cast<int>(chart.axes.size());
  const int met = radar_axes_met(chart.axes);
  std::string legend;
  if (met == n) {
    legend = "all constraints met";
  } else {
    legend = fmt::format("{} of {} met - failing:", met, n);
    for (const auto& a : chart.axes)
      if (!a.is_ok) legend += " " + to_ascii(a.name);
  }
  const int ly = l.height - kRadarLegendRows * text_height("X", kRadarLabelScale) - 12;
  draw_text(img, (l.width - text_width(legend, kRadarLabelScale)) / 2, ly, legend,
            met == n ? kRadarOkColour : kRadarFailColour, kRadarLabelScale);
  const std::string key = "circle: target   r = 1 + (value - target) / scale   ticks: tolerance";
  draw_text(img, (l.width - text_width(key, 1)) / 2, ly + text_height("X", kRadarLabelScale) + 4,
            key, Rgb{110, 110, 110}, 1);
}

}  // namespace

Image render_radar_chart(const RadarChart& chart) {
  validate_radar(chart);
  const RadarLayout l = radar_layout(chart);
  const int n = static_cast<int>(chart.axes.size());
  Image img(l.width, l.height, kWhite);
  const double px_per_r = l.r_out / kRadarMaxRadius;

  const std::string title = to_ascii(chart.title);
  draw_text(img, (l.width - text_width(title, kRadarTitleScale)) / 2, 12, title, kInk, kRadarTitleScale);

  // Grid rings, the value polygon, the axes, the target circle, ticks, points.
  for (double r : {0.5, 1.5, kRadarMaxRadius}) draw2d::stroke_circle(img, l.centre, r * px_per_r, 1.0, kGrid);
  std::vector<Vector2d> poly;
  std::vector<double> radii;
  for (int k = 0; k < n; ++k) {
    const double r = radar_radius(chart.axes[k]);
    radii.push_back(r);
    poly.push_back(radar_point(l, k, n, std::clamp(r, 0.0, kRadarMaxRadius)));
  }
  draw2d::fill_polygon(img, poly, kPolygonColour, 0.25f);
  for (int k = 0; k < n; ++k)
    draw2d::stroke_segment(img, l.centre, radar_point(l, k, n, kRadarMaxRadius), 3.0,
                           radar_axis_colour(chart.axes[k]));
  draw2d::stroke_circle(img, l.centre, px_per_r, 3.0, kTargetColour);
  draw_radar_tolerance_ticks(img, chart, l);
  for (int k = 0; k < n; ++k) draw2d::stroke_segment(img, poly[k], poly[(k + 1) % n], 2.0, kPolygonColour);
  draw_radar_points(img, chart, poly, radii);
  draw_radar_labels(img, chart, l);
  draw_radar_legend(img, chart, l);
  return img;
}

void write_radar_chart(const std::filesystem::path& path, const RadarChart& chart) {
  write_png(path, render_radar_chart(chart));
}

// ==== pressure maps =========================================================================

SurfaceFrame surface_frame(const geometry::LimbFrame& frame) {
  SurfaceFrame f;
  f.origin = frame.origin;
  f.axis = frame.axis.normalized();
  f.anterior = frame.anterior.normalized();
  f.medial = frame.medial();
  return f;
}

Image render_pressure_map(const PressureMapData& data) {
  require(data.surface != nullptr && !data.surface->empty(),
          "render_pressure_map: '{}' has no surface triangles (expected the stump's skin mesh)",
          data.title);
  const geometry::TriMesh& mesh = *data.surface;
  require(data.values.size() == mesh.vertices.size(),
          "render_pressure_map: {} values for {} vertices (expected one per vertex)",
          data.values.size(), mesh.vertices.size());
  validate_frame(data.frame, "render_pressure_map");
  require(std::isfinite(data.brim_tube_radius_m) && data.brim_tube_radius_m > 0,
          "render_pressure_map: brim tube radius {} m (expected > 0)", data.brim_tube_radius_m);
  double vmin = data.value_min, vmax = data.value_max;
  if (!(vmax > vmin)) {
    require(std::isfinite(vmin) && std::isfinite(vmax),
            "render_pressure_map: value range {}..{} (expected finite numbers)", vmin, vmax);
    double lo = 0, hi = -std::numeric_limits<double>::infinity();
    for (double v : data.values)
      if (std::isfinite(v)) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
    vmin = lo;
    vmax = hi > lo ? hi : lo + 1;
  }
  require(std::isfinite(vmin) && std::isfinite(vmax),
          "render_pressure_map: value range {}..{} (expected finite numbers)", vmin, vmax);

  MeshLayer field;
  field.mesh = &mesh;
  field.vertex_values = data.values;
  field.colour = data.no_data_colour;
  field.value_min = vmin;
  field.value_max = vmax;
  field.colormap = data.colormap;
  field.value_label = to_ascii(data.value_label);
  std::vector<MeshLayer> layers{field};
  geometry::TriMesh tube;
  if (!data.brim.empty()) {
    for (const auto& p : data.brim)
      require(p.allFinite(), "render_pressure_map: a brim point is not finite");
    tube = brim_tube(data.brim, data.brim_tube_radius_m);
    if (!tube.empty()) {
      MeshLayer b;
      b.mesh = &tube;
      b.colour = Rgb{25, 25, 25};
      layers.push_back(b);
    }
  }
  std::vector<Marker> markers;
  for (const auto& lm : data.landmarks) {
    Marker m;
    m.position = lm.position;
    m.label = to_ascii(lm.code);
    m.colour = lm.is_estimated ? Rgb{220, 60, 220} : Rgb{250, 250, 250};
    m.radius_px = 5;
    markers.push_back(m);
  }
  const SurfaceFrame& f = data.frame;
  const std::vector<std::pair<Camera, std::string>> views{{{-f.anterior, f.axis}, "anterior"},
                                                          {{-f.medial, f.axis}, "medial"},
                                                          {{f.anterior, f.axis}, "posterior"},
                                                          {{f.medial, f.axis}, "lateral"}};
  require(data.view_px >= 64 && data.view_px <= 2048,
          "render_pressure_map: view size {} px (expected 64..2048)", data.view_px);
  return render_views(layers, markers, views, data.view_px, to_ascii(data.title));
}

void write_pressure_map(const std::filesystem::path& path, const PressureMapData& data) {
  write_png(path, render_pressure_map(data));
}

}  // namespace socketsmith::report
