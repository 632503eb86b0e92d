#include "socketsmith/geometry/mesh_checks.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <CGAL/Box_intersection_d/Box_with_info_d.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/box_intersection_d.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>
#include <fmt/format.h>

#include "socketsmith/core/errors.h"

namespace socketsmith::geometry {
namespace {

bool is_finite(const Vec3& p) { return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z()); }

bool indices_in_range(const std::array<int, 3>& t, int nv) {
  return t[0] >= 0 && t[0] < nv && t[1] >= 0 && t[1] < nv && t[2] >= 0 && t[2] < nv;
}

bool has_repeated_index(const std::array<int, 3>& t) { return t[0] == t[1] || t[1] == t[2] || t[0] == t[2]; }

/// Disjoint sets with path halving and union by size.
class UnionFind {
 public:
  explicit UnionFind(int n) : parent_(static_cast<std::size_t>(n)), size_(static_cast<std::size_t>(n), 1) {
    std::iota(parent_.begin(), parent_.end(), 0);
  }
  int find(int x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];
      x = parent_[x];
    }
    return x;
  }
  void unite(int a, int b) {
    a = find(a);
    b = find(b);
    if (a == b) return;
    if (size_[a] < size_[b]) std::swap(a, b);
    parent_[b] = a;
    size_[a] += size_[b];
  }

 private:
  std::vector<int> parent_;
  std::vector<int> size_;
};

/// One use of an undirected edge {v, other} (v < other) by a triangle.
struct EdgeUse {
  int other;     ///< the larger vertex index of the edge
  int tri;       ///< triangle using the edge
  bool forward;  ///< the triangle traverses the edge from the smaller to the larger index
};

/// Undirected edges as a sorted edge list bucketed by their smaller vertex (a counting sort, so
/// O(#triangles) rather than a global sort): the uses of one edge are contiguous.
struct EdgeList {
  std::vector<int> offsets;  ///< uses of edges whose smaller vertex is v: [offsets[v], offsets[v+1])
  std::vector<EdgeUse> uses;

  /// Calls f(a, b, first_use, count) once per undirected edge {a, b}, a < b.
  template <class F>
  void for_each_edge(F&& f) const {
    const int nv = static_cast<int>(offsets.size()) - 1;
    for (int a = 0; a < nv; ++a) {
      const int end = offsets[a + 1];
      for (int i = offsets[a]; i < end;) {
        int j = i + 1;
        while (j < end && uses[j].other == uses[i].other) ++j;
        f(a, uses[i].other, &uses[i], j - i);
        i = j;
      }
    }
  }
};

/// Builds the edge list of the triangles with include[t] != 0 (their indices must be in range).
EdgeList build_edges(const TriMesh& mesh, const std::vector<char>& include) {
  const int nv = mesh.num_vertices();
  EdgeList e;
  e.offsets.assign(static_cast<std::size_t>(nv) + 1, 0);
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    if (!include[t]) continue;
    const auto& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) {
      const int a = tri[k], b = tri[(k + 1) % 3];
      if (a != b) ++e.offsets[std::min(a, b) + 1];
    }
  }
  std::partial_sum(e.offsets.begin(), e.offsets.end(), e.offsets.begin());
  e.uses.resize(static_cast<std::size_t>(e.offsets.back()));
  std::vector<int> cursor(e.offsets.begin(), e.offsets.end() - 1);
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    if (!include[t]) continue;
    const auto& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) {
      const int a = tri[k], b = tri[(k + 1) % 3];
      if (a == b) continue;
      e.uses[cursor[std::min(a, b)]++] = EdgeUse{std::max(a, b), t, a < b};
    }
  }
  // Sort each vertex's bucket by the other vertex; buckets are tiny except at fan apices.
  auto by_other = [](const EdgeUse& x, const EdgeUse& y) { return x.other < y.other; };
  for (int v = 0; v < nv; ++v) {
    EdgeUse* b = e.uses.data() + e.offsets[v];
    EdgeUse* end = e.uses.data() + e.offsets[v + 1];
    if (end - b > 16) {
      std::sort(b, end, by_other);
    } else {
      for (EdgeUse* i = b + 1; i < end; ++i)  // insertion sort
        for (EdgeUse* j = i; j > b && by_other(*j, *(j - 1)); --j) std::swap(*j, *(j - 1));
    }
  }
  return e;
}

