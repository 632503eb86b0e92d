#include "socketsmith/geometry/surface_query.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include "socketsmith/core/errors.h"

namespace socketsmith::geometry {
namespace {

// Exact predicates (do the ray and the triangle meet? is the point on the triangle?) with
// floating-point constructions: the inside test never misses a crossing through rounding.
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Ray = Kernel::Ray_3;
using Segment = Kernel::Segment_3;
using Triangle = Kernel::Triangle_3;
using TriangleIterator = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, TriangleIterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;

/// Two ray crossings closer than this along the ray are one crossing (a ray through an edge or a
/// vertex meets every triangle around it at the same point) [m].
constexpr double kSameCrossing_m = 1e-9;

Point to_cgal(const Vec3& p) { return {p.x(), p.y(), p.z()}; }
Vec3 to_vec3(const Point& p) { return {p.x(), p.y(), p.z()}; }

bool is_finite(const Vec3& p) { return p.allFinite(); }

/// Directions of the inside-test rays: unit, not parallel to any axis, to each other, nor to the
/// diagonals x = ±y, y = ±z, x = ±z of grid-aligned triangulations (all components differ in
/// magnitude), so a ray from a grid point rarely runs along an edge.
std::array<Vec3, 3> inside_test_directions() {
  return {Vec3(0.4352, 0.8173, 0.3779).normalized(), Vec3(-0.7681, 0.2946, 0.5684).normalized(),
          Vec3(0.1913, -0.5329, -0.8242).normalized()};
}

/// Closest point of triangle abc to p, by the Voronoi regions of its vertices, edges and face
/// (Ericson, Real-Time Collision Detection, 2005, §5.1.5).
Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

/// Squared distance from p to the box (0 inside).
double squared_distance_to_box(const Vec3& p, const CGAL::Bbox_3& box) {
  double d2 = 0.0;
  for (int i = 0; i < 3; ++i) {
    const double below = box.min(i) - p[i], above = p[i] - box.max(i);
    if (below > 0) d2 += below * below;
    else if (above > 0) d2 += above * above;
  }
  return d2;
}

/// Traversal traits of a closest-point search that visits the nearer child box first and skips
/// boxes farther than the best point so far. (CGAL's own search visits the children in a fixed
/// order; on a limb scan it was 1.5× slower near the surface and 2× slower 3 cm inside it.)
class NearestFirstSearch {
 public:
  using Priority = double;  ///< −(squared distance to the box): the nearer child first

  /// Starts from a point known to be on the surface (e.g. the kd-tree hint).
  NearestFirstSearch(const Vec3& query, const Vec3& surface_point, TriangleIterator triangle)
      : query_(query),
        best_(surface_point),
        best_d2_((query - surface_point).squaredNorm()),
        best_triangle_(triangle) {}

  /// Searches only within @p limit of the query; triangle() stays @p none when nothing is nearer.
  NearestFirstSearch(const Vec3& query, double limit, TriangleIterator none)
      : query_(query), best_(query), best_d2_(limit * limit), best_triangle_(none) {}

  bool go_further() const { return true; }

  void intersection(const Point&, const Primitive& primitive) {
    const Triangle& t = *primitive.id();
    const Vec3 c = closest_on_triangle(query_, to_vec3(t[0]), to_vec3(t[1]), to_vec3(t[2]));
    const double d2 = (query_ - c).squaredNorm();
    if (d2 < best_d2_) {
      best_ = c;
      best_d2_ = d2;
      best_triangle_ = primitive.id();
    }
  }

  template <class Node>
  bool do_intersect(const Point&, const Node& node) const {
    return squared_distance_to_box(query_, node.bbox()) < best_d2_;
  }

  template <class Node>
  std::pair<bool, Priority> do_intersect_with_priority(const Point&, const Node& node) const {
    const double d2 = squared_distance_to_box(query_, node.bbox());
    return {d2 < best_d2_, -d2};
  }

  const Vec3& point() const { return best_; }
  TriangleIterator triangle() const { return best_triangle_; }
  double squared_distance() const { return best_d2_; }

 private:
  Vec3 query_;
  Vec3 best_;
  double best_d2_;
  TriangleIterator best_triangle_;
};

/// Boxes are grown by this much in the ray–box tests, so that rounding never skips a box the ray
/// touches (the ray–triangle tests themselves are exact) [m].
constexpr double kBoxMargin_m = 1e-9;

/// A ray origin + t·d, t >= 0, as the ray searches need it.
struct RayData {
  Ray ray;
  Vec3 origin;
  Vec3 d;
  Vec3 inverse;  ///< 1 / d per coordinate

