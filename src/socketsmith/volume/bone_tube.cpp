// A tube swept along a bone's control points with a radius per point (detail::sweep_tube): the
// shafts of the template bones. Apart from bone_template.cpp because it is a geometric tool the
// template uses, not the template.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "socketsmith/core/errors.h"
#include "socketsmith/volume/bone_template.h"
#include "socketsmith/volume/shape_math.h"

namespace socketsmith::volume {

using geometry::TriMesh;
using geometry::Vec3;

namespace {
using shape::kPi;
using shape::clamp01;
constexpr double kInf = std::numeric_limits<double>::infinity();

/// Points along a tube's centreline with the tube's radius [m] at each, and (when sampled finely)
/// the arc length [m] from the first.
struct TubeCurve {
  std::vector<Vec3> points;
  std::vector<double> radii, arc;
};

/// The clamped uniform cubic B-spline of the control points and their radii (the end points
/// tripled), 40 samples per segment with their arc length.
TubeCurve sample_spline(const std::vector<Vec3>& control, const std::vector<double>& radii) {
  std::vector<Vec3> q;
  std::vector<double> rq;
  for (int k = 0; k < 2; ++k) {
    q.push_back(control.front());
    rq.push_back(radii.front());
  }
  q.insert(q.end(), control.begin(), control.end());
  rq.insert(rq.end(), radii.begin(), radii.end());
  for (int k = 0; k < 2; ++k) {
    q.push_back(control.back());
    rq.push_back(radii.back());
  }
  TubeCurve fine;
  const int per_segment = 40;
  for (std::size_t i = 0; i + 3 < q.size(); ++i)
    for (int j = 0; j < per_segment + (i + 4 == q.size() ? 1 : 0); ++j) {
      const double t = static_cast<double>(j) / per_segment, t2 = t * t, t3 = t2 * t;
      const double b0 = (1 - t) * (1 - t) * (1 - t) / 6.0, b1 = (3 * t3 - 6 * t2 + 4) / 6.0,
                   b2 = (-3 * t3 + 3 * t2 + 3 * t + 1) / 6.0, b3 = t3 / 6.0;
      fine.points.push_back(b0 * q[i] + b1 * q[i + 1] + b2 * q[i + 2] + b3 * q[i + 3]);
      fine.radii.push_back(b0 * rq[i] + b1 * rq[i + 1] + b2 * rq[i + 2] + b3 * rq[i + 3]);
      const std::size_t m = fine.points.size();
      fine.arc.push_back(fine.arc.empty() ? 0.0 : fine.arc.back() + (fine.points.back() - fine.points[m - 2]).norm());
    }
  return fine;
}

/// The ring centres and radii: the sampled curve at equal arc-length steps of at most spacing_m.
TubeCurve resample_by_arc(const TubeCurve& fine, double spacing_m) {
  const double total = fine.arc.back();
  require(total > 0.0, "sweep_tube: the control points coincide (no curve to sweep)");
  const int rings = std::max(2, static_cast<int>(std::ceil(total / spacing_m)) + 1);
  TubeCurve t;
  t.points.resize(static_cast<std::size_t>(rings));
  t.radii.resize(t.points.size());
  std::size_t k = 0;
  for (int i = 0; i < rings; ++i) {
    const double target = total * i / (rings - 1);
    while (k + 2 < fine.arc.size() && fine.arc[k + 1] < target) ++k;
    const std::vector<double>& arc = fine.arc;
    const double w = arc[k + 1] > arc[k] ? clamp01((target - arc[k]) / (arc[k + 1] - arc[k])) : 0.0;
    t.points[static_cast<std::size_t>(i)] = (1 - w) * fine.points[k] + w * fine.points[k + 1];
    t.radii[static_cast<std::size_t>(i)] = (1 - w) * fine.radii[k] + w * fine.radii[k + 1];
  }
  return t;
}

/// The smallest ratio of the centreline's radius of curvature to the tube's radius.
double tightest_bend(const std::vector<Vec3>& c, const std::vector<double>& rr) {
  double worst = kInf;
  for (std::size_t i = 1; i + 1 < c.size(); ++i) {
    const Vec3 a = c[i] - c[i - 1], b = c[i + 1] - c[i];
    const double turn = std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0));
    if (turn < 1e-9) continue;
    worst = std::min(worst, 0.5 * (a.norm() + b.norm()) / turn / rr[i]);
  }
  return worst;
}

/// Where the curve bends more tightly than the tube is thick, its inner side would fold: smooths
/// the centreline (ends fixed) until the radius of curvature exceeds 1.5 × the tube's radius.
void unfold_centreline(std::vector<Vec3>& c, const std::vector<double>& rr) {
  for (int it = 0; it < 2000 && tightest_bend(c, rr) < 1.5; ++it) {
    std::vector<Vec3> next = c;
    for (std::size_t i = 1; i + 1 < c.size(); ++i) next[i] = 0.5 * c[i] + 0.25 * (c[i - 1] + c[i + 1]);
    c = std::move(next);
  }
}