std::string plural(int n, const char* one, const char* many) { return fmt::format("{} {}", n, n == 1 ? one : many); }

}  // namespace

std::vector<std::string> MeshCheckReport::problems() const {
  std::vector<std::string> out;
  if (num_triangles == 0) out.push_back("no triangles");
  if (non_finite_vertices > 0)
    out.push_back(fmt::format("{} with NaN or infinite coordinates", plural(non_finite_vertices, "vertex", "vertices")));
  if (out_of_range_indices > 0)
    out.push_back(fmt::format("{} outside [0, {})", plural(out_of_range_indices, "triangle index", "triangle indices"),
                              num_vertices));
  if (boundary_edges > 0)
    out.push_back(fmt::format("open: {} with {}", plural(boundary_loops, "boundary loop", "boundary loops"),
                              plural(boundary_edges, "boundary edge", "boundary edges")));
  if (non_manifold_edges > 0)
    out.push_back(fmt::format("non-manifold: {} shared by more than two triangles",
                              plural(non_manifold_edges, "edge", "edges")));
  if (inconsistently_oriented_edges > 0)
    out.push_back(fmt::format("inconsistent orientation: {} traversed the same way by both of their triangles",
                              plural(inconsistently_oriented_edges, "edge", "edges")));
  if (degenerate_triangles > 0)
    out.push_back(fmt::format("{} (zero area or a repeated vertex)",
                              plural(degenerate_triangles, "degenerate triangle", "degenerate triangles")));
  if (self_intersecting_pairs > 0)
    out.push_back(fmt::format("self-intersecting: {} cross each other (the first near ({:.1f}, {:.1f}, {:.1f}) mm in "
                              "the file's frame): two shells overlap or the surface folds through itself",
                              plural(self_intersecting_pairs, "pair of triangles", "pairs of triangles"),
                              first_self_intersection.x() * 1e3, first_self_intersection.y() * 1e3,
                              first_self_intersection.z() * 1e3));
  if (is_valid_closed_surface() && signed_volume_m3 < 0.0)
    out.push_back(fmt::format("inside-out: normals point inward (signed volume {:.4g} m^3)", signed_volume_m3));
  return out;
}

