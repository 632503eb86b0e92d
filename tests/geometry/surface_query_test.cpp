#include "socketsmith/geometry/surface_query.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <thread>
#include <vector>

#include "socketsmith/core/errors.h"
#include "test_shapes.h"

namespace socketsmith::geometry {
namespace {

using test::make_cube;
using test::make_icosphere;

/// Half side of the test cube [m]: a limb-sized box [−h, h]^3.
constexpr double kHalf = 0.05;

TriMesh centred_cube() { return make_cube(2 * kHalf, Vec3::Constant(-kHalf)); }

/// Closest point of segment ab to p.
Vec3 closest_on_segment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const double s = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
  return a + s * (b - a);
}

/// Closest point of triangle abc to p, the textbook way (an independent reference for the
/// library's Voronoi-region code): the projection onto the plane when it falls inside the
/// triangle, else the nearest of the three edges.
Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a).normalized();
  const Vec3 q = p - n.dot(p - a) * n;
  const bool inside = n.dot((b - a).cross(q - a)) >= 0 && n.dot((c - b).cross(q - b)) >= 0 &&
                      n.dot((a - c).cross(q - c)) >= 0;
  if (inside) return q;
  Vec3 best = closest_on_segment(p, a, b);
  for (const Vec3& e : {closest_on_segment(p, b, c), closest_on_segment(p, c, a)})
    if ((p - e).squaredNorm() < (p - best).squaredNorm()) best = e;
  return best;
}

double brute_force_distance(const TriMesh& m, const Vec3& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& t : m.triangles)
    best = std::min(best, (p - closest_on_triangle(p, m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]])).norm());
  return best;
}

/// Closest point of the surface of the box [−h, h]^3 to p, inside or outside.
Vec3 closest_on_box_surface(const Vec3& p, double h) {
  if ((p.array().abs() > h).any()) return p.cwiseMax(Vec3::Constant(-h)).cwiseMin(Vec3::Constant(h));
  int axis = 0;
  (Vec3::Constant(h) - p.cwiseAbs()).minCoeff(&axis);
  Vec3 q = p;
  q[axis] = p[axis] >= 0 ? h : -h;
  return q;
}

/// Distance of @p q from the plane of triangle @p t.
double plane_offset(const TriMesh& m, int t, const Vec3& q) {
  return std::abs(triangle_normal(m, t).dot(q - m.vertices[m.triangles[t][0]]));
}

/// Inside test of a convex closed polyhedron with outward normals: behind every face plane.
/// Returns the smallest distance to a face plane through @p clearance (to skip ambiguous points).
bool inside_convex(const TriMesh& m, const Vec3& p, double* clearance) {
  bool inside = true;
  *clearance = std::numeric_limits<double>::infinity();
  for (int t = 0; t < m.num_triangles(); ++t) {
    const double s = triangle_normal(m, t).dot(p - m.vertices[m.triangles[t][0]]);
    inside = inside && s < 0;
    *clearance = std::min(*clearance, std::abs(s));
  }
  return inside;
}

TEST(SurfaceQuery, rejects_empty_and_fully_degenerate_meshes) {
  EXPECT_THROW(SurfaceQuery(TriMesh{}), InvalidInputError);
  TriMesh flat;
  flat.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0)};
  flat.triangles = {{0, 1, 2}};
  const std::string msg = test::error_message<InvalidInputError>([&] { SurfaceQuery q(flat); });
  EXPECT_NE(msg.find("degenerate"), std::string::npos) << msg;
  TriMesh bad = make_cube();
  bad.triangles[3][1] = 99;
  EXPECT_THROW(SurfaceQuery{bad}, InvalidInputError);
}

TEST(SurfaceQuery, closest_point_on_a_cube_matches_the_analytic_projection) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2 * kHalf, 2 * kHalf);
  for (unsigned motion = 0; motion < 3; ++motion) {
    // The identity, then random rigid motions of the whole problem.
    const Eigen::Isometry3d x = motion == 0 ? Eigen::Isometry3d::Identity() : test::random_rigid_motion(motion);
    const TriMesh cube = test::transformed(centred_cube(), x);
    const SurfaceQuery query(cube);
    for (int i = 0; i < 500; ++i) {
      const Vec3 local(u(rng), u(rng), u(rng));
      const Vec3 expected = closest_on_box_surface(local, kHalf);
      const SurfaceHit hit = query.closest_point(x * local);
      EXPECT_LT((hit.point - x * expected).norm(), 1e-12) << "local point " << local.transpose();
      EXPECT_NEAR(hit.distance, (local - expected).norm(), 1e-12);
      ASSERT_GE(hit.triangle, 0);
      ASSERT_LT(hit.triangle, cube.num_triangles());
      EXPECT_LT(plane_offset(cube, hit.triangle, hit.point), 1e-12);
    }
  }
}

