#include "socketsmith/tissue/mass_spring_model.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "socketsmith/core/errors.h"
#include "socketsmith/tissue/spring.h"
#include "socketsmith/volume/hex_element.h"
#include "test_models.h"

namespace socketsmith::tissue {
namespace {
using namespace testing;
using Eigen::Vector3d;

// ---------- the two-node spring ----------

TEST(Spring, force_is_k_times_extension_along_the_axis_and_obeys_newtons_third_law) {
  const Vector3d xi(0.1, -0.2, 0.3), xj(0.4, 0.2, 0.3);  // l = 0.5
  const Vector3d f = spring_force(xi, xj, 200.0, 0.4);
  EXPECT_NEAR(f.norm(), 200.0 * 0.1, 1e-12);
  EXPECT_NEAR(f.normalized().dot((xj - xi).normalized()), 1.0, 1e-12);  // pulls i towards j
  EXPECT_NEAR((f + spring_force(xj, xi, 200.0, 0.4)).norm(), 0.0, 1e-12);
  // compressed: pushes apart
  EXPECT_LT(spring_force(xi, xj, 200.0, 0.6).dot(xj - xi), 0.0);
}

TEST(Spring, hessian_matches_finite_differences_and_rotates_with_a_rigid_motion) {
  const Vector3d xi(0.0, 0.0, 0.0), xj(0.03, 0.01, -0.02);
  for (double rest : {0.02, 0.05}) {
    const Eigen::Matrix3d H = spring_hessian(xi, xj, 150.0, rest, false);
    Eigen::Matrix3d fd;
    const double eps = 1e-7;
    for (int a = 0; a < 3; ++a) {
      Vector3d p = xj, m = xj;
      p[a] += eps;
      m[a] -= eps;
      // f_j = −f_i(xj); ∂f_j/∂x_j = −H
      fd.col(a) = (-spring_force(xi, p, 150.0, rest) + spring_force(xi, m, 150.0, rest)) / (2 * eps);
    }
    EXPECT_LT((fd + H).norm(), 1e-6 * H.norm()) << "rest " << rest;
    const Eigen::Matrix3d R = random_rotation(7);
    const Eigen::Matrix3d HR = spring_hessian(R * xi, R * xj, 150.0, rest, false);
    EXPECT_LT((HR - R * H * R.transpose()).norm(), 1e-9 * H.norm());
  }
  // PSD variant of a compressed spring has non-negative eigenvalues
  const Eigen::Matrix3d P = spring_hessian(xi, xj, 150.0, 0.05, true);
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(P).eigenvalues().minCoeff(), -1e-9);
}

// ---------- hexahedron volume ----------

TEST(HexElement, volume_gradient_and_hessian_match_finite_differences) {
  const auto mesh = small_lattice(1, 0.01);
  MassSpringModel m(mesh, {}, options_for(TissueModelKind::Mss));
  const VectorXd x = deformed(m, 3, 0.1);
  volume::HexNodes xe;
  for (int k = 0; k < 8; ++k) xe[k] = x.segment<3>(3 * mesh.hexahedra[0][k]);
  volume::HexGradient g;
  const double v = volume::hex_volume_gradient(xe, g);
  EXPECT_NEAR(v, volume::hex_volume(xe), 1e-18);
  volume::HexHessian H;
  volume::hex_volume_hessian(xe, H);
  const double eps = 1e-8;
  for (int k = 0; k < 8; ++k)
    for (int a = 0; a < 3; ++a) {
      auto p = xe, q = xe;
      p[k][a] += eps;
      q[k][a] -= eps;
      EXPECT_NEAR((volume::hex_volume(p) - volume::hex_volume(q)) / (2 * eps), g[k][a], 1e-9 * 1e-4);
      volume::HexGradient gp, gq;
      volume::hex_volume_gradient(p, gp);
      volume::hex_volume_gradient(q, gq);
      for (int l = 0; l < 8; ++l)
        for (int b = 0; b < 3; ++b)
          EXPECT_NEAR((gp[l][b] - gq[l][b]) / (2 * eps), H(3 * l + b, 3 * k + a), 1e-7);
    }
}

TEST(HexElement, volume_of_a_box_is_exact_and_invariant_under_rigid_motion) {
  volume::BoxMeshOptions o;
  o.size = Vector3d(0.02, 0.03, 0.05);
  o.divisions = {1, 1, 1};
  const auto mesh = volume::mesh_box(o);
  auto xe = volume::gather(mesh.nodes, mesh.hexahedra[0]);
  EXPECT_NEAR(volume::hex_volume(xe), 0.02 * 0.03 * 0.05, 1e-15);
  const Eigen::Matrix3d R = random_rotation(11);
  for (auto& p : xe) p = R * p + Vector3d(1, 2, 3);
  EXPECT_NEAR(volume::hex_volume(xe), 0.02 * 0.03 * 0.05, 1e-15);
  for (double sj : volume::corner_scaled_jacobians(xe)) EXPECT_NEAR(sj, 1.0, 1e-12);
}

// ---------- the models ----------

struct Variant {
  TissueModelKind kind;
  CorrectiveLaw law;
  const char* name;
};
const Variant kVariants[] = {{TissueModelKind::Mss, CorrectiveLaw::Symmetric, "mss"},
                             {TissueModelKind::MssCs, CorrectiveLaw::Symmetric, "mss-cs thesis"},
                             {TissueModelKind::MssCs, CorrectiveLaw::CompressionOnly, "mss-cs recommended"},
                             {TissueModelKind::MssCf, CorrectiveLaw::Symmetric, "mss-cf"},
                             {TissueModelKind::StVenantKirchhoff, CorrectiveLaw::Symmetric, "fe"},
                             {TissueModelKind::NeoHookean, CorrectiveLaw::Symmetric, "neo-hookean"}};

TEST(MassSpringModel, jacobian_matches_finite_differences_of_the_forces_for_every_variant) {
  const auto mesh = small_lattice(2);
  for (const auto& var : kVariants) {
    MassSpringModel m(mesh, {50e3, 1060}, options_for(var.kind, var.law));
    const VectorXd x = deformed(m, 5);
    SparseMatrix J;
    m.jacobian(x, JacobianKind::Exact, J);
    const Eigen::MatrixXd Jd(J);
    const Eigen::MatrixXd fd = fd_jacobian([&](const VectorXd& y) { return m.elastic_forces(y); }, x, 1e-9);
    EXPECT_LT((fd - Jd).norm(), 1e-6 * Jd.norm()) << var.name;
    if (var.kind != TissueModelKind::MssCs) {
      EXPECT_LT((Jd - Jd.transpose()).norm(), 1e-10 * Jd.norm()) << var.name;
    }
  }
}

TEST(MassSpringModel, forces_are_minus_the_energy_gradient_where_an_energy_exists) {
  const auto mesh = small_lattice(2);
  for (const auto& var : kVariants) {
    MassSpringModel m(mesh, {50e3, 1060}, options_for(var.kind, var.law));
    const VectorXd x = deformed(m, 9);
    if (!m.has_energy()) {
      EXPECT_THROW(m.energy(x), Error) << var.name;
      continue;
    }
    const VectorXd f = m.elastic_forces(x);
    const double eps = 1e-9;
    for (int c = 0; c < m.num_dofs(); ++c) {
      VectorXd p = x, q = x;
      p[c] += eps;
      q[c] -= eps;
      EXPECT_NEAR(-(m.energy(p) - m.energy(q)) / (2 * eps), f[c], 1e-6 * f.cwiseAbs().maxCoeff()) << var.name;
    }
  }
}

TEST(MassSpringModel, psd_jacobian_is_symmetric_negative_semidefinite) {
  const auto mesh = small_lattice(2);
  for (const auto& var : kVariants) {
    MassSpringModel m(mesh, {50e3, 1060}, options_for(var.kind, var.law));
    SparseMatrix J;
    m.jacobian(deformed(m, 4), JacobianKind::SymmetricPsd, J);
    const Eigen::MatrixXd K = -Eigen::MatrixXd(J);
    EXPECT_LT((K - K.transpose()).norm(), 1e-10 * K.norm()) << var.name;
    EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(K).eigenvalues().minCoeff(), -1e-8 * K.norm()) << var.name;
  }
}

