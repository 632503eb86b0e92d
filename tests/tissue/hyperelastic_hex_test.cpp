#include "socketsmith/tissue/hyperelastic_hex.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/SparseLU>

#include "socketsmith/core/errors.h"
#include "test_models.h"

namespace socketsmith::tissue {
namespace {
using namespace testing;
using Eigen::Matrix3d;
using Eigen::Vector3d;

TEST(HyperelasticHex, energy_of_an_affine_deformation_is_exact_on_distorted_bricks) {
  // A homogeneous deformation x = F X gives the same E in every element, and the 2×2×2 rule
  // integrates a constant exactly: W = V (λ/2 tr(E)² + μ E:E) whatever the element shapes.
  const double a = 0.03, E = 80e3, nu = 0.45;
  const auto mesh = distorted_lattice(a, 3);
  const HyperelasticHexElements fe(mesh, E, nu);
  Matrix3d F;
  F << 1.1, 0.05, 0.0, -0.02, 0.9, 0.1, 0.03, 0.0, 0.95;
  Eigen::VectorXd x(3 * mesh.num_nodes());
  for (int i = 0; i < mesh.num_nodes(); ++i) x.segment<3>(3 * i) = F * mesh.nodes[i];
  const Matrix3d G = 0.5 * (F.transpose() * F - Matrix3d::Identity());
  const Lame l = lame_constants(E, nu);
  const double expected = a * a * a * (0.5 * l.lambda * G.trace() * G.trace() + l.mu * G.squaredNorm());
  EXPECT_NEAR(fe.energy(x), expected, 1e-12 * expected);
  // Interior nodes carry no force under a homogeneous stress (the patch test).
  Eigen::VectorXd f = Eigen::VectorXd::Zero(x.size());
  fe.add_forces(x, f);
  double boundary_max = 0.0;
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    const auto& p = mesh.nodes[i];
    bool interior = true;
    for (int d = 0; d < 3; ++d) interior = interior && p[d] > 1e-9 && p[d] < a - 1e-9;
    if (!interior) boundary_max = std::max(boundary_max, f.segment<3>(3 * i).norm());
  }
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    const auto& p = mesh.nodes[i];
    if (p.minCoeff() > 1e-9 && p.maxCoeff() < a - 1e-9) {
      EXPECT_LT(f.segment<3>(3 * i).norm(), 1e-9 * boundary_max);
    }
  }
}

