#include "socketsmith/geometry/mesh_repair.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "test_shapes.h"

namespace socketsmith::geometry {
namespace {

using test::make_cube;
using test::make_icosphere;
using Vec2 = Eigen::Vector2d;

double sphere_volume(double r) { return 4.0 / 3.0 * M_PI * r * r * r; }

/// Volume of the spherical cap of height h of a sphere of radius r.
double cap_volume(double r, double h) { return M_PI * h * h * (3 * r - h) / 3.0; }

bool contains(const std::vector<std::string>& lines, const std::string& needle) {
  return std::any_of(lines.begin(), lines.end(),
                     [&](const std::string& l) { return l.find(needle) != std::string::npos; });
}

/// Area and first moments (∫x dA, ∫y dA) of a simple polygon (shoelace formulas).
struct PolygonMoments {
  double area = 0, sx = 0, sy = 0;
};
PolygonMoments moments(const std::vector<Vec2>& poly) {
  PolygonMoments m;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const Vec2& p = poly[i];
    const Vec2& q = poly[(i + 1) % poly.size()];
    const double c = p.x() * q.y() - q.x() * p.y();
    m.area += c / 2;
    m.sx += (p.x() + q.x()) * c / 6;
    m.sy += (p.y() + q.y()) * c / 6;
  }
  return m;
}

/// Closed prism z ∈ [0, height] over a counter-clockwise polygon. @p points holds the outline
/// (first @p outline_size points) then any interior points; @p cap triangulates the polygon
/// (counter-clockwise triples into @p points).
TriMesh make_prism(const std::vector<Vec2>& points, int outline_size, const std::vector<std::array<int, 3>>& cap,
                   double height) {
  TriMesh m;
  const int n = static_cast<int>(points.size());
  for (const Vec2& p : points) m.vertices.emplace_back(p.x(), p.y(), 0.0);
  for (const Vec2& p : points) m.vertices.emplace_back(p.x(), p.y(), height);
  for (const auto& t : cap) {
    m.triangles.push_back({t[0], t[2], t[1]});              // bottom, facing −z
    m.triangles.push_back({t[0] + n, t[1] + n, t[2] + n});  // top, facing +z
  }
  for (int i = 0; i < outline_size; ++i) {
    const int j = (i + 1) % outline_size;
    m.triangles.push_back({i, j, j + n});
    m.triangles.push_back({i, j + n, i + n});
  }
  return m;
}

/// Prism over a polygon that is star-shaped around the origin (caps fanned from the origin).
TriMesh make_star_shaped_prism(const std::vector<Vec2>& outline, double height) {
  std::vector<Vec2> points = outline;
  const int centre = static_cast<int>(points.size());
  points.push_back(Vec2::Zero());
  std::vector<std::array<int, 3>> cap;
  for (int i = 0; i < centre; ++i) cap.push_back({centre, i, (i + 1) % centre});
  return make_prism(points, centre, cap, height);
}

/// A star with @p spikes spikes between radii r_in and r_out (counter-clockwise).
std::vector<Vec2> star_outline(int spikes, double r_in, double r_out) {
  std::vector<Vec2> p;
  for (int i = 0; i < 2 * spikes; ++i) {
    const double a = M_PI * i / spikes;
    const double r = i % 2 ? r_in : r_out;
    p.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  return p;
}

/// An annular sector ("C") between radii r_in and r_out, open around angle 0 (counter-clockwise).
std::vector<Vec2> c_outline(int segments, double r_in, double r_out) {
  const double a0 = 0.5, a1 = 2 * M_PI - 0.5;
  std::vector<Vec2> p;
  for (int k = 0; k <= segments; ++k) {
    const double a = a0 + (a1 - a0) * k / segments;
    p.emplace_back(r_out * std::cos(a), r_out * std::sin(a));
  }
  for (int k = 0; k <= segments; ++k) {
    const double a = a1 - (a1 - a0) * k / segments;
    p.emplace_back(r_in * std::cos(a), r_in * std::sin(a));
  }
  return p;
}

/// Triangulation of c_outline's polygon: the quad strip between its two arcs.
std::vector<std::array<int, 3>> c_cap(int segments) {
  std::vector<std::array<int, 3>> cap;
  auto inner = [&](int k) { return (segments + 1) + (segments - k); };  // inner point at outer k's angle
  for (int k = 0; k < segments; ++k) {
    cap.push_back({k, k + 1, inner(k + 1)});
    cap.push_back({k, inner(k + 1), inner(k)});
  }
  return cap;
}

/// Total area of the cap triangles (unsigned: overlapping caps would count twice).
double cap_area(const TrimResult& r) {
  double a = 0;
  for (int t = r.first_cap_triangle; t < r.mesh.num_triangles(); ++t) a += triangle_area(r.mesh, t);
  return a;
}

/// Area enclosed by a planar loop with unit normal @p n (shoelace in 3D).
double loop_area(const std::vector<Vec3>& loop, const Vec3& n) {
  Vec3 sum = Vec3::Zero();
  for (std::size_t i = 0; i < loop.size(); ++i) sum += loop[i].cross(loop[(i + 1) % loop.size()]);
  return 0.5 * std::abs(sum.dot(n));
}

/// Expectations common to every trim: a valid closed surface, loops in the plane, caps facing
/// +normal, kept vertices on the kept side.
void expect_clean_trim(const TrimResult& r, const Vec3& point, const Vec3& normal, double tol_m) {
  const Vec3 n = normal.normalized();
  const MeshCheckReport check = check_mesh(r.mesh);
  EXPECT_TRUE(check.is_valid_closed_surface()) << ::testing::PrintToString(check.problems());
  EXPECT_GT(check.signed_volume_m3, 0.0);
  ASSERT_GE(r.first_cap_triangle, 0);
  ASSERT_LE(r.first_cap_triangle, r.mesh.num_triangles());
  for (int t = r.first_cap_triangle; t < r.mesh.num_triangles(); ++t)
    EXPECT_GT(triangle_normal(r.mesh, t).dot(n), 1 - 1e-9) << "cap triangle " << t;
  // The caps tile their loops exactly: no overlap, no gap.
  double loops_area = 0;
  for (const auto& loop : r.loops) {
    EXPECT_GE(loop.size(), 3u);
    for (const Vec3& p : loop) EXPECT_LT(std::abs(n.dot(p - point)), tol_m);
    loops_area += loop_area(loop, n);
  }
  EXPECT_NEAR(cap_area(r), loops_area, 1e-9 * loops_area);
  for (const Vec3& p : r.mesh.vertices) EXPECT_LE(n.dot(p - point), tol_m);
}


// ---------------------------------------------------------------------------------------------
// repair_surface

TEST(MeshRepair, clean_closed_surfaces_are_left_unchanged) {
  for (const TriMesh& original : {make_cube(0.1), make_icosphere(0.06, 3)}) {
    TriMesh m = original;
    const RepairReport r = repair_surface(m);
    EXPECT_TRUE(r.changes().empty()) << ::testing::PrintToString(r.changes());
    EXPECT_EQ(r.remaining_boundary_loops, 0);
    EXPECT_EQ(m.triangles, original.triangles);
  }
}

TEST(MeshRepair, reorients_flipped_triangles_of_a_cube) {
  const TriMesh original = make_cube(0.1);
  TriMesh m = original;
  for (const int t : {1, 4, 7, 10}) std::swap(m.triangles[t][0], m.triangles[t][1]);
  ASSERT_FALSE(check_mesh(m).is_oriented());
  const RepairReport r = repair_surface(m);
  EXPECT_EQ(r.flipped_triangles, 4);
  EXPECT_FALSE(r.flipped_inside_out);
  EXPECT_TRUE(check_mesh(m).is_valid_closed_surface());
  EXPECT_NEAR(signed_volume(m), 1e-3, 1e-15);
  EXPECT_TRUE(contains(r.changes(), "re-oriented 4 triangles")) << ::testing::PrintToString(r.changes());
}

TEST(MeshRepair, flips_an_inside_out_sphere) {
  TriMesh m = make_icosphere(0.06, 3);
  const double volume = signed_volume(m);
  flip_orientation(m);
  ASSERT_LT(signed_volume(m), 0.0);
  const RepairReport r = repair_surface(m);
  EXPECT_TRUE(r.flipped_inside_out);
  EXPECT_EQ(r.flipped_triangles, 0);
  EXPECT_NEAR(signed_volume(m), volume, 1e-15);
  EXPECT_TRUE(check_mesh(m).is_valid_closed_surface());
  EXPECT_TRUE(contains(r.changes(), "inside-out"));
}

TEST(MeshRepair, mostly_inward_sphere_gets_its_minority_flipped_then_turned_outward) {
  TriMesh m = make_icosphere(0.06, 3);
  const double volume = signed_volume(m);
  flip_orientation(m);
  for (int t = 0; t < m.num_triangles(); t += 50) std::swap(m.triangles[t][1], m.triangles[t][2]);
  const RepairReport r = repair_surface(m);
  EXPECT_EQ(r.flipped_triangles, (m.num_triangles() + 49) / 50);
  EXPECT_TRUE(r.flipped_inside_out);
  EXPECT_NEAR(signed_volume(m), volume, 1e-15);
  EXPECT_TRUE(check_mesh(m).is_valid_closed_surface());
}

TEST(MeshRepair, fills_small_holes_in_a_sphere) {
  const double r = 0.06;
  const TriMesh original = make_icosphere(r, 4);
  // One triangle missing (a 3-edge hole), and elsewhere the whole fan of vertex 0 (5 edges,
  // not planar).
  TriMesh m = original;
  m.triangles.erase(m.triangles.begin() + 1000);
  std::erase_if(m.triangles, [](const std::array<int, 3>& t) { return t[0] == 0 || t[1] == 0 || t[2] == 0; });
  ASSERT_EQ(check_mesh(m).boundary_loops, 2);
  const RepairReport report = repair_surface(m);
  EXPECT_EQ(report.filled_holes, 2);
  EXPECT_EQ(report.remaining_boundary_loops, 0);
  EXPECT_FALSE(report.flipped_inside_out);
  EXPECT_EQ(m.num_triangles(), original.num_triangles() - 5 + 3);
  const MeshCheckReport check = check_mesh(m);
  EXPECT_TRUE(check.is_valid_closed_surface()) << ::testing::PrintToString(check.problems());
  EXPECT_NEAR(check.signed_volume_m3, sphere_volume(r), 0.01 * sphere_volume(r));
  EXPECT_NEAR(check.signed_volume_m3, signed_volume(original), 1e-3 * signed_volume(original));
  EXPECT_TRUE(contains(report.changes(), "filled 2 small holes"));
}

TEST(MeshRepair, fills_the_ends_of_a_tube_only_when_they_are_small_enough) {
  const int segments = 24;
  const double radius = 0.05, height = 0.2;
  TriMesh m = test::make_open_tube(radius, height, segments);
  RepairOptions options;
  options.max_hole_edges = segments - 1;
  RepairReport r = repair_surface(m, options);
  EXPECT_EQ(r.filled_holes, 0);
  EXPECT_EQ(r.remaining_boundary_loops, 2);
  EXPECT_TRUE(r.changes().empty());

  options.max_hole_edges = segments;
  r = repair_surface(m, options);
  EXPECT_EQ(r.filled_holes, 2);
  EXPECT_EQ(r.remaining_boundary_loops, 0);
  EXPECT_FALSE(r.flipped_inside_out);
  EXPECT_TRUE(check_mesh(m).is_valid_closed_surface());
  // The caps are exact: the volume is the prism over the regular 24-gon.
  const double polygon_area = 0.5 * segments * radius * radius * std::sin(2 * M_PI / segments);
  EXPECT_NEAR(signed_volume(m), polygon_area * height, 1e-15);
}

TEST(MeshRepair, removes_degenerate_and_duplicate_triangles) {
  TriMesh m = make_cube(0.1);
  m.vertices.emplace_back(0.05, 0.0, 0.0);  // 8: midpoint of the edge 0–1
  m.triangles.push_back({0, 8, 1});         // zero area
  m.triangles.push_back({2, 2, 5});         // repeated vertex
  m.triangles.push_back(m.triangles[0]);    // duplicate
  const auto t3 = m.triangles[3];
  m.triangles.push_back({t3[2], t3[1], t3[0]});  // duplicate with the opposite orientation
  const RepairReport r = repair_surface(m);
  EXPECT_EQ(r.removed_degenerate_triangles, 2);
  EXPECT_EQ(r.removed_duplicate_triangles, 2);
  EXPECT_EQ(r.flipped_triangles, 0);
  EXPECT_EQ(m.triangles, make_cube(0.1).triangles);
  EXPECT_TRUE(check_mesh(m).is_valid_closed_surface());
  EXPECT_EQ(r.changes().size(), 2u);
  EXPECT_TRUE(contains(r.changes(), "removed 2 degenerate triangles"));
  EXPECT_TRUE(contains(r.changes(), "removed 2 duplicate triangles"));
}

TEST(MeshRepair, repairs_each_component_on_its_own) {
  // An outward cube and an inside-out sphere in one mesh.
  TriMesh sphere = make_icosphere(0.03, 2, Vec3(0.3, 0, 0));
  flip_orientation(sphere);
  TriMesh m = test::merged(make_cube(0.1), sphere);
  const double expected = 1e-3 - signed_volume(sphere);
  const RepairReport r = repair_surface(m);
  EXPECT_TRUE(r.flipped_inside_out);
  EXPECT_NEAR(signed_volume(m), expected, 1e-15);
  EXPECT_EQ(check_mesh(m).connected_components, 2);
  EXPECT_TRUE(check_mesh(m).is_valid_closed_surface());
}

TEST(MeshRepair, rejects_out_of_range_indices) {
  TriMesh m = make_cube();
  m.triangles[2][0] = 42;
  const std::string msg = test::error_message<InvalidInputError>([&] { repair_surface(m); });
  EXPECT_NE(msg.find("repair_surface: triangle 2 refers to vertex 42"), std::string::npos) << msg;
}

// ---------------------------------------------------------------------------------------------
// trim_and_cap

TEST(TrimAndCap, sphere_cut_above_its_centre_matches_the_spherical_cap_volume) {
  const TriMesh sphere = make_icosphere(1.0, 5);
  const double expected = sphere_volume(1.0) - cap_volume(1.0, 0.7);
  for (unsigned motion = 0; motion < 3; ++motion) {
    const Eigen::Isometry3d x = motion == 0 ? Eigen::Isometry3d::Identity() : test::random_rigid_motion(motion);
    const Vec3 point = x * Vec3(0, 0, 0.3), normal = x.linear() * Vec3::UnitZ();
    const TrimResult r = trim_and_cap(test::transformed(sphere, x), point, normal);
    expect_clean_trim(r, point, normal, 1e-12);
    ASSERT_EQ(r.loops.size(), 1u);
    EXPECT_NEAR(signed_volume(r.mesh), expected, 0.01 * expected);
    // The cut circle (radius sqrt(1 − 0.3²)) and its disc.
    const double rho = std::sqrt(1 - 0.09);
    for (const Vec3& p : r.loops[0]) EXPECT_NEAR((p - point).norm(), rho, 2e-3);
    EXPECT_NEAR(cap_area(r), M_PI * rho * rho, 0.01 * M_PI * rho * rho);
  }
}

TEST(TrimAndCap, keeps_the_side_opposite_to_the_normal) {
  const TriMesh sphere = make_icosphere(1.0, 5);
  const TrimResult r = trim_and_cap(sphere, Vec3(0, 0, 0.3), -Vec3::UnitZ());
  expect_clean_trim(r, Vec3(0, 0, 0.3), -Vec3::UnitZ(), 1e-12);
  EXPECT_NEAR(signed_volume(r.mesh), cap_volume(1.0, 0.7), 0.01 * cap_volume(1.0, 0.7));
}

TEST(TrimAndCap, two_disjoint_spheres_give_two_loops_and_two_caps) {
  const TriMesh two = test::merged(make_icosphere(1.0, 4), make_icosphere(0.5, 4, Vec3(3, 0, 0)));
  const TrimResult r = trim_and_cap(two, Vec3(0, 0, 0.1), Vec3(0, 0, 2));
  expect_clean_trim(r, Vec3(0, 0, 0.1), Vec3::UnitZ(), 1e-12);
  ASSERT_EQ(r.loops.size(), 2u);
  EXPECT_EQ(check_mesh(r.mesh).connected_components, 2);
  const double expected = sphere_volume(1.0) - cap_volume(1.0, 0.9) + sphere_volume(0.5) - cap_volume(0.5, 0.4);
  EXPECT_NEAR(signed_volume(r.mesh), expected, 0.01 * expected);
  // One loop around each sphere.
  std::vector<double> centre_x;
  for (const auto& loop : r.loops) {
    Vec3 c = Vec3::Zero();
    for (const Vec3& p : loop) c += p;
    centre_x.push_back(c.x() / static_cast<double>(loop.size()));
  }
  std::sort(centre_x.begin(), centre_x.end());
  EXPECT_NEAR(centre_x[0], 0.0, 1e-2);
  EXPECT_NEAR(centre_x[1], 3.0, 1e-2);
}

TEST(TrimAndCap, nested_shells_each_get_their_own_cap) {
  // Skin and bone: a small outward sphere inside a larger one, both crossing the plane.
  const TriMesh limb = test::merged(make_icosphere(1.0, 4), make_icosphere(0.4, 4, Vec3(0.1, 0, 0)));
  const TrimResult r = trim_and_cap(limb, Vec3(0, 0, 0.2), Vec3::UnitZ());
  expect_clean_trim(r, Vec3(0, 0, 0.2), Vec3::UnitZ(), 1e-12);
  ASSERT_EQ(r.loops.size(), 2u);
  EXPECT_EQ(check_mesh(r.mesh).connected_components, 2);
  const double expected = sphere_volume(1.0) - cap_volume(1.0, 0.8) + sphere_volume(0.4) - cap_volume(0.4, 0.2);
  EXPECT_NEAR(signed_volume(r.mesh), expected, 0.01 * expected);
  EXPECT_NEAR(cap_area(r), M_PI * (1 - 0.04) + M_PI * (0.16 - 0.04), 0.01 * M_PI);
}

TEST(TrimAndCap, a_cavity_loop_gets_its_own_cap_facing_against_the_normal) {
  // A hollow ball: the inner shell faces inwards, so its cut loop winds the other way.
  TriMesh inner = make_icosphere(0.5, 4);
  flip_orientation(inner);
  const TriMesh hollow = test::merged(make_icosphere(1.0, 4), inner);
  const TrimResult r = trim_and_cap(hollow, Vec3::Zero(), Vec3::UnitZ());
  ASSERT_EQ(r.loops.size(), 2u);
  const MeshCheckReport check = check_mesh(r.mesh);
  EXPECT_TRUE(check.is_valid_closed_surface()) << ::testing::PrintToString(check.problems());
  const double expected = 0.5 * (signed_volume(make_icosphere(1.0, 4)) - signed_volume(make_icosphere(0.5, 4)));
  EXPECT_NEAR(check.signed_volume_m3, expected, 1e-9);
  double up = 0, down = 0;
  for (int t = r.first_cap_triangle; t < r.mesh.num_triangles(); ++t)
    (triangle_normal(r.mesh, t).z() > 0 ? up : down) += triangle_area(r.mesh, t);
  EXPECT_NEAR(up, M_PI, 0.01 * M_PI);
  EXPECT_NEAR(down, M_PI * 0.25, 0.01 * M_PI * 0.25);
}

TEST(TrimAndCap, non_convex_star_cross_section_is_capped_exactly) {
  const std::vector<Vec2> star = star_outline(9, 0.35, 1.0);
  const TriMesh prism = make_star_shaped_prism(star, 1.0);
  const double area = moments(star).area;
  // Across the axis (the loop has collinear points: both ends of each side's diagonal), then slanted.
  const TrimResult flat = trim_and_cap(prism, Vec3(0, 0, 0.37), Vec3::UnitZ());
  expect_clean_trim(flat, Vec3(0, 0, 0.37), Vec3::UnitZ(), 1e-12);
  ASSERT_EQ(flat.loops.size(), 1u);
  EXPECT_EQ(flat.loops[0].size(), 2 * star.size());
  EXPECT_NEAR(signed_volume(flat.mesh), 0.37 * area, 1e-12);
  EXPECT_NEAR(cap_area(flat), area, 1e-12);

  const Vec3 normal(0.1, -0.15, 1.0);
  const TrimResult slanted = trim_and_cap(prism, Vec3(0, 0, 0.5), normal);
  expect_clean_trim(slanted, Vec3(0, 0, 0.5), normal, 1e-12);
  ASSERT_EQ(slanted.loops.size(), 1u);
  EXPECT_NEAR(signed_volume(slanted.mesh), 0.5 * area, 1e-12);  // the star's centroid is the origin
  EXPECT_NEAR(cap_area(slanted), area * normal.norm(), 1e-12);
}

TEST(TrimAndCap, c_shaped_cross_section_is_capped_exactly_under_a_slanted_plane) {
  const int segments = 60;
  const std::vector<Vec2> c = c_outline(segments, 0.5, 1.0);
  const TriMesh prism = make_prism(c, static_cast<int>(c.size()), c_cap(segments), 1.0);
  ASSERT_TRUE(check_mesh(prism).is_valid_closed_surface());
  const Vec3 normal(0.08, 0.12, 1.0), point(0.1, 0.0, 0.6);
  const TrimResult r = trim_and_cap(prism, point, normal);
  expect_clean_trim(r, point, normal, 1e-12);
  ASSERT_EQ(r.loops.size(), 1u);
  // Kept volume: ∫ z_plane(x, y) dA with z_plane = z0 − (a (x − x0) + b (y − y0)) / c.
  const PolygonMoments mo = moments(c);
  const double expected =
      point.z() * mo.area - (normal.x() * (mo.sx - point.x() * mo.area) + normal.y() * (mo.sy - point.y() * mo.area)) /
                                normal.z();
  EXPECT_NEAR(signed_volume(r.mesh), expected, 1e-12);
  EXPECT_NEAR(cap_area(r), mo.area * normal.norm() / normal.z(), 1e-12);
}

TEST(TrimAndCap, limb_like_wavy_section_with_hundreds_of_vertices) {
  std::vector<Vec2> outline;
  const int n = 400;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    const double r = 0.05 * (1 + 0.3 * std::sin(5 * a) + 0.1 * std::cos(13 * a));
    outline.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  const TriMesh prism = make_star_shaped_prism(outline, 0.3);
  const TrimResult r = trim_and_cap(prism, Vec3(0, 0, 0.2), Vec3::UnitZ());
  expect_clean_trim(r, Vec3(0, 0, 0.2), Vec3::UnitZ(), 1e-12);
  ASSERT_EQ(r.loops.size(), 1u);
  EXPECT_EQ(r.loops[0].size(), 2u * n);
  EXPECT_EQ(r.mesh.num_triangles() - r.first_cap_triangle, 2 * n - 2);
  EXPECT_NEAR(signed_volume(r.mesh), 0.2 * moments(outline).area, 1e-15);
}

TEST(TrimAndCap, vertices_on_the_plane_are_cut_points_without_slivers) {
  // The plane x = y through four vertices (and two face diagonals) of the cube: no new vertex,
  // half the volume, also when the vertices are only within 1e-9 m of the plane.
  const Vec3 normal = Vec3(1, -1, 0).normalized();
  for (const double offset : {0.0, 5e-10, -5e-10}) {
    const Vec3 point = offset * normal;
    const TrimResult r = trim_and_cap(make_cube(0.1), point, normal);
    expect_clean_trim(r, point, normal, 1e-9);
    EXPECT_EQ(r.mesh.num_vertices(), 6) << "offset " << offset;
    ASSERT_EQ(r.loops.size(), 1u);
    EXPECT_EQ(r.loops[0].size(), 4u);
    EXPECT_NEAR(signed_volume(r.mesh), 0.5e-3, 1e-12);
  }
  // A plane that misses the mesh keeps it whole, without loops.
  const TrimResult whole = trim_and_cap(make_cube(0.1), Vec3(0, 0, 0.5), Vec3::UnitZ());
  EXPECT_TRUE(whole.loops.empty());
  EXPECT_EQ(whole.first_cap_triangle, 12);
  EXPECT_NEAR(signed_volume(whole.mesh), 1e-3, 1e-15);
}

TEST(TrimAndCap, rejects_bad_planes_and_empty_meshes) {
  const TriMesh cube = make_cube(0.1);
  EXPECT_THROW(trim_and_cap(cube, Vec3::Zero(), Vec3::Zero()), InvalidInputError);
  EXPECT_THROW(trim_and_cap(TriMesh{}, Vec3::Zero(), Vec3::UnitZ()), InvalidInputError);
  const std::string msg =
      test::error_message<InvalidInputError>([&] { trim_and_cap(cube, Vec3(0, 0, -1), Vec3::UnitZ()); });
  EXPECT_NE(msg.find("nothing is kept"), std::string::npos) << msg;
}

TEST(TrimAndCap, real_limb_scan_trimmed_below_its_open_end_is_a_closed_surface) {
  const std::filesystem::path file = SOCKETSMITH_SHARED_DATA_DIR "/limbs/transtibial/ampscan_limb_scan_mm.stl";
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "real limb scan not found: " << file;
  test::LogCapture quiet;
  MeshReadOptions options;
  options.unit = units::LengthUnit::Millimetre;
  const TriMesh scan = read_mesh(file, options);

  // Boundary vertices: ends of edges used by one triangle.
  std::map<std::pair<int, int>, int> uses;
  for (const auto& t : scan.triangles)
    for (int k = 0; k < 3; ++k) ++uses[std::minmax(t[k], t[(k + 1) % 3])];
  std::vector<Vec3> boundary;
  for (const auto& [edge, count] : uses)
    if (count == 1) {
      boundary.push_back(scan.vertices[edge.first]);
      boundary.push_back(scan.vertices[edge.second]);
    }
  ASSERT_FALSE(boundary.empty()) << "the scan was expected to be open at its proximal end";

  // Longest box axis, pointing to the open side; the plane 10 mm below the lowest boundary point.
  const Aabb box = bounding_box(scan);
  int axis = 0;
  box.extent().maxCoeff(&axis);
  Vec3 boundary_centre = Vec3::Zero();
  for (const Vec3& p : boundary) boundary_centre += p;
  boundary_centre /= static_cast<double>(boundary.size());
  const Vec3 normal = (boundary_centre - box.center())[axis] > 0 ? Vec3::Unit(axis) : Vec3(-Vec3::Unit(axis));
  double lowest = std::numeric_limits<double>::infinity();
  for (const Vec3& p : boundary) lowest = std::min(lowest, normal.dot(p));
  const Vec3 point = (lowest - 10 * units::mm) * normal;

  const TrimResult r = trim_and_cap(scan, point, normal);
  expect_clean_trim(r, point, normal, 1e-9);
  ASSERT_EQ(r.loops.size(), 1u);
  EXPECT_GT(r.loops[0].size(), 50u);
}

TEST(TrimAndCap, real_limb_with_bones_cut_across_the_shaft_caps_every_shell) {
  const std::filesystem::path file =
      SOCKETSMITH_SHARED_DATA_DIR "/limbs/transtibial/openlimb_tt_mean_limb_with_bones_mm.stl";
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "real limb-with-bones mesh not found: " << file;
  test::LogCapture quiet;
  MeshReadOptions options;
  options.unit = units::LengthUnit::Millimetre;
  const TriMesh limb = read_mesh(file, options);
  ASSERT_GT(check_mesh(limb).connected_components, 1) << "expected skin and bone shells in one mesh";

  // Halfway along the long axis: skin, tibia and fibula are all cut; each shell gets its cap.
  const Aabb box = bounding_box(limb);
  int axis = 0;
  box.extent().maxCoeff(&axis);
  const Vec3 point = box.center(), normal = Vec3::Unit(axis);
  const TrimResult r = trim_and_cap(limb, point, normal);
  expect_clean_trim(r, point, normal, 1e-9);
  EXPECT_GE(r.loops.size(), 2u);
  EXPECT_EQ(check_mesh(r.mesh).connected_components, static_cast<int>(r.loops.size()));
}

}  // namespace
}  // namespace socketsmith::geometry