TEST(MassSpringModel, forces_vanish_at_rest_and_under_rigid_motion_and_rotate_with_it) {
  const auto mesh = small_lattice(2);
  const Eigen::Matrix3d R = random_rotation(21);
  const Vector3d t(0.3, -0.1, 0.2);
  for (const auto& var : kVariants) {
    MassSpringModel m(mesh, {50e3, 1060}, options_for(var.kind, var.law));
    const VectorXd x0 = m.rest_positions();
    const double scale = 50e3 * 0.01 * 0.01;
    EXPECT_LT(m.elastic_forces(x0).cwiseAbs().maxCoeff(), 1e-12 * scale) << var.name;
    EXPECT_LT(m.elastic_forces(rigid_motion(x0, R, t)).cwiseAbs().maxCoeff(), 1e-10 * scale) << var.name;
    const VectorXd x = deformed(m, 13);
    const VectorXd f = m.elastic_forces(x);
    const VectorXd fr = m.elastic_forces(rigid_motion(x, R, t));
    EXPECT_LT((rigid_motion(f, R, Vector3d::Zero()) - fr).norm(), 1e-9 * f.norm()) << var.name;
    // internal forces sum to zero (Newton's third law) and exert no net torque
    Vector3d total = Vector3d::Zero(), torque = Vector3d::Zero();
    for (int i = 0; i < m.num_nodes(); ++i) {
      total += f.segment<3>(3 * i);
      torque += Vector3d(x.segment<3>(3 * i)).cross(Vector3d(f.segment<3>(3 * i)));
    }
    EXPECT_LT(total.norm(), 1e-10 * f.norm()) << var.name;
    if (var.kind != TissueModelKind::MssCs) {
      EXPECT_LT(torque.norm(), 1e-9 * f.norm() * 0.02) << var.name;
    }
  }
}

