#pragma once
// An independent check of a socket's wall (issue 22): its own point-to-triangle distances (no
// CGAL, no geometry::SurfaceQuery), a uniform grid only to pick the candidate triangles near a
// point. Used by the socket builder's tests and the pipeline's tests on the demo, generated and
// real limbs.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

#include <fmt/format.h>

#include "socketsmith/design/socket_builder.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::wall_check {

using geometry::TriMesh;
using geometry::Vec3;

/// Closest point of triangle abc to p: the nearest of the projection onto the face's plane (when
/// it falls inside) and the nearest points of the three edges, written out directly (not
/// Ericson's region walk of SurfaceQuery).
inline Vec3 closest_point_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a);
  const double nn = n.squaredNorm();
  if (nn > 0) {
    const Vec3 q = p - (p - a).dot(n) / nn * n;  // projection onto the plane
    // Inside when q is on the inner side of all three edges.
    if ((b - a).cross(q - a).dot(n) >= 0 && (c - b).cross(q - b).dot(n) >= 0 && (a - c).cross(q - c).dot(n) >= 0)
      return q;
  }
  Vec3 best = a;
  for (const auto& [u, v] : {std::pair{a, b}, std::pair{b, c}, std::pair{c, a}}) {
    const Vec3 e = v - u;
    const double ee = e.squaredNorm();
    const Vec3 q = u + (ee > 0 ? std::clamp((p - u).dot(e) / ee, 0.0, 1.0) : 0.0) * e;
    if ((q - p).squaredNorm() < (best - p).squaredNorm()) best = q;
  }
  return best;
}

inline double point_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  return (closest_point_on_triangle(p, a, b, c) - p).norm();
}

/// Parameter t ≥ 0 where the line o + t d crosses triangle abc (Möller–Trumbore), or -1.
inline double ray_triangle(const Vec3& o, const Vec3& d, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e1 = b - a, e2 = c - a, pv = d.cross(e2);
  const double det = e1.dot(pv);
  if (std::abs(det) < 1e-30) return -1;
  const Vec3 tv = o - a;
  const double u = tv.dot(pv) / det;
  if (u < 0 || u > 1) return -1;
  const Vec3 qv = tv.cross(e1);
  const double v = d.dot(qv) / det;
  if (v < 0 || u + v > 1) return -1;
  const double t = e2.dot(qv) / det;
  return t >= 0 ? t : -1;
}

/// Distances to a set of triangles, exact below @p reach (and @p reach, meaning "at least",
/// beyond): a uniform grid of cells holds the triangles whose bounding box touches them; a query
/// visits the cells in growing shells around its own and stops once no farther cell can hold a
/// closer triangle. Every candidate's distance is computed exactly.
class Distance {
 public:
  Distance(std::vector<std::array<Vec3, 3>> tris, double reach) : tris_(std::move(tris)), reach_(reach) {
    cell_ = std::max(reach / 4, 1e-3);
    stamp_.assign(tris_.size(), 0);
    for (std::size_t i = 0; i < tris_.size(); ++i) {
      Vec3 lo = tris_[i][0], hi = tris_[i][0];
      for (const auto& v : tris_[i]) {
        lo = lo.cwiseMin(v);
        hi = hi.cwiseMax(v);
      }
      const auto a = key3(lo), b = key3(hi);
      for (long x = a[0]; x <= b[0]; ++x)
        for (long y = a[1]; y <= b[1]; ++y)
          for (long z = a[2]; z <= b[2]; ++z) grid_[hash(x, y, z)].push_back(static_cast<int>(i));
    }
  }
  double operator()(const Vec3& p) const { return closest(p).first; }
  /// Distance and closest point (the point is p itself when nothing lies within the reach).
  std::pair<double, Vec3> closest(const Vec3& p) const {
    const auto k0 = key3(p);
    std::pair<double, Vec3> best{reach_, p};
    ++query_;
    const long shells = static_cast<long>(std::ceil(reach_ / cell_)) + 1;
    for (long k = 0; k <= shells; ++k) {
      for (long x = -k; x <= k; ++x)
        for (long y = -k; y <= k; ++y)
          for (long z = -k; z <= k; ++z) {
            if (std::max({std::abs(x), std::abs(y), std::abs(z)}) != k) continue;  // this shell only
            const auto it = grid_.find(hash(k0[0] + x, k0[1] + y, k0[2] + z));
            if (it == grid_.end()) continue;
            for (int i : it->second) {
              if (stamp_[i] == query_) continue;
              stamp_[i] = query_;
              const Vec3 q = closest_point_on_triangle(p, tris_[i][0], tris_[i][1], tris_[i][2]);
              const double d = (q - p).norm();
              if (d < best.first) best = {d, q};
            }
          }
      if (best.first <= k * cell_) break;  // every cell of the next shells is at least k cells away
    }
    return best;
  }
  double reach() const { return reach_; }

