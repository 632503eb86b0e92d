#pragma once
/// @file brute_force.h
/// Independent brute-force geometry for the volume tests (not the library's code): distances to
/// triangles, an inside test by ray parity, the volume centroid.

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::volume::test {

using geometry::TriMesh;
using geometry::Vec3;

inline double point_segment_distance(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
  return (a + t * ab - p).norm();
}

/// Distance from p to triangle abc: the plane distance when the projection falls inside (same
/// side of all three edges), else the nearest edge.
inline double point_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a);
  const double nn = n.norm();
  if (nn > 1e-20) {
    const Vec3 u = n / nn;
    const Vec3 q = p - (p - a).dot(u) * u;
    const bool inside = (b - a).cross(q - a).dot(n) >= 0 && (c - b).cross(q - b).dot(n) >= 0 && (a - c).cross(q - c).dot(n) >= 0;
    if (inside) return std::abs((p - a).dot(u));
  }
  return std::min({point_segment_distance(p, a, b), point_segment_distance(p, b, c), point_segment_distance(p, c, a)});
}

/// Smallest distance from the vertices of @p from to the triangles of @p to (stride: every n-th vertex).
inline double min_vertex_distance(const TriMesh& from, const TriMesh& to, int stride = 1) {
  std::vector<geometry::Aabb> boxes(to.triangles.size());
  for (std::size_t t = 0; t < to.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) boxes[t].extend(to.vertices[to.triangles[t][k]]);
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t v = 0; v < from.vertices.size(); v += static_cast<std::size_t>(stride)) {
    const Vec3& p = from.vertices[v];
    for (std::size_t t = 0; t < to.triangles.size(); ++t) {
      const Vec3 lo = boxes[t].min - p, hi = p - boxes[t].max;
      if (lo.cwiseMax(hi).cwiseMax(Vec3::Zero()).norm() >= best) continue;
      const auto& tr = to.triangles[t];
      best = std::min(best, point_triangle_distance(p, to.vertices[tr[0]], to.vertices[tr[1]], to.vertices[tr[2]]));
    }
  }
  return best;
}

/// Inside test by the parity of the crossings of a ray along @p d (horizontal by default: the
/// skin may be open at the top).
inline bool inside_by_parity(const Vec3& p, const TriMesh& mesh, const Vec3& d = Vec3(0.6, 0.8, 0.0)) {
  int hits = 0;
  for (const auto& t : mesh.triangles) {
    const Vec3 &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
    const Vec3 n = (b - a).cross(c - a);
    const double den = n.dot(d);
    if (std::abs(den) < 1e-20) continue;
    const double s = n.dot(a - p) / den;
    if (s <= 0) continue;
    const Vec3 q = p + s * d;
    if ((b - a).cross(q - a).dot(n) >= 0 && (c - b).cross(q - b).dot(n) >= 0 && (a - c).cross(q - c).dot(n) >= 0) ++hits;
  }
  return hits % 2 == 1;
}

/// Volume centroid of a closed outward mesh (divergence theorem over tetrahedra from the origin).
inline Vec3 volume_centroid(const TriMesh& m) {
  Vec3 c = Vec3::Zero();
  double vol = 0.0;
  for (const auto& t : m.triangles) {
    const Vec3 &a = m.vertices[t[0]], &b = m.vertices[t[1]], &d = m.vertices[t[2]];
    const double v = a.dot(b.cross(d)) / 6.0;
    vol += v;
    c += v * (a + b + d) / 4.0;
  }
  return c / vol;
}

}  // namespace socketsmith::volume::test