/// Tangents and rotation-minimising frames (double reflection, Wang et al. 2008): tan[i] and the
/// normal u[i] at each centre.
void rotation_minimising_frames(const std::vector<Vec3>& c, std::vector<Vec3>& tan, std::vector<Vec3>& u) {
  tan.resize(c.size());
  u.resize(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Vec3 d = c[std::min(i + 1, c.size() - 1)] - c[i == 0 ? 0 : i - 1];
    tan[i] = d.normalized();
  }
  {
    const Vec3 trial = std::abs(tan[0].x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
    u[0] = (trial - trial.dot(tan[0]) * tan[0]).normalized();
  }
  for (std::size_t i = 0; i + 1 < c.size(); ++i) {
    const Vec3 v1 = c[i + 1] - c[i];
    const double c1 = v1.squaredNorm();
    if (c1 < 1e-24) {
      u[i + 1] = u[i];
      continue;
    }
    const Vec3 rl = u[i] - (2.0 / c1) * v1.dot(u[i]) * v1, tl = tan[i] - (2.0 / c1) * v1.dot(tan[i]) * v1;
    const Vec3 v2 = tan[i + 1] - tl;
    const double c2 = v2.squaredNorm();
    const Vec3 un = c2 < 1e-24 ? rl : Vec3(rl - (2.0 / c2) * v2.dot(rl) * v2);
    u[i + 1] = (un - un.dot(tan[i + 1]) * tan[i + 1]).normalized();
  }
}

/// n points on the circle of the given radius about centre, in the plane normal to t, from uu.
std::vector<Vec3> ring_at(const Vec3& centre, const Vec3& t, const Vec3& uu, double radius, int n) {
  const Vec3 vv = t.cross(uu).normalized();
  std::vector<Vec3> ring(static_cast<std::size_t>(n));
  for (int j = 0; j < n; ++j) {
    const double a = 2.0 * kPi * j / n;
    ring[static_cast<std::size_t>(j)] = centre + radius * (std::cos(a) * uu + std::sin(a) * vv);
  }
  return ring;
}

/// The closed tube: the bottom pole, the rings in order, the top pole, stitched into triangles and
/// oriented outward.
TriMesh stitch_rings(const Vec3& bottom_pole, const std::vector<std::vector<Vec3>>& ring_pts, const Vec3& top_pole,
                     int n) {
  TriMesh m;
  m.vertices.push_back(bottom_pole);
  for (const auto& ring : ring_pts) m.vertices.insert(m.vertices.end(), ring.begin(), ring.end());
  m.vertices.push_back(top_pole);
  const int nr = static_cast<int>(ring_pts.size());
  auto vid = [&](int ring, int j) { return 1 + ring * n + ((j % n) + n) % n; };
  for (int j = 0; j < n; ++j) m.triangles.push_back({0, vid(0, j + 1), vid(0, j)});
  for (int i = 0; i + 1 < nr; ++i)
    for (int j = 0; j < n; ++j) {
      m.triangles.push_back({vid(i, j), vid(i, j + 1), vid(i + 1, j + 1)});
      m.triangles.push_back({vid(i, j), vid(i + 1, j + 1), vid(i + 1, j)});
    }
  const int top = m.num_vertices() - 1;
  for (int j = 0; j < n; ++j) m.triangles.push_back({top, vid(nr - 1, j), vid(nr - 1, j + 1)});
  if (geometry::signed_volume(m) < 0.0) geometry::flip_orientation(m);
  return m;
}

}  // namespace

namespace detail {

TriMesh sweep_tube(const std::vector<Vec3>& control, const std::vector<double>& radii, int ring_vertices,
                   double spacing_m) {
  require(control.size() >= 2 && control.size() == radii.size(),
          "sweep_tube: {} control points and {} radii (expected at least 2, one radius per point)", control.size(),
          radii.size());
  require(ring_vertices >= 6 && spacing_m > 0.0, "sweep_tube: {} ring vertices, spacing {} m (expected ≥ 6, > 0)",
          ring_vertices, spacing_m);
  for (double r : radii) require(std::isfinite(r) && r > 0.0, "sweep_tube: radius {} m is not positive", r);
  TubeCurve centres = resample_by_arc(sample_spline(control, radii), spacing_m);
  std::vector<Vec3>& c = centres.points;
  const std::vector<double>& rr = centres.radii;
  unfold_centreline(c, rr);
  std::vector<Vec3> tan, u;
  rotation_minimising_frames(c, tan, u);
  // Rings: hemispherical cap rings, the body, cap rings; poles at both ends.
  const int n = ring_vertices;
  std::vector<std::vector<Vec3>> ring_pts;
  constexpr int kCapRings = 3;
  const Vec3 bottom_pole = c.front() - rr.front() * tan.front();
  for (int i = kCapRings; i >= 1; --i) {
    const double a = 0.5 * kPi * i / (kCapRings + 1);
    ring_pts.push_back(ring_at(c.front() - rr.front() * std::sin(a) * tan.front(), tan.front(), u.front(),
                               rr.front() * std::cos(a), n));
  }
  for (std::size_t i = 0; i < c.size(); ++i) ring_pts.push_back(ring_at(c[i], tan[i], u[i], rr[i], n));
  for (int i = 1; i <= kCapRings; ++i) {
    const double a = 0.5 * kPi * i / (kCapRings + 1);
    ring_pts.push_back(ring_at(c.back() + rr.back() * std::sin(a) * tan.back(), tan.back(), u.back(),
                               rr.back() * std::cos(a), n));
  }
  const Vec3 top_pole = c.back() + rr.back() * tan.back();
  return stitch_rings(bottom_pole, ring_pts, top_pole, n);
}

}  // namespace detail

}  // namespace socketsmith::volume
