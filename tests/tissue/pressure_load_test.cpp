// Pressures on the skin (pressure_load.h): the follower pressure's forces and exact Jacobian.
#include "socketsmith/tissue/pressure_load.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "socketsmith/core/errors.h"
#include "test_models.h"

namespace socketsmith::tissue {
namespace {
using namespace testing;

/// A distorted 3×3×3 brick whose whole boundary is skin except the base (z = 0, the "cut"), and a
/// pressure that varies over the skin nodes.
struct SkinnedBrick {
  SkinnedBrick() : mesh(distorted_lattice(0.03, 21)) {
    volume::tag_boundary_nodes(mesh);
    for (int i = 0; i < mesh.num_nodes(); ++i)
      if (mesh.nodes[i].z() < 1e-9) mesh.node_tags[i] |= volume::kNodeProximal | volume::kNodeFixed;
    skin = volume::extract_skin_surface(mesh);
    for (size_t k = 0; k < skin.nodes.size(); ++k) {
      const auto& p = mesh.nodes[skin.nodes[k]];
      pressure.push_back(k % 7 == 3 ? 0.0 : 5e3 + 4e5 * p.x() - 2e5 * p.y() + 1e5 * p.z());
    }
  }
  volume::HexMesh mesh;
  volume::SkinSurface skin;
  std::vector<double> pressure;
};

TEST(FollowerPressure, at_rest_the_forces_are_the_rest_skins_pressure_forces) {
  const SkinnedBrick b;
  const MassSpringModel m(b.mesh, {50e3, 1060}, {});
  const FollowerPressure load(b.skin, b.pressure, m.num_nodes());
  const VectorXd f = load.forces(m.rest_positions());
  const VectorXd g = pressure_forces(b.skin, b.pressure, m.num_nodes());
  EXPECT_LT((f - g).norm(), 1e-12 * g.norm());
}

TEST(FollowerPressure, jacobian_matches_finite_differences_of_the_forces) {
  const SkinnedBrick b;
  MassSpringOptions o;
  o.kind = TissueModelKind::NeoHookean;
  const MassSpringModel m(b.mesh, {50e3, 1060}, o);
  const FollowerPressure load(b.skin, b.pressure, m.num_nodes());
  const VectorXd x = deformed(m, 17);
  SparseMatrix J;
  m.jacobian(x, JacobianKind::Exact, J);  // the model's pattern
  std::fill(J.valuePtr(), J.valuePtr() + J.nonZeros(), 0.0);
  const double scale = 0.7;
  load.add_jacobian(x, scale, J);
  const Eigen::MatrixXd Jd(J);
  const Eigen::MatrixXd fd = scale * fd_jacobian([&](const VectorXd& y) { return load.forces(y); }, x, 1e-9);
  const double rel = (fd - Jd).norm() / Jd.norm();
  std::printf("[ info ] follower pressure Jacobian vs FD: relative error %.2e\n", rel);
  EXPECT_LT(rel, 1e-6);
  EXPECT_GT((Jd - Jd.transpose()).norm(), 1e-3 * Jd.norm());  // a non-uniform follower pressure is not conservative
}

TEST(FollowerPressure, rejects_mismatched_or_non_finite_pressures) {
  const SkinnedBrick b;
  EXPECT_THROW(FollowerPressure(b.skin, {1.0, 2.0}, b.mesh.num_nodes()), InvalidInputError);
  auto p = b.pressure;
  p[2] = std::nan("");
  EXPECT_THROW(FollowerPressure(b.skin, p, b.mesh.num_nodes()), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::tissue