 private:
  std::array<long, 3> key3(const Vec3& p) const {
    return {static_cast<long>(std::floor(p.x() / cell_)), static_cast<long>(std::floor(p.y() / cell_)),
            static_cast<long>(std::floor(p.z() / cell_))};
  }
  static long long hash(long x, long y, long z) {
    return (static_cast<long long>(x) * 73856093LL) ^ (static_cast<long long>(y) * 19349663LL) ^
           (static_cast<long long>(z) * 83492791LL);
  }
  std::vector<std::array<Vec3, 3>> tris_;
  double reach_ = 0, cell_ = 0;
  std::unordered_map<long long, std::vector<int>> grid_;
  mutable std::vector<unsigned> stamp_;  // the last query that measured each triangle
  mutable unsigned query_ = 0;
};

inline std::vector<std::array<Vec3, 3>> triangles_of(const TriMesh& m, const std::vector<int>& faces) {
  std::vector<std::array<Vec3, 3>> out;
  out.reserve(faces.size());
  for (int f : faces) out.push_back({m.vertices[m.triangles[f][0]], m.vertices[m.triangles[f][1]],
                                     m.vertices[m.triangles[f][2]]});
  return out;
}

/// What the check found on the outer surface.
struct WallReport {
  int samples = 0;           ///< outer-surface points measured
  int skipped_near_brim = 0; ///< points within the brim band (not measured)
  double min_ratio = 0;      ///< min of distance / asked thickness
  double min_m = 0, median_m = 0, max_m = 0;  ///< distances (max saturates at the reach)
  Vec3 worst = Vec3::Zero(); ///< where min_ratio is
  std::string summary() const {
    return fmt::format("{} points: wall min {:.3f} / median {:.3f} / max {:.3f} mm, min ratio {:.3f} at ({:.1f}, "
                       "{:.1f}, {:.1f}) mm; {} within the brim band",
                       samples, min_m * 1e3, median_m * 1e3, max_m * 1e3, min_ratio, worst.x() * 1e3,
                       worst.y() * 1e3, worst.z() * 1e3, skipped_near_brim);
  }
};

/// Measures the wall: for sample points of the @p outer faces of @p solid (each face's vertices,
/// edge midpoints, centroid and two interior points), the distance to the @p inner faces; points
/// within @p band_m of a @p lip face are skipped. @p asked(q) is the thickness asked at q, the inner
/// point nearest the sample (constant for a uniform wall).
template <class Asked>
WallReport measure_wall(const TriMesh& solid, const std::vector<int>& inner, const std::vector<int>& outer,
                        const std::vector<int>& lip, double band_m, double reach_m, Asked asked) {
  const Distance to_inner(triangles_of(solid, inner), reach_m);
  const Distance to_lip(triangles_of(solid, lip), band_m);
  WallReport r;
  r.min_ratio = std::numeric_limits<double>::infinity();
  std::vector<double> d;
  const std::array<std::array<double, 3>, 9> bary = {{{1, 0, 0},
                                                       {0, 1, 0},
                                                       {0, 0, 1},
                                                       {0.5, 0.5, 0},
                                                       {0, 0.5, 0.5},
                                                       {0.5, 0, 0.5},
                                                       {1.0 / 3, 1.0 / 3, 1.0 / 3},
                                                       {0.6, 0.2, 0.2},
                                                       {0.2, 0.2, 0.6}}};
  for (int f : outer) {
    const auto& t = solid.triangles[f];
    for (const auto& w : bary) {
      const Vec3 p = w[0] * solid.vertices[t[0]] + w[1] * solid.vertices[t[1]] + w[2] * solid.vertices[t[2]];
      if (!lip.empty() && to_lip(p) < band_m) {
        ++r.skipped_near_brim;
        continue;
      }
      const auto [dist, q] = to_inner.closest(p);
      const double ratio = dist / asked(q);
      if (ratio < r.min_ratio) {
        r.min_ratio = ratio;
        r.worst = p;
      }
      d.push_back(dist);
    }
  }
  r.samples = static_cast<int>(d.size());
  if (!d.empty()) {
    std::sort(d.begin(), d.end());
    r.min_m = d.front();
    r.max_m = d.back();
    r.median_m = d[d.size() / 2];
  }
  return r;
}