  RayData(const Vec3& o, const Vec3& dir)
      : ray(to_cgal(o), Kernel::Vector_3(dir.x(), dir.y(), dir.z())), origin(o), d(dir), inverse(dir.cwiseInverse()) {}

  /// Smallest t >= 0 where the ray enters the box grown by kBoxMargin_m, +inf if it misses it
  /// (slab test, plain floating point).
  double entry(const CGAL::Bbox_3& box) const {
    double t_enter = 0.0, t_exit = std::numeric_limits<double>::infinity();
    for (int i = 0; i < 3; ++i) {
      const double lo = box.min(i) - kBoxMargin_m, hi = box.max(i) + kBoxMargin_m;
      if (d[i] == 0.0) {
        if (origin[i] < lo || origin[i] > hi) return std::numeric_limits<double>::infinity();
        continue;
      }
      const double t0 = (lo - origin[i]) * inverse[i], t1 = (hi - origin[i]) * inverse[i];
      t_enter = std::max(t_enter, std::min(t0, t1));
      t_exit = std::min(t_exit, std::max(t0, t1));
    }
    return t_enter <= t_exit ? t_enter : std::numeric_limits<double>::infinity();
  }

  /// True when the ray runs inside the plane of @p t (exact).
  bool in_plane_of(const Triangle& t) const {
    return CGAL::orientation(t[0], t[1], t[2], ray.source()) == CGAL::COPLANAR &&
           CGAL::orientation(t[0], t[1], t[2], ray.second_point()) == CGAL::COPLANAR;
  }

  /// Ray parameter where the ray first meets @p t, which it must intersect.
  double first_parameter(const Triangle& t) const {
    const Vec3 a = to_vec3(t[0]);
    const Vec3 n = (to_vec3(t[1]) - a).cross(to_vec3(t[2]) - a);
    const double along = n.dot(d);
    // Crossing the plane: where it does (clamped against rounding, the exact answer is >= 0).
    if (along != 0.0) return std::max(0.0, n.dot(a - origin) / along);
    // Running inside the plane (or too close to it to tell): where the overlap starts.
    const auto overlap = CGAL::intersection(ray, t);
    const auto parameter = [&](const Point& q) { return (to_vec3(q) - origin).dot(d) / d.squaredNorm(); };
    if (const Segment* s = boost::get<Segment>(&*overlap))
      return std::min(parameter(s->source()), parameter(s->target()));
    return parameter(boost::get<Point>(*overlap));
  }
};

/// Traversal traits that collect the ray parameters t where a ray crosses the triangles. Boxes
/// are tested in plain floating point with a margin (fast, conservative); triangles with CGAL's
/// exact predicate. Triangles whose plane contains the ray are not crossings (the ray grazes).
class RayCrossingSearch {
 public:
  RayCrossingSearch(const RayData& ray, std::vector<double>& ts) : ray_(ray), ts_(ts) {}

  bool go_further() const { return true; }

  void intersection(const Ray& ray, const Primitive& primitive) {
    const Triangle& t = *primitive.id();
    if (CGAL::do_intersect(ray, t) && !ray_.in_plane_of(t)) ts_.push_back(ray_.first_parameter(t));
  }

  template <class Node>
  bool do_intersect(const Ray&, const Node& node) const {
    return ray_.entry(node.bbox()) < std::numeric_limits<double>::infinity();
  }

 private:
  const RayData& ray_;
  std::vector<double>& ts_;
};

/// Traversal traits of a first-hit search: boxes in order of where the ray enters them, skipping
/// those entered beyond the best hit so far. Triangles through the ray origin are ignored (they
/// meet the ray at t = 0 only, or along a segment starting there).
class FirstHitSearch {
 public:
  using Priority = double;  ///< −(ray parameter where the box is entered): the nearer child first

  explicit FirstHitSearch(const RayData& ray) : ray_(ray) {}

  bool go_further() const { return true; }

  void intersection(const Ray& ray, const Primitive& primitive) {
    const Triangle& t = *primitive.id();
    if (!CGAL::do_intersect(ray, t) || t.has_on(ray.source())) return;
    const double hit_t = ray_.first_parameter(t);
    if (hit_t < best_t_) {
      best_t_ = hit_t;
      best_triangle_ = primitive.id();
    }
  }

  template <class Node>
  bool do_intersect(const Ray&, const Node& node) const {
    return ray_.entry(node.bbox()) < best_t_;
  }

