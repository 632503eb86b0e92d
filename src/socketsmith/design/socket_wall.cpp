// The socket's wall: the thickness asked at each inner-wall vertex, the outer offsets corrected
// until the wall is as thick as asked, and the shell assembled from the inner wall, the outer wall
// and the lip along the rim (socket_builder_detail.h says why this is apart).
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "socketsmith/core/errors.h"
#include "socketsmith/design/socket_builder_detail.h"

namespace socketsmith::design::socket_detail {

/// Asked thickness at every vertex of the cut wall.
std::vector<double> asked_per_vertex(const CutSurface& cut, const geometry::LimbFrame& frame, const BrimLine& brim,
                                     const SocketOptions& o) {
  std::vector<double> t(cut.mesh.vertices.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    const geometry::Cylindrical c = frame.to_cylindrical(cut.mesh.vertices[i]);
    t[i] = asked_thickness_m(o, c.h, brim.height(c.theta));
  }
  return t;
}

/// Offsets along the normals that make the wall as thick as asked. Starting from the asked
/// thickness, every pass measures the distance to the inner wall at each outer vertex, edge
/// midpoint and centroid; where it falls short of 0.995 × asked (concave regions, where the
/// offset surface comes closer to the neighbouring faces, and facets across convex ones, whose
/// chords cut the corners) the vertices involved move further out, to 1.002 × asked: the deficit
/// divided by the rate at which moving along the normal opens the distance. At most three walls
/// out and four passes (a thinner spot left is reported by the measurement). Returns the passes
/// that raised.
int correct_offsets(const CutSurface& cut, const geometry::SurfaceQuery& inner, const std::vector<double>& asked,
                    std::vector<double>& s) {
  constexpr double kTrigger = 0.995, kAim = 1.002;
  constexpr int kMaxPasses = 4;
  const auto& x = cut.mesh.vertices;
  const auto& n = cut.normal;
  const std::size_t nv = x.size();
  std::vector<Vec3> p(nv);
  std::vector<double> raise(nv);
  // Deficit at q (asked thickness target, moving along direction dir): 0 when thick enough.
  // Each sample is offset from a point of the inner wall on a known triangle: the search starts there.
  auto deficit = [&](const Vec3& q, double target, const Vec3& dir, const Vec3& from, int triangle) {
    geometry::SurfaceHit hint;
    hint.point = from;
    hint.triangle = triangle;
    const geometry::SurfaceHit h = inner.closest_point(q, hint);
    if (h.distance >= kTrigger * target) return 0.0;
    const double need = kAim * target - h.distance;
    const double rate = h.distance > 0 ? dir.dot((q - h.point) / h.distance) : 1.0;
    return need / std::max(0.5, rate);
  };
  // A sample's distance to the (fixed) inner wall changes only when its vertices move: after the
  // first pass only the samples around the vertices just raised are measured again.
  std::vector<char> moved(nv, 1);
  std::vector<std::array<int, 3>> edges;  // each edge once: its ends and a triangle holding it
  std::vector<int> vertex_triangle(nv, -1);
  {
    std::unordered_map<std::uint64_t, char> seen;
    for (int f = 0; f < cut.mesh.num_triangles(); ++f) {
      const auto& t = cut.mesh.triangles[f];
      for (int k = 0; k < 3; ++k) {
        vertex_triangle[t[k]] = f;
        if (seen.emplace(edge_key(t[k], t[(k + 1) % 3]), 1).second) edges.push_back({t[k], t[(k + 1) % 3], f});
      }
    }
  }
  for (int pass = 0; pass < kMaxPasses; ++pass) {
    for (std::size_t i = 0; i < nv; ++i) p[i] = x[i] + s[i] * n[i];
    std::fill(raise.begin(), raise.end(), 0.0);
    bool any = false;
    for (std::size_t i = 0; i < nv; ++i) {
      if (!moved[i]) continue;
      raise[i] = deficit(p[i], asked[i], n[i], x[i], vertex_triangle[i]);
      any = any || raise[i] > 0;
    }
    for (int f = 0; f < cut.mesh.num_triangles(); ++f) {
      const auto& t = cut.mesh.triangles[f];
      if (!moved[t[0]] && !moved[t[1]] && !moved[t[2]]) continue;
      const Vec3 dir = (n[t[0]] + n[t[1]] + n[t[2]]).normalized();
      const double c = deficit((p[t[0]] + p[t[1]] + p[t[2]]) / 3.0, (asked[t[0]] + asked[t[1]] + asked[t[2]]) / 3.0, dir,
                               (x[t[0]] + x[t[1]] + x[t[2]]) / 3.0, f);
      for (int k = 0; k < 3; ++k) raise[t[k]] = std::max(raise[t[k]], c);
      any = any || c > 0;
    }
    for (const auto& [a, b, f] : edges) {
      if (!moved[a] && !moved[b]) continue;
      const double e =
          deficit(0.5 * (p[a] + p[b]), 0.5 * (asked[a] + asked[b]), (n[a] + n[b]).normalized(), 0.5 * (x[a] + x[b]), f);
      raise[a] = std::max(raise[a], e);
      raise[b] = std::max(raise[b], e);
      any = any || e > 0;
    }
    if (!any) return pass;
    for (std::size_t i = 0; i < nv; ++i) {
      const double next = std::min(s[i] + raise[i], 3.0 * asked[i]);  // at most three walls out
      moved[i] = next > s[i];
      s[i] = next;
    }
  }
  return kMaxPasses;
}


/// The shell: inner wall (reversed), outer wall at offsets @p s, lip along the rim.
Attempt assemble(const CutSurface& cut, const geometry::LimbFrame& frame, const SocketOptions& o,
                 const std::vector<double>& s) {
  const int nv = cut.mesh.num_vertices();
  Attempt a;
  TriMesh& m = a.solid;
  // Inner wall: reversed (the solid's outside faces the limb there).
  m.vertices = cut.mesh.vertices;
  for (const auto& tri : cut.mesh.triangles) m.triangles.push_back({tri[0], tri[2], tri[1]});
  a.inner = cut.mesh.num_triangles();
  // Outer wall.
  for (int i = 0; i < nv; ++i) m.vertices.push_back(cut.mesh.vertices[i] + s[i] * cut.normal[i]);
  for (const auto& tri : cut.mesh.triangles) m.triangles.push_back({tri[0] + nv, tri[1] + nv, tri[2] + nv});
  a.outer = cut.mesh.num_triangles();
  // Lip: rings of vertices per rim vertex, from the inner (ring 0) to the outer rim (ring K).
  const int K = o.round_brim ? o.lip_segments : 1;
  std::unordered_map<int, int> ring_base;  // rim vertex -> index of its ring 1 vertex
  for (int i = 0; i < nv; ++i) {
    if (!cut.on_rim[i]) continue;
    ring_base[i] = m.num_vertices();
    const Vec3 n = cut.normal[i];
    Vec3 up = frame.axis - frame.axis.dot(n) * n;
    up = up.norm() > 1e-9 ? Vec3(up.normalized()) : frame.axis;
    const Vec3 centre = cut.mesh.vertices[i] + 0.5 * s[i] * n;
    for (int k = 1; k < K; ++k) {
      const double phi = kPi * k / K;
      m.vertices.push_back(centre - 0.5 * s[i] * std::cos(phi) * n + 0.5 * s[i] * std::sin(phi) * up);
    }
  }
  auto ring = [&](int v, int k) { return k == 0 ? v : k == K ? v + nv : ring_base.at(v) + k - 1; };
  for (const auto& e : directed_boundary_edges(cut.mesh)) {
    for (int k = 0; k < K; ++k) {
      const int a0 = ring(e[0], k), b0 = ring(e[1], k), a1 = ring(e[0], k + 1), b1 = ring(e[1], k + 1);
      m.triangles.push_back({a0, b0, b1});
      m.triangles.push_back({a0, b1, a1});
      a.lip += 2;
    }
  }
  a.kind.assign(a.inner, SocketFace::Inner);
  a.kind.insert(a.kind.end(), a.outer, SocketFace::Outer);
  a.kind.insert(a.kind.end(), a.lip, SocketFace::Lip);
  return a;
}

}  // namespace socketsmith::design::socket_detail