TEST(SurfaceQuery, closest_point_on_a_sphere_matches_brute_force_and_the_analytic_distance) {
  const double r = 0.06;
  const TriMesh sphere = make_icosphere(r, 3, Vec3(0.01, -0.02, 0.3));
  const SurfaceQuery query(sphere);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-2 * r, 2 * r);
  // The facets lie at most the sagitta of the longest edge inside the sphere.
  double max_edge = 0;
  for (const auto& t : sphere.triangles)
    for (int k = 0; k < 3; ++k)
      max_edge = std::max(max_edge, (sphere.vertices[t[k]] - sphere.vertices[t[(k + 1) % 3]]).norm());
  const double sagitta = max_edge * max_edge / (8 * r) * 1.5;
  for (int i = 0; i < 300; ++i) {
    const Vec3 p = Vec3(0.01, -0.02, 0.3) + Vec3(u(rng), u(rng), u(rng));
    const SurfaceHit hit = query.closest_point(p);
    EXPECT_NEAR(hit.distance, brute_force_distance(sphere, p), 1e-13);
    EXPECT_NEAR(hit.distance, std::abs((p - Vec3(0.01, -0.02, 0.3)).norm() - r), sagitta);
    EXPECT_LT(plane_offset(sphere, hit.triangle, hit.point), 1e-13);
  }
}

TEST(SurfaceQuery, closest_point_from_a_hint_gives_the_same_answer) {
  const double r = 0.06;
  const TriMesh sphere = make_icosphere(r, 3, Vec3(0.01, -0.02, 0.3));
  const SurfaceQuery query(sphere);
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> tri(0, sphere.num_triangles() - 1);
  std::uniform_real_distribution<double> u(0.0, 0.03);
  for (int i = 0; i < 300; ++i) {
    // A point offset from a surface point along its face's normal, hinted from there — and from
    // an unrelated face: the answer is the same (the hint only starts the search).
    const int t = tri(rng);
    const auto& f = sphere.triangles[t];
    const Vec3 on = (sphere.vertices[f[0]] + sphere.vertices[f[1]] + sphere.vertices[f[2]]) / 3.0;
    const Vec3 n = (sphere.vertices[f[1]] - sphere.vertices[f[0]]).cross(sphere.vertices[f[2]] - sphere.vertices[f[0]]);
    const Vec3 p = on + (u(rng) - 0.01) * n.normalized();
    SurfaceHit hint;
    hint.point = on;
    hint.triangle = t;
    EXPECT_NEAR(query.closest_point(p, hint).distance, brute_force_distance(sphere, p), 1e-13);
    const int other = tri(rng);
    const auto& g = sphere.triangles[other];
    hint.point = sphere.vertices[g[0]];
    hint.triangle = other;
    EXPECT_NEAR(query.closest_point(p, hint).distance, brute_force_distance(sphere, p), 1e-13);
  }
  SurfaceHit bad;
  bad.triangle = sphere.num_triangles() + 5;  // ignored: the plain search
  const Vec3 p(0.1, 0.0, 0.3);
  EXPECT_NEAR(query.closest_point(p, bad).distance, query.closest_point(p).distance, 0.0);
}

TEST(SurfaceQuery, first_hit_distance_matches_the_analytic_ray_box_intersection) {
  const SurfaceQuery query(centred_cube());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int hits = 0, misses = 0;
  for (int i = 0; i < 1000; ++i) {
    const Vec3 origin = 2 * kHalf * Vec3(u(rng), u(rng), u(rng));
    const Vec3 dir = Vec3(u(rng), u(rng), u(rng)) * (0.1 + std::abs(u(rng)) * 10);  // not unit
    // Slab method: the ray is inside the box for t in [t_enter, t_exit].
    double t_enter = -std::numeric_limits<double>::infinity(), t_exit = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
      const double t0 = (-kHalf - origin[a]) / dir[a], t1 = (kHalf - origin[a]) / dir[a];
      t_enter = std::max(t_enter, std::min(t0, t1));
      t_exit = std::min(t_exit, std::max(t0, t1));
    }
    const bool expect_hit = t_enter <= t_exit && t_exit > 0;
    const std::optional<SurfaceHit> hit = query.first_hit(origin, dir);
    ASSERT_EQ(hit.has_value(), expect_hit) << "origin " << origin.transpose() << " dir " << dir.transpose();
    if (!hit) {
      ++misses;
      continue;
    }
    ++hits;
    const double t = t_enter > 0 ? t_enter : t_exit;
    EXPECT_NEAR(hit->distance, t * dir.norm(), 1e-12);
    EXPECT_LT((hit->point - (origin + t * dir)).norm(), 1e-12);
    EXPECT_LT(plane_offset(query.mesh(), hit->triangle, hit->point), 1e-12);
  }
  EXPECT_GT(hits, 100);
  EXPECT_GT(misses, 100);
}

