#include "socketsmith/design/socket_builder.h"

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

namespace socketsmith::design {
namespace {

using geometry::TriMesh;
constexpr double kMm = units::mm;
constexpr double kDeg = units::deg;
constexpr double kPi = std::numbers::pi;

std::uint64_t edge_key(int a, int b) {
  const auto lo = static_cast<std::uint64_t>(std::min(a, b)), hi = static_cast<std::uint64_t>(std::max(a, b));
  return (lo << 32) | hi;
}

void check_options(const SocketOptions& o) {
  require(std::isfinite(o.thickness_m) && o.thickness_m > 0.0 && o.thickness_m <= 0.05,
          "build_socket: thickness_m = {} m is out of range (expected a wall of (0, 50] mm, e.g. 0.005)",
          o.thickness_m);
  for (const auto& [name, v] : {std::pair{"distal_thickness_m", o.distal_thickness_m},
                                std::pair{"brim_thickness_m", o.brim_thickness_m}})
    require(std::isfinite(v) && v >= 0.0 && v <= 0.05,
            "build_socket: {} = {} m is out of range (0 = thickness_m, else a wall of (0, 50] mm)", name, v);
  require(std::isfinite(o.min_feature_m) && o.min_feature_m > 0.0 && o.min_feature_m <= 0.01,
          "build_socket: min_feature_m = {} m is out of range (0, 10 mm] (a printer's smallest feature, e.g. 0.001)",
          o.min_feature_m);
  for (const auto& [name, v] : {std::pair{"thickness_m", o.thickness_m},
                                std::pair{"distal_thickness_m", o.distal_thickness_m},
                                std::pair{"brim_thickness_m", o.brim_thickness_m}})
    require(v == 0.0 || v >= o.min_feature_m,
            "build_socket: {} = {:.2f} mm is below the smallest printable feature ({:.2f} mm); thicken the wall",
            name, v / kMm, o.min_feature_m / kMm);
  require(std::isfinite(o.brim_band_m) && o.brim_band_m >= 0.0 && o.brim_band_m <= 0.02,
          "build_socket: brim_band_m = {} m is out of range [0, 20 mm]", o.brim_band_m);
  require(!o.round_brim || (o.lip_segments >= 2 && o.lip_segments <= 32),
          "build_socket: lip_segments = {} is out of range [2, 32]", o.lip_segments);
  require(!o.distal_pad || (std::isfinite(o.distal_pad_diameter_m) && o.distal_pad_diameter_m > 0.0 &&
                            o.distal_pad_diameter_m <= 0.15),
          "build_socket: distal_pad_diameter_m = {} m is out of range (0, 0.15]", o.distal_pad_diameter_m);
  for (const auto& [name, v] : {std::pair{"flexion", o.alignment.flexion_rad},
                                std::pair{"adduction", o.alignment.adduction_rad}})
    require(std::isfinite(v) && std::abs(v) <= 30.0 * kDeg,
            "build_socket: socket {} {:.1f}° is out of range [−30°, 30°] (bench alignment: a few degrees)", name,
            v / kDeg);
  if (o.attachment.enabled) {
    const SocketAttachment& a = o.attachment;
    for (const auto& [name, v] : {std::pair{"bolt_diameter_m", a.bolt_diameter_m},
                                  std::pair{"hole_diameter_m", a.hole_diameter_m},
                                  std::pair{"hole_spacing_m", a.hole_spacing_m},
                                  std::pair{"platform_diameter_m", a.platform_diameter_m},
                                  std::pair{"platform_thickness_m", a.platform_thickness_m}})
      require(std::isfinite(v) && v > 0.0 && v <= 0.15, "build_socket: attachment {} = {} m is out of range (0, 150 mm]",
              name, v);
    require(a.hole_diameter_m >= a.bolt_diameter_m,
            "build_socket: attachment hole {:.2f} mm is narrower than its {:.1f} mm bolt; give a clearance hole "
            "(ISO 273: M6 → 6.6 mm)",
            a.hole_diameter_m / kMm, a.bolt_diameter_m / kMm);
    require(a.hole_diameter_m >= o.min_feature_m,
            "build_socket: attachment hole {:.2f} mm is below the smallest printable feature ({:.2f} mm)",
            a.hole_diameter_m / kMm, o.min_feature_m / kMm);
    require(a.hole_spacing_m - a.hole_diameter_m >= o.min_feature_m,
            "build_socket: attachment holes {:.1f} mm apart leave {:.2f} mm between {:.1f} mm holes (< {:.2f} mm, the "
            "smallest printable feature); widen the spacing or use thinner bolts",
            a.hole_spacing_m / kMm, (a.hole_spacing_m - a.hole_diameter_m) / kMm, a.hole_diameter_m / kMm,
            o.min_feature_m / kMm);
    require(a.platform_thickness_m >= o.min_feature_m,
            "build_socket: attachment platform_thickness {:.2f} mm is below the smallest printable feature",
            a.platform_thickness_m / kMm);
    require(std::isfinite(a.rotation_rad) && std::isfinite(a.offset_anterior_m) && std::isfinite(a.offset_medial_m) &&
                std::abs(a.offset_anterior_m) <= 0.02 && std::abs(a.offset_medial_m) <= 0.02,
            "build_socket: attachment offset ({:.1f}, {:.1f}) mm is out of range (at most 20 mm each way; align the "
            "rest with the pyramid adapter)",
            a.offset_anterior_m / kMm, a.offset_medial_m / kMm);
    // Ligament from the outermost hole's edge to the platform's rim.
    const double reach = 0.5 * std::sqrt(2.0) * a.hole_spacing_m + 0.5 * a.hole_diameter_m;
    require(0.5 * a.platform_diameter_m - reach >= o.min_feature_m,
            "build_socket: the attachment platform ({:.1f} mm) is too small for holes {:.1f} mm apart: the holes reach "
            "{:.1f} mm from its centre; make platform_diameter_mm at least {:.1f}",
            a.platform_diameter_m / kMm, a.hole_spacing_m / kMm, reach / kMm,
            2.0 * (reach + o.min_feature_m) / kMm);
  }
  require(o.subdivisions >= 0 && o.subdivisions <= 3, "build_socket: subdivisions = {} is out of range [0, 3]",
          o.subdivisions);
  require(o.normal_smoothing_iterations >= 0 && o.normal_smoothing_iterations <= 200,
          "build_socket: normal_smoothing_iterations = {} is out of range [0, 200]", o.normal_smoothing_iterations);
  require(std::isfinite(o.level_step_m) && o.level_step_m > 0.0,
          "build_socket: level_step_m = {} m must be > 0", o.level_step_m);
}

/// One-to-four midpoint subdivision (keeps the geometry, halves the edges).
TriMesh subdivide(const TriMesh& m) {
  TriMesh out;
  out.vertices = m.vertices;
  std::unordered_map<std::uint64_t, int> mid;
  auto midpoint = [&](int a, int b) {
    const auto [it, is_new] = mid.try_emplace(edge_key(a, b), out.num_vertices());
    if (is_new) out.vertices.push_back(0.5 * (m.vertices[a] + m.vertices[b]));
    return it->second;
  };
  for (const auto& t : m.triangles) {
    const int ab = midpoint(t[0], t[1]), bc = midpoint(t[1], t[2]), ca = midpoint(t[2], t[0]);
    out.triangles.push_back({t[0], ab, ca});
    out.triangles.push_back({ab, t[1], bc});
    out.triangles.push_back({ca, bc, t[2]});
    out.triangles.push_back({ab, bc, ca});
  }
  return out;
}

/// Area-weighted vertex normals, then @p passes of neighbour averaging.
std::vector<Vec3> smoothed_normals(const TriMesh& m, int passes) {
  std::vector<Vec3> n(m.vertices.size(), Vec3::Zero());
  for (const auto& t : m.triangles) {
    const Vec3 f = (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]);  // 2 A n
    for (int k = 0; k < 3; ++k) n[t[k]] += f;
  }
  for (auto& v : n) v.normalize();
  if (passes == 0) return n;
  std::vector<std::vector<int>> nb(m.vertices.size());
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) nb[t[k]].push_back(t[(k + 1) % 3]);  // each edge seen from both sides
  for (int p = 0; p < passes; ++p) {
    std::vector<Vec3> next(n.size());
    for (std::size_t i = 0; i < n.size(); ++i) {
      Vec3 s = n[i];
      for (int j : nb[i]) s += n[j];
      next[i] = s.norm() > 0 ? Vec3(s.normalized()) : n[i];
    }
    n.swap(next);
  }
  return n;
}