TEST(MassSpringModel, single_hexahedron_under_uniaxial_stretch_gives_the_analytic_spring_sum) {
  // One cube element of edge l stretched by (1+e) in x: the x-force on the +x face is the sum of
  // 4 edges, 8 face diagonals and 4 body diagonals (eq. 2), and → C11 e l² for small e with
  // C11 = E (9A + 12) / (10 + 7.5A).
  const double l = 0.01, E = 50e3, A = 0.5;
  const auto mesh = small_lattice(1, l);
  MassSpringModel m(mesh, {E, 1060}, options_for(TissueModelKind::Mss));
  const double D = 10 + 7.5 * A;
  const double ke = (0.75 * A + 2) * E * l / D, kf = 1.5 * A * E * l / D, kc = 3 * E * l / D;
  const Eigen::Matrix3d R = random_rotation(5);
  for (double e : {1e-4, 0.1, 0.4, -0.3}) {
    VectorXd x = m.rest_positions();
    for (int i = 0; i < m.num_nodes(); ++i) x[3 * i] *= (1 + e);
    const double df = l * std::sqrt((1 + e) * (1 + e) + 1), dc = l * std::sqrt((1 + e) * (1 + e) + 2);
    const double expected = 4 * ke * e * l + 8 * kf * (df - std::sqrt(2.0) * l) * (1 + e) * l / df +
                            4 * kc * (dc - std::sqrt(3.0) * l) * (1 + e) * l / dc;
    for (bool rotated : {false, true}) {
      const VectorXd xr = rotated ? rigid_motion(x, R, Vector3d(0.1, 0.2, 0.3)) : x;
      const VectorXd f = m.elastic_forces(xr);
      Vector3d face = Vector3d::Zero();
      for (int i = 0; i < m.num_nodes(); ++i)
        if (mesh.nodes[i].x() > 0.5 * l) face += f.segment<3>(3 * i);
      const Vector3d axis = rotated ? Vector3d(R.col(0)) : Vector3d::UnitX();
      EXPECT_NEAR(-face.dot(axis), expected, 1e-9 * std::abs(expected)) << "e = " << e;
      EXPECT_NEAR((face + face.dot(axis) * -axis).norm(), 0.0, 1e-9 * std::abs(expected));
    }
    if (e == 1e-4) {
      EXPECT_NEAR(expected, E * (9 * A + 12) / D * e * l * l, 1e-3 * expected);
    }
  }
}

