#include "socketsmith/geometry/tri_mesh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "socketsmith/core/errors.h"
#include "test_shapes.h"

namespace socketsmith::geometry {
namespace {

using test::make_cube;
using test::make_icosphere;

TEST(TriMesh, unit_cube_has_volume_one_and_area_six) {
  const TriMesh cube = make_cube(1.0);
  EXPECT_NEAR(signed_volume(cube), 1.0, 1e-12);
  EXPECT_NEAR(surface_area(cube), 6.0, 1e-12);
}

TEST(TriMesh, volume_and_area_are_invariant_under_rigid_motion) {
  const TriMesh cube = make_cube(0.3);
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const TriMesh moved = test::transformed(cube, test::random_rigid_motion(seed));
    EXPECT_NEAR(signed_volume(moved), 0.027, 1e-12);
    EXPECT_NEAR(surface_area(moved), 6 * 0.09, 1e-12);
  }
}

TEST(TriMesh, area_centroid_is_the_cubes_centre_and_follows_a_rigid_motion_but_a_flat_surface_has_none) {
  const TriMesh cube = make_cube(0.3);
  Vec3 centre = Vec3::Zero();
  for (const Vec3& v : cube.vertices) centre += v / static_cast<double>(cube.vertices.size());
  ASSERT_TRUE(area_centroid(cube).has_value());
  EXPECT_LT((*area_centroid(cube) - centre).norm(), 1e-12);
  const auto motion = test::random_rigid_motion(3);
  const auto moved = area_centroid(test::transformed(cube, motion));
  ASSERT_TRUE(moved.has_value());
  EXPECT_LT((*moved - motion * centre).norm(), 1e-12);
  TriMesh collapsed = cube;
  for (Vec3& v : collapsed.vertices) v = centre;  // every triangle of zero area
  EXPECT_FALSE(area_centroid(collapsed).has_value());
}

TEST(TriMesh, icosphere_volume_and_area_converge_to_the_sphere) {
  const double r = 0.07;
  const double v_exact = 4.0 / 3.0 * M_PI * r * r * r;
  const double a_exact = 4.0 * M_PI * r * r;
  double previous_error = 1.0;
  for (int level = 1; level <= 4; ++level) {
    const TriMesh s = make_icosphere(r, level, Vec3(1, 2, 3));
    const double err = std::abs(signed_volume(s) - v_exact) / v_exact;
    EXPECT_LT(err, previous_error) << "level " << level;
    previous_error = err;
    EXPECT_LT(std::abs(surface_area(s) - a_exact) / a_exact, 0.2);
  }
  // Level 4 (5120 triangles): inscribed polyhedron within 0.5% of the sphere, and below it.
  const TriMesh s = make_icosphere(r, 4);
  EXPECT_NEAR(signed_volume(s), v_exact, 0.005 * v_exact);
  EXPECT_LT(signed_volume(s), v_exact);
  EXPECT_NEAR(surface_area(s), a_exact, 0.005 * a_exact);
}

TEST(TriMesh, flipping_the_orientation_negates_the_volume) {
  TriMesh s = make_icosphere(1.0, 2);
  const double v = signed_volume(s);
  flip_orientation(s);
  EXPECT_NEAR(signed_volume(s), -v, 1e-12);
  flip_orientation(s);
  EXPECT_NEAR(signed_volume(s), v, 1e-12);
}

TEST(TriMesh, cube_normals_point_outward_and_are_unit) {
  const TriMesh cube = make_cube(2.0);
  const Vec3 c(1, 1, 1);
  for (int t = 0; t < cube.num_triangles(); ++t) {
    const Vec3 n = triangle_normal(cube, t);
    EXPECT_NEAR(n.norm(), 1.0, 1e-12);
    const auto& tri = cube.triangles[t];
    const Vec3 centroid = (cube.vertices[tri[0]] + cube.vertices[tri[1]] + cube.vertices[tri[2]]) / 3.0;
    EXPECT_GT(n.dot(centroid - c), 0.0) << "triangle " << t;
    EXPECT_NEAR(triangle_area(cube, t), 2.0, 1e-12);
  }
}

TEST(TriMesh, degenerate_triangle_has_zero_normal_and_area) {
  TriMesh m;
  m.vertices = {Vec3(0, 0, 0), Vec3(1, 1, 1), Vec3(2, 2, 2)};
  m.triangles = {{0, 1, 2}};
  EXPECT_EQ(triangle_normal(m, 0), Vec3::Zero());
  EXPECT_DOUBLE_EQ(triangle_area(m, 0), 0.0);
}

TEST(TriMesh, bounding_box_of_a_cube) {
  const TriMesh cube = make_cube(0.5, Vec3(-1, 2, 3));
  const Aabb box = bounding_box(cube);
  EXPECT_FALSE(box.is_empty());
  EXPECT_TRUE(box.min.isApprox(Vec3(-1, 2, 3)));
  EXPECT_TRUE(box.max.isApprox(Vec3(-0.5, 2.5, 3.5)));
  EXPECT_TRUE(box.extent().isApprox(Vec3::Constant(0.5)));
  EXPECT_TRUE(bounding_box(TriMesh{}).is_empty());
}

TEST(TriMesh, scale_scales_volume_by_the_cube_of_the_factor) {
  TriMesh cube = make_cube(100.0);  // "millimetres"
  scale(cube, 1e-3);
  EXPECT_NEAR(signed_volume(cube), 1e-3, 1e-15);
  EXPECT_THROW(scale(cube, 0.0), InvalidInputError);
  EXPECT_THROW(scale(cube, std::nan("")), InvalidInputError);
}

TEST(TriMesh, volume_rejects_out_of_range_indices) {
  TriMesh cube = make_cube();
  cube.triangles[3][1] = 8;
  EXPECT_THROW(signed_volume(cube), InvalidInputError);
  EXPECT_THROW(weld_vertices(cube, 1e-9), InvalidInputError);
}

/// The cube as an STL-like soup: three fresh vertices per triangle.
TriMesh soup_of(const TriMesh& m) {
  TriMesh s;
  for (const auto& t : m.triangles) {
    const int b = s.num_vertices();
    for (int k = 0; k < 3; ++k) s.vertices.push_back(m.vertices[t[k]]);
    s.triangles.push_back({b, b + 1, b + 2});
  }
  return s;
}

TEST(WeldVertices, welds_a_triangle_soup_back_to_the_shared_mesh) {
  const TriMesh cube = make_cube(0.1);
  const TriMesh soup = soup_of(cube);
  ASSERT_EQ(soup.num_vertices(), 36);
  for (double tol : {0.0, 1e-9}) {
    const TriMesh w = weld_vertices(soup, tol);
    EXPECT_EQ(w.num_vertices(), 8) << "tol " << tol;
    EXPECT_EQ(w.num_triangles(), 12);
    EXPECT_NEAR(signed_volume(w), 1e-3, 1e-15);
  }
}

TEST(WeldVertices, merges_within_tolerance_also_across_cell_borders) {
  const double tol = 1e-6;
  TriMesh m;
  // Pairs 0.87*tol (diagonal) or 0.9*tol (one axis) apart, centred on multiples of tol and of
  // 2*tol so that the two points fall into different grid cells; pairs are 20*tol apart.
  int pairs = 0;
  for (int i = -6; i <= 6; ++i) {
    const double c = (20.0 * i + (i % 2 != 0 ? 1.0 : 0.0)) * tol;
    const Vec3 centre(c, -c, 2 * c);
    m.vertices.push_back(centre - Vec3::Constant(0.25 * tol));
    m.vertices.push_back(centre + Vec3::Constant(0.25 * tol));
    for (int axis = 0; axis < 3; ++axis) {
      const Vec3 shifted = centre + Vec3(0, 0, 5.0 * (axis + 1) * tol);
      m.vertices.push_back(shifted - 0.45 * tol * Vec3::Unit(axis));
      m.vertices.push_back(shifted + 0.45 * tol * Vec3::Unit(axis));
    }
    pairs += 4;
  }
  EXPECT_EQ(weld_vertices(m, tol).num_vertices(), pairs);

  TriMesh far_apart;  // just over tol apart: nothing merges
  for (int i = 0; i < 4; ++i) far_apart.vertices.emplace_back(1.01 * tol * i, 0.0, 0.0);
  EXPECT_EQ(weld_vertices(far_apart, tol).num_vertices(), 4);
}

TEST(WeldVertices, representatives_are_apart_and_cover_every_input_point) {
  // Compare with a brute-force O(n^2) check on jittered lattice points.
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> jitter(-0.6e-3, 0.6e-3);
  std::uniform_int_distribution<int> cell(0, 9);
  TriMesh m;
  for (int i = 0; i < 3000; ++i)
    m.vertices.emplace_back(cell(rng) * 3e-3 + jitter(rng), cell(rng) * 3e-3 + jitter(rng),
                            cell(rng) * 3e-3 + jitter(rng));
  const double tol = 1e-3;
  const TriMesh w = weld_vertices(m, tol);
  ASSERT_GT(w.num_vertices(), 100);
  ASSERT_LT(w.num_vertices(), m.num_vertices());
  for (int i = 0; i < w.num_vertices(); ++i)
    for (int j = i + 1; j < w.num_vertices(); ++j)
      ASSERT_GT((w.vertices[i] - w.vertices[j]).norm(), tol) << i << " " << j;
  for (const Vec3& p : m.vertices) {
    double best = 1e9;
    for (const Vec3& q : w.vertices) best = std::min(best, (p - q).norm());
    ASSERT_LE(best, tol);
  }
}

TEST(WeldVertices, drops_triangles_that_collapse) {
  TriMesh m;
  m.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1e-12, 0, 0), Vec3(0, 1, 0)};
  m.triangles = {{0, 1, 3}, {0, 2, 3}};  // the second collapses when 0 and 2 merge
  const TriMesh w = weld_vertices(m, 1e-9);
  EXPECT_EQ(w.num_vertices(), 3);
  EXPECT_EQ(w.num_triangles(), 1);
  EXPECT_THROW(weld_vertices(m, -1.0), InvalidInputError);
}

TEST(WeldVertices, never_merges_non_finite_vertices) {
  TriMesh m;
  const double nan = std::nan("");
  m.vertices = {Vec3(nan, 0, 0), Vec3(nan, 0, 0), Vec3(0, 0, 0)};
  m.triangles = {{0, 1, 2}};
  EXPECT_EQ(weld_vertices(m, 1e-9).num_vertices(), 3);
}

}  // namespace
}  // namespace socketsmith::geometry
