#include "socketsmith/geometry/mesh_repair.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <unordered_map>
#include <utility>

#include <fmt/format.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_checks.h"

namespace socketsmith::geometry {
namespace {

using Tri = std::array<int, 3>;
using Vec2 = Eigen::Vector2d;

/// Vertices closer than this to the cutting plane count as on it (kept, and used as cut points
/// themselves instead of creating sliver triangles) [m].
constexpr double kOnPlane_m = 1e-9;

/// Markers of edge_neighbours for edges without exactly one neighbour.
constexpr int kBoundary = -1;
constexpr int kNonManifold = -2;

std::uint64_t edge_key(int a, int b) {
  const auto [lo, hi] = std::minmax(a, b);
  return (static_cast<std::uint64_t>(lo) << 32) | static_cast<std::uint64_t>(hi);
}

/// across[t][k]: the triangle on the other side of edge (tri[k], tri[k+1]) of triangle t when
/// exactly two triangles use that edge; kBoundary when only t does; kNonManifold when more do.
std::vector<Tri> edge_neighbours(const std::vector<Tri>& tris) {
  struct HalfEdge {
    std::uint64_t key;
    int tri;
    int k;
  };
  std::vector<HalfEdge> half;
  half.reserve(3 * tris.size());
  for (int t = 0; t < static_cast<int>(tris.size()); ++t)
    for (int k = 0; k < 3; ++k) half.push_back({edge_key(tris[t][k], tris[t][(k + 1) % 3]), t, k});
  std::sort(half.begin(), half.end(), [](const HalfEdge& a, const HalfEdge& b) { return a.key < b.key; });

  std::vector<Tri> across(tris.size());
  for (std::size_t i = 0; i < half.size();) {
    std::size_t j = i + 1;
    while (j < half.size() && half[j].key == half[i].key) ++j;
    if (j - i == 2) {
      across[half[i].tri][half[i].k] = half[i + 1].tri;
      across[half[i + 1].tri][half[i + 1].k] = half[i].tri;
    } else {
      for (std::size_t e = i; e < j; ++e) across[half[e].tri][half[e].k] = j - i == 1 ? kBoundary : kNonManifold;
    }
    i = j;
  }
  return across;
}

/// True when triangle @p u traverses the edge a → b in the same direction as @p a → @p b (the
/// two triangles sharing it then disagree on orientation).
bool traverses(const Tri& u, int a, int b) {
  for (int k = 0; k < 3; ++k)
    if (u[k] == a && u[(k + 1) % 3] == b) return true;
  return false;
}

void flip(Tri& t) { std::swap(t[1], t[2]); }

/// Edge-connected components over manifold edges (two triangles per edge), in order of their
/// first triangle. Triangles joined only through non-manifold edges are separate components.
std::vector<std::vector<int>> manifold_components(const std::vector<Tri>& across) {
  const int nt = static_cast<int>(across.size());
  std::vector<char> seen(static_cast<std::size_t>(nt), 0);
  std::vector<std::vector<int>> components;
  for (int seed = 0; seed < nt; ++seed) {
    if (seen[seed]) continue;
    std::vector<int> comp{seed};
    seen[seed] = 1;
    for (std::size_t i = 0; i < comp.size(); ++i)  // breadth-first: comp doubles as the queue
      for (const int u : across[comp[i]])
        if (u >= 0 && !seen[u]) {
          seen[u] = 1;
          comp.push_back(u);
        }
    components.push_back(std::move(comp));
  }
  return components;
}

/// Chains directed edges (from → to) into closed loops of distinct vertices, each loop listing
/// its vertices in edge order. Where several loops pass through one vertex (a pinch), the walk
/// splits them there. Edges that do not close a loop are dropped.
/// @param num_vertices all vertex indices in @p edges are below this.
std::vector<std::vector<int>> chain_loops(const std::vector<std::pair<int, int>>& edges, int num_vertices) {
  // Outgoing edges of each vertex (counting sort by source).
  std::vector<int> first(static_cast<std::size_t>(num_vertices) + 1, 0);
  for (const auto& e : edges) ++first[e.first + 1];
  for (int v = 0; v < num_vertices; ++v) first[v + 1] += first[v];
  std::vector<int> target(edges.size());
  {
    std::vector<int> cursor(first.begin(), first.end() - 1);
    for (const auto& e : edges) target[cursor[e.first]++] = e.second;
  }
  std::vector<int> next_unused(first.begin(), first.end() - 1);  // per vertex: next edge not walked yet
  auto take_edge = [&](int v) { return next_unused[v] < first[v + 1] ? target[next_unused[v]++] : -1; };

  std::vector<std::vector<int>> loops;
  std::vector<int> position(static_cast<std::size_t>(num_vertices), -1);  // index in path, or -1
  std::vector<int> path;
  for (int start = 0; start < num_vertices; ++start) {
    while (next_unused[start] < first[start + 1]) {
      path.assign(1, start);
      position[start] = 0;
      for (int w = take_edge(start); w >= 0; w = take_edge(path.back())) {
        if (position[w] < 0) {
          position[w] = static_cast<int>(path.size());
          path.push_back(w);
          continue;
        }
        // Back at a vertex of the path: the walk since then is a loop.
        const auto begin = path.begin() + position[w];
        loops.emplace_back(begin, path.end());
        for (auto it = begin + 1; it != path.end(); ++it) position[*it] = -1;
        path.erase(begin + 1, path.end());
      }
      // Whatever is left of the path (beyond the start) is an open chain: dropped.
      for (const int v : path) position[v] = -1;
    }
  }
  return loops;
}

/// Twice the signed area of the 2D triangle (a, b, c): positive when counter-clockwise.
double orient2d(const Vec2& a, const Vec2& b, const Vec2& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

/// Twice the signed area of a 2D polygon (shoelace): positive when counter-clockwise.
double signed_area2(const std::vector<Vec2>& poly) {
  double a = 0.0;
  for (std::size_t i = 0, n = poly.size(); i < n; ++i) {
    const Vec2& p = poly[i];
    const Vec2& q = poly[(i + 1) % n];
    a += p.x() * q.y() - p.y() * q.x();
  }
  return a;
}

/// Triangulates a simple counter-clockwise 2D polygon by ear clipping, always cutting the
/// best-shaped ear (largest area / sum of squared edge lengths) so caps have few slivers.
/// Collinear vertices are never ear tips, and a vertex on an ear's boundary blocks it, so no
/// zero-area triangle is made from a simple polygon. Returns counter-clockwise index triples
/// into @p poly. O(n²); a polygon that is not simple (e.g. a non-planar hole projected onto a
/// plane) still yields n − 2 triangles, by cutting the most convex corner when no ear is left.
std::vector<Tri> ear_clip(const std::vector<Vec2>& poly) {
  const int n = static_cast<int>(poly.size());
  std::vector<Tri> out;
  if (n < 3) return out;
  out.reserve(static_cast<std::size_t>(n - 2));
  std::vector<int> prev(static_cast<std::size_t>(n)), next(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    prev[i] = (i + n - 1) % n;
    next[i] = (i + 1) % n;
  }
  std::vector<double> turn(static_cast<std::size_t>(n));     // orient2d at the corner: > 0 convex
  std::vector<double> quality(static_cast<std::size_t>(n));  // ear quality, < 0 when not an ear
  auto update_turn = [&](int i) { turn[i] = orient2d(poly[prev[i]], poly[i], poly[next[i]]); };
  auto update_ear = [&](int i) {
    quality[i] = -1.0;
    if (turn[i] <= 0.0) return;
    const Vec2 &a = poly[prev[i]], &b = poly[i], &c = poly[next[i]];
    // Only non-convex corners can lie in an ear of a simple polygon; points on its edges count.
    for (int j = next[next[i]]; j != prev[i]; j = next[j]) {
      if (turn[j] > 0.0) continue;
      const Vec2& p = poly[j];
      if (p == a || p == b || p == c) continue;  // a repeated point is no obstacle
      if (orient2d(a, b, p) >= 0.0 && orient2d(b, c, p) >= 0.0 && orient2d(c, a, p) >= 0.0) return;
    }
    const double edges2 = (b - a).squaredNorm() + (c - b).squaredNorm() + (a - c).squaredNorm();
    quality[i] = turn[i] / edges2;
  };
  for (int i = 0; i < n; ++i) update_turn(i);
  for (int i = 0; i < n; ++i) update_ear(i);

  int head = 0;
  for (int remaining = n; remaining > 3; --remaining) {
    // Clipping an ear only makes its neighbours more convex, so cached ears stay ears; a corner
    // whose ear status was blocked by a neighbour that turned convex is caught by the rescan.
    auto best_ear = [&] {
      int best = -1;
      int i = head;
      do {
        if (quality[i] >= 0.0 && (best < 0 || quality[i] > quality[best])) best = i;
        i = next[i];
      } while (i != head);
      return best;
    };
    int ear = best_ear();
    if (ear < 0) {
      int i = head;
      do {
        update_ear(i);
        i = next[i];
      } while (i != head);
      ear = best_ear();
    }
    if (ear < 0) {  // not a simple polygon: cut the most convex corner
      ear = head;
      for (int i = next[head]; i != head; i = next[i])
        if (turn[i] > turn[ear]) ear = i;
    }
    const int p = prev[ear], q = next[ear];
    out.push_back({p, ear, q});
    next[p] = q;
    prev[q] = p;
    head = q;
    update_turn(p);
    update_turn(q);
    update_ear(p);
    update_ear(q);
  }
  out.push_back({prev[head], head, next[head]});
  return out;
}

/// Unit vectors (u, v) spanning the plane normal to unit @p n, with u × v = n.
std::pair<Vec3, Vec3> plane_basis(const Vec3& n) {
  int smallest = 0;
  n.cwiseAbs().minCoeff(&smallest);
  const Vec3 u = Vec3::Unit(smallest).cross(n).normalized();
  return {u, n.cross(u)};
}

/// Triangulates the 3D vertex loop @p loop (indices into @p vertices) in the plane normal to
/// @p normal. Triangles follow the loop's order: each traverses its loop edges in loop order.
std::vector<Tri> triangulate_loop(const std::vector<Vec3>& vertices, const std::vector<int>& loop,
                                  const Vec3& normal) {
  const auto [u, v] = plane_basis(normal);
  const Vec3& origin = vertices[loop.front()];  // local coordinates keep the 2D tests accurate
  std::vector<Vec2> poly;
  poly.reserve(loop.size());
  for (const int i : loop) poly.emplace_back(u.dot(vertices[i] - origin), v.dot(vertices[i] - origin));
  // Clockwise in this basis: triangulate the mirror image, which is counter-clockwise. Ear
  // clipping emits each triangle as (previous, tip, next) in polygon order, so the triangles
  // follow the loop's order either way.
  if (signed_area2(poly) < 0.0)
    for (Vec2& p : poly) p.y() = -p.y();
  std::vector<Tri> tris = ear_clip(poly);
  for (Tri& t : tris)
    for (int& i : t) i = loop[i];
  return tris;
}

/// Six times the signed volume enclosed by the listed triangles (relative to their first vertex,
/// for accuracy far from the origin).
double six_volume(const std::vector<Vec3>& vertices, const std::vector<Tri>& tris, const std::vector<int>& which) {
  const Vec3 o = vertices[tris[which.front()][0]];
  double sum = 0.0;
  for (const int t : which) {
    const Vec3 a = vertices[tris[t][0]] - o, b = vertices[tris[t][1]] - o, c = vertices[tris[t][2]] - o;
    sum += a.dot(b.cross(c));
  }
  return sum;
}

/// Throws InvalidInputError unless every vertex is finite and every index in range.
void require_valid(const TriMesh& mesh, const char* function) {
  const int nv = mesh.num_vertices();
  for (int v = 0; v < nv; ++v)
    require(mesh.vertices[v].allFinite(), "{}: vertex {} has NaN or infinite coordinates (fix the mesh first)",
            function, v);
  for (int t = 0; t < mesh.num_triangles(); ++t)
    for (const int v : mesh.triangles[t])
      require(v >= 0 && v < nv, "{}: triangle {} refers to vertex {} but the mesh has {} vertices (valid: 0..{})",
              function, t, v, nv, nv - 1);
}

std::string count_of(int n, const char* one, const char* many) { return fmt::format("{} {}", n, n == 1 ? one : many); }

/// Removes triangles with a repeated vertex or an area below @p min_area_m2, then repeated
/// triangles (same three vertices in any order; the first is kept).
void remove_degenerate_and_duplicates(const std::vector<Vec3>& vertices, std::vector<Tri>& tris,
                                      double min_area_m2, RepairReport& report) {
  std::vector<Tri> kept;
  kept.reserve(tris.size());
  for (const Tri& t : tris) {
    const bool repeated = t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
    const Vec3 &a = vertices[t[0]], &b = vertices[t[1]], &c = vertices[t[2]];
    if (repeated || 0.5 * (b - a).cross(c - a).norm() < min_area_m2) {
      ++report.removed_degenerate_triangles;
      continue;
    }
    kept.push_back(t);
  }
  std::vector<std::pair<Tri, int>> sorted(kept.size());
  for (int i = 0; i < static_cast<int>(kept.size()); ++i) {
    Tri key = kept[i];
    std::sort(key.begin(), key.end());
    sorted[i] = {key, i};
  }
  std::sort(sorted.begin(), sorted.end());
  std::vector<char> duplicate(kept.size(), 0);
  for (std::size_t i = 1; i < sorted.size(); ++i)
    if (sorted[i].first == sorted[i - 1].first) duplicate[sorted[i].second] = 1;
  tris.clear();
  for (std::size_t i = 0; i < kept.size(); ++i) {
    if (duplicate[i]) ++report.removed_duplicate_triangles;
    else tris.push_back(kept[i]);
  }
}

/// Orients each manifold-edge-connected component consistently by breadth-first propagation
/// across manifold edges, keeping the orientation most of its triangles already have. Returns
/// the number of triangles flipped.
int orient_components(std::vector<Tri>& tris) {
  const std::vector<Tri> across = edge_neighbours(tris);
  const int nt = static_cast<int>(tris.size());
  // Per triangle: −1 not reached yet, else 1 when it disagrees with its component's seed.
  std::vector<signed char> disagrees(static_cast<std::size_t>(nt), -1);
  std::vector<int> comp;
  int flipped = 0;
  for (int seed = 0; seed < nt; ++seed) {
    if (disagrees[seed] >= 0) continue;
    comp.assign(1, seed);
    disagrees[seed] = 0;
    int num_disagreeing = 0;
    for (std::size_t i = 0; i < comp.size(); ++i) {  // comp doubles as the queue
      const int t = comp[i];
      for (int k = 0; k < 3; ++k) {
        const int u = across[t][k];
        if (u < 0 || disagrees[u] >= 0) continue;
        // t's edge a → b, as t will be once it agrees with the seed; u agrees iff it runs b → a.
        int a = tris[t][k], b = tris[t][(k + 1) % 3];
        if (disagrees[t]) std::swap(a, b);
        disagrees[u] = traverses(tris[u], a, b) ? 1 : 0;
        num_disagreeing += disagrees[u];
        comp.push_back(u);
      }
    }
    // Flip the minority.
    const signed char flip_value = 2 * num_disagreeing > static_cast<int>(comp.size()) ? 0 : 1;
    for (const int t : comp) {
      if (disagrees[t] != flip_value) continue;
      flip(tris[t]);
      ++flipped;
    }
  }
  return flipped;
}

/// The boundary loops of @p tris, each in a closing patch's direction (reversed boundary edges).
std::vector<std::vector<int>> hole_loops(const std::vector<Tri>& tris, int num_vertices) {
  const std::vector<Tri> across = edge_neighbours(tris);
  std::vector<std::pair<int, int>> hole_edges;
  for (std::size_t t = 0; t < tris.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (across[t][k] == kBoundary) hole_edges.emplace_back(tris[t][(k + 1) % 3], tris[t][k]);
  return chain_loops(hole_edges, num_vertices);
}

/// Fills every boundary loop of at most @p max_edges edges with an ear-clipped patch in the
/// loop's best-fit plane, oriented like the triangles around it. Returns the loops filled.
int fill_small_holes(const std::vector<Vec3>& vertices, std::vector<Tri>& tris, int max_edges) {
  int filled = 0;
  for (const std::vector<int>& loop : hole_loops(tris, static_cast<int>(vertices.size()))) {
    if (static_cast<int>(loop.size()) > max_edges) continue;
    const Vec3 n = newell_normal(vertices, loop);
    if (!(n.norm() > 0.0)) continue;  // a flat, zero-area loop has no plane to fill in
    for (const Tri& t : triangulate_loop(vertices, loop, n.normalized())) tris.push_back(t);
    ++filled;
  }
  return filled;
}

/// Flips every closed component (all edges manifold) that encloses a negative volume. Returns
/// true when one was flipped.
bool flip_inside_out_components(const std::vector<Vec3>& vertices, std::vector<Tri>& tris) {
  const std::vector<Tri> across = edge_neighbours(tris);
  bool any = false;
  for (const std::vector<int>& comp : manifold_components(across)) {
    const bool closed = std::all_of(comp.begin(), comp.end(), [&](int t) {
      return across[t][0] >= 0 && across[t][1] >= 0 && across[t][2] >= 0;
    });
    if (!closed || six_volume(vertices, tris, comp) >= 0.0) continue;
    for (const int t : comp) flip(tris[t]);
    any = true;
  }
  return any;
}


/// The part of a mesh kept below a cutting plane, built triangle by triangle into @p out: the kept
/// vertices and one new vertex per crossing edge (shared by the edge's two triangles), each
/// flagged in on_plane when it lies on the plane.
struct HalfSpaceClip {
  const TriMesh& mesh;
  const std::vector<double>& height;     // [m] per input vertex, along the plane's normal
  const std::vector<signed char>& side;  // per input vertex: −1 below, 0 on, +1 above
  TriMesh& out;
  std::vector<char> on_plane;  // per output vertex
  std::vector<int> out_index;  // per input vertex: its output vertex, or −1
  std::unordered_map<std::uint64_t, int> crossing;

  HalfSpaceClip(const TriMesh& m, const std::vector<double>& h, const std::vector<signed char>& s, TriMesh& o)
      : mesh(m), height(h), side(s), out(o), out_index(m.vertices.size(), -1) {}

  int kept_vertex(int v) {
    if (out_index[v] < 0) {
      out_index[v] = static_cast<int>(out.vertices.size());
      out.vertices.push_back(mesh.vertices[v]);
      on_plane.push_back(side[v] == 0);
    }
    return out_index[v];
  }

  int crossing_vertex(int a, int b) {
    const auto [it, added] = crossing.try_emplace(edge_key(a, b), static_cast<int>(out.vertices.size()));
    if (added) {
      const auto [lo, hi] = std::minmax(a, b);
      const double s = height[lo] / (height[lo] - height[hi]);  // in (0, 1): opposite strict sides
      out.vertices.push_back(mesh.vertices[lo] + s * (mesh.vertices[hi] - mesh.vertices[lo]));
      on_plane.push_back(1);
    }
    return it->second;
  }

  /// Adds the kept part of triangle @p t: all of it, none, or its clipped polygon.
  void add(const Tri& t) {
    const int above = (side[t[0]] > 0) + (side[t[1]] > 0) + (side[t[2]] > 0);
    const int below = (side[t[0]] < 0) + (side[t[1]] < 0) + (side[t[2]] < 0);
    if (above == 0) {
      out.triangles.push_back({kept_vertex(t[0]), kept_vertex(t[1]), kept_vertex(t[2])});
      return;
    }
    if (below == 0) return;  // above, or touching the plane from above
    // Clip the triangle to the kept half-space (Sutherland–Hodgman): a convex polygon of 3 or 4
    // vertices. Vertices on the plane are their own cut points.
    std::array<int, 4> poly{};
    int m = 0;
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      if (side[a] <= 0) poly[m++] = kept_vertex(a);
      if (side[a] * side[b] < 0) poly[m++] = crossing_vertex(a, b);
    }
    if (m == 3) {
      out.triangles.push_back({poly[0], poly[1], poly[2]});
    } else {  // quad: split along the shorter diagonal
      const auto& x = out.vertices;
      if ((x[poly[0]] - x[poly[2]]).squaredNorm() <= (x[poly[1]] - x[poly[3]]).squaredNorm()) {
        out.triangles.push_back({poly[0], poly[1], poly[2]});
        out.triangles.push_back({poly[0], poly[2], poly[3]});
      } else {
        out.triangles.push_back({poly[1], poly[2], poly[3]});
        out.triangles.push_back({poly[1], poly[3], poly[0]});
      }
    }
  }
};

/// Caps the cut: the boundary edges of the kept part that lie in the plane, reversed (the cap
/// traverses them opposite to the kept triangles), chained into loops and each filled in the
/// plane of normal @p n; the loops go to result.loops.
void cap_cut(TrimResult& result, const std::vector<char>& on_plane, const Vec3& n) {
  std::vector<Vec3>& out_vertices = result.mesh.vertices;
  std::vector<Tri>& out_tris = result.mesh.triangles;
  const std::vector<Tri> across = edge_neighbours(out_tris);
  std::vector<std::pair<int, int>> cut_edges;
  for (std::size_t t = 0; t < out_tris.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const int a = out_tris[t][k], b = out_tris[t][(k + 1) % 3];
      if (across[t][k] == kBoundary && on_plane[a] && on_plane[b]) cut_edges.emplace_back(b, a);
    }
  }
  result.first_cap_triangle = static_cast<int>(out_tris.size());
  for (const std::vector<int>& loop : chain_loops(cut_edges, static_cast<int>(out_vertices.size()))) {
    for (const Tri& t : triangulate_loop(out_vertices, loop, n)) out_tris.push_back(t);
    std::vector<Vec3>& polyline = result.loops.emplace_back();
    polyline.reserve(loop.size());
    for (const int v : loop) polyline.push_back(out_vertices[v]);
  }
}

}  // namespace

std::vector<std::string> RepairReport::changes() const {
  std::vector<std::string> out;
  if (removed_degenerate_triangles > 0)
    out.push_back("removed " + count_of(removed_degenerate_triangles, "degenerate triangle", "degenerate triangles"));
  if (removed_duplicate_triangles > 0)
    out.push_back("removed " + count_of(removed_duplicate_triangles, "duplicate triangle", "duplicate triangles"));
  if (flipped_triangles > 0)
    out.push_back("re-oriented " + count_of(flipped_triangles, "triangle", "triangles") +
                  " to agree with their neighbours");
  if (filled_holes > 0) out.push_back("filled " + count_of(filled_holes, "small hole", "small holes"));
  if (flipped_inside_out) out.push_back("turned an inside-out surface (negative volume) outward");
  return out;
}

Vec3 newell_normal(const std::vector<Vec3>& vertices, const std::vector<int>& loop) {
  Vec3 centroid = Vec3::Zero();
  for (const int i : loop) centroid += vertices[i];
  centroid /= static_cast<double>(loop.size());
  Vec3 n = Vec3::Zero();
  for (std::size_t k = 0; k < loop.size(); ++k)
    n += (vertices[loop[k]] - centroid).cross(vertices[loop[(k + 1) % loop.size()]] - centroid);
  return n;
}

std::vector<std::vector<int>> open_boundary_loops(const TriMesh& mesh) {
  require_valid(mesh, "open_boundary_loops");
  return hole_loops(mesh.triangles, mesh.num_vertices());
}

RepairReport repair_surface(TriMesh& mesh, const RepairOptions& options) {
  require_valid(mesh, "repair_surface");
  require(options.max_hole_edges >= 0, "repair_surface: max_hole_edges is {} (expected >= 0)", options.max_hole_edges);
  require(options.degenerate_area_m2 >= 0.0, "repair_surface: degenerate_area_m2 is {} (expected >= 0)",
          options.degenerate_area_m2);
  RepairReport report;
  std::vector<Tri>& tris = mesh.triangles;
  remove_degenerate_and_duplicates(mesh.vertices, tris, options.degenerate_area_m2, report);
  report.flipped_triangles = orient_components(tris);
  report.filled_holes = fill_small_holes(mesh.vertices, tris, options.max_hole_edges);
  report.flipped_inside_out = flip_inside_out_components(mesh.vertices, tris);
  MeshCheckOptions check_options;
  check_options.degenerate_area_tol_m2 = options.degenerate_area_m2;
  report.remaining_boundary_loops = check_mesh(mesh, check_options).boundary_loops;
  return report;
}

TrimResult trim_and_cap(const TriMesh& mesh, const Vec3& point, const Vec3& normal) {
  require_valid(mesh, "trim_and_cap");
  require(!mesh.empty(), "trim_and_cap: the mesh has no triangles (expected a surface to trim)");
  require(point.allFinite() && normal.allFinite() && normal.norm() > 0.0,
          "trim_and_cap: plane point ({}, {}, {}) and normal ({}, {}, {}) must be finite and the normal non-zero",
          point.x(), point.y(), point.z(), normal.x(), normal.y(), normal.z());
  const Vec3 n = normal.normalized();

  // Side of each vertex: −1 strictly below (kept), 0 on the plane (kept), +1 above (cut away).
  const int nv = mesh.num_vertices();
  std::vector<double> height(static_cast<std::size_t>(nv));
  std::vector<signed char> side(static_cast<std::size_t>(nv));
  for (int v = 0; v < nv; ++v) {
    height[v] = n.dot(mesh.vertices[v] - point);
    side[v] = height[v] > kOnPlane_m ? 1 : (height[v] < -kOnPlane_m ? -1 : 0);
  }

  TrimResult result;
  HalfSpaceClip clip(mesh, height, side, result.mesh);
  for (const Tri& t : mesh.triangles) clip.add(t);
  require(!result.mesh.triangles.empty(),
          "trim_and_cap: nothing is kept: every vertex is above the plane through ({}, {}, {}) with normal "
          "({}, {}, {}) (the kept side is normal·(x − point) <= 0; flip the normal?)",
          point.x(), point.y(), point.z(), normal.x(), normal.y(), normal.z());
  cap_cut(result, clip.on_plane, n);
  return result;
}

}  // namespace socketsmith::geometry