TEST(MassSpringModel, corrective_dead_zone_is_silent_below_d_and_exact_beyond) {
  // One element compressed uniformly: δv = s³ − 1. With a dead zone d the corrective springs carry
  // nothing while −δv ≤ d (forces equal the Golec lattice's, C = 0), and beyond it the model is
  // the law shifted by d, with a Jacobian that matches finite differences.
  const auto mesh = small_lattice(1);
  for (CorrectiveLaw law : {CorrectiveLaw::CompressionOnly, CorrectiveLaw::Symmetric}) {
    MassSpringOptions zoned = options_for(TissueModelKind::MssCs, CorrectiveLaw::CompressionOnly);
    zoned.corrective.law = law;
    zoned.corrective.beta = 1.5;  // a tangent that would be felt at once without the zone
    zoned.corrective.dead_zone = 0.02;
    MassSpringOptions golec = zoned;
    golec.corrective.c = 0;
    MassSpringOptions shifted = zoned;  // same law without the zone, for the force comparison
    shifted.corrective.dead_zone = 0;
    const MassSpringModel m(mesh, {50e3, 1060}, zoned), g(mesh, {50e3, 1060}, golec), n(mesh, {50e3, 1060}, shifted);
    auto scaled = [&](double dv) {
      const double s = std::cbrt(1 + dv);
      VectorXd x = m.rest_positions();
      for (Eigen::Index i = 0; i < x.size(); ++i) x[i] *= s;
      x[0] += 1e-6;  // break the symmetry a little: not a pure scaling
      return x;
    };
    for (double dv : {-0.005, -0.018, 0.015}) {
      const VectorXd x = scaled(dv);
      EXPECT_LT((m.elastic_forces(x) - g.elastic_forces(x)).norm(), 1e-12 * g.elastic_forces(x).norm() + 1e-15)
          << to_string(law) << " dv " << dv;
      if (dv < 0 || law == CorrectiveLaw::Symmetric) {
        EXPECT_GT((n.elastic_forces(x) - g.elastic_forces(x)).norm(), 1e-6 * g.elastic_forces(x).norm())
            << "without the zone the corrective springs act at dv " << dv;
      }
    }
    const VectorXd x = scaled(-0.06);
    EXPECT_GT((m.elastic_forces(x) - g.elastic_forces(x)).norm(), 1e-3 * g.elastic_forces(x).norm()) << to_string(law);
    SparseMatrix J;
    m.jacobian(x, JacobianKind::Exact, J);
    const Eigen::MatrixXd Jd(J);
    const Eigen::MatrixXd fd = fd_jacobian([&](const VectorXd& y) { return m.elastic_forces(y); }, x, 1e-9);
    EXPECT_LT((fd - Jd).norm(), 1e-6 * Jd.norm()) << to_string(law);
  }
  MassSpringOptions bad;
  bad.corrective.dead_zone = -0.01;
  EXPECT_THROW(MassSpringModel(mesh, {50e3, 1060}, bad), InvalidInputError);
  bad.corrective.dead_zone = 0.5;
  EXPECT_THROW(MassSpringModel(mesh, {50e3, 1060}, bad), InvalidInputError);
}

TEST(MassSpringModel, corrective_slopes_given_to_the_jacobian_replace_the_laws_own) {
  // The law's own slopes reproduce the Jacobian; a steeper slope adds a positive semi-definite
  // volumetric stiffness to K_psd (what the solvers hold for an element about to enter the law),
  // also for elements still inside the dead zone (k' = 0 there).
  MassSpringOptions o;
  o.corrective = CorrectiveSpringConstants::cube_targets();
  const MassSpringModel m(small_lattice(2, 0.02), {50e3, 1060}, o);
  VectorXd mild = m.rest_positions() * 0.997;  // δv ≈ −0.9 %: inside the dead zone
  mild[3] += 1e-5;
  for (const VectorXd& x : {deformed(m, 7, 0.02), mild}) {
    const VectorXd dv = m.element_volume_changes(x);
    EXPECT_NEAR(dv[0], m.element_volumes(x)[0] / m.element_volumes(m.rest_positions())[0] - 1, 1e-12);
    VectorXd own(m.num_elements()), steeper(m.num_elements());
    int in_law = 0;
    for (int e = 0; e < m.num_elements(); ++e) {
      in_law += m.corrective_stiffness(e, dv[e], &own[e]) > 0;
      double ahead = 0.0;
      m.corrective_stiffness(e, dv[e] - 0.01, &ahead);
      steeper[e] = std::min(own[e], ahead);
      EXPECT_LT(steeper[e], own[e]);
    }
    EXPECT_EQ(in_law, dv.maxCoeff() < -0.0133 ? m.num_elements() : 0);
    for (JacobianKind kind : {JacobianKind::Exact, JacobianKind::SymmetricPsd}) {
      SparseMatrix a, b;
      m.jacobian(x, kind, a);
      m.jacobian(x, kind, b, &own);
      EXPECT_LT(Eigen::MatrixXd(a - b).norm(), 1e-12 * Eigen::MatrixXd(a).norm());
    }
    SparseMatrix a, b;
    m.jacobian(x, JacobianKind::SymmetricPsd, a);
    m.jacobian(x, JacobianKind::SymmetricPsd, b, &steeper);
    const Eigen::MatrixXd extra = Eigen::MatrixXd(a - b);  // K(steeper) − K(own), K = −J
    EXPECT_LT((extra - extra.transpose()).norm(), 1e-10 * extra.norm());
    EXPECT_GT(extra.norm(), 1e-3 * Eigen::MatrixXd(a).norm());
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(extra).eigenvalues().minCoeff(), -1e-9 * extra.norm());
  }
  SparseMatrix a;
  const VectorXd x = m.rest_positions();
  VectorXd wrong(1);
  EXPECT_THROW(m.jacobian(x, JacobianKind::Exact, a, &wrong), InvalidInputError);
  EXPECT_EQ(MassSpringModel(small_lattice(1), {50e3, 1060}, options_for(TissueModelKind::MssCf)).corrective_stiffness(0, -0.1),
            0.0);
}