TEST(SurfaceQuery, first_hit_from_a_surface_point_finds_the_opposite_side) {
  const SurfaceQuery query(centred_cube());
  // From the middle of the bottom face, straight up and slanted: the top face, not t = 0.
  const auto up = query.first_hit(Vec3(0.01, 0.02, -kHalf), Vec3(0, 0, 3));
  ASSERT_TRUE(up.has_value());
  EXPECT_NEAR(up->distance, 2 * kHalf, 1e-14);
  EXPECT_NEAR(up->point.z(), kHalf, 1e-14);
  const auto slanted = query.first_hit(Vec3(0, 0, -kHalf), Vec3(0.1, 0.2, 1));
  ASSERT_TRUE(slanted.has_value());
  EXPECT_NEAR(slanted->distance, 2 * kHalf * Vec3(0.1, 0.2, 1).norm(), 1e-14);
  // Pointing away from the surface it starts on, the ray meets nothing.
  EXPECT_FALSE(query.first_hit(Vec3(0, 0, -kHalf), Vec3(0, 0, -1)).has_value());
  EXPECT_THROW((void)query.first_hit(Vec3::Zero(), Vec3::Zero()), InvalidInputError);
}

TEST(SurfaceQuery, is_inside_agrees_with_the_analytic_cube_including_axes_and_grid_lines) {
  const SurfaceQuery query(centred_cube());
  auto expected = [](const Vec3& p) { return (p.array().abs() < kHalf).all(); };
  int checked = 0, inside = 0;
  // Grid points (many on the coordinate axes and on lines through edges and face diagonals of
  // the triangulation), skipping the ones on the surface itself.
  for (int i = -6; i <= 6; ++i)
    for (int j = -6; j <= 6; ++j)
      for (int k = -6; k <= 6; ++k) {
        const Vec3 p = Vec3(i, j, k) * (kHalf / 4);
        if (std::abs(i) == 4 || std::abs(j) == 4 || std::abs(k) == 4) continue;
        ASSERT_EQ(query.is_inside(p), expected(p)) << "grid point " << p.transpose();
        ++checked;
        inside += expected(p);
      }
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-2 * kHalf, 2 * kHalf);
  for (int i = 0; i < 2000; ++i) {
    const Vec3 p(u(rng), u(rng), u(rng));
    ASSERT_EQ(query.is_inside(p), expected(p)) << "random point " << p.transpose();
    ++checked;
    inside += expected(p);
  }
  EXPECT_GT(inside, 300);
  EXPECT_GT(checked - inside, 300);
}

TEST(SurfaceQuery, distance_up_to_is_the_distance_capped_at_the_limit) {
  const TriMesh sphere = make_icosphere(0.04, 3, Vec3(0.01, -0.02, 0.03));
  const SurfaceQuery query(sphere);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  int capped = 0, exact = 0;
  for (int i = 0; i < 500; ++i) {
    const Vec3 p(u(rng), u(rng), u(rng));
    const double d = brute_force_distance(sphere, p);
    for (const double limit : {0.0, 0.005, 0.02, 0.2}) {
      EXPECT_NEAR(query.distance_up_to(p, limit), std::min(d, limit), 1e-15) << p.transpose() << " limit " << limit;
      (d < limit ? exact : capped)++;
    }
  }
  EXPECT_GT(exact, 300);
  EXPECT_GT(capped, 300);
  EXPECT_THROW((void)query.distance_up_to(Vec3::Zero(), -1.0), InvalidInputError);
  EXPECT_THROW((void)query.distance_up_to(Vec3::Constant(std::nan("")), 1.0), InvalidInputError);
}

