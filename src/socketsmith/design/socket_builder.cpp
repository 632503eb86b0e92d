#include "socketsmith/design/socket_builder.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <limits>
#include <numbers>
#include <numeric>
#include <unordered_map>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/geometry/surface_query.h"

namespace socketsmith::design {
namespace {

using geometry::TriMesh;
using geometry::Vec3;
constexpr double kMm = units::mm;

std::uint64_t edge_key(int a, int b) {
  const auto lo = static_cast<std::uint64_t>(std::min(a, b)), hi = static_cast<std::uint64_t>(std::max(a, b));
  return (lo << 32) | hi;
}

void check_options(const SocketOptions& o) {
  require(std::isfinite(o.thickness_m) && o.thickness_m > 0.0 && o.thickness_m <= 0.05,
          "build_socket: thickness_m = {} m is out of range (expected a wall of (0, 50] mm, e.g. 0.005)",
          o.thickness_m);
  require(!o.round_brim || (o.lip_segments >= 2 && o.lip_segments <= 32),
          "build_socket: lip_segments = {} is out of range [2, 32]", o.lip_segments);
  require(!o.distal_pad || (std::isfinite(o.distal_pad_diameter_m) && o.distal_pad_diameter_m > 0.0 &&
                            o.distal_pad_diameter_m <= 0.15),
          "build_socket: distal_pad_diameter_m = {} m is out of range (0, 0.15]", o.distal_pad_diameter_m);
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

bool self_intersects(const TriMesh& m) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  using SM = CGAL::Surface_mesh<K::Point_3>;
  SM sm;
  std::vector<SM::Vertex_index> v;
  v.reserve(m.vertices.size());
  for (const auto& p : m.vertices) v.push_back(sm.add_vertex(K::Point_3(p.x(), p.y(), p.z())));
  for (const auto& t : m.triangles)
    if (sm.add_face(v[t[0]], v[t[1]], v[t[2]]) == SM::null_face())
      fail<TopologyError>("build_socket: internal: the socket solid is not a manifold surface (CGAL rejected a face)");
  return CGAL::Polygon_mesh_processing::does_self_intersect(sm);
}

struct Attempt {
  TriMesh solid;
  int inner = 0, outer = 0, lip = 0;
  int outer_offset = 0;         // first outer-wall vertex in solid
  std::vector<char> pad;        // per kept vertex: outer copy moved onto the pad plane
  double pad_plane_h = 0.0;
  bool pad_lowered = false;     // the plane was capped below the cavity's lowest point
};

Attempt assemble(const CutSurface& cut, const geometry::LimbFrame& frame, const SocketOptions& o) {
  const int nv = cut.mesh.num_vertices();
  const double t = o.thickness_m;
  Attempt a;
  a.pad.assign(nv, 0);
  TriMesh& s = a.solid;
  // Inner wall: reversed (the solid's outside faces the limb there).
  s.vertices = cut.mesh.vertices;
  for (const auto& tri : cut.mesh.triangles) s.triangles.push_back({tri[0], tri[2], tri[1]});
  a.inner = cut.mesh.num_triangles();
  // Outer wall.
  a.outer_offset = nv;
  for (int i = 0; i < nv; ++i) s.vertices.push_back(cut.mesh.vertices[i] + t * cut.normal[i]);
  if (o.distal_pad) {
    std::vector<int> order(nv);
    std::iota(order.begin(), order.end(), 0);
    auto h_of = [&](int i) { return frame.to_cylindrical(s.vertices[nv + i]).h; };
    std::vector<double> h(nv);
    for (int i = 0; i < nv; ++i) h[i] = h_of(i);
    std::sort(order.begin(), order.end(), [&](int x, int y) { return h[x] < h[y]; });
    // Lowest plane whose cap (outer vertices below it) reaches the requested radius.
    double plane = h[order.front()];
    for (int i : order) {
      if (cut.on_rim[i]) break;
      plane = h[i];
      if (frame.to_cylindrical(s.vertices[nv + i]).rho >= 0.5 * o.distal_pad_diameter_m) break;
    }
    // Never above the cavity: on a pointed distal end the cap reaches the pad's radius only above
    // the inner wall's lowest point, and a plane there would cut through the inner wall. Keep it
    // half a wall below the lowest inner vertex (the pad is then narrower than asked).
    double lowest_inner = std::numeric_limits<double>::infinity();
    for (int i = 0; i < nv; ++i) lowest_inner = std::min(lowest_inner, frame.to_cylindrical(cut.mesh.vertices[i]).h);
    if (plane > lowest_inner - 0.5 * t) {
      plane = lowest_inner - 0.5 * t;
      a.pad_lowered = true;
    }
    a.pad_plane_h = plane;
    for (int i : order) {
      if (h[i] >= plane) break;
      s.vertices[nv + i] += (plane - h[i]) * frame.axis;
      a.pad[i] = 1;
    }
  }
  for (const auto& tri : cut.mesh.triangles) s.triangles.push_back({tri[0] + nv, tri[1] + nv, tri[2] + nv});
  a.outer = cut.mesh.num_triangles();
  // Lip: rings of vertices per rim vertex, from the inner (ring 0) to the outer rim (ring K).
  const int K = o.round_brim ? o.lip_segments : 1;
  std::unordered_map<int, int> ring_base;  // rim vertex -> index of its ring 1 vertex
  for (int i = 0; i < nv; ++i) {
    if (!cut.on_rim[i]) continue;
    ring_base[i] = s.num_vertices();
    const Vec3 n = cut.normal[i];
    Vec3 up = frame.axis - frame.axis.dot(n) * n;
    up = up.norm() > 1e-9 ? Vec3(up.normalized()) : frame.axis;
    const Vec3 centre = cut.mesh.vertices[i] + 0.5 * t * n;
    for (int k = 1; k < K; ++k) {
      const double phi = std::numbers::pi * k / K;
      s.vertices.push_back(centre - 0.5 * t * std::cos(phi) * n + 0.5 * t * std::sin(phi) * up);
    }
  }
  auto ring = [&](int v, int k) { return k == 0 ? v : k == K ? v + nv : ring_base.at(v) + k - 1; };
  for (const auto& e : boundary_edges(cut.mesh)) {
    for (int k = 0; k < K; ++k) {
      const int a0 = ring(e[0], k), b0 = ring(e[1], k), a1 = ring(e[0], k + 1), b1 = ring(e[1], k + 1);
      s.triangles.push_back({a0, b0, b1});
      s.triangles.push_back({a0, b1, a1});
      a.lip += 2;
    }
  }
  return a;
}

double perimeter_at(const TriMesh& m, const geometry::LimbFrame& frame, double h) {
  return geometry::slice_surface(m, frame.on_axis(h), frame.axis).perimeter;
}

}  // namespace

namespace {
SocketResult build_socket_once(const TriMesh& inner_in, const geometry::LimbFrame& frame, const BrimLine& brim,
                               const SocketOptions& options);
}  // namespace

SocketResult build_socket(const TriMesh& inner_in, const geometry::LimbFrame& frame, const BrimLine& brim,
                          const SocketOptions& options) {
  // A coarse stump surface (a few thousand nodes) with a distal pad can leave an offset that
  // self-intersects however smooth the normals: refine the surface (midpoint subdivision) and
  // try again, at most to two subdivisions.
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
      if (o.subdivisions >= 2 || std::string(e.what()).find("self-intersects") == std::string::npos) throw;
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

    Attempt a = assemble(cut, frame, options);
    const geometry::MeshCheckReport sr = geometry::check_mesh(a.solid);
    if (!sr.is_valid_closed_surface()) {
      const auto problems = sr.problems();
      fail<TopologyError>("build_socket: internal: the socket solid is not a valid closed surface ({}); please report",
                          problems.empty() ? std::string("?") : problems.front());
    }
    const double vol = geometry::signed_volume(a.solid);
    const bool bad = vol <= 0.0 || self_intersects(a.solid);
    if (bad) {
      last_problem = vol <= 0.0 ? fmt::format("its volume is {:.3g} m^3", vol) : "it self-intersects";
      r.notes.push_back(fmt::format("offset with {} normal-smoothing passes failed ({}); retrying with more smoothing",
                                    passes[attempt], last_problem));
      continue;
    }
    if (dropped > 0)
      r.notes.push_back(fmt::format("dropped {} triangles of islands below the brim not connected to the socket", dropped));
    if (a.pad_lowered)
      r.notes.push_back(fmt::format("the distal pad's plane was kept half a wall below the cavity's lowest point (a "
                                    "pointed distal end), so the pad is narrower than {:.0f} mm",
                                    options.distal_pad_diameter_m / kMm));
    if (attempt > 0)
      r.notes.push_back(fmt::format("the offset needed {} normal-smoothing passes (concave skin with a radius below "
                                    "the {:.1f} mm wall); the wall is thinner there, see min_thickness_m",
                                    passes[attempt], options.thickness_m / kMm));
    r.normal_smoothing_used = passes[attempt];
    r.inner_triangles = a.inner;
    r.outer_triangles = a.outer;
    r.lip_triangles = a.lip;
    r.shell_volume_m3 = vol;
    r.cavity_volume_m3 = cavity;
    r.pad_plane_h_m = options.distal_pad ? a.pad_plane_h : 0.0;
    r.pad_vertices = static_cast<int>(std::count(a.pad.begin(), a.pad.end(), 1));
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
    // Wall thickness: distance of every outer-wall vertex (not on the pad) to the inner wall.
    const geometry::SurfaceQuery inner_query(cut.mesh);
    double sum = 0.0;
    int count = 0;
    r.min_thickness_m = std::numeric_limits<double>::infinity();
    r.max_thickness_m = 0.0;
    for (int i = 0; i < cut.mesh.num_vertices(); ++i) {
      if (a.pad[i]) continue;
      const double d = inner_query.closest_point(a.solid.vertices[a.outer_offset + i]).distance;
      r.min_thickness_m = std::min(r.min_thickness_m, d);
      r.max_thickness_m = std::max(r.max_thickness_m, d);
      sum += d;
      ++count;
    }
    r.mean_thickness_m = count > 0 ? sum / count : 0.0;
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
    r.solid = std::move(a.solid);
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