/// Where the case puts the platform and its holes, computed here from the options (the pylon
/// direction of the alignment, the square of holes turned and offset in the platform's plane).
struct ExpectedPlatform {
  Vec3 origin, up, anterior, medial;
  double radius = 0, hole_radius = 0;
  std::vector<Eigen::Vector2d> holes;
  double z(const Vec3& p) const { return (p - origin).dot(up); }
  Eigen::Vector2d xy(const Vec3& p) const { return {(p - origin).dot(anterior), (p - origin).dot(medial)}; }
  Vec3 at(const Eigen::Vector2d& q, double z) const { return origin + q.x() * anterior + q.y() * medial + z * up; }
};

inline ExpectedPlatform expected_platform(const geometry::LimbFrame& frame, const design::SocketOptions& o) {
  ExpectedPlatform e;
  const double tf = std::tan(o.alignment.flexion_rad), ta = std::tan(o.alignment.adduction_rad);
  e.up = (frame.axis - tf * frame.anterior + ta * frame.medial()).normalized();
  e.anterior = (frame.anterior - frame.anterior.dot(e.up) * e.up).normalized();
  e.medial = (frame.medial() - frame.medial().dot(e.up) * e.up - frame.medial().dot(e.anterior) * e.anterior).normalized();
  const auto& a = o.attachment;
  e.origin = frame.origin;
  if (a.enabled) e.origin += a.offset_anterior_m * e.anterior + a.offset_medial_m * e.medial;
  e.radius = 0.5 * (a.enabled ? a.platform_diameter_m : o.distal_pad_diameter_m);
  if (a.enabled) {
    e.hole_radius = 0.5 * a.hole_diameter_m;
    for (const auto& [x, y] : {std::pair{1.0, 1.0}, std::pair{-1.0, 1.0}, std::pair{-1.0, -1.0}, std::pair{1.0, -1.0}}) {
      const double h = 0.5 * a.hole_spacing_m, c = std::cos(a.rotation_rad), s = std::sin(a.rotation_rad);
      e.holes.emplace_back(c * x * h - s * y * h, s * x * h + c * y * h);
    }
  }
  return e;
}

/// Everything issue 22 asks of a socket, checked independently of the builder's own numbers.
struct SocketCheck {
  WallReport wall;
  std::vector<std::string> failures;  ///< empty when every check passes
  double flatness_m = 0;              ///< spread of the platform's face along the pylon [m]
  double min_hole_depth_m = 0;        ///< shortest hole, face to cavity [m]
  std::string text() const {
    std::string out = wall.summary() + fmt::format("; flatness {:.4f} mm, shortest hole {:.2f} mm", flatness_m * 1e3,
                                                   min_hole_depth_m * 1e3);
    for (const auto& f : failures) out += "\n  FAIL: " + f;
    return out;
  }
};

