// The rigid socket: mass properties of an analytic shell, the inner wall seen from the axis, gaps
// against it (also for nodes pushed beyond the outer wall), bad sockets rejected.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "socketsmith/contact/rigid_socket.h"
#include "socketsmith/core/errors.h"

namespace socketsmith::contact {
namespace {

/// A closed tube (open-ended cup without bottom would not be closed): inner radius ri, outer ro,
/// from z = 0 to z = H, with an annular top and bottom: a thick-walled pipe.
geometry::TriMesh pipe(double ri, double ro, double H, int seg = 96) {
  geometry::TriMesh m;
  for (int k = 0; k < seg; ++k) {
    const double a = 2 * std::numbers::pi * k / seg;
    const Vec3 d(std::cos(a), std::sin(a), 0);
    m.vertices.push_back(ri * d);                   // 4k: inner bottom
    m.vertices.push_back(ri * d + Vec3(0, 0, H));   // 4k+1: inner top
    m.vertices.push_back(ro * d);                   // 4k+2: outer bottom
    m.vertices.push_back(ro * d + Vec3(0, 0, H));   // 4k+3: outer top
  }
  for (int k = 0; k < seg; ++k) {
    const int a = 4 * k, b = 4 * ((k + 1) % seg);
    // outer wall (normal outward)
    m.triangles.push_back({a + 2, b + 2, b + 3});
    m.triangles.push_back({a + 2, b + 3, a + 3});
    // inner wall (normal towards the axis)
    m.triangles.push_back({a, a + 1, b + 1});
    m.triangles.push_back({a, b + 1, b});
    // top annulus (normal +z)
    m.triangles.push_back({a + 1, a + 3, b + 3});
    m.triangles.push_back({a + 1, b + 3, b + 1});
    // bottom annulus (normal −z)
    m.triangles.push_back({a, b, b + 2});
    m.triangles.push_back({a, b + 2, a + 2});
  }
  return m;
}

geometry::LimbFrame z_frame() {
  geometry::LimbFrame f;
  f.origin = Vec3::Zero();
  f.axis = Vec3::UnitZ();
  f.anterior = Vec3::UnitX();
  return f;
}

TEST(RigidSocket, mass_properties_and_inner_wall_of_a_pipe) {
  const double ri = 0.05, ro = 0.055, H = 0.2, rho = 1250;
  const RigidSocket s(pipe(ri, ro, H), z_frame(), rho);
  const double seg_area = 0.5 * 96 * std::sin(2 * std::numbers::pi / 96);  // polygon area / r²
  const double vol = seg_area * (ro * ro - ri * ri) * H;
  EXPECT_NEAR(s.mass_kg(), rho * vol, 1e-9 * rho * vol);
  EXPECT_NEAR(s.centre_of_mass().z(), H / 2, 1e-9);
  EXPECT_NEAR(s.centre_of_mass().head<2>().norm(), 0.0, 1e-9);
  // Thin-walled tube about its axis: I_zz ≈ m (ri² + ro²) / 2.
  EXPECT_NEAR(s.inertia()(2, 2), s.mass_kg() * (ri * ri + ro * ro) / 2, 0.01 * s.mass_kg() * ro * ro);
  EXPECT_EQ(s.inner_triangles(), 2 * 96);  // exactly the inner wall
}

TEST(RigidSocket, gaps_against_the_inner_wall_even_beyond_the_outer_wall) {
  RigidSocket s(pipe(0.05, 0.055, 0.2), z_frame());
  const double inner = 0.05 * std::cos(std::numbers::pi / 96);  // mid-facet radius
  const Vec3 d(std::cos(std::numbers::pi / 96), std::sin(std::numbers::pi / 96), 0);  // mid-facet direction
  auto g = s.gap(0.03 * d + Vec3(0, 0, 0.1));  // in the cavity
  EXPECT_TRUE(g.valid);
  EXPECT_NEAR(g.gap_m, inner - 0.03, 1e-9);
  EXPECT_NEAR(g.normal.dot(d), -1.0, 1e-9);
  g = s.gap(0.052 * d + Vec3(0, 0, 0.1));  // inside the wall material
  EXPECT_NEAR(g.gap_m, inner - 0.052, 1e-9);
  g = s.gap(0.07 * d + Vec3(0, 0, 0.1));  // pushed through beyond the outer wall: still pushed back inwards
  EXPECT_TRUE(g.valid);
  EXPECT_NEAR(g.gap_m, inner - 0.07, 1e-9);
  EXPECT_NEAR(g.normal.dot(d), -1.0, 1e-9);
  g = s.gap(0.03 * d + Vec3(0, 0, 0.3));  // above the rim: not facing the wall
  EXPECT_FALSE(g.valid);
  s.set_translation(Vec3(0, 0, 0.15));  // the socket moved up: the same point is now inside it
  g = s.gap(0.03 * d + Vec3(0, 0, 0.3));
  EXPECT_TRUE(g.valid);
  EXPECT_NEAR(g.gap_m, inner - 0.03, 1e-9);
}

TEST(RigidSocket, rejects_open_and_misplaced_sockets) {
  auto open = pipe(0.05, 0.055, 0.2);
  open.triangles.resize(open.triangles.size() - 8);
  EXPECT_THROW(RigidSocket(open, z_frame()), TopologyError);
  geometry::LimbFrame far = z_frame();
  far.origin = Vec3(1.0, 0, 0);  // the limb's axis 1 m away: the socket does not surround it
  try {
    RigidSocket s(pipe(0.05, 0.055, 0.2), far);
    ADD_FAILURE() << "no error";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("does not surround the limb"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace socketsmith::contact