// An open tube (a cylinder without its end caps, axis along a tilted direction): rays across the
// axis see it as closed, so points inside the tube are inside at any height.
TEST(SurfaceQuery, is_inside_across_an_axis_sees_a_tube_open_at_its_ends_as_closed) {
  const Vec3 axis = Vec3(0.2, -0.3, 1.0).normalized();
  const Vec3 u = axis.cross(Vec3::UnitX()).normalized(), v = axis.cross(u);
  const double radius = 0.1, length = 0.04;  // a short wide band: most rays not across the axis leave through an end
  const int n = 48, rings = 30;
  TriMesh tube;
  for (int r = 0; r <= rings; ++r)
    for (int j = 0; j < n; ++j) {
      const double a = 2 * M_PI * j / n;
      tube.vertices.push_back(length * r / rings * axis + radius * (std::cos(a) * u + std::sin(a) * v));
    }
  for (int r = 0; r < rings; ++r)
    for (int j = 0; j < n; ++j) {
      const int a = r * n + j, b = r * n + (j + 1) % n;
      tube.triangles.push_back({a, b, b + n});
      tube.triangles.push_back({a, b + n, a + n});
    }
  const SurfaceQuery query(tube);
  const double inner = radius * std::cos(M_PI / n);  // the polygon's smallest radius
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> h(0.005, length - 0.005), a(0.0, 2 * M_PI), r(0.0, 2 * radius);
  int inside = 0, outside = 0;
  for (int i = 0; i < 1000; ++i) {
    const double rr = r(rng), aa = a(rng);
    if (std::abs(rr - radius) < 1e-3) continue;
    const Vec3 p = h(rng) * axis + rr * (std::cos(aa) * u + std::sin(aa) * v);
    const bool expected = rr < inner;
    ASSERT_EQ(query.is_inside_across(p, 2.5 * axis), expected) << "r = " << rr;
    (expected ? inside : outside)++;
  }
  EXPECT_GT(inside, 200);
  EXPECT_GT(outside, 200);
  // The plain test casts rays that leave through the open ends: it does not see the tube closed.
  int plain_wrong = 0;
  for (int i = 0; i < 200; ++i) plain_wrong += !query.is_inside(h(rng) * axis);
  EXPECT_GT(plain_wrong, 0);
  EXPECT_THROW((void)query.is_inside_across(Vec3::Zero(), Vec3::Zero()), InvalidInputError);
}

TEST(SurfaceQuery, is_inside_agrees_with_the_exact_polyhedron_of_an_icosphere) {
  const Vec3 c(0.02, 0.0, -0.1);
  const TriMesh sphere = make_icosphere(0.06, 3, c);
  const SurfaceQuery query(sphere);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-0.09, 0.09);
  int inside = 0, outside = 0;
  std::vector<Vec3> points;
  for (int i = 0; i < 3000; ++i) points.push_back(c + Vec3(u(rng), u(rng), u(rng)));
  // Points on the axes through the centre and on its vertices' rays.
  for (int i = -8; i <= 8; ++i)
    for (int a = 0; a < 3; ++a) points.push_back(c + 0.01 * i * Vec3::Unit(a));
  for (int v = 0; v < 12; ++v)
    for (const double s : {0.3, 0.9, 1.1}) points.push_back(c + s * (sphere.vertices[v] - c));
  for (const Vec3& p : points) {
    double clearance = 0;
    const bool expected = inside_convex(sphere, p, &clearance);
    if (clearance < 1e-9) continue;
    ASSERT_EQ(query.is_inside(p), expected) << "point " << (p - c).transpose() << " relative to the centre";
    (expected ? inside : outside)++;
  }
  EXPECT_GT(inside, 300);
  EXPECT_GT(outside, 300);
}

TEST(SurfaceQuery, signed_distance_is_negative_inside_with_the_analytic_value) {
  const SurfaceQuery query(centred_cube());
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(-2 * kHalf, 2 * kHalf);
  for (int i = 0; i < 500; ++i) {
    const Vec3 p(u(rng), u(rng), u(rng));
    const double distance = (p - closest_on_box_surface(p, kHalf)).norm();
    const bool inside = (p.array().abs() < kHalf).all();
    EXPECT_NEAR(query.signed_distance(p), inside ? -distance : distance, 1e-12) << p.transpose();
  }
  EXPECT_NEAR(query.signed_distance(Vec3::Zero()), -kHalf, 1e-15);
  EXPECT_NEAR(query.signed_distance(Vec3(3 * kHalf, 0, 0)), 2 * kHalf, 1e-15);
}

TEST(SurfaceQuery, concurrent_queries_give_the_serial_answers) {
  const TriMesh sphere = make_icosphere(0.06, 4);
  const SurfaceQuery query(sphere);
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  std::vector<Vec3> points(2000);
  for (Vec3& p : points) p = Vec3(u(rng), u(rng), u(rng));
  std::vector<double> serial(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) serial[i] = query.signed_distance(points[i]);

  constexpr int kThreads = 4;
  std::vector<double> parallel(points.size());
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      for (std::size_t i = t; i < points.size(); i += kThreads) parallel[i] = query.signed_distance(points[i]);
    });
  for (std::thread& th : threads) th.join();
  EXPECT_EQ(parallel, serial);
}

TEST(SurfaceQuery, copies_the_mesh_and_survives_a_move) {
  TriMesh cube = centred_cube();
  SurfaceQuery query(cube);
  cube.vertices.clear();  // later edits of the source are not seen
  const SurfaceQuery moved(std::move(query));
  EXPECT_EQ(moved.mesh().num_triangles(), 12);
  EXPECT_NEAR(moved.closest_point(Vec3(0, 0, 1)).distance, 1 - kHalf, 1e-15);
}

}  // namespace
}  // namespace socketsmith::geometry
