#include "socketsmith/report/design_report.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/report/draw_2d.h"
#include "socketsmith/report/html.h"
#include "socketsmith/report/nice_number.h"

namespace socketsmith::report {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;
constexpr double kPi = std::numbers::pi;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr Rgb kWhite{255, 255, 255};
constexpr Rgb kInk{30, 30, 30};
constexpr Rgb kGrid{200, 200, 200};
constexpr Rgb kTargetColour{30, 60, 150};
constexpr Rgb kPolygonColour{70, 130, 220};

std::string num(double v, int digits = 3) { return format_number(v, digits); }

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

double radar_radius(const RadarAxis& a) { return 1 + (a.value - a.target) / a.scale; }

std::string radar_value_text(const RadarAxis& a) {
  return a.unit.empty() ? num(a.value) : num(a.value) + " " + a.unit;
}

// ---- frame checks --------------------------------------------------------------------------

void validate_frame(const SurfaceFrame& f, const char* fn) {
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

double wrap_pi(double a) {
  a = std::remainder(a, 2 * kPi);  // [-π, π]
  return a <= -kPi ? a + 2 * kPi : a;
}

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

// ---- HTML ----------------------------------------------------------------------------------

// A value below 1e-9 of its display unit is round-off (an optimised angle of 5.8e-17°, an amplitude
// of 9.4e-17 kPa: the browser showed them as such): shown as 0.
double shown(double v) { return std::abs(v) < 1e-9 ? 0.0 : v; }
std::string deg(double rad) { return num(shown(rad * 180 / kPi)); }
std::string mm(double m) { return num(shown(m * 1e3)); }
std::string kpa(double pa) { return num(shown(pa * 1e-3)); }

std::string spot_theta(const ReportSpot& s) {
  if (s.type == "cos2" || s.type == "cos-sig")
    return fmt::format("θ0 {} ± {}", deg(s.theta0_rad), deg(s.r_theta_rad));
  if (s.type == "sig2")
    return fmt::format("{} … {} (λ {} /°)", deg(s.theta1_rad), deg(s.theta2_rad),
                       num(s.lambda_theta_per_rad * kPi / 180));
  return "all";
}

std::string spot_height(const ReportSpot& s) {
  if (s.type == "cos2") return fmt::format("h0 {} ± {}", mm(s.h0_m), mm(s.r_h_m));
  if (s.type == "sig2" || s.type == "cos-sig")
    return fmt::format("{} … {} (λ {} /mm)", mm(s.h1_m), mm(s.h2_m), num(s.lambda_h_per_m * 1e-3));
  if (s.type == "grad") return fmt::format("full below {}, none above {}", mm(s.h1_m), mm(s.h2_m));
  return "";
}

}  // namespace

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

Image render_radar_chart(const RadarChart& chart) {
  validate_radar(chart);
  const RadarLayout l = radar_layout(chart);
  const int n = static_cast<int>(chart.axes.size());
  Image img(l.width, l.height, kWhite);
  const double px_per_r = l.r_out / kRadarMaxRadius;
  auto at = [&](int k, double r) -> Vector2d { return l.centre + r * px_per_r * radar_direction(k, n); };

  const std::string title = to_ascii(chart.title);
  draw_text(img, (l.width - text_width(title, kRadarTitleScale)) / 2, 12, title, kInk, kRadarTitleScale);

  // Grid rings, the value polygon, the axes, the target circle, ticks, points.
  for (double r : {0.5, 1.5, kRadarMaxRadius}) draw2d::stroke_circle(img, l.centre, r * px_per_r, 1.0, kGrid);
  std::vector<Vector2d> poly;
  std::vector<double> radii;
  for (int k = 0; k < n; ++k) {
    const double r = radar_radius(chart.axes[k]);
    radii.push_back(r);
    poly.push_back(at(k, std::clamp(r, 0.0, kRadarMaxRadius)));
  }
  draw2d::fill_polygon(img, poly, kPolygonColour, 0.25f);
  for (int k = 0; k < n; ++k) {
    const Rgb c = chart.axes[k].is_ok ? kRadarOkColour : kRadarFailColour;
    draw2d::stroke_segment(img, l.centre, at(k, kRadarMaxRadius), 3.0, c);
  }
  draw2d::stroke_circle(img, l.centre, px_per_r, 3.0, kTargetColour);
  for (int k = 0; k < n; ++k) {
    const RadarAxis& a = chart.axes[k];
    const Vector2d d = radar_direction(k, n), perp(-d.y(), d.x());
    const double lo = a.is_lower_bound ? 1.0 : 1 - a.tolerance / a.scale;
    const double hi = a.is_lower_bound ? kRadarMaxRadius : 1 + a.tolerance / a.scale;
    for (double r : {lo, hi}) {
      if (r < 0 || r > kRadarMaxRadius) continue;
      const Vector2d p = at(k, r);
      draw2d::stroke_segment(img, p - 7 * perp, p + 7 * perp, 2.0, kInk);
    }
  }
  for (int k = 0; k < n; ++k) draw2d::stroke_segment(img, poly[k], poly[(k + 1) % n], 2.0, kPolygonColour);
  for (int k = 0; k < n; ++k) {
    const Rgb c = chart.axes[k].is_ok ? kRadarOkColour : kRadarFailColour;
    const bool clamped = radii[k] < 0 || radii[k] > kRadarMaxRadius;
    draw2d::fill_disc(img, poly[k].x(), poly[k].y(), 7.5, kInk, draw2d::whole(img));
    if (clamped) {
      draw2d::fill_disc(img, poly[k].x(), poly[k].y(), 5.5, kWhite, draw2d::whole(img));
      draw2d::stroke_circle(img, poly[k], 4.0, 2.5, c);
    } else {
      draw2d::fill_disc(img, poly[k].x(), poly[k].y(), 6.0, c, draw2d::whole(img));
    }
  }

  // Labels outside the outer ring: "name" over "value unit".
  for (int k = 0; k < n; ++k) {
    const RadarAxis& a = chart.axes[k];
    const Rgb c = a.is_ok ? kRadarOkColour : kRadarFailColour;
    const std::string text = to_ascii(a.name) + "\n" + to_ascii(radar_value_text(a));
    const int w = text_width(text, kRadarLabelScale), h = text_height(text, kRadarLabelScale);
    const Vector2d d = radar_direction(k, n);
    const Vector2d p = at(k, kRadarMaxRadius) + 14 * d;
    const double x = d.x() > 0.3 ? p.x() : (d.x() < -0.3 ? p.x() - w : p.x() - 0.5 * w);
    const double y = d.y() < -0.3 ? p.y() - h : (d.y() > 0.3 ? p.y() : p.y() - 0.5 * h);
    draw_text(img, static_cast<int>(std::lround(x)), static_cast<int>(std::lround(y)), text, c,
              kRadarLabelScale);
  }

  // Legend.
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

// ==== paths =================================================================================

std::vector<PathSample> sample_path(const std::vector<Eigen::Vector3d>& points,
                                    const std::vector<double>& values, const SurfaceFrame& frame,
                                    const PathSpec& path) {
  require(values.empty() || values.size() == points.size(),
          "sample_path: {} values for {} points (expected one per point or none)", values.size(),
          points.size());
  validate_frame(frame, "sample_path");
  require(std::isfinite(path.band_m) && path.band_m > 0,
          "sample_path: band {} m (expected > 0, e.g. half a node spacing)", path.band_m);
  require(std::isfinite(path.bin_m) && path.bin_m >= 0, "sample_path: bin {} m (expected ≥ 0)",
          path.bin_m);
  require(std::isfinite(path.theta_rad) && std::isfinite(path.height_m),
          "sample_path: path angle {} rad / height {} m (expected finite)", path.theta_rad,
          path.height_m);
  const bool vertical = path.kind == PathKind::Vertical;
  std::vector<PathSample> out;
  for (std::size_t i = 0; i < points.size(); ++i) {
    require(points[i].allFinite(), "sample_path: point {} is not finite", i);
    const Vector3d d = points[i] - frame.origin;
    const double h = d.dot(frame.axis);
    const double a = d.dot(frame.anterior), m = d.dot(frame.medial);
    const double rho = std::hypot(a, m);
    const double theta = std::atan2(m, a);
    PathSample s;
    s.index = static_cast<int>(i);
    s.value = values.empty() ? kNaN : values[i];
    s.rho_m = rho;
    s.theta_rad = theta;
    s.h_m = h;
    if (vertical) {
      s.distance_m = std::abs(wrap_pi(theta - path.theta_rad)) * rho;
      s.s = h;
    } else {
      s.distance_m = std::abs(h - path.height_m);
      double phi = std::fmod(theta - path.theta_rad, 2 * kPi);
      if (phi < 0) phi += 2 * kPi;
      if (phi >= 2 * kPi) phi = 0;
      s.s = phi;
    }
    if (s.distance_m <= path.band_m) out.push_back(s);
  }
  auto by_s = [](const PathSample& x, const PathSample& y) {
    return x.s != y.s ? x.s < y.s : x.distance_m < y.distance_m;
  };
  std::sort(out.begin(), out.end(), by_s);
  if (path.bin_m > 0 && !out.empty()) {
    // Length along the path: h, or the mean radius × angle on a circumference.
    double rho_mean = 0;
    for (const auto& s : out) rho_mean += s.rho_m;
    rho_mean /= static_cast<double>(out.size());
    const double length_per_s = vertical ? 1.0 : rho_mean;
    // Greedy bins: a bin starts at its first sample and holds the samples less than bin_m
    // further along (robust to nodes lying exactly on a grid of bin_m).
    std::vector<PathSample> thinned;
    double bin_start = -std::numeric_limits<double>::infinity();
    for (const auto& s : out) {
      const double len = s.s * length_per_s;
      if (len >= bin_start + path.bin_m) {
        thinned.push_back(s);
        bin_start = len;
      } else if (s.distance_m < thinned.back().distance_m) {
        thinned.back() = s;
      }
    }
    out = std::move(thinned);
  }
  return out;
}

std::vector<NamedPath> thesis_paths(double front_theta_rad, double mid_height_m,
                                    const std::vector<double>& node_areas_m2) {
  double spacing = 0;
  for (double a : node_areas_m2) spacing += std::sqrt(a) / static_cast<double>(node_areas_m2.size());
  const auto make = [&](std::string key, std::string label, PathKind kind, double theta, double h) {
    NamedPath p{std::move(key), std::move(label), {}};
    p.spec.kind = kind;
    p.spec.theta_rad = theta;
    p.spec.height_m = h;
    p.spec.band_m = 0.75 * spacing;
    p.spec.bin_m = 0.8 * spacing;
    return p;
  };
  return {make("front", "front line (through the patellar tendon)", PathKind::Vertical, front_theta_rad, 0),
          make("back", "back line", PathKind::Vertical, std::remainder(front_theta_rad + std::numbers::pi, 2 * std::numbers::pi), 0),
          make("mid", "circumference at mid-stump", PathKind::Circumferential, 0, mid_height_m)};
}

double interpolate_path(const std::vector<PathSample>& samples, double s) {
  if (samples.empty() || !std::isfinite(s) || s < samples.front().s || s > samples.back().s)
    return kNaN;
  const auto it = std::lower_bound(samples.begin(), samples.end(), s,
                                   [](const PathSample& a, double x) { return a.s < x; });
  if (it == samples.begin()) return it->value;
  const PathSample& b = *it;
  const PathSample& a = *(it - 1);
  if (b.s == a.s) return b.value;
  const double t = (s - a.s) / (b.s - a.s);
  return (1 - t) * a.value + t * b.value;
}

PathProfile make_path_profile(const std::string& name, PathKind kind,
                              const std::vector<PathSample>& samples,
                              const std::vector<double>& pressure_pa,
                              const std::vector<double>& threshold_pa) {
  PathProfile p;
  p.name = name;
  const bool vertical = kind == PathKind::Vertical;
  p.s_label = vertical ? "height above the distal end [mm]"
                       : "angle along the circumference from its start, towards medial [deg]";
  if (!vertical) {
    p.s_min = 0;
    p.s_max = 360;
  }
  for (const auto& s : samples) {
    require(s.index >= 0 && static_cast<std::size_t>(s.index) < pressure_pa.size(),
            "make_path_profile: '{}' sample index {} outside the {} pressures", name, s.index,
            pressure_pa.size());
    require(threshold_pa.empty() || static_cast<std::size_t>(s.index) < threshold_pa.size(),
            "make_path_profile: '{}' sample index {} outside the {} thresholds", name, s.index,
            threshold_pa.size());
    p.s.push_back(vertical ? s.s * 1e3 : s.s * 180 / kPi);
    p.pressure_kpa.push_back(pressure_pa[s.index] * 1e-3);
    if (!threshold_pa.empty()) p.threshold_kpa.push_back(threshold_pa[s.index] * 1e-3);
  }
  return p;
}

Plot path_profile_plot(const PathProfile& profile) {
  require(profile.pressure_kpa.size() == profile.s.size() &&
              (profile.threshold_kpa.empty() || profile.threshold_kpa.size() == profile.s.size()),
          "path_profile_plot: '{}' has {} coordinates, {} pressures, {} thresholds (expected the "
          "same count, or no thresholds)",
          profile.name, profile.s.size(), profile.pressure_kpa.size(), profile.threshold_kpa.size());
  Plot plot;
  plot.title = profile.name;
  plot.x_label = profile.s_label;
  plot.y_label = "pressure [kPa]";
  plot.width_px = 640;
  plot.height_px = 360;
  PlotSeries pressure;
  pressure.name = "applied pressure";
  pressure.x = profile.s;
  pressure.y = profile.pressure_kpa;
  pressure.color = "#0072B2";
  pressure.markers = true;
  plot.series.push_back(pressure);
  if (!profile.threshold_kpa.empty()) {
    PlotSeries threshold;
    threshold.name = "pain threshold";
    threshold.x = profile.s;
    threshold.y = profile.threshold_kpa;
    threshold.color = "#D55E00";
    threshold.dashed = true;
    plot.series.push_back(threshold);
  }
  double ymax = -std::numeric_limits<double>::infinity();
  int finite_x = 0;
  double xmin = std::numeric_limits<double>::infinity(), xmax = -xmin;
  for (std::size_t i = 0; i < profile.s.size(); ++i) {
    if (std::isfinite(profile.s[i])) {
      ++finite_x;
      xmin = std::min(xmin, profile.s[i]);
      xmax = std::max(xmax, profile.s[i]);
    }
    if (std::isfinite(profile.pressure_kpa[i])) ymax = std::max(ymax, profile.pressure_kpa[i]);
    if (!profile.threshold_kpa.empty() && std::isfinite(profile.threshold_kpa[i]))
      ymax = std::max(ymax, profile.threshold_kpa[i]);
  }
  plot.y_min = 0.0;
  plot.y_max = nice_ceil(ymax > 0 ? 1.1 * ymax : 1.0);
  if (std::isfinite(profile.s_min) && std::isfinite(profile.s_max) && profile.s_max > profile.s_min) {
    plot.x_min = profile.s_min;
    plot.x_max = profile.s_max;
  } else if (finite_x == 0 || !(xmax > xmin)) {  // nothing to span: an explicit unit range
    const double c = finite_x == 0 ? 0.0 : xmin;
    plot.x_min = c - 0.5;
    plot.x_max = c + 0.5;
  }
  return plot;
}

// ==== helpers ===============================================================================

std::string html_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string base64_encode(std::string_view bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  auto byte = [&](std::size_t k) { return static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[k])); };
  for (; i + 3 <= bytes.size(); i += 3) {
    const std::uint32_t v = byte(i) << 16 | byte(i + 1) << 8 | byte(i + 2);
    out += kAlphabet[v >> 18 & 63];
    out += kAlphabet[v >> 12 & 63];
    out += kAlphabet[v >> 6 & 63];
    out += kAlphabet[v & 63];
  }
  const std::size_t rest = bytes.size() - i;
  if (rest > 0) {
    std::uint32_t v = byte(i) << 16;
    if (rest == 2) v |= byte(i + 1) << 8;
    out += kAlphabet[v >> 18 & 63];
    out += kAlphabet[v >> 12 & 63];
    out += rest == 2 ? kAlphabet[v >> 6 & 63] : '=';
    out += '=';
  }
  return out;
}

