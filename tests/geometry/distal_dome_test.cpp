#include "socketsmith/geometry/distal_dome.h"

#include <gtest/gtest.h>

#include <cmath>
#include <utility>
#include <vector>

#include "socketsmith/geometry/mesh_checks.h"
#include "test_shapes.h"

namespace socketsmith::geometry {
namespace {

using test::make_lathe;

/// A paraboloid z = k r² (tip at the origin, 50 mm across 200 mm up) cut at z0 and at the top:
/// a tube open at both ends, finely ringed near the cut.
TriMesh cut_paraboloid(double k, double z0, double top, int segments) {
  std::vector<std::pair<double, double>> profile;
  for (int i = 0; i <= 80; ++i) {
    const double s = static_cast<double>(i) / 80;
    const double z = z0 + (top - z0) * s * s;  // denser near the cut
    profile.emplace_back(std::sqrt(z / k), z);
  }
  return make_lathe(profile, segments);
}

TEST(DistalDome, closes_a_cut_paraboloid_where_its_tip_was) {
  const double k = 80.0, z0 = 0.01, top = 0.2;  // tip 11 mm across at the cut
  TriMesh m = cut_paraboloid(k, z0, top, 72);
  const int nv = m.num_vertices(), nt = static_cast<int>(m.triangles.size());
  const auto dome = close_distal_opening(m);
  ASSERT_TRUE(dome.has_value());
  EXPECT_EQ(dome->rim_edges, 72);
  EXPECT_EQ(dome->added_vertices, m.num_vertices() - nv);
  EXPECT_NEAR(dome->rim_width_m, 2.0 * std::sqrt(z0 / k), 0.01 * 2.0 * std::sqrt(z0 / k));
  // The rims' tangents of a paraboloid meet the axis 2 z0 below the cut: the dome ends at its tip.
  EXPECT_NEAR(dome->depth_m, z0, 0.05 * z0);
  // Every new point lies on the paraboloid (a quadratic Bézier tangent at both ends is its
  // meridian), to the slope's error from the next ring up.
  for (int v = nv; v < m.num_vertices(); ++v) {
    const Vec3& p = m.vertices[v];
    EXPECT_NEAR(p.z(), k * p.head<2>().squaredNorm(), 0.05 * z0) << "vertex " << v;
  }
  // Open now only at the top; the dome faces out (down, away from the axis) like the surface.
  const MeshCheckReport r = check_mesh(m);
  EXPECT_EQ(r.boundary_loops, 1);
  EXPECT_TRUE(r.is_manifold());
  EXPECT_TRUE(r.is_oriented());
  for (int t = nt; t < static_cast<int>(m.triangles.size()); ++t) {
    const auto& f = m.triangles[t];
    const Vec3 n = (m.vertices[f[1]] - m.vertices[f[0]]).cross(m.vertices[f[2]] - m.vertices[f[0]]);
    EXPECT_LT(n.z(), 0.0) << "dome triangle " << t;
  }
}

TEST(DistalDome, a_rim_that_does_not_turn_inward_gets_a_round_end_past_it) {
  // A cylinder of radius 20 mm (vertical at the cut) under a wider top: no tangent reaches the
  // axis, so the dome is as deep as the rim is wide (a hemisphere-like end), and faces down.
  TriMesh m = make_lathe({{0.02, 0.0}, {0.02, 0.05}, {0.05, 0.2}}, 48);
  const auto dome = close_distal_opening(m);
  ASSERT_TRUE(dome.has_value());
  EXPECT_NEAR(dome->depth_m, 0.5 * dome->rim_width_m, 1e-12);
  double z_min = 1.0;
  for (const Vec3& p : m.vertices) z_min = std::min(z_min, p.z());
  EXPECT_NEAR(z_min, -dome->depth_m, 1e-12);
  EXPECT_EQ(check_mesh(m).boundary_loops, 1);
}

TEST(DistalDome, leaves_alone_what_is_not_a_limb_open_at_both_ends) {
  // Two equal ends (a tube: which end is distal?), one open end (a scan's proximal cut), none.
  for (TriMesh m : {test::make_open_tube(0.03, 0.2, 32), test::make_capsule(0.03, 0.1, 8, 32, true),
                    test::make_icosphere(0.05, 2)}) {
    const TriMesh before = m;
    EXPECT_FALSE(close_distal_opening(m).has_value());
    EXPECT_EQ(m.vertices, before.vertices);
    EXPECT_EQ(m.triangles, before.triangles);
  }
}

}  // namespace
}  // namespace socketsmith::geometry
