#include "socketsmith/geometry/mesh_checks.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_io.h"
#include "test_shapes.h"

namespace socketsmith::geometry {
namespace {

namespace fs = std::filesystem;
using test::error_message;
using test::make_cube;
using test::make_icosphere;

bool contains(const std::string& s, const std::string& needle) { return s.find(needle) != std::string::npos; }

TEST(MeshChecks, closed_cube_and_sphere_are_valid_closed_surfaces) {
  for (const TriMesh& m : {make_cube(0.1), make_icosphere(0.05, 3)}) {
    const MeshCheckReport r = check_mesh(m);
    EXPECT_EQ(r.num_vertices, m.num_vertices());
    EXPECT_EQ(r.num_triangles, m.num_triangles());
    EXPECT_TRUE(r.is_valid_closed_surface());
    EXPECT_EQ(r.boundary_edges, 0);
    EXPECT_EQ(r.boundary_loops, 0);
    EXPECT_EQ(r.connected_components, 1);
    EXPECT_NEAR(r.signed_volume_m3, signed_volume(m), 1e-15);
    EXPECT_GT(r.signed_volume_m3, 0.0);
    EXPECT_TRUE(r.problems().empty());
    EXPECT_NO_THROW(require_closed_surface(m, "limb 'test'"));
  }
  EXPECT_NEAR(check_mesh(make_cube(0.1)).signed_volume_m3, 1e-3, 1e-15);
}

TEST(MeshChecks, cube_missing_a_face_has_one_loop_of_four_edges) {
  TriMesh m = make_cube(0.1);
  m.triangles.erase(m.triangles.begin(), m.triangles.begin() + 2);  // the bottom face
  const MeshCheckReport r = check_mesh(m);
  EXPECT_FALSE(r.is_closed());
  EXPECT_TRUE(r.is_manifold());
  EXPECT_TRUE(r.is_oriented());
  EXPECT_EQ(r.boundary_edges, 4);
  EXPECT_EQ(r.boundary_loops, 1);
  EXPECT_EQ(r.connected_components, 1);
  ASSERT_EQ(r.problems().size(), 1u);
  EXPECT_TRUE(contains(r.problems()[0], "1 boundary loop with 4 boundary edges")) << r.problems()[0];

  const std::string msg = error_message<TopologyError>([&] { require_closed_surface(m, "limb 'x.stl'"); });
  EXPECT_EQ(msg, "limb 'x.stl' is open: 1 boundary loop with 4 edges (close or cap it first)");
}

TEST(MeshChecks, open_tube_has_two_boundary_loops) {
  const TriMesh tube = test::make_open_tube(0.05, 0.2, 24);
  const MeshCheckReport r = check_mesh(tube);
  EXPECT_EQ(r.boundary_edges, 48);
  EXPECT_EQ(r.boundary_loops, 2);
  EXPECT_TRUE(r.is_manifold());
  EXPECT_TRUE(r.is_oriented());
  const std::string msg = error_message<TopologyError>([&] { require_closed_surface(tube, "liner 'tube.stl'"); });
  EXPECT_TRUE(contains(msg, "liner 'tube.stl' is open: 2 boundary loops with 48 edges")) << msg;
}

TEST(MeshChecks, three_triangles_on_one_edge_are_non_manifold) {
  TriMesh m;
  m.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, -1, 0), Vec3(0, 0, 1)};
  m.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  const MeshCheckReport r = check_mesh(m);
  EXPECT_EQ(r.non_manifold_edges, 1);
  EXPECT_EQ(r.boundary_edges, 6);
  EXPECT_EQ(r.connected_components, 1);

  // A closed cube with a fin on one edge: closed elsewhere, non-manifold on that edge.
  TriMesh finned = make_cube(1.0);
  finned.vertices.emplace_back(0.5, -1.0, -1.0);
  finned.triangles.push_back({0, 1, 8});
  const MeshCheckReport f = check_mesh(finned);
  EXPECT_EQ(f.non_manifold_edges, 1);
  EXPECT_EQ(f.boundary_edges, 2);
  EXPECT_FALSE(f.is_valid_closed_surface());

