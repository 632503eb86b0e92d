#include "socketsmith/calculix/surface_pressure.h"

#include <cmath>
#include <functional>
#include <string>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "socketsmith/core/errors.h"
#include "socketsmith/volume/box_mesher.h"
#include "box_with_top.h"

namespace socketsmith::calculix {
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

/// The .dat block CalculiX prints for the stump's elements: the stress σ(x) at each integration
/// point, points in CalculiX's order (ξ fastest, then η, then ζ), at positions @p x.
DatBlock gauss_stresses(const volume::HexMesh& mesh, const std::vector<Vec3>& x,
                        const std::function<Eigen::Matrix3d(const Vec3&)>& sigma, bool reduced = false) {
  DatBlock b;
  b.title = "stresses (elem, integ.pnt.,sxx,syy,szz,sxy,sxz,syz)";
  b.set = "SKINEL";
  const double g = 1.0 / std::sqrt(3.0);
  for (int e = 0; e < mesh.num_hexahedra(); ++e)
    for (int k = 0; k < (reduced ? 1 : 8); ++k) {
      const Vec3 xi = reduced ? Vec3::Zero() : Vec3((k & 1) ? g : -g, (k & 2) ? g : -g, (k & 4) ? g : -g);
      Vec3 p = Vec3::Zero();
      for (int a = 0; a < 8; ++a) {
        double n = 0.125;
        for (int d = 0; d < 3; ++d) n *= 1 + xi[d] * volume::kHexCorners[a][d];
        p += n * x[mesh.hexahedra[e][a]];
      }
      const Eigen::Matrix3d s = sigma(p);
      b.rows.push_back({double(e + 1), double(k + 1), s(0, 0), s(1, 1), s(2, 2), s(0, 1), s(0, 2), s(1, 2)});
    }
  return b;
}

TEST(SurfacePressure, nodal_force_pressure_integrates_the_traction_a_node_carries) {
  // σ_zz = a + b x (divergence-free): the top face's traction. A node's force is ∫ N σ_zz dA over
  // its quads: at the centre (x = 10 mm) the mean of the field over a symmetric hat, a + b·10 mm;
  // on the x = 0 edge the hat is one-sided, its mean x is h/3 (h = 10 mm). A mix-up of
  // CalculiX's point order moves the field between points and misses both.
  Box b;
  const double a = -10e3, slope = -200e3;  // Pa, Pa/m
  const auto st = gauss_stresses(b.mesh, b.mesh.nodes, [&](const Vec3& p) {
    Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
    s(2, 2) = a + slope * p.x();
    return s;
  });
  std::vector<double> areas;
  const auto n = deformed_surface_normals(b.mesh, b.mesh.nodes, b.top, b.top_nodes, &areas);
  const double h = 0.01;
  EXPECT_NEAR(areas[4], h * h, 1e-15);  // the centre node of the 3×3 top
  EXPECT_NEAR(areas[0], 0.25 * h * h, 1e-15);
  const auto p = nodal_force_pressure(b.mesh, b.mesh.nodes, st, b.top_nodes, n, areas);
  const int centre = 4, edge = 3;  // (i, j) = (1, 1) and (0, 1)
  EXPECT_NEAR(p[centre], -(a + slope * 0.01), 1e-6);
  EXPECT_NEAR(p[edge], -(a + slope * h / 3), 1e-6);
}

TEST(SurfacePressure, nodal_forces_split_into_the_pressure_and_the_shear_the_top_carries) {
  // σ_zz = −8 kPa and σ_xz = 3 kPa on the 20 × 20 mm top: its nodes' forces add up to the traction
  // σ·n times the area — 3.2 N into the box, 1.2 N of shear along +x — and the pressure ignores the
  // shear (at the centre: the nodes on the x = 0 and x = 20 mm edges also carry the sides' σ_xz,
  // ±3 kPa, which cancel in the total).
  Box b;
  Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
  s(2, 2) = -8e3;
  s(0, 2) = s(2, 0) = 3e3;
  const auto st = gauss_stresses(b.mesh, b.mesh.nodes, [&](const Vec3&) { return s; });
  std::vector<double> areas;
  const auto n = deformed_surface_normals(b.mesh, b.mesh.nodes, b.top, b.top_nodes, &areas);
  std::vector<Vec3> f;
  const auto p = nodal_force_pressure(b.mesh, b.mesh.nodes, st, b.top_nodes, n, areas, &f);
  ASSERT_EQ(f.size(), b.top_nodes.size());
  Vec3 total = Vec3::Zero();
  for (const auto& v : f) total += v;
  EXPECT_NEAR(total.z(), -3.2, 1e-9);
  EXPECT_NEAR(total.x(), 1.2, 1e-9);
  EXPECT_NEAR(total.y(), 0.0, 1e-9);
  EXPECT_NEAR(p[4], 8e3, 1e-6);
  EXPECT_NEAR(f[4].x(), 3e3 * 1e-4, 1e-12);
}

TEST(SurfacePressure, nodal_force_pressure_of_a_uniform_stress_on_a_rotated_box_and_reduced_integration) {
  Box b;
  const Eigen::Matrix3d rot = Eigen::AngleAxisd(M_PI / 6, Vec3::UnitX()).toRotationMatrix();
  std::vector<Vec3> deformed;
  for (const auto& x : b.mesh.nodes) deformed.push_back(rot * x + Vec3(0.001, 0.002, 0.003));
  const Vec3 normal = rot * Vec3::UnitZ();
  const Eigen::Matrix3d s = -12e3 * normal * normal.transpose();
  std::vector<double> areas;
  const auto n = deformed_surface_normals(b.mesh, deformed, b.top, b.top_nodes, &areas);
  for (bool reduced : {false, true}) {
    const auto st = gauss_stresses(b.mesh, deformed, [&](const Vec3&) { return s; }, reduced);
    const auto p = nodal_force_pressure(b.mesh, deformed, st, b.top_nodes, n, areas);
    for (double v : p) EXPECT_NEAR(v, 12e3, 1e-6) << (reduced ? "C3D8R" : "C3D8");
  }
  // An element at the surface without its rows is an error that says what the deck lacks.
  auto st = gauss_stresses(b.mesh, deformed, [&](const Vec3&) { return s; });
  st.rows.resize(st.rows.size() - 3);
  EXPECT_THROW(nodal_force_pressure(b.mesh, deformed, st, b.top_nodes, n, areas), InvalidInputError);
  EXPECT_THROW(nodal_force_pressure(b.mesh, deformed, st, b.top_nodes, n, {1.0}), InvalidInputError);
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
}  // namespace socketsmith::calculix
