// Rigid alignment: Kabsch recovers a motion from matched points; point-to-plane ICP recovers a
// known motion of a surface to machine precision; with the uniform normal offset free, a copy of a
// cup grown by 2 mm stays where it is (plain ICP slides it along the axis) and the offset is 2 mm.
#include <gtest/gtest.h>

#include <cmath>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/rigid_alignment.h"
#include "socketsmith/geometry/surface_query.h"
#include "test_shapes.h"

namespace socketsmith::geometry {
namespace {

/// An egg-shaped closed surface with a bump: no rotational symmetry.
TriMesh lumpy_egg() {
  TriMesh m = test::make_icosphere(1.0, 4);
  const Vec3 bump = Vec3(1, 1, 1).normalized();
  for (auto& p : m.vertices) {
    const Vec3 u = p.normalized();
    p = Vec3(0.04 * u.x(), 0.03 * u.y(), 0.09 * u.z()) * (1 + 0.2 * std::exp(-(u - bump).squaredNorm() / 0.1));
  }
  return m;
}

/// Largest |T(p) − p| over the vertices of @p m.
double max_displacement(const RigidTransform& t, const TriMesh& m) {
  double d = 0;
  for (const auto& p : m.vertices) d = std::max(d, (t.apply(p) - p).norm());
  return d;
}

TEST(RigidAlignment, kabsch_recovers_a_random_motion_from_matched_points) {
  const auto motion = test::random_rigid_motion(3);
  std::vector<Vec3> from, to;
  for (int k = 0; k < 10; ++k) {
    from.emplace_back(std::cos(k), std::sin(2 * k), 0.3 * k);
    to.push_back(motion * from.back());
  }
  const RigidTransform t = kabsch(from, to);
  EXPECT_LT((t.rotation - motion.linear()).norm(), 1e-12);
  EXPECT_LT((t.translation - motion.translation()).norm(), 1e-12);
  const auto msg = test::error_message<InvalidInputError>([] {
    kabsch({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0)}, {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0)});
  });
  EXPECT_NE(msg.find("lie on one line"), std::string::npos) << msg;
}

TEST(RigidAlignment, icp_recovers_a_known_motion_of_a_surface) {
  const TriMesh a = lumpy_egg();
  const RigidTransform motion = [] {
    RigidTransform m = rotation_about(Vec3(0.01, 0, 0.02), Vec3(1, 2, 3), 12 * M_PI / 180);
    m.translation += Vec3(0.004, -0.003, 0.006);
    return m;
  }();
  const TriMesh moved = transformed(a, motion);
  const SurfaceQuery qa(a);
  const IcpResult r = align_icp(moved, qa, RigidTransform{});
  ASSERT_TRUE(r.converged) << r.message;
  const RigidTransform residual = r.transform.after(motion);  // identity when recovered
  EXPECT_LT(max_displacement(residual, a), 1e-7);
  EXPECT_LT(residual.angle_rad() * 180 / M_PI, 1e-5);
  EXPECT_NEAR(r.offset_m, 0.0, 1e-8);
  EXPECT_LT(r.rms_m, 1e-8);
}

TEST(RigidAlignment, a_uniformly_grown_copy_stays_put_and_its_offset_is_measured) {
  // An open cup (a limb scan's shape): plain ICP closes the 2 mm gap by sliding the grown copy
  // along the axis; with the offset free the copy stays and the offset is 2 mm.
  const TriMesh cup = test::make_capsule(0.05, 0.15, 24, 128, /*open_top=*/true);
  const TriMesh grown = offset_along_normals(cup, 0.002);
  const SurfaceQuery q(cup);
  const auto below_rim = [](const Vec3& x) { return x.z() < 0.19; };
  const IcpResult r = align_icp(grown, q, RigidTransform{}, {}, below_rim);
  EXPECT_LT(max_displacement(r.transform, cup), 1e-5);
  EXPECT_NEAR(r.offset_m, 0.002, 5e-5);
  IcpOptions plain;
  plain.solve_offset = false;
  const IcpResult p = align_icp(grown, q, RigidTransform{}, plain, below_rim);
  EXPECT_GT(std::abs(p.transform.translation.z()), 0.001) << "plain ICP hides the swelling by a slide along the axis";
}

TEST(RigidAlignment, normals_of_a_sphere_are_radial_and_the_offset_grows_its_radius) {
  const TriMesh s = test::make_icosphere(0.05, 3);
  const auto n = vertex_normals(s);
  for (size_t v = 0; v < n.size(); ++v) EXPECT_GT(n[v].dot(s.vertices[v].normalized()), 0.999);
  const TriMesh g = offset_along_normals(s, -0.003);
  for (const auto& p : g.vertices) EXPECT_NEAR(p.norm(), 0.047, 2e-5);
}

TEST(RigidAlignment, surfaces_that_do_not_overlap_are_one_clear_error) {
  const TriMesh a = lumpy_egg();
  RigidTransform far;
  far.translation = Vec3(1.0, 0, 0);
  const SurfaceQuery qa(a);
  const auto msg = test::error_message<InvalidInputError>([&] { align_icp(a, qa, far); });
  EXPECT_NE(msg.find("do not overlap"), std::string::npos) << msg;
}

}  // namespace
}  // namespace socketsmith::geometry