MeshCheckReport check_mesh(const TriMesh& mesh, const MeshCheckOptions& options) {
  MeshCheckReport r;
  r.num_vertices = mesh.num_vertices();
  r.num_triangles = mesh.num_triangles();
  const int nv = r.num_vertices;
  const int nt = r.num_triangles;

  std::vector<char> finite(static_cast<std::size_t>(nv));
  Aabb box;
  for (int v = 0; v < nv; ++v) {
    finite[v] = is_finite(mesh.vertices[v]);
    if (finite[v]) box.extend(mesh.vertices[v]);
    else ++r.non_finite_vertices;
  }
  const Vec3 origin = box.is_empty() ? Vec3::Zero() : box.center();

  // Triangles that take part in the edge topology: indices in range and three distinct vertices.
  std::vector<char> include(static_cast<std::size_t>(nt), 0);
  double six_volume = 0.0;
  for (int t = 0; t < nt; ++t) {
    const auto& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) r.out_of_range_indices += (tri[k] < 0 || tri[k] >= nv) ? 1 : 0;
    if (!indices_in_range(tri, nv)) continue;
    if (has_repeated_index(tri)) {
      ++r.degenerate_triangles;
      continue;
    }
    include[t] = 1;
    if (!finite[tri[0]] || !finite[tri[1]] || !finite[tri[2]]) continue;
    const Vec3 a = mesh.vertices[tri[0]] - origin;
    const Vec3 b = mesh.vertices[tri[1]] - origin;
    const Vec3 c = mesh.vertices[tri[2]] - origin;
    const Vec3 n = (b - a).cross(c - a);
    if (0.5 * n.norm() < options.degenerate_area_tol_m2) ++r.degenerate_triangles;
    six_volume += a.dot(b.cross(c));
  }
  r.signed_volume_m3 = six_volume / 6.0;

  const EdgeList edges = build_edges(mesh, include);
  UnionFind tri_sets(nt);
  UnionFind boundary_sets(nv);
  std::vector<char> on_boundary(static_cast<std::size_t>(nv), 0);
  edges.for_each_edge([&](int a, int b, const EdgeUse* use, int count) {
    if (count == 1) {
      ++r.boundary_edges;
      boundary_sets.unite(a, b);
      on_boundary[a] = on_boundary[b] = 1;
    } else if (count > 2) {
      ++r.non_manifold_edges;
    } else {
      // Two triangles: consistently oriented iff they traverse the edge in opposite directions.
      if (use[0].forward == use[1].forward) ++r.inconsistently_oriented_edges;
    }
    for (int i = 1; i < count; ++i) tri_sets.unite(use[0].tri, use[i].tri);
  });

  for (int t = 0; t < nt; ++t)
    if (include[t] && tri_sets.find(t) == t) ++r.connected_components;
  for (int v = 0; v < nv; ++v)
    if (on_boundary[v] && boundary_sets.find(v) == v) ++r.boundary_loops;
  if (options.find_self_intersections) {
    const SelfIntersections si = find_self_intersections(mesh);
    r.self_intersecting_pairs = si.pairs;
    if (si.first_a >= 0) {
      const auto& t = mesh.triangles[si.first_a];
      r.first_self_intersection = (mesh.vertices[t[0]] + mesh.vertices[t[1]] + mesh.vertices[t[2]]) / 3.0;
    }
  }
  return r;
}

SelfIntersections find_self_intersections(const TriMesh& mesh) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  using P = K::Point_3;
  using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, int>;
  const int nv = mesh.num_vertices();
  auto point = [&](int v) {
    const Vec3& p = mesh.vertices[v];
    return P(p.x(), p.y(), p.z());
  };
  std::vector<Box> boxes;
  boxes.reserve(mesh.triangles.size());
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    const auto& tri = mesh.triangles[t];
    if (!indices_in_range(tri, nv) || has_repeated_index(tri)) continue;
    if (!is_finite(mesh.vertices[tri[0]]) || !is_finite(mesh.vertices[tri[1]]) || !is_finite(mesh.vertices[tri[2]]))
      continue;
    const P a = point(tri[0]), b = point(tri[1]), c = point(tri[2]);
    if (CGAL::collinear(a, b, c)) continue;
    boxes.emplace_back(a.bbox() + b.bbox() + c.bbox(), t);
  }
  SelfIntersections out;
  auto crosses = [&](int ta, int tb) {
    const auto& A = mesh.triangles[ta];
    const auto& B = mesh.triangles[tb];
    int shared = 0, ia = -1, ib = -1;  // ia/ib: the index in A/B of a shared vertex
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (A[i] == B[j]) {
          ++shared;
          ia = i;
          ib = j;
        }
    const K::Triangle_3 ka(point(A[0]), point(A[1]), point(A[2]));
    const K::Triangle_3 kb(point(B[0]), point(B[1]), point(B[2]));
    if (shared == 0) return CGAL::do_intersect(ka, kb);
    if (shared == 3) return true;  // the same triangle twice
    if (shared == 1) {
      const K::Segment_3 sa(point(A[(ia + 1) % 3]), point(A[(ia + 2) % 3]));
      const K::Segment_3 sb(point(B[(ib + 1) % 3]), point(B[(ib + 2) % 3]));
      return CGAL::do_intersect(sa, kb) || CGAL::do_intersect(sb, ka);
    }
    // Two shared vertices p, q: the triangles meet only along pq unless they are coplanar with
    // their third vertices on the same side of pq (one folded onto the other).
    int p = -1, q = -1, ra = -1, rb = -1;
    for (int i = 0; i < 3; ++i) {
      const bool in_b = A[i] == B[0] || A[i] == B[1] || A[i] == B[2];
      if (!in_b) ra = A[i];
      else if (p < 0) p = A[i];
      else q = A[i];
    }
    for (int j = 0; j < 3; ++j)
      if (B[j] != p && B[j] != q) rb = B[j];
    const P pp = point(p), pq = point(q), pa = point(ra), pb = point(rb);
    return CGAL::orientation(pp, pq, pa, pb) == CGAL::COPLANAR &&
           CGAL::coplanar_orientation(pp, pq, pa, pb) == CGAL::POSITIVE;
  };
  CGAL::box_self_intersection_d(boxes.begin(), boxes.end(), [&](const Box& a, const Box& b) {
    if (!crosses(a.info(), b.info())) return;
    if (out.pairs++ == 0) {
      out.first_a = std::min(a.info(), b.info());
      out.first_b = std::max(a.info(), b.info());
    }
  });
  return out;
}