/// The inner wall below the brim with, per kept vertex, its normal.
struct CutSurface {
  TriMesh mesh;
  std::vector<Vec3> normal;
  std::vector<char> on_rim;  // vertex created on the brim curve
};

CutSurface cut_below_brim(const TriMesh& m, const std::vector<Vec3>& normal, const geometry::LimbFrame& frame,
                          const BrimLine& brim) {
  auto f = [&](const Vec3& p) {
    const geometry::Cylindrical c = frame.to_cylindrical(p);
    return c.h - brim.height(c.theta);
  };
  std::vector<double> s(m.vertices.size());
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = f(m.vertices[i]);
  CutSurface out;
  std::vector<int> kept(m.vertices.size(), -1);
  auto keep = [&](int v) {
    if (kept[v] < 0) {
      kept[v] = out.mesh.num_vertices();
      out.mesh.vertices.push_back(m.vertices[v]);
      out.normal.push_back(normal[v]);
      out.on_rim.push_back(0);
    }
    return kept[v];
  };
  std::unordered_map<std::uint64_t, int> crossing;
  auto cross = [&](int a, int b) {  // s[a] < 0 <= s[b]
    const auto [it, is_new] = crossing.try_emplace(edge_key(a, b), out.mesh.num_vertices());
    if (!is_new) return it->second;
    const Vec3 pa = m.vertices[a], pb = m.vertices[b];
    double lo = 0.0, hi = 1.0;  // f(lo) < 0 <= f(hi): bisection against the exact curve
    for (int k = 0; k < 40; ++k) {
      const double mid = 0.5 * (lo + hi);
      (f(pa + mid * (pb - pa)) < 0.0 ? lo : hi) = mid;
    }
    // Keep the new vertex a little away from the edge's ends, so no triangle degenerates.
    const double t = std::clamp(0.5 * (lo + hi), 1e-3, 1.0 - 1e-3);
    out.mesh.vertices.push_back(pa + t * (pb - pa));
    out.normal.push_back(((1.0 - t) * normal[a] + t * normal[b]).normalized());
    out.on_rim.push_back(1);
    return it->second;
  };
  for (const auto& tri : m.triangles) {
    std::array<int, 4> poly{};
    int n = 0;
    for (int k = 0; k < 3; ++k) {  // Sutherland–Hodgman against s < 0
      const int a = tri[k], b = tri[(k + 1) % 3];
      const bool ia = s[a] < 0.0, ib = s[b] < 0.0;
      if (ia) poly[n++] = keep(a);
      if (ia != ib) poly[n++] = ia ? cross(a, b) : cross(b, a);
    }
    if (n >= 3) out.mesh.triangles.push_back({poly[0], poly[1], poly[2]});
    if (n == 4) out.mesh.triangles.push_back({poly[0], poly[2], poly[3]});
  }
  return out;
}

