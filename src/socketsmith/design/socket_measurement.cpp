// The finished socket read back: its faces labelled (inner, outer, lip, platform, holes) and the
// thickness of its whole outer wall (socket_builder_detail.h says why this is apart).
#include <algorithm>
#include <cmath>
#include <map>
#include <limits>
#include <numbers>
#include <numeric>
#include <optional>
#include <string>
#include <unordered_map>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_boolean.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/geometry/surface_query.h"

#include "socketsmith/design/socket_builder_detail.h"

namespace socketsmith::design::socket_detail {
namespace {

/// Bit pattern of a point: the Booleans keep the vertices they do not cut exactly.
struct PointKey {
  std::array<double, 3> c;
  bool operator==(const PointKey& o) const { return c == o.c; }
};
struct PointKeyHash {
  std::size_t operator()(const PointKey& k) const {
    std::size_t h = 0;
    for (double v : k.c) h = h * 1000003u ^ std::hash<double>()(v);
    return h;
  }
};

}  // namespace

/// Labels the faces of the solid after the Booleans: a face the Booleans left as it was (its three
/// vertices and the face are in @p shell) keeps its label from @p shell_kind; the others are
/// labelled by where they lie.
std::vector<SocketFace> classify_faces(const TriMesh& solid, const TriMesh& shell,
                                       const std::vector<SocketFace>& shell_kind, const geometry::SurfaceQuery& inner,
                                       const geometry::SurfaceQuery& lip, const PlatformBuild& pb) {
  constexpr double kOn = 1e-7;  // on a surface [m]
  std::unordered_map<PointKey, int, PointKeyHash> shell_vertex;
  for (std::size_t v = 0; v < shell.vertices.size(); ++v)
    shell_vertex.emplace(PointKey{{shell.vertices[v].x(), shell.vertices[v].y(), shell.vertices[v].z()}},
                         static_cast<int>(v));
  auto face_key = [](std::array<int, 3> t) {
    std::sort(t.begin(), t.end());
    return (static_cast<std::uint64_t>(t[0]) << 42) ^ (static_cast<std::uint64_t>(t[1]) << 21) ^
           static_cast<std::uint64_t>(t[2]);
  };
  std::unordered_map<std::uint64_t, SocketFace> shell_face;
  for (std::size_t t = 0; t < shell.triangles.size(); ++t) shell_face.emplace(face_key(shell.triangles[t]), shell_kind[t]);
  std::vector<SocketFace> kind(solid.triangles.size(), SocketFace::Outer);
  const PlatformFrame& f = pb.frame;
  const double r_out = pb.hole_radius / std::cos(kPi / kHoleSides);
  for (std::size_t t = 0; t < solid.triangles.size(); ++t) {
    const auto& tri = solid.triangles[t];
    std::array<int, 3> old{-1, -1, -1};
    for (int k = 0; k < 3; ++k) {
      const Vec3& v = solid.vertices[tri[k]];
      const auto it = shell_vertex.find(PointKey{{v.x(), v.y(), v.z()}});
      if (it != shell_vertex.end()) old[k] = it->second;
    }
    if (old[0] >= 0 && old[1] >= 0 && old[2] >= 0) {
      const auto it = shell_face.find(face_key(old));
      if (it != shell_face.end()) {
        kind[t] = it->second;
        continue;
      }
    }
    const Vec3 c = (solid.vertices[tri[0]] + solid.vertices[tri[1]] + solid.vertices[tri[2]]) / 3.0;
    const Vec3 nrm = geometry::triangle_normal(solid, static_cast<int>(t));
    if (inner.closest_point(c).distance < kOn) {
      kind[t] = SocketFace::Inner;
      continue;
    }
    if (lip.closest_point(c).distance < kOn) {
      kind[t] = SocketFace::Lip;
      continue;
    }
    const Eigen::Vector2d q = f.xy_of(c);
    bool is_hole = false;
    for (const auto& h : pb.holes) {
      const double d = (q - h).norm();
      if (d > pb.hole_radius - kOn && d < r_out + kOn && std::abs(nrm.dot(f.up)) < 0.1) is_hole = true;
    }
    if (is_hole) kind[t] = SocketFace::Hole;
    else if (std::abs(f.z_of(c) - pb.z_face) < kOn && nrm.dot(f.up) < -0.99) kind[t] = SocketFace::Platform;
  }
  return kind;
}

/// Thickness of the whole outer surface: per vertex, and statistics over its vertices, edge
/// midpoints and centroids (points within the brim band left out).
void measure_thickness(SocketResult& r, const geometry::SurfaceQuery& inner, const geometry::SurfaceQuery* lip,
                       const geometry::LimbFrame& frame, const BrimLine& brim, const SocketOptions& o) {
  const TriMesh& m = r.solid;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<char> on_inner(m.vertices.size(), 0), on_outer(m.vertices.size(), 0);
  for (std::size_t t = 0; t < m.triangles.size(); ++t)
    for (int v : m.triangles[t]) {
      if (r.face_kind[t] == SocketFace::Inner) on_inner[v] = 1;
      if (r.face_kind[t] == SocketFace::Outer || r.face_kind[t] == SocketFace::Platform) on_outer[v] = 1;
    }
  r.vertex_thickness_m.assign(m.vertices.size(), nan);
  std::vector<double> d;
  double min_ratio = std::numeric_limits<double>::infinity();
  // Only points this high can be within the band of the lip (the lip lies above the outer rim,
  // which is at most a few walls below the inner rim).
  const double near_rim_h = r.rim_min_h_m - o.brim_band_m - 4.0 * std::max({o.thickness_m, o.distal_thickness_m,
                                                                             o.brim_thickness_m});
  auto sample = [&](const Vec3& p) -> double {
    const geometry::SurfaceHit h = inner.closest_point(p);
    if (lip && o.brim_band_m > 0 && frame.to_cylindrical(p).h > near_rim_h &&
        lip->closest_point(p).distance < o.brim_band_m)
      return h.distance;
    const geometry::Cylindrical c = frame.to_cylindrical(h.point);
    min_ratio = std::min(min_ratio, h.distance / asked_thickness_m(o, c.h, brim.height(c.theta)));
    d.push_back(h.distance);
    return h.distance;
  };
  for (std::size_t v = 0; v < m.vertices.size(); ++v) {
    if (on_inner[v]) continue;
    if (on_outer[v]) r.vertex_thickness_m[v] = sample(m.vertices[v]);
    else r.vertex_thickness_m[v] = inner.closest_point(m.vertices[v]).distance;  // lip, hole-only vertices
  }
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    if (r.face_kind[t] != SocketFace::Outer && r.face_kind[t] != SocketFace::Platform) continue;
    const auto& tri = m.triangles[t];
    const Vec3 a = m.vertices[tri[0]], b = m.vertices[tri[1]], c = m.vertices[tri[2]];
    sample((a + b + c) / 3.0);
    sample(0.5 * (a + b));
    sample(0.5 * (b + c));
    sample(0.5 * (c + a));
  }
  if (d.empty()) return;
  r.min_thickness_ratio = min_ratio;
  r.mean_thickness_m = std::accumulate(d.begin(), d.end(), 0.0) / static_cast<double>(d.size());
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  r.median_thickness_m = d[d.size() / 2];
  const auto [lo, hi] = std::minmax_element(d.begin(), d.end());
  r.min_thickness_m = *lo;
  r.max_thickness_m = *hi;
}

}  // namespace socketsmith::design::socket_detail