void require_closed_surface(const TriMesh& mesh, const std::string& what) {
  const MeshCheckReport r = check_mesh(mesh);
  if (r.non_finite_vertices > 0)
    fail<InvalidInputError>("{} has {} with NaN or infinite coordinates (fix or re-export the file)", what,
                            plural(r.non_finite_vertices, "vertex", "vertices"));
  if (r.out_of_range_indices > 0)
    fail<InvalidInputError>("{} has {} outside [0, {}) (the mesh is corrupt; re-export it)", what,
                            plural(r.out_of_range_indices, "triangle index", "triangle indices"), r.num_vertices);
  if (r.num_triangles == 0)
    fail<TopologyError>("{} is empty: it has no triangles (expected a closed surface)", what);
  if (!r.is_closed())
    fail<TopologyError>("{} is open: {} with {} (close or cap it first)", what,
                        plural(r.boundary_loops, "boundary loop", "boundary loops"),
                        plural(r.boundary_edges, "edge", "edges"));
  if (!r.is_manifold())
    fail<TopologyError>("{} is non-manifold: {} shared by more than two triangles (remove duplicate or "
                        "internal faces first)",
                        what, plural(r.non_manifold_edges, "edge is", "edges are"));
  if (!r.is_oriented())
    fail<TopologyError>("{} is inconsistently oriented: {} traversed the same way by both of their "
                        "triangles (make the triangle orientation consistent, e.g. with a mesh repair tool)",
                        what, plural(r.inconsistently_oriented_edges, "edge is", "edges are"));
  if (r.degenerate_triangles > 0)
    fail<TopologyError>("{} has {} of zero area or with a repeated vertex (remove them or remesh)", what,
                        plural(r.degenerate_triangles, "degenerate triangle", "degenerate triangles"));
  if (r.signed_volume_m3 < 0.0)
    fail<TopologyError>("{} is inside-out: normals point inward, signed volume {:.4g} m^3 (flip the "
                        "orientation)",
                        what, r.signed_volume_m3);
}