TEST(MassSpringModel, masses_sum_to_rho_times_volume) {
  const auto mesh = small_lattice(3, 0.03);
  MassSpringModel m(mesh, {50e3, 1060}, {});
  EXPECT_NEAR(m.masses().sum(), 1060 * 0.03 * 0.03 * 0.03, 1e-12);
  EXPECT_NEAR(m.total_volume(m.rest_positions()), 0.03 * 0.03 * 0.03, 1e-15);
}

TEST(MassSpringModel, rejects_bad_material_constants_nan_nodes_and_inverted_elements) {
  const auto mesh = small_lattice(1);
  EXPECT_THROW(MassSpringModel(mesh, {0.0, 1060}, {}), InvalidInputError);
  EXPECT_THROW(MassSpringModel(mesh, {-5e3, 1060}, {}), InvalidInputError);
  EXPECT_THROW(MassSpringModel(mesh, {50e3, 0.0}, {}), InvalidInputError);
  EXPECT_THROW(MassSpringModel(mesh, {std::nan(""), 1060}, {}), InvalidInputError);
  MassSpringOptions bad_alpha;
  bad_alpha.corrective.alpha = 0.9;
  EXPECT_THROW(MassSpringModel(mesh, {50e3, 1060}, bad_alpha), InvalidInputError);
  auto nan_mesh = mesh;
  nan_mesh.nodes[3].y() = std::nan("");
  EXPECT_THROW(MassSpringModel(nan_mesh, {50e3, 1060}, {}), InvalidInputError);
  auto inverted = mesh;
  std::swap(inverted.hexahedra[0][0], inverted.hexahedra[0][4]);
  std::swap(inverted.hexahedra[0][1], inverted.hexahedra[0][5]);
  std::swap(inverted.hexahedra[0][2], inverted.hexahedra[0][6]);
  std::swap(inverted.hexahedra[0][3], inverted.hexahedra[0][7]);
  EXPECT_THROW(MassSpringModel(inverted, {50e3, 1060}, {}), TopologyError);
}

TEST(MassSpringModel, parses_names_and_presets) {
  EXPECT_EQ(parse_tissue_model("mss-cs"), TissueModelKind::MssCs);
  EXPECT_EQ(to_string(parse_tissue_model("mss-cf")), "mss-cf");
  EXPECT_EQ(parse_tissue_model("fe"), TissueModelKind::StVenantKirchhoff);
  EXPECT_EQ(parse_tissue_model("neo-hookean"), TissueModelKind::NeoHookean);
  EXPECT_EQ(to_string(TissueModelKind::NeoHookean), "neo-hookean");
  EXPECT_THROW(parse_tissue_model("fem"), InvalidInputError);
  EXPECT_EQ(CorrectiveSpringConstants::preset("thesis").c, 25.0);
  EXPECT_THROW(CorrectiveSpringConstants::preset("best"), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::tissue