/// Keeps the largest edge-connected component (by triangle count) of the cut surface.
int keep_largest_component(CutSurface& cut) {
  const int nt = cut.mesh.num_triangles();
  std::vector<int> parent(cut.mesh.vertices.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const auto& t : cut.mesh.triangles) {
    parent[find(t[0])] = find(t[1]);
    parent[find(t[1])] = find(t[2]);
  }
  std::map<int, int> count;
  for (const auto& t : cut.mesh.triangles) ++count[find(t[0])];
  if (count.size() <= 1) return 0;
  const int best = std::max_element(count.begin(), count.end(), [](auto& a, auto& b) { return a.second < b.second; })->first;
  CutSurface out;
  std::vector<int> map(cut.mesh.vertices.size(), -1);
  for (const auto& t : cut.mesh.triangles) {
    if (find(t[0]) != best) continue;
    std::array<int, 3> nt3{};
    for (int k = 0; k < 3; ++k) {
      if (map[t[k]] < 0) {
        map[t[k]] = out.mesh.num_vertices();
        out.mesh.vertices.push_back(cut.mesh.vertices[t[k]]);
        out.normal.push_back(cut.normal[t[k]]);
        out.on_rim.push_back(cut.on_rim[t[k]]);
      }
      nt3[k] = map[t[k]];
    }
    out.mesh.triangles.push_back(nt3);
  }
  const int dropped = nt - out.mesh.num_triangles();
  cut = std::move(out);
  return dropped;
}

/// Directed boundary edges (a → b as they appear in a triangle) of a surface.
std::vector<std::array<int, 2>> boundary_edges(const TriMesh& m) {
  std::unordered_map<std::uint64_t, int> count;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) ++count[edge_key(t[k], t[(k + 1) % 3])];
  std::vector<std::array<int, 2>> out;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k)
      if (count[edge_key(t[k], t[(k + 1) % 3])] == 1) out.push_back({t[k], t[(k + 1) % 3]});
  return out;
}


// ------------------------------------------------------------------------------------------------
// Wall: the outer wall offset, corrected until it is as thick as asked
// ------------------------------------------------------------------------------------------------

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