TEST(HyperelasticHex, parallel_assembly_adds_every_element_once_as_the_serial_sums_do) {
  // The forces and stiffness are added colour by colour in parallel; the result must be the
  // element-by-element sum, every element visited once, never two sharing a node at one time.
  const auto mesh = distorted_lattice(0.03, 5);
  const HyperelasticHexElements fe(mesh, 60e3, 0.45, HyperelasticLaw::NeoHookean);
  Eigen::VectorXd x(3 * mesh.num_nodes());
  for (int i = 0; i < mesh.num_nodes(); ++i)
    x.segment<3>(3 * i) = mesh.nodes[i] + 0.002 * Vector3d(std::sin(7.0 * i), std::cos(5.0 * i), std::sin(3.0 * i));
  const int n = 3 * mesh.num_nodes();
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n, n), K_serial = K;
  std::vector<int> visits(static_cast<size_t>(fe.num_elements()), 0);
  std::vector<std::atomic<int>> busy(static_cast<size_t>(mesh.num_nodes()));
  std::atomic<int> clashes{0};
  fe.for_each_element_stiffness(x, false, [&](int e, const HyperelasticHexElements::ElementMatrix& Ke) {
    const auto& hex = fe.hex(e);
    for (int a : hex)
      if (busy[static_cast<size_t>(a)].fetch_add(1) != 0) ++clashes;
    ++visits[static_cast<size_t>(e)];
    for (int p = 0; p < 8; ++p)
      for (int q = 0; q < 8; ++q) K.block<3, 3>(3 * hex[p], 3 * hex[q]) += Ke.block<3, 3>(3 * p, 3 * q);
    for (int a : hex) busy[static_cast<size_t>(a)].fetch_sub(1);
  });
  EXPECT_EQ(clashes.load(), 0);
  Eigen::VectorXd f_serial = Eigen::VectorXd::Zero(n);
  for (int e = 0; e < fe.num_elements(); ++e) {
    EXPECT_EQ(visits[static_cast<size_t>(e)], 1);
    HyperelasticHexElements::ElementMatrix Ke;
    fe.element_stiffness(e, x, false, Ke);
    const auto& hex = fe.hex(e);
    for (int p = 0; p < 8; ++p)
      for (int q = 0; q < 8; ++q) K_serial.block<3, 3>(3 * hex[p], 3 * hex[q]) += Ke.block<3, 3>(3 * p, 3 * q);
    // The element's own forces: the same element alone in a mesh.
    volume::HexMesh one;
    for (int a = 0; a < 8; ++a) one.nodes.push_back(mesh.nodes[static_cast<size_t>(hex[a])]);
    one.hexahedra = {{0, 1, 2, 3, 4, 5, 6, 7}};
    one.node_tags.assign(8, 0);
    const HyperelasticHexElements single(one, 60e3, 0.45, HyperelasticLaw::NeoHookean);
    Eigen::VectorXd xe(24), fe_one = Eigen::VectorXd::Zero(24);
    for (int a = 0; a < 8; ++a) xe.segment<3>(3 * a) = x.segment<3>(3 * hex[a]);
    single.add_forces(xe, fe_one);
    for (int a = 0; a < 8; ++a) f_serial.segment<3>(3 * hex[a]) += fe_one.segment<3>(3 * a);
  }
  EXPECT_LT((K - K_serial).norm(), 1e-12 * K_serial.norm());
  Eigen::VectorXd f = Eigen::VectorXd::Zero(n);
  fe.add_forces(x, f);
  EXPECT_LT((f - f_serial).norm(), 1e-12 * f_serial.norm());
}

TEST(HyperelasticHex, one_brick_has_exactly_the_six_rigid_zero_modes_at_rest) {
  // Full integration: no hourglass modes, so K₀ of one element has rank 18.
  const auto mesh = small_lattice(1, 0.01);
  const HyperelasticHexElements fe(mesh, 50e3, 0.3);
  Eigen::VectorXd x(24);
  for (int i = 0; i < 8; ++i) x.segment<3>(3 * i) = mesh.nodes[i];
  HyperelasticHexElements::ElementMatrix K;
  fe.element_stiffness(0, x, false, K);
  const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<HyperelasticHexElements::ElementMatrix>(K).eigenvalues();
  for (int k = 0; k < 6; ++k) EXPECT_LT(std::abs(ev[k]), 1e-9 * ev[23]);
  EXPECT_GT(ev[6], 1e-3 * ev[23]);
}

TEST(HyperelasticHex, linear_uniaxial_compression_gives_F_L_over_A_E_and_poisson_contraction) {
  // A 30 mm cube on rollers (z fixed at the base, x and y fixed on one symmetry face each),
  // a uniform pressure on the top: the linearised model is exact for uniform strain.
  const double a = 0.03, E = 60e3, p = 2e3;
  for (double nu : {0.0, 0.3, 0.45}) {
    const auto mesh = small_lattice(3, a);
    MassSpringOptions o;
    o.kind = TissueModelKind::StVenantKirchhoff;
    o.fe_poisson_ratio = nu;
    const MassSpringModel m(mesh, {E, 1060}, o);
    DofConstraints c;
    Eigen::VectorXd f = Eigen::VectorXd::Zero(m.num_dofs());
    const double h = a / 3;
    for (int i = 0; i < m.num_nodes(); ++i) {
      const auto& q = mesh.nodes[i];
      if (q.z() < 1e-9) c.fixed.push_back(dof(i, 2));
      if (q.x() < 1e-9) c.fixed.push_back(dof(i, 0));
      if (q.y() < 1e-9) c.fixed.push_back(dof(i, 1));
      if (q.z() > a - 1e-9) {  // tributary area of a node on the top face
        const auto w = [&](double s) { return (s < 1e-9 || s > a - 1e-9) ? 0.5 * h : h; };
        f[dof(i, 2)] = -p * w(q.x()) * w(q.y());
      }
    }
    const DofMap dofs(m.num_dofs(), c);
    SparseMatrix J;
    m.jacobian(m.rest_positions(), JacobianKind::Exact, J);
    SparseMatrix K;
    dofs.reduce_matrix(J, K);
    K = -K;
    Eigen::SparseLU<SparseMatrix> lu(K);
    ASSERT_EQ(lu.info(), Eigen::Success);
    Eigen::VectorXd u = Eigen::VectorXd::Zero(m.num_dofs());
    dofs.add_expanded(lu.solve(dofs.restrict_vector(f)), u);
    for (int i = 0; i < m.num_nodes(); ++i) {
      const auto& q = mesh.nodes[i];
      EXPECT_NEAR(u[dof(i, 2)], -p / E * q.z(), 1e-9 * p / E * a) << "nu " << nu;
      EXPECT_NEAR(u[dof(i, 0)], nu * p / E * q.x(), 1e-9 * p / E * a) << "nu " << nu;
    }
  }
}

