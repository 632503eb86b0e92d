#include "socketsmith/design/load_regions.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"

namespace socketsmith::design {
namespace {

constexpr double kDeg = units::deg, kMm = units::mm;

const volume::Landmark& need(const std::vector<volume::Landmark>& lms, const std::string& code) {
  for (const auto& l : lms)
    if (l.code == code) return l;
  fail("load_regions: landmark {} is missing (place it in the case file's landmarks)", code);
}

double wrap(double a) {
  a = std::fmod(a + std::numbers::pi, 2.0 * std::numbers::pi);
  if (a < 0) a += 2.0 * std::numbers::pi;
  return a - std::numbers::pi;
}

}  // namespace

bool LoadRegion::contains(double theta, double h) const {
  if (h < h_min_m || h > h_max_m) return false;
  const double span = wrap(theta_to_rad - theta_from_rad);
  if (std::abs(theta_to_rad - theta_from_rad) < 1e-12) return true;
  const double full = span <= 0 ? span + 2.0 * std::numbers::pi : span;
  double d = wrap(theta - theta_from_rad);
  if (d < 0) d += 2.0 * std::numbers::pi;
  return d <= full;
}

std::vector<LoadRegion> load_regions(geometry::LimbType type, const std::vector<volume::Landmark>& lms, double L) {
  std::vector<LoadRegion> r;
  const double distal = 0.2 * L;
  r.push_back({"distal_end", "distal end", 0.0, 0.0, -1e9, distal});
  if (type == geometry::LimbType::Transfemoral) {
    const auto& is = need(lms, "IS").cylindrical;
    const auto& al = need(lms, "AL").cylindrical;
    const double t_is = std::clamp(is.theta, 60 * kDeg, 170 * kDeg);
    const double t_al = std::clamp(al.theta, 0.0, t_is - 20 * kDeg);
    const double gluteal_from = t_is - 20 * kDeg, gluteal_h = is.h - 50 * kMm;
    r.push_back({"ischial_gluteal", "ischial / gluteal", gluteal_from, -135 * kDeg, gluteal_h, 1e9});
    r.push_back({"lateral_wall", "lateral wall", -135 * kDeg, -45 * kDeg, distal, 1e9});
    r.push_back({"anterior", "anterior (Scarpa's triangle)", -45 * kDeg, t_al - 10 * kDeg, distal, 1e9});
    r.push_back({"medial", "medial (adductors, ramus)", t_al - 10 * kDeg, gluteal_from, distal, 1e9});
    r.push_back({"posterior", "posterior thigh", gluteal_from, -135 * kDeg, distal, gluteal_h});
  } else {
    const auto& pt = need(lms, "PT").cylindrical;
    r.push_back({"patellar_tendon", "patellar tendon", pt.theta - 30 * kDeg, pt.theta + 30 * kDeg, pt.h - 25 * kMm,
                 pt.h + 25 * kMm});
    r.push_back({"anterior", "anterior", -45 * kDeg, 45 * kDeg, distal, 1e9});
    r.push_back({"medial", "medial", 45 * kDeg, 135 * kDeg, distal, 1e9});
    r.push_back({"posterior", "posterior", 135 * kDeg, -135 * kDeg, distal, 1e9});
    r.push_back({"lateral", "lateral", -135 * kDeg, -45 * kDeg, distal, 1e9});
  }
  return r;
}

std::vector<int> region_of(const std::vector<LoadRegion>& regions, const std::vector<geometry::Cylindrical>& points) {
  std::vector<int> out(points.size(), -1);
  for (std::size_t i = 0; i < points.size(); ++i)
    for (std::size_t k = 0; k < regions.size(); ++k)
      if (regions[k].contains(points[i].theta, points[i].h)) {
        out[i] = static_cast<int>(k);
        break;
      }
  return out;
}

std::vector<RegionLoad> region_loads(const std::vector<LoadRegion>& regions, const std::vector<geometry::Cylindrical>& rest,
                                     const std::vector<char>& above, const DesignState& state,
                                     const geometry::LimbFrame& frame, double friction) {
  require(rest.size() == state.pressure_pa.size() && above.size() == rest.size() &&
              state.skin_normals.size() == rest.size() && state.skin_areas.size() == rest.size(),
          "region_loads: {} skin nodes but {} pressures, {} brim flags, {} normals (the state is not of this stump)",
          rest.size(), state.pressure_pa.size(), above.size(), state.skin_normals.size());
  std::vector<RegionLoad> out(regions.size());
  for (std::size_t k = 0; k < regions.size(); ++k) {
    out[k].key = regions[k].key;
    out[k].name = regions[k].name;
  }
  const std::vector<int> which = region_of(regions, rest);
  for (std::size_t i = 0; i < rest.size(); ++i) {
    const double p = state.pressure_pa[i];
    if (which[i] < 0 || above[i] || p <= 0.0) continue;
    RegionLoad& r = out[static_cast<std::size_t>(which[i])];
    const double a = state.skin_areas[i];
    const double nz = state.skin_normals[i].dot(frame.axis);
    r.area_m2 += a;
    r.normal_axial_n += -p * a * nz;
    r.friction_axial_n += axial_friction_n(p, a, state.skin_normals[i], frame.axis, friction);
    r.mean_pressure_pa += p * a;
    r.peak_pressure_pa = std::max(r.peak_pressure_pa, p);
  }
  const double fz = state.radar.force_n.z();
  for (auto& r : out) {
    r.axial_n = r.normal_axial_n + r.friction_axial_n;
    r.share = std::abs(fz) > 0 ? r.axial_n / fz : 0.0;
    r.mean_pressure_pa = r.area_m2 > 0 ? r.mean_pressure_pa / r.area_m2 : 0.0;
  }
  return out;
}

double default_ischial_share(BrimTemplate kind) {
  switch (kind) {
    case BrimTemplate::Quad:
      return 0.30;
    case BrimTemplate::Ics:
      return 0.15;
    default:
      return 0.0;
  }
}

}  // namespace socketsmith::design