struct Attempt {
  TriMesh solid;
  std::vector<SocketFace> kind;
  int inner = 0, outer = 0, lip = 0;
};

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
  for (const auto& e : boundary_edges(cut.mesh)) {
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

// ------------------------------------------------------------------------------------------------
// Distal platform: pad or attachment
// ------------------------------------------------------------------------------------------------

/// The pylon's upward direction in the limb frame (SocketAlignment).
Vec3 pylon_up(const geometry::LimbFrame& frame, const SocketAlignment& al) {
  return (frame.axis - std::tan(al.flexion_rad) * frame.anterior + std::tan(al.adduction_rad) * frame.medial())
      .normalized();
}

/// Where the platform goes, in its own frame: x along `anterior`, y along `medial`, z along the
/// pylon `up`, origin on the pylon axis at the limb frame's distal level.
struct PlatformFrame {
  Vec3 origin = Vec3::Zero(), up = Vec3::UnitZ(), anterior = Vec3::UnitX(), medial = Vec3::UnitY();
  Vec3 at(double x, double y, double z) const { return origin + x * anterior + y * medial + z * up; }
  double z_of(const Vec3& p) const { return (p - origin).dot(up); }
  Eigen::Vector2d xy_of(const Vec3& p) const { return {(p - origin).dot(anterior), (p - origin).dot(medial)}; }
};

PlatformFrame platform_frame(const geometry::LimbFrame& frame, const SocketOptions& o) {
  PlatformFrame f;
  f.up = pylon_up(frame, o.alignment);
  f.anterior = (frame.anterior - frame.anterior.dot(f.up) * f.up).normalized();
  f.medial = f.up.cross(f.anterior);
  if (f.medial.dot(frame.medial()) < 0) f.medial = -f.medial;
  f.origin = frame.origin;
  if (o.attachment.enabled)
    f.origin += o.attachment.offset_anterior_m * f.anterior + o.attachment.offset_medial_m * f.medial;
  return f;
}

/// Hole centres of the four-hole pattern in the platform's plane.
std::vector<Eigen::Vector2d> hole_pattern(const SocketAttachment& a) {
  std::vector<Eigen::Vector2d> out;
  const double h = 0.5 * a.hole_spacing_m, c = std::cos(a.rotation_rad), s = std::sin(a.rotation_rad);
  for (const auto& [x, y] : {std::pair{h, h}, std::pair{-h, h}, std::pair{-h, -h}, std::pair{h, -h}})
    out.emplace_back(c * x - s * y, s * x + c * y);
  return out;
}

constexpr int kPlatformSectors = 72;  ///< around the platform's disc
constexpr int kHoleSides = 24;        ///< of each drill's polygon (circumscribed: never narrower than asked)
constexpr double kPlatformGap_m = 0.5e-3;  ///< flat face below the lowest outer-wall point of the disc

/// A closed block: the flat disc of radius R at z = z0 below, and above every point of a polar
/// grid the height top(j, k) (ring j of `rings`, sector k; ring 0 is the centre).
TriMesh platform_block(const PlatformFrame& f, double R, int rings, double z0,
                       const std::vector<std::vector<double>>& top, double phase) {
  TriMesh m;
  const int N = kPlatformSectors;
  auto xy = [&](int j, int k) {
    const double r = R * j / rings, phi = phase + 2 * kPi * k / N;
    return Eigen::Vector2d(r * std::cos(phi), r * std::sin(phi));
  };
  // Top grid: centre, then rings 1..J of N vertices.
  m.vertices.push_back(f.at(0, 0, top[0][0]));
  for (int j = 1; j <= rings; ++j)
    for (int k = 0; k < N; ++k) {
      const auto q = xy(j, k);
      m.vertices.push_back(f.at(q.x(), q.y(), top[j][k]));
    }
  auto T = [&](int j, int k) { return j == 0 ? 0 : 1 + (j - 1) * N + ((k % N) + N) % N; };
  // Top faces look up (+z) when (anterior, medial, up) is right-handed.
  for (int k = 0; k < N; ++k) m.triangles.push_back({T(0, 0), T(1, k), T(1, k + 1)});
  for (int j = 1; j < rings; ++j)
    for (int k = 0; k < N; ++k) {
      m.triangles.push_back({T(j, k), T(j + 1, k), T(j + 1, k + 1)});
      m.triangles.push_back({T(j, k), T(j + 1, k + 1), T(j, k + 1)});
    }
  // Bottom: the flat disc (centre + rim), facing down.
  const int bc = m.num_vertices();
  m.vertices.push_back(f.at(0, 0, z0));
  for (int k = 0; k < N; ++k) {
    const auto q = xy(rings, k);
    m.vertices.push_back(f.at(q.x(), q.y(), z0));
  }
  auto B = [&](int k) { return bc + 1 + ((k % N) + N) % N; };
  for (int k = 0; k < N; ++k) m.triangles.push_back({bc, B(k + 1), B(k)});
  // Side: from the bottom rim up to the top grid's outer ring, facing out.
  for (int k = 0; k < N; ++k) {
    m.triangles.push_back({B(k), B(k + 1), T(rings, k + 1)});
    m.triangles.push_back({B(k), T(rings, k + 1), T(rings, k)});
  }
  // (anterior, medial, up) is left-handed for the other side's limb: the faces then look in.
  if (geometry::signed_volume(m) < 0) geometry::flip_orientation(m);
  return m;
}

/// A prism of kHoleSides sides around (x, y) from z0 to z1, its sides tangent to the circle of
/// radius r (the hole is never narrower than 2r).
void add_drill(TriMesh& m, const PlatformFrame& f, const Eigen::Vector2d& c, double r, double z0, double z1,
               double phase) {
  const int N = kHoleSides;
  const double rv = r / std::cos(kPi / N);
  const int b = m.num_vertices();
  m.vertices.push_back(f.at(c.x(), c.y(), z0));
  m.vertices.push_back(f.at(c.x(), c.y(), z1));
  for (int k = 0; k < N; ++k) {
    const double phi = phase + 2 * kPi * k / N;
    m.vertices.push_back(f.at(c.x() + rv * std::cos(phi), c.y() + rv * std::sin(phi), z0));
    m.vertices.push_back(f.at(c.x() + rv * std::cos(phi), c.y() + rv * std::sin(phi), z1));
  }
  auto lo = [&](int k) { return b + 2 + 2 * (((k % N) + N) % N); };
  auto hi = [&](int k) { return lo(k) + 1; };
  for (int k = 0; k < N; ++k) {
    m.triangles.push_back({b, lo(k + 1), lo(k)});      // bottom, facing down
    m.triangles.push_back({b + 1, hi(k), hi(k + 1)});  // top, facing up
    m.triangles.push_back({lo(k), lo(k + 1), hi(k + 1)});
    m.triangles.push_back({lo(k), hi(k + 1), hi(k)});
  }
}

/// What the platform step decided, for the result and the face classification.
struct PlatformBuild {
  PlatformFrame frame;
  double radius = 0, z_face = 0, hole_radius = 0;
  std::vector<Eigen::Vector2d> holes;
  std::vector<double> hole_top;
  SocketPlatform report;
};

/// Joins the platform to the shell @p a (and drills the holes). The block's top follows the middle
/// of the wall (inner + half the offset), so it lies inside the wall's material: the union adds
/// material below the wall and never into the cavity. Its flat face lies kPlatformGap_m below the
/// lowest outer-wall point over the disc and, with holes, platform_thickness_m below the cavity
/// over every hole.
PlatformBuild add_platform(Attempt& a, const CutSurface& cut, const std::vector<double>& s,
                           const geometry::LimbFrame& frame, const SocketOptions& o, double phase) {
  const bool attach = o.attachment.enabled;
  PlatformBuild pb;
  pb.frame = platform_frame(frame, o);
  const PlatformFrame& f = pb.frame;
  pb.radius = 0.5 * (attach ? o.attachment.platform_diameter_m : o.distal_pad_diameter_m);
  const double R = pb.radius;
  const int nv = cut.mesh.num_vertices();
  TriMesh outer = cut.mesh, mid = cut.mesh;
  for (int i = 0; i < nv; ++i) {
    outer.vertices[i] = cut.mesh.vertices[i] + s[i] * cut.normal[i];
    mid.vertices[i] = cut.mesh.vertices[i] + 0.5 * s[i] * cut.normal[i];
  }
  const geometry::SurfaceQuery outer_q(outer), mid_q(mid), inner_q(cut.mesh);
  double z_low = std::numeric_limits<double>::infinity();
  for (const auto& v : a.solid.vertices) z_low = std::min(z_low, f.z_of(v));
  z_low -= 0.01;
  // First crossing of the vertical (pylon) line through (x, y) with a wall, from below.
  auto up_hit = [&](const geometry::SurfaceQuery& q, double x, double y) -> std::optional<double> {
    const auto h = q.first_hit(f.at(x, y, z_low), f.up);
    if (!h) return std::nullopt;
    return z_low + h->distance;
  };
  const int rings = std::max(4, static_cast<int>(std::ceil(R / (1.5 * kMm))));
  std::vector<std::vector<double>> top(rings + 1, std::vector<double>(kPlatformSectors));
  double z_out_min = std::numeric_limits<double>::infinity(), z_top_max = -z_out_min;
  for (int j = 0; j <= rings; ++j)
    for (int k = 0; k < kPlatformSectors; ++k) {
      if (j == 0 && k > 0) {
        top[0][k] = top[0][0];
        continue;
      }
      const double r = R * j / rings, phi = phase + 2 * kPi * k / kPlatformSectors;
      const double x = r * std::cos(phi), y = r * std::sin(phi);
      const auto zm = up_hit(mid_q, x, y);
      require(zm.has_value(),
              "build_socket: the distal platform ({:.0f} mm across) is wider than the socket's distal end: the pylon "
              "line {:.1f} mm from its centre misses the socket; make the platform (or pad) diameter smaller",
              2 * R / kMm, r / kMm);
      top[j][k] = *zm;
      z_top_max = std::max(z_top_max, *zm);
      if (const auto zo = up_hit(outer_q, x, y)) z_out_min = std::min(z_out_min, *zo);
    }
  for (const auto& v : outer.vertices)
    if (f.xy_of(v).norm() <= R) z_out_min = std::min(z_out_min, f.z_of(v));
  double z_face = z_out_min - kPlatformGap_m;
  if (attach) {
    pb.holes = hole_pattern(o.attachment);
    pb.hole_radius = 0.5 * o.attachment.hole_diameter_m;
    for (std::size_t h = 0; h < pb.holes.size(); ++h) {
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      // The cavity over the hole: its axis, 8 points at half its radius and 32 on its circle.
      for (int k = -1; k < 40; ++k) {
        const double phi = 2 * kPi * k / (k < 8 ? 8 : 32);
        const double rr = k < 0 ? 0.0 : k < 8 ? 0.5 * pb.hole_radius : pb.hole_radius / std::cos(kPi / kHoleSides);
        const Eigen::Vector2d q = pb.holes[h] + rr * Eigen::Vector2d(std::cos(phi), std::sin(phi));
        const auto zi = up_hit(inner_q, q.x(), q.y());
        require(zi.has_value(),
                "build_socket: attachment hole {} at ({:.1f}, {:.1f}) mm from the pylon axis does not reach the "
                "socket's cavity; use a smaller hole spacing or offset",
                h + 1, pb.holes[h].x() / kMm, pb.holes[h].y() / kMm);
        lo = std::min(lo, *zi);
        hi = std::max(hi, *zi);
      }
      z_face = std::min(z_face, lo - o.attachment.platform_thickness_m);
      pb.hole_top.push_back(hi + std::max(2 * kMm, pb.hole_radius));
    }
  }
  const double tallest = z_top_max - z_face;
  const double limit = std::max(2 * R, 0.04) + (attach ? o.attachment.platform_thickness_m : 0.0);
  require(tallest <= limit,
          "build_socket: the distal platform ({:.0f} mm across) would climb {:.0f} mm up the socket's side (more than "
          "{:.0f} mm): it is wider than the socket's distal end; make the platform (or pad) diameter smaller",
          2 * R / kMm, tallest / kMm, limit / kMm);
  pb.z_face = z_face;
  // The shell passed the self-intersection test; the block and the drills are valid by
  // construction (and the result is checked again).
  geometry::BooleanOptions unchecked;
  unchecked.check_operands = false;
  a.solid = geometry::mesh_boolean(a.solid, platform_block(f, R, rings, z_face, top, phase),
                                   geometry::BooleanOperation::Union, unchecked);
  if (attach) {
    TriMesh drills;
    for (std::size_t h = 0; h < pb.holes.size(); ++h)
      add_drill(drills, f, pb.holes[h], pb.hole_radius, z_face - 1 * kMm, pb.hole_top[h], 0.5 * kPi / kHoleSides + phase);
    if (geometry::signed_volume(drills) < 0) geometry::flip_orientation(drills);  // as the block
    a.solid = geometry::mesh_boolean(a.solid, drills, geometry::BooleanOperation::Difference, unchecked);
  }
  SocketPlatform& r = pb.report;
  r.is_built = true;
  r.centre = f.at(0, 0, z_face);
  r.normal = -f.up;
  r.anterior = f.anterior;
  r.medial = f.medial;
  r.diameter_m = 2 * R;
  r.max_height_m = tallest;
  if (attach) {
    r.hole_diameter_m = o.attachment.hole_diameter_m;
    r.min_hole_depth_m = std::numeric_limits<double>::infinity();
    for (std::size_t h = 0; h < pb.holes.size(); ++h) {
      r.hole_centres.push_back(f.at(pb.holes[h].x(), pb.holes[h].y(), z_face));
      const auto zi = up_hit(inner_q, pb.holes[h].x(), pb.holes[h].y());
      r.min_hole_depth_m = std::min(r.min_hole_depth_m, *zi - z_face);
    }
    const double reach = pb.holes.front().norm() + pb.hole_radius;
    r.smallest_feature_m = std::min({o.attachment.hole_diameter_m, o.attachment.hole_spacing_m - 2 * pb.hole_radius,
                                     R - reach});
  }
  return pb;
}

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

double perimeter_at(const TriMesh& m, const geometry::LimbFrame& frame, double h) {
  return geometry::slice_surface(m, frame.on_axis(h), frame.axis).perimeter;
}

}  // namespace