TEST(HyperelasticHex, large_uniaxial_stretch_matches_the_st_venant_kirchhoff_closed_form) {
  // F = diag(s, t, t) with the lateral stress S22 = λ tr(E) + 2μ E22 = 0 gives the lateral
  // stretch t(s); the nominal stress is P11 = s S11 and the end force P11 · A₀.
  const double a = 0.02, E = 50e3, nu = 0.4, s = 1.3;
  const Lame l = lame_constants(E, nu);
  const double e1 = 0.5 * (s * s - 1);
  const double e2 = -l.lambda * e1 / (2 * (l.lambda + l.mu));  // λ(e1 + 2 e2) + 2μ e2 = 0
  const double t = std::sqrt(1 + 2 * e2);
  const double S11 = l.lambda * (e1 + 2 * e2) + 2 * l.mu * e1;
  const auto mesh = small_lattice(2, a);
  const HyperelasticHexElements fe(mesh, E, nu);
  Eigen::VectorXd x(3 * mesh.num_nodes());
  for (int i = 0; i < mesh.num_nodes(); ++i) x.segment<3>(3 * i) = Vector3d(s, t, t).cwiseProduct(mesh.nodes[i]);
  Eigen::VectorXd f = Eigen::VectorXd::Zero(x.size());
  fe.add_forces(x, f);
  double end_force = 0.0, lateral = 0.0;
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    if (mesh.nodes[i].x() > a - 1e-9) end_force -= f[3 * i];  // the load that holds the +x face
    lateral = std::max(lateral, std::abs(f[3 * i + 1]) + std::abs(f[3 * i + 2]));
  }
  EXPECT_NEAR(end_force, s * S11 * a * a, 1e-9 * s * S11 * a * a);
  EXPECT_LT(lateral, 1e-9 * end_force);  // lateral faces are free
}

TEST(HyperelasticHex, rejects_a_bad_poisson_ratio_and_an_inverted_brick) {
  const auto mesh = small_lattice(1, 0.01);
  EXPECT_THROW(HyperelasticHexElements(mesh, 50e3, 0.5), InvalidInputError);
  EXPECT_THROW(HyperelasticHexElements(mesh, 50e3, -0.1), InvalidInputError);
  EXPECT_THROW(HyperelasticHexElements(mesh, 0.0, 0.3), InvalidInputError);
  MassSpringOptions o;
  o.kind = TissueModelKind::StVenantKirchhoff;
  o.fe_poisson_ratio = std::nan("");
  EXPECT_THROW(MassSpringModel(mesh, {50e3, 1060}, o), InvalidInputError);
  auto inverted = mesh;
  std::swap(inverted.hexahedra[0][0], inverted.hexahedra[0][1]);
  std::swap(inverted.hexahedra[0][2], inverted.hexahedra[0][3]);
  std::swap(inverted.hexahedra[0][4], inverted.hexahedra[0][5]);
  std::swap(inverted.hexahedra[0][6], inverted.hexahedra[0][7]);
  EXPECT_THROW(HyperelasticHexElements(inverted, 50e3, 0.3), TopologyError);
}

}  // namespace
}  // namespace socketsmith::tissue