  // Two copies of the same cube on top of each other: every edge is used four times.
  const TriMesh doubled = test::merged(make_cube(1.0), make_cube(1.0));
  TriMesh shared = make_cube(1.0);
  shared.triangles.insert(shared.triangles.end(), doubled.triangles.begin(), doubled.triangles.begin() + 12);
  const MeshCheckReport d = check_mesh(shared);
  EXPECT_EQ(d.non_manifold_edges, 18);
  EXPECT_EQ(d.boundary_edges, 0);
  const std::string msg = error_message<TopologyError>([&] { require_closed_surface(shared, "limb 'd.stl'"); });
  EXPECT_TRUE(contains(msg, "limb 'd.stl' is non-manifold: 18 edges are shared by more than two triangles")) << msg;
}

TEST(MeshChecks, one_flipped_triangle_is_inconsistent_orientation) {
  TriMesh m = make_icosphere(0.05, 2);
  std::swap(m.triangles[7][1], m.triangles[7][2]);
  const MeshCheckReport r = check_mesh(m);
  EXPECT_TRUE(r.is_closed());
  EXPECT_TRUE(r.is_manifold());
  EXPECT_EQ(r.inconsistently_oriented_edges, 3);
  EXPECT_FALSE(r.is_valid_closed_surface());
  const std::string msg = error_message<TopologyError>([&] { require_closed_surface(m, "limb 'f.stl'"); });
  EXPECT_TRUE(contains(msg, "inconsistently oriented: 3 edges")) << msg;
}

TEST(MeshChecks, inside_out_surface_says_flip_the_orientation) {
  TriMesh m = make_icosphere(0.05, 2);
  flip_orientation(m);
  const MeshCheckReport r = check_mesh(m);
  EXPECT_TRUE(r.is_valid_closed_surface());  // topologically fine...
  EXPECT_LT(r.signed_volume_m3, 0.0);        // ...but inside-out
  ASSERT_EQ(r.problems().size(), 1u);
  EXPECT_TRUE(contains(r.problems()[0], "normals point inward"));
  const std::string msg = error_message<TopologyError>([&] { require_closed_surface(m, "limb 'in.stl'"); });
  EXPECT_TRUE(contains(msg, "limb 'in.stl'")) << msg;
  EXPECT_TRUE(contains(msg, "normals point inward")) << msg;
  EXPECT_TRUE(contains(msg, "(flip the orientation)")) << msg;
}

TEST(MeshChecks, two_components_are_counted_and_split_largest_first) {
  const TriMesh cube = make_cube(0.05, Vec3(0.3, 0, 0));
  const TriMesh sphere = make_icosphere(0.05, 2);  // 320 triangles
  const TriMesh both = test::merged(cube, sphere);
  const MeshCheckReport r = check_mesh(both);
  EXPECT_EQ(r.connected_components, 2);
  EXPECT_TRUE(r.is_valid_closed_surface());
  EXPECT_NEAR(r.signed_volume_m3, signed_volume(cube) + signed_volume(sphere), 1e-12);

  const std::vector<TriMesh> parts = split_components(both);
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[0].num_triangles(), 320);
  EXPECT_EQ(parts[0].num_vertices(), sphere.num_vertices());
  EXPECT_EQ(parts[1].num_triangles(), 12);
  EXPECT_EQ(parts[1].num_vertices(), 8);  // compacted
  EXPECT_NEAR(signed_volume(parts[0]), signed_volume(sphere), 1e-15);
  EXPECT_NEAR(signed_volume(parts[1]), signed_volume(cube), 1e-15);
  for (const TriMesh& p : parts) EXPECT_EQ(check_mesh(p).connected_components, 1);
}

TEST(MeshChecks, components_touching_at_one_vertex_are_split_with_a_copy_of_it) {
  TriMesh m;
  m.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(-1, 0, 0), Vec3(0, -1, 0)};
  m.triangles = {{0, 1, 2}, {0, 3, 4}};
  EXPECT_EQ(check_mesh(m).connected_components, 2);
  const auto parts = split_components(m);
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[0].num_vertices(), 3);
  EXPECT_EQ(parts[1].num_vertices(), 3);
}