// ==== HTML report ===========================================================================

namespace {

void rectification_section(HtmlWriter& h, const ReportRectification& r) {
  if (!r.has_rectification) return;
  h.heading("Rectification chart (socket minus limb)");
  h.paragraph("How far " + r.source +
              " lies from the limb's skin, in mm, along the ray from the limb axis (radially), or along the axis where "
              "the skin faces down (the distal end): negative = indentation (the socket presses the tissue in), "
              "positive = relief. Below the brim: mean " + mm(r.mean_m) + " mm, from " + mm(r.min_m) + " to " +
              mm(r.max_m) + " mm.");
  std::vector<std::vector<std::string>> rows;
  for (const auto& p : r.landmarks) {
    const double d = p.rectification_m;
    const bool has = std::isfinite(d);
    rows.push_back({p.code, p.name, deg(p.theta_rad), mm(p.h_m), has ? num(d * 1e3, 2) : "above the brim",
                    has ? (d < 0 ? "indentation" : "relief") : "—", p.is_axial ? "along the axis" : "radial"});
  }
  h.table({"landmark", "zone", "θ [°]", "h [mm]", "socket − limb [mm]", "", "measured"}, rows);
  if (r.has_map)
    h.image(png_data_uri(render_pressure_map(r.map)), r.map.title,
            "Blue: the socket inside the skin (indentation); red: outside (relief); grey: above the brim.");
}

void sock_ply_section(HtmlWriter& h, const ReportSockPly& s) {
  if (!s.has_study) return;
  h.heading("Sock-ply sensitivity (the limb shrunk and grown)");
  h.paragraph(s.summary);
  std::vector<std::vector<std::string>> rows;
  for (const auto& l : s.levels) {
    const std::string name = l.volume_change == 0 ? "as designed" : fmt::format("{:+.0f} %", 100 * l.volume_change);
    rows.push_back({name, num(l.skin_offset_m * 1e3, 2), l.stood ? num(l.stood_offset_m * 1e3, 3) : "—",
                    l.stood ? num(l.sink_m * 1e3, 3) : "—", l.stood ? num(l.peak_ratio, 3) : "—",
                    l.stood ? kpa(l.peak_pressure_pa) : "—", l.stood ? kpa(l.distal_mean_pa) : "—",
                    l.stood ? kpa(l.distal_peak_pa) : "—", l.stood ? l.constraints : l.message});
  }
  h.table({"limb volume", "skin offset [mm]", "socket stood at [mm]", "limb sinks [mm]", "peak p/T", "peak [kPa]",
           "distal mean [kPa]", "distal peak [kPa]", "constraints"},
          rows);
  h.paragraph("Skin offset: the uniform normal offset of the skin (bones fixed) that changes the limb's volume by the "
              "given fraction. Socket stood at: where the socket carried half the body weight, along the axis from its "
              "designed pose. Limb sinks: how much deeper than at the designed volume the limb sits in the socket "
              "(negative: it rises). Peak p/T: the largest contact pressure over the pain threshold below the brim. Distal: "
              "the contact pressure over the distal fifth of the stump. Constraints: the design's seven conditions and "
              "comfort (p/T ≤ 1) evaluated on the delivered pressures with the design's tolerances (a failing one is "
              "shown with its value and target: a donned socket delivers the design only approximately, so compare "
              "with the row 'as designed').");
  for (const auto& m : s.maps) h.image(png_data_uri(render_pressure_map(m)), m.title);
  for (const auto& p : s.plots) h.image(svg_data_uri(render_svg(p)), p.title);
}

}  // namespace