double clearance_hole_diameter_m(const std::string& bolt) {
  if (bolt == "M4") return 4.5 * kMm;
  if (bolt == "M5") return 5.5 * kMm;
  if (bolt == "M6") return 6.6 * kMm;
  if (bolt == "M8") return 9.0 * kMm;
  fail("socket attachment: bolt '{}' is not known (M4, M5, M6 or M8; or give hole_diameter_mm)", bolt);
}

double bolt_diameter_m(const std::string& bolt) {
  (void)clearance_hole_diameter_m(bolt);
  return std::stod(bolt.substr(1)) * kMm;
}

double asked_thickness_m(const SocketOptions& o, double h_m, double brim_h_m) {
  const double distal = o.distal_thickness_m > 0 ? o.distal_thickness_m : o.thickness_m;
  const double at_brim = o.brim_thickness_m > 0 ? o.brim_thickness_m : o.thickness_m;
  if (distal == at_brim || !(brim_h_m > 0)) return distal;
  const double s = std::clamp(h_m / brim_h_m, 0.0, 1.0);
  return distal + s * (at_brim - distal);
}

namespace {
SocketResult build_socket_once(const TriMesh& inner_in, const geometry::LimbFrame& frame, const BrimLine& brim,
                               const SocketOptions& options);
}  // namespace