TEST(MeshChecks, nan_vertex_is_invalid_input) {
  TriMesh m = make_cube(0.1);
  m.vertices[3].y() = std::nan("");
  const MeshCheckReport r = check_mesh(m);
  EXPECT_EQ(r.non_finite_vertices, 1);
  EXPECT_FALSE(r.is_valid_closed_surface());
  EXPECT_TRUE(std::isfinite(r.signed_volume_m3));
  const std::string msg = error_message<InvalidInputError>([&] { require_closed_surface(m, "limb 'n.stl'"); });
  EXPECT_TRUE(contains(msg, "limb 'n.stl' has 1 vertex with NaN or infinite coordinates")) << msg;
}

TEST(MeshChecks, out_of_range_indices_are_counted_not_dereferenced) {
  TriMesh m = make_cube(0.1);
  m.triangles[0][1] = -1;
  m.triangles[5][2] = 8;
  const MeshCheckReport r = check_mesh(m);
  EXPECT_EQ(r.out_of_range_indices, 2);
  EXPECT_FALSE(r.is_valid_closed_surface());
  EXPECT_THROW(require_closed_surface(m, "limb"), InvalidInputError);
  EXPECT_THROW(split_components(m), InvalidInputError);
}

TEST(MeshChecks, degenerate_triangles_are_counted) {
  TriMesh m = make_cube(0.1);
  m.vertices.emplace_back(0.05, 0.02, 0.0);  // vertex 8
  m.triangles.push_back({0, 0, 1});          // repeated index: degenerate
  m.triangles.push_back({0, 3, 8});          // a sliver with real area: not degenerate
  m.vertices.emplace_back(0.1, 0.1, 0.0);    // vertex 9, same position as vertex 3
  m.triangles.push_back({0, 3, 9});          // zero area: degenerate
  const MeshCheckReport r = check_mesh(m);
  EXPECT_EQ(r.degenerate_triangles, 2);
  const std::vector<std::string> problems = r.problems();
  EXPECT_TRUE(std::any_of(problems.begin(), problems.end(),
                          [](const std::string& p) { return contains(p, "2 degenerate triangles"); }));
}

TEST(MeshChecks, empty_mesh) {
  const MeshCheckReport r = check_mesh(TriMesh{});
  EXPECT_FALSE(r.is_valid_closed_surface());
  EXPECT_EQ(r.connected_components, 0);
  EXPECT_EQ(r.problems(), std::vector<std::string>{"no triangles"});
  EXPECT_THROW(require_closed_surface(TriMesh{}, "limb"), TopologyError);
  EXPECT_TRUE(split_components(TriMesh{}).empty());
}