std::string render_design_report_html(const DesignReportData& d) {
  HtmlWriter h(d.title);
  if (!d.generated.empty()) h.paragraph(d.generated);

  if (!d.warnings.empty()) {
    h.heading("Warnings");
    h.raw("<ul class=\"warn\">\n");
    for (const auto& w : d.warnings) {
      h.raw("<li>");
      h.text(w);
      h.raw("</li>\n");
    }
    h.raw("</ul>\n");
  }

  // Patient.
  const ReportPatient& p = d.patient;
  h.heading("Patient");
  std::vector<std::pair<std::string, std::string>> patient;
  if (!p.id.empty()) patient.push_back({"patient", p.id});
  patient.push_back({"body mass", num(p.body_mass_kg) + " kg"});
  patient.push_back({"prosthesis mass", num(p.prosthesis_mass_kg) + " kg"});
  patient.push_back({"tissue Young's modulus E", kpa(p.tissue_youngs_modulus_pa) + " kPa"});
  patient.push_back({"friction coefficient μ (skin–socket)", num(p.friction)});
  h.table(patient);
  if (!p.note.empty()) h.paragraph(p.note, "note");

  // Inputs.
  h.heading("Inputs");
  h.table({{"limb file", d.limb_file.empty() ? "—" : d.limb_file},
           {"limb", (d.limb_type.empty() ? std::string("—") : d.limb_type) +
                        (d.side.empty() ? std::string() : ", " + d.side)},
           {"mesh nodes", d.mesh_nodes > 0 ? std::to_string(d.mesh_nodes) : "—"},
           {"tissue model", d.model.empty() ? "—" : d.model},
           {"brim template", d.brim_template.empty() ? "—" : d.brim_template}});
  if (!d.spots.empty()) {
    h.heading("Pressure spots", 3);
    std::vector<std::vector<std::string>> rows;
    for (const auto& s : d.spots)
      rows.push_back({s.name, s.type, kpa(s.amplitude_pa), spot_theta(s), spot_height(s), s.is_enabled ? "yes" : "no"});
    h.table({"name", "type", "A [kPa]", "θ [°]", "h [mm]", "enabled"}, rows);
    h.paragraph("θ: 0° anterior, +90° medial, 180° posterior; h above the distal end.");
  }
  if (!d.brim_key_points.empty()) {
    h.heading("Brim key points", 3);
    std::vector<std::vector<std::string>> rows;
    for (const auto& k : d.brim_key_points) rows.push_back({deg(k.theta_rad), mm(k.h_m)});
    h.table({"θ [°]", "h [mm]"}, rows);
  }

  // Constraints.
  if (!d.radar.axes.empty()) {
    const int met = radar_axes_met(d.radar.axes);
    const int n = static_cast<int>(d.radar.axes.size());
    h.heading("Constraints");
    h.raw("<p><strong>");
    h.text(met == n ? std::string("all constraints met") : fmt::format("{} of {} met", met, n));
    h.raw("</strong></p>\n");
    h.image(png_data_uri(render_radar_chart(d.radar)), "radar chart of the constraints");
    h.raw("<table>\n");
    h.row({"constraint", "value", "target", "normalised r", "status"}, true);
    for (const auto& a : d.radar.axes) {
      const std::string unit = a.unit.empty() ? "" : " " + a.unit;
      const std::string target = a.is_lower_bound ? "≥ " + num(a.target) + unit
                                                  : num(a.target) + " ± " + num(a.tolerance) + unit;
      h.row({a.name, num(a.value) + unit, target, num(radar_radius(a)), a.is_ok ? "pass" : "FAIL"}, false,
            a.is_ok ? "ok" : "fail");
    }
    h.raw("</table>\n");
    h.paragraph("Radius r = 1 + (value − target) / scale: the target circle is r = 1 for every axis; scale = M g / 2 "
                "for forces and stability, M g / 2 × stump length for torques.");
  }

  // Comfort.
  std::string where = "—";
  if (d.has_max_ratio_position) {
    const auto& lms = !d.landmarks.empty() ? d.landmarks
                                           : (d.maps.empty() ? d.landmarks : d.maps.front().landmarks);
    double best = std::numeric_limits<double>::infinity();
    for (const auto& lm : lms) {
      const double dist = (lm.position - d.max_ratio_position).norm();
      if (dist < best) {
        best = dist;
        where = fmt::format("nearest landmark zone {} ({} mm away)", lm.code, mm(dist));
      }
    }
    if (lms.empty())
      where = fmt::format("at ({}, {}, {}) mm", mm(d.max_ratio_position.x()), mm(d.max_ratio_position.y()),
                          mm(d.max_ratio_position.z()));
  }
  h.heading("Comfort");
  h.table({{"largest applied pressure", kpa(d.max_pressure_pa) + " kPa"},
           {"largest pressure / pain threshold",
            num(d.max_pressure_ratio) + (d.max_pressure_ratio > 1 ? " (above the threshold)" : "")},
           {"where", where}});

  // Axial load by region.
  if (!d.region_loads.empty()) {
    h.raw("<h2>Axial load by region</h2>\n<table>\n");
    h.row({"region", "share of F_z", "axial [N]", "of which friction [N]", "loaded area [cm²]", "mean [kPa]",
           "peak [kPa]"},
          true);
    for (const auto& r : d.region_loads)
      h.row({r.name, num(100 * r.share) + " %", num(r.axial_n), num(r.friction_n), num(r.area_m2 * 1e4),
             kpa(r.mean_pressure_pa), kpa(r.peak_pressure_pa)},
            false, r.is_highlighted ? "ok" : "");
    h.raw("</table>\n<p>");
    h.text("Axial: the normal forces' component along the limb axis plus the available friction μ p A cos θ "
           "(the thesis's F_z, eq. 42), summed over the region's skin below the brim." +
           (d.region_note.empty() ? std::string() : " " + d.region_note));
    h.raw("</p>\n");
  }

  // Maps.
  if (!d.maps.empty()) {
    h.heading("Pressure maps");
    for (const auto& m : d.maps) {
      h.heading(m.title, 3);
      h.image(png_data_uri(render_pressure_map(m)), m.title);
    }
    h.paragraph("Views: anterior, medial, posterior, lateral. Grey: no pressure (above the brim). White markers: "
                "landmarks given; magenta: placed automatically.");
  }

  // Profiles.
  if (!d.profiles.empty()) {
    h.heading("Pressure along paths");
    for (const auto& pr : d.profiles) h.image(svg_data_uri(render_svg(path_profile_plot(pr))), pr.name);
  }

  // Socket.
  const ReportSocket& s = d.socket;
  h.heading("Socket");
  if (!s.has_socket) {
    h.paragraph("No socket built.");
  } else {
    std::vector<std::pair<std::string, std::string>> rows;
    if (!s.stl_file.empty()) rows.push_back({"socket file", s.stl_file});
    rows.push_back({"wall thickness", mm(s.thickness_m) + " mm"});
    if (s.max_thickness_m > 0)
      rows.push_back({"measured wall (min / median / max)",
                      mm(s.min_thickness_m) + " / " + mm(s.median_thickness_m) + " / " + mm(s.max_thickness_m) + " mm"});
    for (const auto& kv : s.details) rows.push_back(kv);
    rows.push_back({"limb volume (below the brim)", num(s.limb_volume_m3 * 1e6) + " cm³"});
    rows.push_back({"socket inner volume", num(s.socket_volume_m3 * 1e6) + " cm³"});
    if (s.limb_volume_m3 > 0)
      rows.push_back({"volume reduction", num(100 * (s.limb_volume_m3 - s.socket_volume_m3) / s.limb_volume_m3) + " %"});
    h.table(rows);
    if (s.has_thickness_map)
      h.image(png_data_uri(render_pressure_map(s.thickness_map)), "wall thickness",
              "Wall thickness: the distance from each point of the outer surface to the inner wall (grey: the inner "
              "wall). The minimum leaves out the rounded brim edge.");
    if (!s.circumferences.empty()) {
      std::vector<std::vector<std::string>> circ;
      for (const auto& c : s.circumferences)
        circ.push_back({mm(c.height_m), mm(c.limb_m), mm(c.socket_m),
                        c.limb_m > 0 ? num(100 * (c.limb_m - c.socket_m) / c.limb_m) : "—"});
      h.table({"h [mm]", "limb [mm]", "socket [mm]", "reduction [%]"}, circ);
    }
  }
  rectification_section(h, d.rectification);
  if (!d.slices.rows.empty()) append_slice_section(h, d.slices);

  // Delivered pressures.
  const ReportDelivery& dl = d.delivery;
  if (dl.has_delivery) {
    h.heading("Delivered pressures (the socket donned and stood on)");
    h.paragraph(dl.summary);
    std::vector<std::vector<std::string>> rows;
    for (const auto& a : dl.rows)
      rows.push_back({a.region, a.stage, std::to_string(a.count), kpa(a.target_mean_pa), kpa(a.delivered_mean_pa),
                      kpa(a.mae_pa), kpa(a.p99_pa), kpa(a.max_error_pa), std::isfinite(a.r) ? num(a.r, 3) : "—",
                      kpa(a.target_sd_pa)});
    h.table({"region", "socket", "nodes", "designed mean [kPa]", "delivered mean [kPa]", "MAE [kPa]",
             "99th pct. error [kPa]", "max error [kPa]", "R", "designed SD [kPa]"},
            rows);
    if (!dl.details.empty()) h.table(dl.details);
    for (const auto& m : dl.maps) {
      h.heading(m.title, 3);
      h.image(png_data_uri(render_pressure_map(m)), m.title);
    }
    for (const auto& pl : dl.plots) h.image(svg_data_uri(render_svg(pl)), pl.title);
  }
  sock_ply_section(h, d.sock_ply);

  // Runs.
  auto run_section = [&](const char* heading, const ReportRun& r) {
    h.heading(heading);
    if (!r.has_run) {
      h.paragraph("Not run.");
      return;
    }
    std::vector<std::pair<std::string, std::string>> rows{{"converged", r.converged ? "yes" : "no"},
                                                          {"iterations", std::to_string(r.iterations)},
                                                          {"residual", num(r.residual, 4)},
                                                          {"time", num(r.seconds) + " s"}};
    if (!r.message.empty()) rows.push_back({"message", r.message});
    for (const auto& kv : r.details) rows.push_back(kv);
    h.table(rows);
  };
  run_section("Optimiser", d.optimiser);
  run_section("Solver", d.solver);
  return h.finish();
}

void write_design_report_html(const std::filesystem::path& path, const DesignReportData& data) {
  const std::string html = render_design_report_html(data);  // any error: nothing written
  write_text_atomically(path, html);
}

}  // namespace socketsmith::report