  template <class Node>
  std::pair<bool, Priority> do_intersect_with_priority(const Ray&, const Node& node) const {
    const double t = ray_.entry(node.bbox());
    return {t < best_t_, -t};
  }

  bool found() const { return best_t_ < std::numeric_limits<double>::infinity(); }
  double t() const { return best_t_; }
  TriangleIterator triangle() const { return best_triangle_; }

 private:
  const RayData& ray_;
  double best_t_ = std::numeric_limits<double>::infinity();
  TriangleIterator best_triangle_{};
};

}  // namespace

struct SurfaceQuery::Impl {
  TriMesh mesh;
  std::vector<Triangle> triangles;  ///< the non-degenerate triangles, in the tree
  std::vector<int> mesh_triangle;   ///< mesh_triangle[i]: index in `mesh` of triangles[i]
  std::vector<int> tree_triangle;   ///< tree_triangle[t]: index in `triangles` of mesh triangle t, −1 if left out
  Tree tree;
  std::array<Vec3, 3> inside_directions = inside_test_directions();

  /// Index in `mesh` of the triangle behind a tree primitive id.
  int triangle_index(TriangleIterator id) const {
    return mesh_triangle[static_cast<std::size_t>(id - triangles.begin())];
  }

  /// Number of distinct points where the ray from @p p along unit @p d crosses the surface.
  int crossings(const Vec3& p, const Vec3& d) const {
    const RayData ray(p, d);
    std::vector<double> ts;
    RayCrossingSearch search(ray, ts);
    tree.traversal(ray.ray, search);
    std::sort(ts.begin(), ts.end());
    int count = 0;
    for (std::size_t i = 0; i < ts.size(); ++i)
      if (i == 0 || ts[i] - ts[i - 1] > kSameCrossing_m) ++count;
    return count;
  }

  /// Majority of the parities of three rays: the third is cast only when the first two disagree.
  bool majority_inside(const Vec3& p, const std::array<Vec3, 3>& directions) const {
    int inside = 0, outside = 0;
    for (const Vec3& d : directions) {
      ++(crossings(p, d) % 2 == 1 ? inside : outside);
      if (inside == 2 || outside == 2) break;
    }
    return inside == 2;
  }
};

SurfaceQuery::SurfaceQuery(const TriMesh& mesh) : impl_(std::make_unique<Impl>()) {
  require(!mesh.empty(), "SurfaceQuery: the mesh has no triangles (expected a surface)");
  const int nv = mesh.num_vertices();
  for (int v = 0; v < nv; ++v)
    require(is_finite(mesh.vertices[v]), "SurfaceQuery: vertex {} has NaN or infinite coordinates", v);

  Impl& m = *impl_;
  m.mesh = mesh;
  m.triangles.reserve(mesh.triangles.size());
  m.mesh_triangle.reserve(mesh.triangles.size());
  m.tree_triangle.assign(mesh.triangles.size(), -1);
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    const auto& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k)
      require(tri[k] >= 0 && tri[k] < nv, "SurfaceQuery: triangle {} refers to vertex {} (valid: 0..{})", t,
              tri[k], nv - 1);
    const Triangle triangle(to_cgal(mesh.vertices[tri[0]]), to_cgal(mesh.vertices[tri[1]]),
                            to_cgal(mesh.vertices[tri[2]]));
    // Degenerate triangles hold no surface of their own (their points lie on neighbouring
    // triangles) and have no plane to project onto: leave them out of the tree.
    if (triangle.is_degenerate()) continue;
    m.tree_triangle[t] = static_cast<int>(m.triangles.size());
    m.triangles.push_back(triangle);
    m.mesh_triangle.push_back(t);
  }
  require(!m.triangles.empty(), "SurfaceQuery: all {} triangles of the mesh are degenerate (zero area)",
          mesh.num_triangles());

  // Build the tree and its distance-query kd-tree now, so that const queries never trigger a
  // lazy build (they are then safe to run from several threads).
  m.tree.insert(m.triangles.cbegin(), m.triangles.cend());
  m.tree.build();
  m.tree.accelerate_distance_queries();
}

SurfaceQuery::~SurfaceQuery() = default;
SurfaceQuery::SurfaceQuery(SurfaceQuery&&) noexcept = default;
SurfaceQuery& SurfaceQuery::operator=(SurfaceQuery&&) noexcept = default;

const TriMesh& SurfaceQuery::mesh() const { return impl_->mesh; }

