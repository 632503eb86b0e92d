#include "socketsmith/fe/surface_pressure.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "socketsmith/core/errors.h"
#include "socketsmith/volume/box_mesher.h"
#include "box_with_top.h"

namespace socketsmith::fe {
namespace {

using Box = testing::BoxWithTop;

/// An frd STRESS block with the same stress tensor at every node.
FrdBlock uniform_stress(int num_nodes, const Eigen::Matrix3d& s) {
  FrdBlock b;
  b.name = "STRESS";
  b.components = {"SXX", "SYY", "SZZ", "SXY", "SYZ", "SZX"};
  for (int id = 1; id <= num_nodes; ++id) {
    b.node_ids.push_back(id);
    for (double v : {s(0, 0), s(1, 1), s(2, 2), s(0, 1), s(1, 2), s(2, 0)}) b.values.push_back(v);
  }
  return b;
}

TEST(SurfacePressure, top_of_a_box_has_the_outward_normal_and_reads_minus_szz) {
  Box b;
  const auto n = deformed_surface_normals(b.mesh, b.mesh.nodes, b.top, b.top_nodes);
  for (const auto& v : n) EXPECT_NEAR((v - Vec3::UnitZ()).norm(), 0.0, 1e-12);
  Eigen::Matrix3d s;
  s << -1000, 200, 300, 200, -2000, 400, 300, 400, -15000;
  const auto p = normal_surface_pressure(uniform_stress(b.mesh.num_nodes(), s), b.top_nodes, n, b.mesh.num_nodes());
  for (double v : p) EXPECT_NEAR(v, 15000.0, 1e-9);  // compression positive
  // A node on none of the faces (the bottom centre) gets a zero normal and no pressure.
  const int bottom = volume::box_node_index(b.options.divisions, 1, 1, 0);
  EXPECT_EQ(deformed_surface_normals(b.mesh, b.mesh.nodes, b.top, {bottom})[0], Vec3::Zero());
}

TEST(SurfacePressure, the_deformed_normal_is_used_not_the_rest_one) {
  // The box rotated by 30° about x (its deformed state): the top's normal turns with it, and a
  // uniaxial compression of 12 kPa along that normal reads 12 kPa; along the rest normal (z) it
  // would read 12 cos²30° = 9 kPa.
  Box b;
  const Eigen::Matrix3d rot = Eigen::AngleAxisd(M_PI / 6, Vec3::UnitX()).toRotationMatrix();
  std::vector<Vec3> deformed;
  for (const auto& x : b.mesh.nodes) deformed.push_back(rot * x + Vec3(0.001, 0.002, 0.003));
  const auto n = deformed_surface_normals(b.mesh, deformed, b.top, b.top_nodes);
  const Vec3 expected = rot * Vec3::UnitZ();
  for (const auto& v : n) EXPECT_NEAR((v - expected).norm(), 0.0, 1e-12);
  const Eigen::Matrix3d s = -12e3 * expected * expected.transpose();
  const auto p = normal_surface_pressure(uniform_stress(b.mesh.num_nodes(), s), b.top_nodes, n, b.mesh.num_nodes());
  for (double v : p) EXPECT_NEAR(v, 12e3, 1e-9);
  const auto p_rest = normal_surface_pressure(uniform_stress(b.mesh.num_nodes(), s), b.top_nodes,
                                              std::vector<Vec3>(b.top_nodes.size(), Vec3::UnitZ()), b.mesh.num_nodes());
  EXPECT_NEAR(p_rest[0], 9e3, 1e-9);
}

TEST(SurfacePressure, missing_components_and_bad_sizes_are_errors) {
  Box b;
  FrdBlock disp;
  disp.name = "DISP";
  disp.components = {"D1", "D2", "D3"};
  EXPECT_THROW(normal_surface_pressure(disp, {0}, {Vec3::UnitZ()}, b.mesh.num_nodes()), InvalidInputError);
  const auto st = uniform_stress(b.mesh.num_nodes(), Eigen::Matrix3d::Identity());
  EXPECT_THROW(normal_surface_pressure(st, {0, 1}, {Vec3::UnitZ()}, b.mesh.num_nodes()), InvalidInputError);
  EXPECT_THROW(normal_surface_pressure(st, {b.mesh.num_nodes()}, {Vec3::UnitZ()}, b.mesh.num_nodes()),
               InvalidInputError);
  EXPECT_THROW(deformed_surface_normals(b.mesh, {Vec3::Zero()}, b.top, b.top_nodes), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::fe