std::vector<TriMesh> split_components(const TriMesh& mesh) {
  const int nv = mesh.num_vertices();
  const int nt = mesh.num_triangles();
  for (int t = 0; t < nt; ++t)
    if (!indices_in_range(mesh.triangles[t], nv))
      fail("split_components: triangle {} has a vertex index outside [0, {}) (the mesh is corrupt)", t, nv);

  const std::vector<char> include(static_cast<std::size_t>(nt), 1);
  const EdgeList edges = build_edges(mesh, include);
  UnionFind sets(nt);
  edges.for_each_edge([&](int, int, const EdgeUse* use, int count) {
    for (int i = 1; i < count; ++i) sets.unite(use[0].tri, use[i].tri);
  });

  // Component ids in order of first triangle, then sizes.
  std::vector<int> comp_of_root(static_cast<std::size_t>(nt), -1);
  std::vector<int> comp(static_cast<std::size_t>(nt));
  std::vector<int> size;
  for (int t = 0; t < nt; ++t) {
    const int root = sets.find(t);
    if (comp_of_root[root] < 0) {
      comp_of_root[root] = static_cast<int>(size.size());
      size.push_back(0);
    }
    comp[t] = comp_of_root[root];
    ++size[comp[t]];
  }
  const int nc = static_cast<int>(size.size());
  std::vector<int> order(static_cast<std::size_t>(nc));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return size[a] > size[b]; });
  std::vector<int> rank(static_cast<std::size_t>(nc));
  for (int i = 0; i < nc; ++i) rank[order[i]] = i;

  // Triangles grouped by component (counting sort), so each component is compacted in one go.
  std::vector<int> first(static_cast<std::size_t>(nc) + 1, 0);
  for (int t = 0; t < nt; ++t) ++first[rank[comp[t]] + 1];
  std::partial_sum(first.begin(), first.end(), first.begin());
  std::vector<int> by_comp(static_cast<std::size_t>(nt));
  {
    std::vector<int> cursor(first.begin(), first.end() - 1);
    for (int t = 0; t < nt; ++t) by_comp[cursor[rank[comp[t]]]++] = t;
  }

  std::vector<TriMesh> out(static_cast<std::size_t>(nc));
  // local[v] is v's index in the component being built; stamp[v] says which component set it
  // (components touching at a single vertex each get their own copy of it).
  std::vector<int> local(static_cast<std::size_t>(nv), -1);
  std::vector<int> stamp(static_cast<std::size_t>(nv), -1);
  for (int c = 0; c < nc; ++c) {
    TriMesh& m = out[c];
    m.triangles.reserve(static_cast<std::size_t>(first[c + 1] - first[c]));
    for (int i = first[c]; i < first[c + 1]; ++i) {
      const auto& src = mesh.triangles[by_comp[i]];
      std::array<int, 3> tri;
      for (int k = 0; k < 3; ++k) {
        const int v = src[k];
        if (stamp[v] != c) {
          stamp[v] = c;
          local[v] = static_cast<int>(m.vertices.size());
          m.vertices.push_back(mesh.vertices[v]);
        }
        tri[k] = local[v];
      }
      m.triangles.push_back(tri);
    }
  }
  return out;
}

bool has_self_intersections(const TriMesh& mesh) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  using SM = CGAL::Surface_mesh<K::Point_3>;
  SM sm;
  std::vector<SM::Vertex_index> v;
  v.reserve(mesh.vertices.size());
  for (const auto& p : mesh.vertices) {
    require(is_finite(p), "has_self_intersections: the mesh has a NaN/inf vertex");
    v.push_back(sm.add_vertex(K::Point_3(p.x(), p.y(), p.z())));
  }
  const int nv = mesh.num_vertices();
  for (const auto& t : mesh.triangles) {
    require(indices_in_range(t, nv), "has_self_intersections: a triangle has a vertex index out of range");
    if (sm.add_face(v[t[0]], v[t[1]], v[t[2]]) == SM::null_face())
      fail<TopologyError>("has_self_intersections: the mesh is not a manifold surface (a face could not be added); "
                          "check it with socketsmith check mesh");
  }
  return CGAL::Polygon_mesh_processing::does_self_intersect(sm);
}

}  // namespace socketsmith::geometry
