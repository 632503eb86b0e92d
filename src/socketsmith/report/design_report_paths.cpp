// The design report's paths: the skin's values sampled along the thesis's three paths (front line
// through PT, back line, mid-stump circumference) and their profile plots (design_report_detail.h
// says why this is apart).
#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/report/design_report.h"
#include "socketsmith/report/design_report_detail.h"
#include "socketsmith/report/nice_number.h"
#include "socketsmith/report/plot.h"

namespace socketsmith::report {
using namespace design_report_detail;
namespace {
using Eigen::Vector3d;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

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
  plot.series.push_back(PlotSeries{.name = "applied pressure",
                                   .x = profile.s,
                                   .y = profile.pressure_kpa,
                                   .color = "#0072B2",
                                   .markers = true});
  if (!profile.threshold_kpa.empty())
    plot.series.push_back(PlotSeries{.name = "pain threshold",
                                     .x = profile.s,
                                     .y = profile.threshold_kpa,
                                     .color = "#D55E00",
                                     .dashed = true});
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

}  // namespace socketsmith::report