TEST(MeshChecks, report_is_invariant_under_rigid_motion) {
  const TriMesh s = make_icosphere(0.05, 3);
  const MeshCheckReport a = check_mesh(s);
  const MeshCheckReport b = check_mesh(test::transformed(s, test::random_rigid_motion(7)));
  EXPECT_EQ(a.boundary_edges, b.boundary_edges);
  EXPECT_EQ(a.connected_components, b.connected_components);
  EXPECT_NEAR(a.signed_volume_m3, b.signed_volume_m3, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Real assets from ../shared/data (skipped when the folder is absent).

fs::path shared_data_dir() { return fs::path(SOCKETSMITH_SHARED_DATA_DIR); }

#define SKIP_WITHOUT_SHARED_DATA(file)                                                           \
  do {                                                                                           \
    if (!fs::exists(file))                                                                       \
      GTEST_SKIP() << "shared data not found at '" << fs::path(file).string()                    \
                   << "' (expected ../shared/data next to the source folder); skipping asset test"; \
  } while (0)

// find_self_intersections on pairs whose answer is known by construction, one rule each.
TEST(SelfIntersections, triangle_pairs_by_what_they_share) {
  auto count = [](const std::vector<Vec3>& v, const std::vector<std::array<int, 3>>& t) {
    TriMesh m;
    m.vertices = v;
    m.triangles = t;
    return find_self_intersections(m).pairs;
  };
  // No shared vertex: two triangles crossing like links of a chain; the same two apart.
  const std::vector<Vec3> chain{{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0.5, 0.5, -1}, {0.5, 0.5, 1}, {3, 3, 0}};
  EXPECT_EQ(count(chain, {{0, 1, 2}, {3, 4, 5}}), 1);
  std::vector<Vec3> apart = chain;
  for (int i = 3; i < 6; ++i) apart[i] += Vec3(5, 0, 0);
  EXPECT_EQ(count(apart, {{0, 1, 2}, {3, 4, 5}}), 0);
  // One shared vertex: a fan around it meets only there; a triangle whose far edge pierces the other does not.
  const std::vector<Vec3> fan{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0.2}, {0, -1, 0.3}, {0.3, 0.3, -1}, {0.3, 0.3, 1}};
  EXPECT_EQ(count(fan, {{0, 1, 2}, {0, 3, 4}}), 0);
  EXPECT_EQ(count(fan, {{0, 1, 2}, {0, 5, 6}}), 1);
  // One shared edge: a hinge at 90 degrees, flat on the other side, or folded onto the first.
  const std::vector<Vec3> hinge{{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0.5, 0, 1}, {0.5, -1, 0}, {0.5, 0.5, 0}};
  EXPECT_EQ(count(hinge, {{0, 1, 2}, {1, 0, 3}}), 0);
  EXPECT_EQ(count(hinge, {{0, 1, 2}, {1, 0, 4}}), 0);
  EXPECT_EQ(count(hinge, {{0, 1, 2}, {0, 1, 5}}), 1);
  // The same triangle twice.
  EXPECT_EQ(count(hinge, {{0, 1, 2}, {2, 0, 1}}), 1);
  // Skipped: a degenerate (collinear) triangle through the other, an index out of range.
  EXPECT_EQ(count({{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0.5, 0.5, -1}, {0.5, 0.5, 1}, {0.5, 0.5, 0}}, {{0, 1, 2}, {3, 4, 5}}), 0);
  EXPECT_EQ(count(chain, {{0, 1, 2}, {3, 4, 99}}), 0);
}

// Shells: a sphere inside another does not cross it, two overlapping spheres do — as CGAL's own
// does_self_intersect says (has_self_intersections, an independent implementation) — and the
// first pair found lies on the circle where they cross; a rigid motion changes nothing.
TEST(SelfIntersections, nested_spheres_do_not_cross_overlapping_ones_do) {
  const TriMesh outer = make_icosphere(1.0, 3);
  const TriMesh nested = test::merged(outer, make_icosphere(0.5, 3));
  // The second sphere turned about its centre, so that no vertex of one lies exactly on the other
  // (mirror-image tessellations touch on the plane between them).
  Eigen::Isometry3d turn = test::random_rigid_motion(3);
  turn.translation() = Vec3(1.0, 0, 0);
  const TriMesh overlapping = test::merged(outer, test::transformed(make_icosphere(1.0, 3), turn));
  EXPECT_EQ(find_self_intersections(outer).pairs, 0);
  EXPECT_EQ(find_self_intersections(nested).pairs, 0);
  EXPECT_FALSE(has_self_intersections(nested));
  const SelfIntersections si = find_self_intersections(overlapping);
  EXPECT_TRUE(has_self_intersections(overlapping));
  // The spheres cross on the circle x = 0.5, radius sqrt(3)/2; level-3 icosphere edges are < 0.2.
  ASSERT_GT(si.pairs, 0);
  for (int t : {si.first_a, si.first_b}) {
    const auto& tri = overlapping.triangles[t];
    const Vec3 c = (overlapping.vertices[tri[0]] + overlapping.vertices[tri[1]] + overlapping.vertices[tri[2]]) / 3.0;
    EXPECT_NEAR(c.x(), 0.5, 0.2);
    EXPECT_NEAR(std::hypot(c.y(), c.z()), std::sqrt(3.0) / 2.0, 0.2);
  }
  // Every crossing pair has one triangle of each sphere: as many pairs as after a rigid motion.
  EXPECT_EQ(find_self_intersections(test::transformed(overlapping, test::random_rigid_motion(7))).pairs, si.pairs);
}

// A sphere with one vertex pushed through to the far side folds through itself (CGAL agrees);
// check_mesh counts it only when asked and then lists it as a problem.
TEST(SelfIntersections, a_vertex_pushed_through_the_sphere_is_a_problem_check_mesh_reports) {
  TriMesh m = make_icosphere(1.0, 2);
  int top = 0;
  for (int v = 0; v < m.num_vertices(); ++v)
    if (m.vertices[v].z() > m.vertices[top].z()) top = v;
  m.vertices[top] = Vec3(0.01, 0.02, -1.5);
  EXPECT_TRUE(has_self_intersections(m));
  EXPECT_GT(find_self_intersections(m).pairs, 0);
  EXPECT_EQ(check_mesh(m).self_intersecting_pairs, -1);
  MeshCheckOptions o;
  o.find_self_intersections = true;
  const MeshCheckReport r = check_mesh(m, o);
  EXPECT_EQ(r.self_intersecting_pairs, find_self_intersections(m).pairs);
  EXPECT_FALSE(r.is_valid_closed_surface());
  const auto problems = r.problems();
  ASSERT_FALSE(problems.empty());
  EXPECT_TRUE(contains(problems.back(), "self-intersecting: ")) << problems.back();
  EXPECT_TRUE(check_mesh(make_icosphere(1.0, 2), o).is_valid_closed_surface());
}

TEST(RealAssets, openlimb_transtibial_limb_with_bones) {
  const fs::path file = shared_data_dir() / "limbs/transtibial/openlimb_tt_mean_limb_with_bones_mm.stl";
  SKIP_WITHOUT_SHARED_DATA(file);
  test::LogCapture quiet;
  MeshReadOptions opt;
  opt.unit = units::LengthUnit::Millimetre;
  MeshReadInfo info;
  const TriMesh m = read_mesh(file, opt, &info);
  EXPECT_TRUE(info.warning.empty()) << info.warning;

  const Vec3 extent = bounding_box(m).extent();
  EXPECT_NEAR(extent.x(), 0.128, 0.005);
  EXPECT_NEAR(extent.y(), 0.135, 0.005);
  EXPECT_NEAR(extent.z(), 0.257, 0.005);

  const MeshCheckReport r = check_mesh(m);
  EXPECT_EQ(r.connected_components, 5);
  EXPECT_EQ(r.non_finite_vertices, 0);
  EXPECT_EQ(r.out_of_range_indices, 0);

  const std::vector<TriMesh> parts = split_components(m);
  ASSERT_EQ(parts.size(), 5u);
  for (std::size_t i = 1; i < parts.size(); ++i)
    EXPECT_GE(parts[i - 1].num_triangles(), parts[i].num_triangles());
  // The skin is the largest part: open at the top with one boundary loop; it contains the bones.
  const MeshCheckReport skin = check_mesh(parts[0]);
  EXPECT_EQ(skin.boundary_loops, 1);
  EXPECT_FALSE(skin.is_closed());
  EXPECT_TRUE(bounding_box(parts[0]).extent().isApprox(extent, 1e-9));

  // Unit guess agrees (the file is in mm).
  MeshReadInfo guessed;
  read_mesh(file, {}, &guessed);
  EXPECT_TRUE(guessed.unit_was_guessed);
  EXPECT_EQ(guessed.unit, units::LengthUnit::Millimetre);
}

TEST(RealAssets, ampscan_limb_scan_is_open_with_one_boundary_loop) {
  const fs::path file = shared_data_dir() / "limbs/transtibial/ampscan_limb_scan_mm.stl";
  SKIP_WITHOUT_SHARED_DATA(file);
  test::LogCapture quiet;
  MeshReadOptions opt;
  opt.unit = units::LengthUnit::Millimetre;
  MeshReadInfo info;
  const TriMesh m = read_mesh(file, opt, &info);
  EXPECT_TRUE(info.warning.empty()) << info.warning;
  const MeshCheckReport r = check_mesh(m);
  EXPECT_EQ(r.boundary_loops, 1);
  EXPECT_EQ(r.non_finite_vertices, 0);
  const double diagonal = bounding_box(m).extent().norm();
  EXPECT_GT(diagonal, kMinPlausibleSize_m);
  EXPECT_LT(diagonal, 1.0);
  const std::string msg = error_message<TopologyError>([&] { require_closed_surface(m, "limb 'ampscan'"); });
  EXPECT_TRUE(contains(msg, "is open: 1 boundary loop")) << msg;
}

}  // namespace
}  // namespace socketsmith::geometry