SocketResult build_socket(const TriMesh& inner_in, const geometry::LimbFrame& frame, const BrimLine& brim,
                          const SocketOptions& options) {
  // A coarse stump surface (a few thousand nodes) can leave an offset that self-intersects however
  // smooth the normals: refine the surface once more (midpoint subdivision) and try again, up to
  // two subdivisions.
  SocketOptions o = options;
  for (;;) {
    try {
      SocketResult r = build_socket_once(inner_in, frame, brim, o);
      if (o.subdivisions != options.subdivisions)
        r.notes.push_back(fmt::format("the stump surface was subdivided {} time(s) so that the offset does not "
                                      "self-intersect",
                                      o.subdivisions));
      return r;
    } catch (const TopologyError& e) {
      if (o.subdivisions >= std::max(2, options.subdivisions) || o.subdivisions > options.subdivisions ||
          std::string(e.what()).find("self-intersects") == std::string::npos)
        throw;
      ++o.subdivisions;
    }
  }
}

namespace {
SocketResult build_socket_once(const TriMesh& inner_in, const geometry::LimbFrame& frame, const BrimLine& brim,
                               const SocketOptions& options) {
  check_options(options);
  require(!brim.spline().empty(), "build_socket: the brim has no key points (pick a template or give key points)");
  require(!inner_in.empty(), "build_socket: the stump surface has no triangles (expected the deformed skin)");
  const geometry::MeshCheckReport rep = geometry::check_mesh(inner_in);
  require(rep.non_finite_vertices == 0, "build_socket: the stump surface has {} vertices with NaN/inf coordinates",
          rep.non_finite_vertices);
  require(rep.out_of_range_indices == 0, "build_socket: the stump surface has {} vertex indices out of range",
          rep.out_of_range_indices);
  require<TopologyError>(rep.is_manifold(),
                         "build_socket: the stump surface has {} non-manifold edges; repair it (socketsmith check mesh)",
                         rep.non_manifold_edges);
  require<TopologyError>(rep.is_oriented(),
                         "build_socket: the stump surface has {} inconsistently oriented edges; repair it",
                         rep.inconsistently_oriented_edges);

  double top = -std::numeric_limits<double>::infinity(), bottom = std::numeric_limits<double>::infinity();
  for (const auto& v : inner_in.vertices) {
    const double h = frame.to_cylindrical(v).h;
    top = std::max(top, h);
    bottom = std::min(bottom, h);
  }
  const double brim_top = brim.max_height(), brim_low = brim.min_height();
  require(brim_top < top - 1e-4,
          "build_socket: the brim reaches h = {:.1f} mm, above the top of the stump surface ({:.1f} mm); "
          "lower its key points below the cut",
          brim_top / kMm, top / kMm);
  require(brim_low > bottom, "build_socket: the brim dips to h = {:.1f} mm, below the distal end ({:.1f} mm); raise it",
          brim_low / kMm, bottom / kMm);

  TriMesh inner = inner_in;
  for (int k = 0; k < options.subdivisions; ++k) inner = subdivide(inner);

  const bool has_platform = options.distal_pad || options.attachment.enabled;
  SocketResult r;
  const int base_passes = options.normal_smoothing_iterations;
  const std::array<int, 3> passes = {base_passes, std::max(4, 4 * base_passes), std::max(16, 16 * base_passes)};
  std::string last_problem;
  for (int attempt = 0; attempt < 3; ++attempt) {
    CutSurface cut = cut_below_brim(inner, smoothed_normals(inner, passes[attempt]), frame, brim);
    require(cut.mesh.num_triangles() > 0, "build_socket: nothing of the stump surface lies below the brim; raise it");
    const int dropped = keep_largest_component(cut);
    // Every boundary edge of the kept wall must lie on the brim (else the surface has a hole below it).
    const auto rim = boundary_edges(cut.mesh);
    for (const auto& e : rim)
      require<TopologyError>(cut.on_rim[e[0]] && cut.on_rim[e[1]],
                             "build_socket: the stump surface is open below the brim (a hole or boundary at h = "
                             "{:.1f} mm); close it (a closed skin) or lower the brim below its open edge",
                             frame.to_cylindrical(cut.mesh.vertices[e[0]]).h / kMm);
    require<TopologyError>(!rim.empty(), "build_socket: the brim does not cut the stump surface; check the frame and the brim heights");

    // Cavity volume with a fan to the rim centroid (the fan's tetrahedra have zero volume).
    Vec3 c = Vec3::Zero();
    int nrim = 0;
    for (int i = 0; i < cut.mesh.num_vertices(); ++i)
      if (cut.on_rim[i]) {
        c += cut.mesh.vertices[i];
        ++nrim;
      }
    c /= std::max(nrim, 1);
    double cavity = 0.0;
    for (const auto& t : cut.mesh.triangles)
      cavity += (cut.mesh.vertices[t[0]] - c).dot((cut.mesh.vertices[t[1]] - c).cross(cut.mesh.vertices[t[2]] - c)) / 6.0;
    require(cavity > 0.0,
            "build_socket: the stump surface is inside-out (cavity volume {:.3g} m^3); flip its triangles", cavity);

    const geometry::SurfaceQuery inner_q(cut.mesh);
    const std::vector<double> asked = asked_per_vertex(cut, frame, brim, options);
    std::vector<double> offset = asked;
    const int thickness_passes = correct_offsets(cut, inner_q, asked, offset);
    Attempt a = assemble(cut, frame, options, offset);
    auto validity = [&](const TriMesh& solid, const char* stage) -> std::string {
      const geometry::MeshCheckReport sr = geometry::check_mesh(solid);
      if (!sr.is_valid_closed_surface()) {
        const auto problems = sr.problems();
        fail<TopologyError>("build_socket: internal: the socket solid ({}) is not a valid closed surface ({}); please "
                            "report",
                            stage, problems.empty() ? std::string("?") : problems.front());
      }
      const double vol = geometry::signed_volume(solid);
      if (vol <= 0.0) return fmt::format("its volume is {:.3g} m^3", vol);
      if (geometry::has_self_intersections(solid)) return "it self-intersects";
      return {};
    };
    last_problem = validity(a.solid, "shell");
    if (!last_problem.empty()) {
      r.notes.push_back(fmt::format("offset with {} normal-smoothing passes failed ({}); retrying with more smoothing",
                                    passes[attempt], last_problem));
      continue;
    }
    // The lip before any Boolean: the face classification and the brim band refer to it.
    TriMesh lip_mesh;
    lip_mesh.vertices = a.solid.vertices;
    lip_mesh.triangles.assign(a.solid.triangles.begin() + a.inner + a.outer, a.solid.triangles.end());
    const geometry::SurfaceQuery lip_q(lip_mesh);
    if (has_platform) {
      // The Booleans' result is exact; rounded to double, two intersection points a few nm apart
      // can merge (a degenerate triangle) when the block's grid lines up with the wall's vertices
      // (generated limbs are symmetric about planes through the axis). The block and the drills
      // are then turned by a fraction of a sector and joined again.
      const TriMesh shell = a.solid;
      PlatformBuild pb;
      std::string problem;
      for (const double phase : {0.0137, 0.0291, 0.0457, 0.0611}) {
        a.solid = shell;
        try {
          pb = add_platform(a, cut, offset, frame, options, phase);
        } catch (const TopologyError& e) {
          problem = e.what();
          continue;
        }
        const geometry::MeshCheckReport sr = geometry::check_mesh(a.solid);
        if (!sr.is_valid_closed_surface()) {
          const auto p = sr.problems();
          problem = p.empty() ? std::string("?") : p.front();
          continue;
        }
        problem = validity(a.solid, "with its distal platform");
        if (problem.empty()) break;
      }
      require<TopologyError>(problem.empty(),
                             "build_socket: the socket with its distal platform fails the final check ({}); change the "
                             "platform diameter or the alignment slightly",
                             problem);
      a.kind = classify_faces(a.solid, shell, a.kind, inner_q, lip_q, pb);
      r.platform = pb.report;
      if (options.attachment.enabled)
        r.platform.smallest_feature_m = std::min(r.platform.smallest_feature_m, r.platform.min_hole_depth_m);
    }
    if (dropped > 0)
      r.notes.push_back(fmt::format("dropped {} triangles of islands below the brim not connected to the socket", dropped));
    if (attempt > 0)
      r.notes.push_back(fmt::format("the offset needed {} normal-smoothing passes (concave skin with a radius below "
                                    "the {:.1f} mm wall)",
                                    passes[attempt], options.thickness_m / kMm));
    r.normal_smoothing_used = passes[attempt];
    r.thickness_passes = thickness_passes;
    r.inner_triangles = a.inner;
    r.outer_triangles = a.outer;
    r.lip_triangles = a.lip;
    r.shell_volume_m3 = geometry::signed_volume(a.solid);
    r.cavity_volume_m3 = cavity;
    // Rim heights and their error against the curve.
    r.rim_min_h_m = std::numeric_limits<double>::infinity();
    r.rim_max_h_m = -std::numeric_limits<double>::infinity();
    for (int i = 0; i < cut.mesh.num_vertices(); ++i) {
      if (!cut.on_rim[i]) continue;
      const geometry::Cylindrical q = frame.to_cylindrical(cut.mesh.vertices[i]);
      r.rim_min_h_m = std::min(r.rim_min_h_m, q.h);
      r.rim_max_h_m = std::max(r.rim_max_h_m, q.h);
      r.max_rim_error_m = std::max(r.max_rim_error_m, std::abs(q.h - brim.height(q.theta)));
    }
    r.solid = std::move(a.solid);
    r.face_kind = std::move(a.kind);
    measure_thickness(r, inner_q, &lip_q, frame, brim, options);
    // Circumferences of full rings below the brim.
    for (double h = options.level_step_m; h < r.rim_min_h_m - 1e-6; h += options.level_step_m) {
      if (h <= bottom) continue;
      SocketLevel l;
      l.h_m = h;
      l.inner_circumference_m = perimeter_at(cut.mesh, frame, h);
      l.limb_circumference_m = std::numeric_limits<double>::quiet_NaN();
      l.reduction_percent = std::numeric_limits<double>::quiet_NaN();
      if (options.undeformed_skin) {
        l.limb_circumference_m = perimeter_at(*options.undeformed_skin, frame, h);
        if (l.limb_circumference_m > 0)
          l.reduction_percent = 100.0 * (1.0 - l.inner_circumference_m / l.limb_circumference_m);
      }
      r.levels.push_back(l);
    }
    return r;
  }
  fail<TopologyError>("build_socket: the {:.1f} mm offset of the stump surface still fails after {} normal-smoothing "
                      "passes ({}); use a thinner wall or smooth the stump surface",
                      options.thickness_m / kMm, passes.back(), last_problem);
}
}  // namespace

void write_socket_stl(const std::filesystem::path& path, const SocketResult& result) {
  require(!result.solid.empty(), "write_socket_stl: the socket has no triangles (build it first) for '{}'",
          path.string());
  geometry::write_mesh(path, result.solid, units::LengthUnit::Millimetre, geometry::MeshFormat::StlBinary);
}

}  // namespace socketsmith::design
