// Booleans of closed surfaces: volumes against the analytic ones (overlapping cubes, a drilled
// cube), valid closed results, and the operands' checks.
#include "socketsmith/geometry/mesh_boolean.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "test_shapes.h"

namespace socketsmith::geometry {
namespace {

using test::make_cube;

/// Two meshes as one (disjoint components).
TriMesh merged(TriMesh a, const TriMesh& b) {
  const int off = a.num_vertices();
  a.vertices.insert(a.vertices.end(), b.vertices.begin(), b.vertices.end());
  for (auto t : b.triangles) a.triangles.push_back({t[0] + off, t[1] + off, t[2] + off});
  return a;
}

/// A closed prism of n sides around the z axis through (x, y), tangent to the circle of radius r.
TriMesh drill(double x, double y, double r, double z0, double z1, int n = 32) {
  TriMesh m;
  const double rv = r / std::cos(std::numbers::pi / n);
  m.vertices.push_back({x, y, z0});
  m.vertices.push_back({x, y, z1});
  for (int k = 0; k < n; ++k) {
    const double a = 2 * std::numbers::pi * (k + 0.5) / n;
    m.vertices.push_back({x + rv * std::cos(a), y + rv * std::sin(a), z0});
    m.vertices.push_back({x + rv * std::cos(a), y + rv * std::sin(a), z1});
  }
  for (int k = 0; k < n; ++k) {
    const int lo = 2 + 2 * k, hi = lo + 1, lo1 = 2 + 2 * ((k + 1) % n), hi1 = lo1 + 1;
    m.triangles.push_back({0, lo1, lo});
    m.triangles.push_back({1, hi, hi1});
    m.triangles.push_back({lo, lo1, hi1});
    m.triangles.push_back({lo, hi1, hi});
  }
  return m;
}

void expect_solid(const TriMesh& m) {
  const MeshCheckReport rep = check_mesh(m);
  EXPECT_TRUE(rep.is_valid_closed_surface()) << (rep.problems().empty() ? "" : rep.problems().front());
  EXPECT_FALSE(has_self_intersections(m));
}

TEST(MeshBoolean, overlapping_cubes_give_the_analytic_volumes) {
  const TriMesh a = make_cube(1.0), b = make_cube(1.0, Vec3::Constant(0.5));
  const TriMesh u = mesh_boolean(a, b, BooleanOperation::Union);
  const TriMesh d = mesh_boolean(a, b, BooleanOperation::Difference);
  const TriMesh i = mesh_boolean(a, b, BooleanOperation::Intersection);
  EXPECT_NEAR(signed_volume(u), 2.0 - 0.125, 1e-12);
  EXPECT_NEAR(signed_volume(d), 1.0 - 0.125, 1e-12);
  EXPECT_NEAR(signed_volume(i), 0.125, 1e-12);
  expect_solid(u);
  expect_solid(d);
  expect_solid(i);
}

TEST(MeshBoolean, four_drills_at_once_make_four_through_holes) {
  const TriMesh plate = make_cube(1.0);
  TriMesh drills;
  for (const auto& [x, y] : {std::pair{0.25, 0.25}, std::pair{0.75, 0.25}, std::pair{0.75, 0.75}, std::pair{0.25, 0.75}})
    drills = drills.empty() ? drill(x, y, 0.1, -0.5, 1.5) : merged(drills, drill(x, y, 0.1, -0.5, 1.5));
  const TriMesh holed = mesh_boolean(plate, drills, BooleanOperation::Difference);
  expect_solid(holed);
  // Four prisms of 32 sides circumscribing r = 0.1 (area n r² tan(π/n)), through the unit height.
  const double prism = 32 * 0.01 * std::tan(std::numbers::pi / 32);
  EXPECT_NEAR(signed_volume(holed), 1.0 - 4 * prism, 1e-12);
  EXPECT_EQ(check_mesh(holed).connected_components, 1);
}

TEST(MeshBoolean, operands_that_are_not_solids_are_refused_in_one_line) {
  const TriMesh cube = make_cube(1.0);
  TriMesh open = cube;
  open.triangles.pop_back();
  EXPECT_THROW(mesh_boolean(cube, open, BooleanOperation::Union), TopologyError);
  const TriMesh folded = merged(cube, make_cube(1.0, Vec3::Constant(0.5)));  // two overlapping shells
  EXPECT_TRUE(has_self_intersections(folded));
  EXPECT_FALSE(has_self_intersections(cube));
  try {
    mesh_boolean(folded, cube, BooleanOperation::Union);
    ADD_FAILURE() << "no error";
  } catch (const TopologyError& e) {
    EXPECT_NE(std::string(e.what()).find("the first operand self-intersects"), std::string::npos) << e.what();
  }
  EXPECT_THROW(mesh_boolean(TriMesh{}, cube, BooleanOperation::Union), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::geometry