/// @param inner_input the surface given to build_socket (the deformed skin)
/// @param min_ratio   the wall must be at least this × the asked thickness (0.95)
inline SocketCheck check_socket(const design::SocketResult& r, const TriMesh& inner_input,
                                const geometry::LimbFrame& frame, const design::BrimLine& brim,
                                const design::SocketOptions& o, double min_ratio = 0.95) {
  SocketCheck out;
  auto fail = [&](std::string what) { out.failures.push_back(std::move(what)); };
  const TriMesh& m = r.solid;
  const auto rep = geometry::check_mesh(m);
  if (!rep.is_valid_closed_surface())
    fail("not a valid closed surface: " + (rep.problems().empty() ? "?" : rep.problems().front()));
  if (rep.connected_components != 1) fail(fmt::format("{} connected components", rep.connected_components));
  if (rep.signed_volume_m3 <= 0) fail("volume not positive");
  if (geometry::has_self_intersections(m)) fail("self-intersects");
  if (r.face_kind.size() != m.triangles.size()) {
    fail("face_kind has the wrong size");
    return out;
  }
  const double t_max = std::max({o.thickness_m, o.distal_thickness_m, o.brim_thickness_m});
  std::vector<int> inner, outer, lip, flat, holes;
  for (int f = 0; f < m.num_triangles(); ++f) switch (r.face_kind[f]) {
      case design::SocketFace::Inner: inner.push_back(f); break;
      case design::SocketFace::Outer: outer.push_back(f); break;
      case design::SocketFace::Lip: lip.push_back(f); break;
      case design::SocketFace::Platform: flat.push_back(f); outer.push_back(f); break;
      case design::SocketFace::Hole: holes.push_back(f); break;
    }
  auto centroid = [&](int f) {
    const auto& t = m.triangles[f];
    return Vec3((m.vertices[t[0]] + m.vertices[t[1]] + m.vertices[t[2]]) / 3.0);
  };
  // The labels are what they say: inner faces on the given surface, lip faces at the brim.
  {
    std::vector<int> all(inner_input.triangles.size());
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
    const Distance to_input(triangles_of(inner_input, all), 1e-3);
    int off = 0;
    for (int f : inner)
      if (to_input(centroid(f)) > 1e-6) ++off;
    if (off > 0) fail(fmt::format("{} faces labelled inner are not on the stump surface", off));
    int low = 0;
    for (int f : lip)
      for (int v : m.triangles[f]) {
        const auto c = frame.to_cylindrical(m.vertices[v]);
        if (c.h < brim.height(c.theta) - 3 * t_max - 1e-6) ++low;
      }
    if (low > 0) fail(fmt::format("{} vertices of faces labelled lip lie below the brim band", low));
  }
  // The wall.
  out.wall = measure_wall(m, inner, outer, lip, o.brim_band_m, 2 * t_max, [&](const Vec3& q) {
    const auto c = frame.to_cylindrical(q);
    return design::asked_thickness_m(o, c.h, brim.height(c.theta));
  });
  if (out.wall.samples == 0) fail("no outer-wall point measured");
  if (out.wall.min_ratio < min_ratio)
    fail(fmt::format("wall below {} x asked: {}", min_ratio, out.wall.summary()));
  // The platform: flat, normal to the pylon, the lowest part, as wide as asked, centred.
  const bool platform = o.distal_pad || o.attachment.enabled;
  const ExpectedPlatform e = expected_platform(frame, o);
  if (!platform) {
    if (!flat.empty() || !holes.empty()) fail("platform or hole faces without a platform");
    return out;
  }
  if (flat.empty()) {
    fail("no platform face");
    return out;
  }
  double zlo = 1e9, zhi = -1e9, area = 0, worst_normal = 1;
  Eigen::Vector2d c2 = Eigen::Vector2d::Zero();
  for (int f : flat) {
    for (int v : m.triangles[f]) {
      zlo = std::min(zlo, e.z(m.vertices[v]));
      zhi = std::max(zhi, e.z(m.vertices[v]));
    }
    const auto& t = m.triangles[f];
    const Vec3 n = (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]);
    area += 0.5 * n.norm();
    c2 += 0.5 * n.norm() * e.xy(centroid(f));
    worst_normal = std::min(worst_normal, -n.normalized().dot(e.up));
  }
  c2 /= area;
  out.flatness_m = zhi - zlo;
  if (out.flatness_m > 0.2e-3) fail(fmt::format("platform not flat: {:.3f} mm", out.flatness_m * 1e3));
  if (worst_normal < std::cos(0.5 * 3.14159265358979 / 180))
    fail(fmt::format("platform face not normal to the pylon (cos {:.5f})", worst_normal));
  double zmin = 1e9;
  for (const auto& v : m.vertices) zmin = std::min(zmin, e.z(v));
  if (zmin < zlo - 1e-6) fail(fmt::format("the solid reaches {:.3f} mm below its platform", (zlo - zmin) * 1e3));
  const double hole_area = e.holes.size() * 3.14159265358979 * std::pow(e.hole_radius / std::cos(3.14159265358979 / 24), 2);
  const double disc = 3.14159265358979 * e.radius * e.radius;
  if (area < 0.97 * (disc - hole_area) || area > 1.01 * disc)
    fail(fmt::format("platform face {:.0f} mm2, expected a disc of {:.0f} mm2 less the holes", area * 1e6, disc * 1e6));
  if (c2.norm() > 0.5e-3) fail(fmt::format("platform centred {:.2f} mm off the pylon axis", c2.norm() * 1e3));
  // The holes: where the case puts them, real through-holes into the cavity, deep enough.
  if (e.holes.empty()) {
    if (!holes.empty()) fail("hole faces without an attachment");
    return out;
  }
  std::vector<std::array<Vec3, 3>> solid_tris = triangles_of(m, [&] {
    std::vector<int> all(m.triangles.size());
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
    return all;
  }());
  out.min_hole_depth_m = 1e9;
  int stray = 0;
  for (int f : holes) {
    const Eigen::Vector2d q = e.xy(centroid(f));
    bool on_one = false;
    for (const auto& h : e.holes) {
      const double d = (q - h).norm();
      if (d > e.hole_radius - 1e-5 && d < e.hole_radius * 1.02) on_one = true;
    }
    if (!on_one) ++stray;
  }
  if (stray > 0) fail(fmt::format("{} hole faces are not on any of the case's hole cylinders", stray));
  for (std::size_t k = 0; k < e.holes.size(); ++k) {
    const Eigen::Vector2d& h = e.holes[k];
    // Bore faces all around the expected axis.
    std::array<int, 8> octant{};
    for (int f : holes) {
      const Eigen::Vector2d q = e.xy(centroid(f)) - h;
      if (q.norm() > e.hole_radius * 1.02) continue;
      const double a = std::atan2(q.y(), q.x()) + 3.14159265358979;
      octant[std::min(7, static_cast<int>(a / (2 * 3.14159265358979) * 8))]++;
    }
    if (*std::min_element(octant.begin(), octant.end()) == 0) fail(fmt::format("hole {}: no bore all around its axis", k + 1));
    // Cavity above the hole (from the given surface) and nothing of the solid between.
    double top = -1e9, bottom = 1e9;
    for (int j = -1; j < 12; ++j) {
      const double phi = 2 * 3.14159265358979 * j / 12;
      const Eigen::Vector2d q = h + (j < 0 ? 0.0 : 0.999 * e.hole_radius) * Eigen::Vector2d(std::cos(phi), std::sin(phi));
      const Vec3 o0 = e.at(q, zlo - 0.05);
      double t_in = 1e9;
      for (const auto& tri : inner_input.triangles) {
        const double t = ray_triangle(o0, e.up, inner_input.vertices[tri[0]], inner_input.vertices[tri[1]],
                                      inner_input.vertices[tri[2]]);
        if (t >= 0) t_in = std::min(t_in, t);
      }
      if (t_in > 1e8) {
        fail(fmt::format("hole {}: its axis misses the cavity", k + 1));
        break;
      }
      top = std::max(top, zlo - 0.05 + t_in);
      bottom = std::min(bottom, zlo - 0.05 + t_in);
      if (j >= 0) continue;
      for (const auto& tri : solid_tris) {
        const double t = ray_triangle(o0, e.up, tri[0], tri[1], tri[2]);
        if (t >= 0 && zlo - 0.05 + t < zlo - 0.05 + t_in + 0.5e-3) {
          fail(fmt::format("hole {}: the solid blocks its axis at {:.2f} mm above the platform", k + 1,
                           (t - 0.05) * 1e3));
          break;
        }
      }
    }
    out.min_hole_depth_m = std::min(out.min_hole_depth_m, bottom - zlo);
    if (bottom - zlo < o.attachment.platform_thickness_m - 0.02e-3)
      fail(fmt::format("hole {}: only {:.2f} mm of material (asked {:.2f})", k + 1, (bottom - zlo) * 1e3,
                       o.attachment.platform_thickness_m * 1e3));
    // The flat face leaves the hole open.
    const Vec3 axis_point = e.at(h, zlo);
    for (int f : flat) {
      const auto& t = m.triangles[f];
      const double tt = ray_triangle(axis_point - 1e-3 * e.up, e.up, m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]);
      if (tt >= 0 && tt < 2e-3) fail(fmt::format("hole {}: the platform face covers its axis", k + 1));
    }
  }
  return out;
}

}  // namespace socketsmith::wall_check