SurfaceHit SurfaceQuery::closest_point(const Vec3& p) const {
  require(is_finite(p), "SurfaceQuery::closest_point: query point ({}, {}, {}) is not finite", p.x(), p.y(), p.z());
  const Point query = to_cgal(p);
  const auto [hint, hint_triangle] = impl_->tree.best_hint(query);  // nearest vertex, by the kd-tree
  NearestFirstSearch search(p, to_vec3(hint), hint_triangle);
  impl_->tree.traversal_with_priority(query, search);
  SurfaceHit hit;
  hit.point = search.point();
  hit.triangle = impl_->triangle_index(search.triangle());
  hit.distance = (p - hit.point).norm();
  return hit;
}

SurfaceHit SurfaceQuery::closest_point(const Vec3& p, const SurfaceHit& hint) const {
  require(is_finite(p), "SurfaceQuery::closest_point: query point ({}, {}, {}) is not finite", p.x(), p.y(), p.z());
  const int tri = hint.triangle >= 0 && hint.triangle < static_cast<int>(impl_->tree_triangle.size())
                      ? impl_->tree_triangle[hint.triangle]
                      : -1;
  if (tri < 0 || !is_finite(hint.point)) return closest_point(p);
  NearestFirstSearch search(p, hint.point, impl_->triangles.cbegin() + tri);
  impl_->tree.traversal_with_priority(to_cgal(p), search);
  SurfaceHit hit;
  hit.point = search.point();
  hit.triangle = impl_->triangle_index(search.triangle());
  hit.distance = (p - hit.point).norm();
  return hit;
}

std::optional<SurfaceHit> SurfaceQuery::first_hit(const Vec3& origin, const Vec3& direction) const {
  require(is_finite(origin) && is_finite(direction) && direction.squaredNorm() > 0.0,
          "SurfaceQuery::first_hit: origin ({}, {}, {}) and direction ({}, {}, {}) must be finite and the "
          "direction non-zero",
          origin.x(), origin.y(), origin.z(), direction.x(), direction.y(), direction.z());
  const RayData ray(origin, direction);
  FirstHitSearch search(ray);
  impl_->tree.traversal_with_priority(ray.ray, search);
  if (!search.found()) return std::nullopt;
  SurfaceHit hit;
  hit.point = origin + search.t() * direction;
  hit.triangle = impl_->triangle_index(search.triangle());
  hit.distance = search.t() * direction.norm();
  return hit;
}

double SurfaceQuery::distance_up_to(const Vec3& p, double limit_m) const {
  require(is_finite(p), "SurfaceQuery::distance_up_to: query point ({}, {}, {}) is not finite", p.x(), p.y(), p.z());
  require(std::isfinite(limit_m) && limit_m >= 0.0,
          "SurfaceQuery::distance_up_to: limit_m = {} (expected a finite distance >= 0)", limit_m);
  NearestFirstSearch search(p, limit_m, impl_->triangles.cend());
  impl_->tree.traversal_with_priority(to_cgal(p), search);
  return search.triangle() == impl_->triangles.cend() ? limit_m : (p - search.point()).norm();
}

bool SurfaceQuery::is_inside(const Vec3& p) const {
  require(is_finite(p), "SurfaceQuery::is_inside: query point ({}, {}, {}) is not finite", p.x(), p.y(), p.z());
  return impl_->majority_inside(p, impl_->inside_directions);
}

bool SurfaceQuery::is_inside_across(const Vec3& p, const Vec3& axis) const {
  require(is_finite(p), "SurfaceQuery::is_inside_across: query point ({}, {}, {}) is not finite", p.x(), p.y(), p.z());
  require(is_finite(axis) && axis.squaredNorm() > 0.0,
          "SurfaceQuery::is_inside_across: axis ({}, {}, {}) must be finite and non-zero", axis.x(), axis.y(), axis.z());
  // Three rays in the plane across the axis, at angles that are no simple fraction of a turn (so a
  // ray from a point of a ring-built surface rarely runs along an edge).
  const Vec3 n = axis.normalized();
  const Vec3 trial = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 u = (trial - trial.dot(n) * n).normalized(), v = n.cross(u);
  std::array<Vec3, 3> directions;
  const std::array<double, 3> angles{0.3183, 2.4142, 4.2361};
  for (std::size_t i = 0; i < 3; ++i) directions[i] = std::cos(angles[i]) * u + std::sin(angles[i]) * v;
  return impl_->majority_inside(p, directions);
}

double SurfaceQuery::signed_distance(const Vec3& p) const {
  const double d = closest_point(p).distance;
  return is_inside(p) ? -d : d;
}

}  // namespace socketsmith::geometry
