// The neo-Hookean hexahedra (hyperelastic_hex.h, TissueModelKind::NeoHookean): derivatives by finite
// differences at large strain, closed forms of the energy, the rest tangent, rigid invariance,
// inverted integration points, and the cube on rollers against the analytic uniaxial solution of
// the same strain energy, solved here independently of the element code.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include <Eigen/Dense>

#include "socketsmith/core/errors.h"
#include "socketsmith/tissue/cube_experiment.h"
#include "socketsmith/tissue/hyperelastic_hex.h"
#include "socketsmith/tissue/pressure_load.h"
#include "socketsmith/tissue/static_solver.h"
#include "test_models.h"

namespace socketsmith::tissue {
namespace {
using namespace testing;
using Eigen::Matrix3d;
using Eigen::MatrixXd;
using Eigen::Vector3d;

constexpr double kE = 50e3, kNu = 0.45;

/// CalculiX's constants for (E, ν): C10 = E/(4(1+ν)), D1 = 6(1−2ν)/E.
double c10(double E, double nu) { return E / (4 * (1 + nu)); }
double d1(double E, double nu) { return 6 * (1 - 2 * nu) / E; }

/// W(F) = C10 (J^(−2/3) tr(FᵀF) − 3) + (J − 1)²/D1, written out from CalculiX's definition.
double neo_hookean_w(const Matrix3d& F, double E, double nu) {
  const double J = F.determinant();
  return c10(E, nu) * (std::pow(J, -2.0 / 3.0) * (F.transpose() * F).trace() - 3) + (J - 1) * (J - 1) / d1(E, nu);
}

/// The uniaxial state F = diag(t, t, s) of that energy: with Ī1 = s^(4/3) t^(−4/3) + 2 s^(−2/3) t^(2/3)
/// and J = s t², the lateral stretch solves ∂W/∂t = 0 (1-D Newton from t = 1), the nominal stress is
/// P33 = ∂W/∂s at that t.
struct Uniaxial {
  double lateral_stretch;
  double nominal_stress_pa;
  double volume_ratio;
};
Uniaxial analytic_uniaxial(double s, double E, double nu) {
  const double C = c10(E, nu), D = d1(E, nu);
  double t = 1.0;
  for (int it = 0; it < 100; ++it) {
    const double J = s * t * t;
    const double g = C * (-4.0 / 3 * std::pow(s, 4.0 / 3) * std::pow(t, -7.0 / 3) +
                          4.0 / 3 * std::pow(s, -2.0 / 3) * std::pow(t, -1.0 / 3)) +
                     4 * s * t / D * (J - 1);
    const double dg = C * (28.0 / 9 * std::pow(s, 4.0 / 3) * std::pow(t, -10.0 / 3) -
                           4.0 / 9 * std::pow(s, -2.0 / 3) * std::pow(t, -4.0 / 3)) +
                      4 * s / D * (3 * J - 1);
    const double dt = -g / dg;
    t += dt;
    if (std::abs(dt) < 1e-15) break;
  }
  const double J = s * t * t;
  const double p = C * (4.0 / 3 * std::pow(s, 1.0 / 3) * std::pow(t, -4.0 / 3) -
                        4.0 / 3 * std::pow(s, -5.0 / 3) * std::pow(t, 2.0 / 3)) +
                   2 * t * t / D * (J - 1);
  return {t, p, J};
}

/// Node positions of @p mesh under x = F X + noise (relative to the element size).
Eigen::VectorXd mapped(const volume::HexMesh& mesh, const Matrix3d& F, double noise_m = 0.0, unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::VectorXd x(3 * mesh.num_nodes());
  for (int i = 0; i < mesh.num_nodes(); ++i)
    x.segment<3>(3 * i) = F * mesh.nodes[i] + noise_m * Vector3d(g(rng), g(rng), g(rng));
  return x;
}

/// The strained states of the finite-difference checks: 30 % and 60 % compression with shear,
/// plus random nodal noise so that no two Gauss points share F.
std::vector<std::pair<const char*, Matrix3d>> large_strains() {
  Matrix3d c30, c60, shear;
  c30 << 1.12, 0.0, 0.25, 0.0, 1.1, 0.0, 0.0, 0.05, 0.7;
  c60 << 1.35, 0.1, 0.4, 0.0, 1.3, -0.1, 0.05, 0.0, 0.4;
  shear << 1.0, 0.6, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0;
  return {{"30% compression + shear", c30}, {"60% compression + shear", c60}, {"simple shear 0.6", shear}};
}

/// The elements' forces at @p x into @p f, and their largest difference from central differences
/// (step @p eps) of the energy [N].
double force_fd_error(const HyperelasticHexElements& fe, const Eigen::VectorXd& x, double eps, Eigen::VectorXd& f) {
  f = Eigen::VectorXd::Zero(x.size());
  fe.add_forces(x, f);
  double worst = 0.0;
  for (Eigen::Index c = 0; c < x.size(); ++c) {
    Eigen::VectorXd p = x, q = x;
    p[c] += eps;
    q[c] -= eps;
    worst = std::max(worst, std::abs(-(fe.energy(p) - fe.energy(q)) / (2 * eps) - f[c]));
  }
  return worst;
}

TEST(NeoHookean, forces_match_finite_differences_of_the_energy_at_large_strain) {
  const double a = 0.03;
  const auto mesh = distorted_lattice(a, 11);
  const HyperelasticHexElements fe(mesh, kE, kNu, HyperelasticLaw::NeoHookean);
  for (const auto& [name, F] : large_strains()) {
    const Eigen::VectorXd x = mapped(mesh, F, 0.02 * a / 3, 3);
    ASSERT_GT(fe.min_gauss_jacobian(x), 0) << name;
    Eigen::VectorXd f;
    const double worst = force_fd_error(fe, x, 1e-7 * a, f);
    std::printf("[ info ] %s: force vs energy FD, max error %.2e of max force %.3g N\n", name, worst / f.cwiseAbs().maxCoeff(),
                f.cwiseAbs().maxCoeff());
    EXPECT_LT(worst, 1e-6 * f.cwiseAbs().maxCoeff()) << name;
  }
}

TEST(NeoHookean, tangent_matches_finite_differences_of_the_forces_at_large_strain) {
  const double a = 0.03;
  const auto mesh = distorted_lattice(a, 12);
  MassSpringOptions o;
  o.kind = TissueModelKind::NeoHookean;
  o.fe_poisson_ratio = kNu;
  const MassSpringModel m(mesh, {kE, 1060}, o);
  for (const auto& [name, F] : large_strains()) {
    const Eigen::VectorXd x = mapped(mesh, F, 0.02 * a / 3, 5);
    SparseMatrix J;
    m.jacobian(x, JacobianKind::Exact, J);
    const MatrixXd Jd(J);
    const MatrixXd fd = fd_jacobian([&](const Eigen::VectorXd& y) { return m.elastic_forces(y); }, x, 1e-7 * a);
    const double rel = (fd - Jd).norm() / Jd.norm();
    std::printf("[ info ] %s: tangent vs force FD, relative error %.2e\n", name, rel);
    EXPECT_LT(rel, 1e-6) << name;
    EXPECT_LT((Jd - Jd.transpose()).norm(), 1e-12 * Jd.norm()) << name;
  }
}

TEST(NeoHookean, psd_tangent_is_symmetric_positive_semidefinite_where_the_exact_one_is_not) {
  const double a = 0.03;
  const auto mesh = distorted_lattice(a, 13);
  const HyperelasticHexElements fe(mesh, kE, kNu, HyperelasticLaw::NeoHookean);
  int indefinite = 0;
  for (const auto& [name, F] : large_strains()) {
    const Eigen::VectorXd x = mapped(mesh, F, 0.02 * a / 3, 7);
    for (int e = 0; e < fe.num_elements(); ++e) {
      HyperelasticHexElements::ElementMatrix K, Kp;
      fe.element_stiffness(e, x, false, K);
      fe.element_stiffness(e, x, true, Kp);
      const auto exact = Eigen::SelfAdjointEigenSolver<HyperelasticHexElements::ElementMatrix>(K).eigenvalues();
      const auto proj = Eigen::SelfAdjointEigenSolver<HyperelasticHexElements::ElementMatrix>(Kp).eigenvalues();
      if (exact[0] < -1e-6 * exact[23]) ++indefinite;
      EXPECT_LT((Kp - Kp.transpose()).norm(), 1e-12 * Kp.norm()) << name << ", element " << e;
      EXPECT_GE(proj[0], -1e-10 * proj[23]) << name << ", element " << e;
    }
  }
  // The check means something only if some exact tangents were indefinite.
  EXPECT_GT(indefinite, 0);
  // Where every Gauss point's tangent is positive definite (at rest) the projection changes nothing.
  const Eigen::VectorXd x0 = mapped(mesh, Matrix3d::Identity());
  HyperelasticHexElements::ElementMatrix K, Kp;
  fe.element_stiffness(0, x0, false, K);
  fe.element_stiffness(0, x0, true, Kp);
  EXPECT_LT((K - Kp).norm(), 1e-12 * K.norm());
}

// The element loops run in parallel chunks of 2,048 elements summed in element order: on a
// lattice of several chunks, the one-pass forces and energy (what a line search's trial point asks)
// give the closed-form energy of a homogeneous deformation, no force on interior nodes (the patch
// test across the chunks' seams), the separate passes' values, and refuse an inverted state
// leaving the forces untouched.
TEST(NeoHookean, one_pass_forces_and_energy_over_several_chunks_match_the_closed_form_and_refuse_inversion) {
  const double edge = 0.07;
  const int n = 14;  // 2,744 elements: two chunks
  const auto mesh = small_lattice(n, edge);
  MassSpringOptions o;
  o.kind = TissueModelKind::NeoHookean;
  o.fe_poisson_ratio = kNu;
  const MassSpringModel m(mesh, {kE, 1060}, o);
  ASSERT_GT(m.num_elements(), 2048);
  Matrix3d F;
  F << 1.08, 0.05, 0.0, -0.02, 0.85, 0.1, 0.03, 0.0, 0.9;
  const Eigen::VectorXd x = mapped(mesh, F);
  Eigen::VectorXd f = Eigen::VectorXd::Zero(x.size());
  double w = 0.0;
  ASSERT_TRUE(m.forces_and_energy(x, f, w));
  const double expected = edge * edge * edge * neo_hookean_w(F, kE, kNu);
  EXPECT_NEAR(w, expected, 1e-10 * expected);
  EXPECT_NEAR(m.energy(x), w, 1e-12 * expected);
  EXPECT_LT((m.elastic_forces(x) - f).norm(), 1e-12 * f.norm());
  double boundary_max = 0.0, interior_max = 0.0;
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    const auto& p = mesh.nodes[i];
    const bool interior = p.minCoeff() > 1e-9 && p.maxCoeff() < edge - 1e-9;
    (interior ? interior_max : boundary_max) = std::max(interior ? interior_max : boundary_max, f.segment<3>(3 * i).norm());
  }
  EXPECT_LT(interior_max, 1e-9 * boundary_max);
  // The tangent assembled from the chunks: symmetric, and a rigid translation is a zero mode.
  SparseMatrix J;
  m.jacobian(x, JacobianKind::Exact, J);
  EXPECT_LT(SparseMatrix(SparseMatrix(J.transpose()) - J).norm(), 1e-12 * J.norm());
  Eigen::VectorXd shift(x.size());
  for (int i = 0; i < mesh.num_nodes(); ++i) shift.segment<3>(3 * i) = Vector3d(0.3, -0.5, 0.8);
  EXPECT_LT((J * shift).norm(), 1e-9 * J.norm() * shift.norm());
  // An element turned inside out (a node of the second chunk pushed through its opposite face).
  Eigen::VectorXd bad = x;
  const int node = mesh.num_nodes() - 2 * (n + 1) * (n + 1) - (n + 1) - 2;  // interior, high z
  bad[3 * node + 2] -= 3.0 * edge / n;
  ASSERT_TRUE(m.has_inverted_element(bad));
  Eigen::VectorXd g = Eigen::VectorXd::Constant(x.size(), 7.0);
  EXPECT_FALSE(m.forces_and_energy(bad, g, w));
  EXPECT_TRUE((g.array() == 7.0).all());
  EXPECT_TRUE(std::isinf(m.energy(bad)));
  EXPECT_THROW(m.elastic_forces(bad), SolverError);
}

TEST(NeoHookean, one_brick_has_exactly_the_six_rigid_zero_modes_at_rest) {
  const auto mesh = small_lattice(1, 0.01);
  const HyperelasticHexElements fe(mesh, kE, kNu, HyperelasticLaw::NeoHookean);
  HyperelasticHexElements::ElementMatrix K;
  fe.element_stiffness(0, mapped(mesh, Matrix3d::Identity()), false, K);
  const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<HyperelasticHexElements::ElementMatrix>(K).eigenvalues();
  for (int k = 0; k < 6; ++k) EXPECT_LT(std::abs(ev[k]), 1e-9 * ev[23]);
  EXPECT_GT(ev[6], 1e-3 * ev[23]);
}

TEST(NeoHookean, energy_of_a_homogeneous_deformation_is_volume_times_w_on_distorted_bricks) {
  // x = F X: the same F at every Gauss point, integrated exactly by the 2×2×2 rule whatever the
  // element shapes; interior nodes carry no force (patch test). F-bar too: its J̄ is then J.
  const double a = 0.03;
  const auto mesh = distorted_lattice(a, 3);
  for (const auto formulation : {HexFormulation::Full, HexFormulation::FBar}) {
    for (const auto& [name, F] : large_strains()) {
      const HyperelasticHexElements fe(mesh, kE, kNu, HyperelasticLaw::NeoHookean, formulation);
      const Eigen::VectorXd x = mapped(mesh, F);
      const double expected = a * a * a * neo_hookean_w(F, kE, kNu);
      EXPECT_NEAR(fe.energy(x), expected, 1e-12 * expected) << name;
      Eigen::VectorXd f = Eigen::VectorXd::Zero(x.size());
      fe.add_forces(x, f);
      for (int i = 0; i < mesh.num_nodes(); ++i)
        if (mesh.nodes[i].minCoeff() > 1e-9 && mesh.nodes[i].maxCoeff() < a - 1e-9) {
          EXPECT_LT(f.segment<3>(3 * i).norm(), 1e-9 * f.cwiseAbs().maxCoeff()) << name;
        }
    }
  }
}

TEST(NeoHookean, rest_tangent_equals_the_linear_elastic_st_venant_kirchhoff_tangent) {
  // Both laws linearise to λ tr(ε) I + 2μ ε at rest (λ = K − 2μ/3): the same K₀ on the same mesh.
  const auto mesh = distorted_lattice(0.03, 4);
  MassSpringOptions nh, svk;
  nh.kind = TissueModelKind::NeoHookean;
  svk.kind = TissueModelKind::StVenantKirchhoff;
  const MassSpringModel m_nh(mesh, {kE, 1060}, nh), m_svk(mesh, {kE, 1060}, svk);
  SparseMatrix J_nh, J_svk;
  m_nh.jacobian(m_nh.rest_positions(), JacobianKind::Exact, J_nh);
  m_svk.jacobian(m_svk.rest_positions(), JacobianKind::Exact, J_svk);
  EXPECT_LT((MatrixXd(J_nh) - MatrixXd(J_svk)).norm(), 1e-10 * MatrixXd(J_svk).norm());
  EXPECT_NEAR(m_nh.continuum_material()->c10(), c10(kE, kNu), 1e-9 * kE);
  EXPECT_NEAR(m_nh.continuum_material()->d1(), d1(kE, kNu), 1e-9 * d1(kE, kNu));
}

TEST(NeoHookean, energy_forces_and_tangent_are_invariant_under_a_rigid_rotation) {
  const double a = 0.03;
  const auto mesh = distorted_lattice(a, 6);
  const HyperelasticHexElements fe(mesh, kE, kNu, HyperelasticLaw::NeoHookean);
  const Matrix3d R = random_rotation(8);
  const Eigen::VectorXd x = mapped(mesh, large_strains()[1].second, 0.02 * a / 3, 9);
  const Eigen::VectorXd xr = rigid_motion(x, R, Vector3d(0.2, -0.4, 1.0));
  EXPECT_NEAR(fe.energy(xr), fe.energy(x), 1e-11 * fe.energy(x));
  Eigen::VectorXd f = Eigen::VectorXd::Zero(x.size()), fr = f;
  fe.add_forces(x, f);
  fe.add_forces(xr, fr);
  EXPECT_LT((rigid_motion(f, R, Vector3d::Zero()) - fr).norm(), 1e-10 * f.norm());
  Eigen::Matrix<double, 24, 24> Rb = Eigen::Matrix<double, 24, 24>::Zero();
  for (int k = 0; k < 8; ++k) Rb.block<3, 3>(3 * k, 3 * k) = R;
  for (int e : {0, 13, 26}) {
    HyperelasticHexElements::ElementMatrix K, Kr;
    fe.element_stiffness(e, x, false, K);
    fe.element_stiffness(e, xr, false, Kr);
    EXPECT_LT((Rb * K * Rb.transpose() - Kr).norm(), 1e-10 * K.norm()) << "element " << e;
  }
}

TEST(NeoHookean, an_inverted_gauss_point_gives_infinite_energy_and_a_solver_error_not_nan) {
  const auto mesh = small_lattice(1, 0.01);
  MassSpringOptions o;
  o.kind = TissueModelKind::NeoHookean;
  const MassSpringModel m(mesh, {kE, 1060}, o);
  Eigen::VectorXd x = m.rest_positions();
  for (int i = 0; i < m.num_nodes(); ++i) x[3 * i + 2] *= -0.5;  // mirrored: J < 0 everywhere
  EXPECT_EQ(m.energy(x), std::numeric_limits<double>::infinity());
  EXPECT_TRUE(m.has_inverted_element(x));
  EXPECT_THROW(m.elastic_forces(x), SolverError);
  SparseMatrix J;
  EXPECT_THROW(m.jacobian(x, JacobianKind::Exact, J), SolverError);
  // St Venant–Kirchhoff is defined for any F: finite forces, no exception.
  o.kind = TissueModelKind::StVenantKirchhoff;
  const MassSpringModel svk(mesh, {kE, 1060}, o);
  EXPECT_TRUE(svk.elastic_forces(x).allFinite());
}

TEST(NeoHookean, uniaxial_stress_state_of_the_library_matches_the_closed_form) {
  // The cube experiment's reference (uniaxial_stress_state) against this file's own 1-D solution.
  const HyperelasticMaterial nh(HyperelasticLaw::NeoHookean, kE, kNu);
  for (double s : {0.95, 0.7, 0.4, 1.3}) {
    const Uniaxial u = analytic_uniaxial(s, kE, kNu);
    const UniaxialStressState st = uniaxial_stress_state(nh, u.nominal_stress_pa);
    ASSERT_TRUE(st.found) << "s = " << s;
    EXPECT_NEAR(st.axial_stretch, s, 1e-9) << "s = " << s;
    EXPECT_NEAR(st.lateral_stretch, u.lateral_stretch, 1e-9) << "s = " << s;
  }
  // St Venant–Kirchhoff has a compressive limit point: no uniaxial state beyond it.
  const HyperelasticMaterial svk(HyperelasticLaw::StVenantKirchhoff, kE, kNu);
  EXPECT_TRUE(uniaxial_stress_state(svk, -0.1 * kE).found);
  EXPECT_FALSE(uniaxial_stress_state(svk, -2.0 * kE).found);
}

/// The cube on rollers: base z fixed, the x = 0 and y = 0 faces held in x and y (symmetry planes),
/// lateral faces free.
struct RollerCube {
  RollerCube(int n, double edge) : mesh(small_lattice(n, edge)), edge_m(edge) {
    MassSpringOptions o;
    o.kind = TissueModelKind::NeoHookean;
    o.fe_poisson_ratio = kNu;
    model = std::make_unique<MassSpringModel>(mesh, TissueMaterial{kE, 1060}, o);
    for (int i = 0; i < mesh.num_nodes(); ++i) {
      const auto& q = mesh.nodes[i];
      if (q.z() < 1e-9) base.fixed.push_back(dof(i, 2));
      if (q.x() < 1e-9) base.fixed.push_back(dof(i, 0));
      if (q.y() < 1e-9) base.fixed.push_back(dof(i, 1));
      if (q.z() > edge - 1e-9) top.push_back(i);
    }
  }
  volume::HexMesh mesh;
  double edge_m;
  std::unique_ptr<MassSpringModel> model;
  DofConstraints base;
  std::vector<int> top;
};

TEST(NeoHookean, cube_on_rollers_follows_the_analytic_uniaxial_solution_to_60_percent_compression) {
  // Displacement control: the top face is moved down to the stretch s (its z DOFs prescribed),
  // the lateral faces are free; the reaction on the top over the rest area is the nominal stress.
  RollerCube cube(3, 0.05);
  const MassSpringModel& m = *cube.model;
  DofConstraints c = cube.base;
  for (int t : cube.top) c.fixed.push_back(dof(t, 2));
  const DofMap dofs(m.num_dofs(), c);
  StaticSolver solver(m, dofs);
  Eigen::VectorXd x = m.rest_positions();
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(m.num_dofs());
  const double area = cube.edge_m * cube.edge_m, v0 = m.total_volume(x);
  double worst_stress = 0.0, worst_volume = 0.0;
  for (int k = 1; k <= 12; ++k) {
    const double s = 1.0 - 0.05 * k;  // to 60 % compression
    for (int t : cube.top) x[dof(t, 2)] = s * cube.edge_m;
    const StaticResult r = solver.solve(zero, x);
    ASSERT_TRUE(r.converged) << "s = " << s << ": " << r.message;
    const Eigen::VectorXd f = m.elastic_forces(x);
    double reaction = 0.0;
    for (int t : cube.top) reaction += f[dof(t, 2)];  // internal force the plate holds back
    const Uniaxial u = analytic_uniaxial(s, kE, kNu);
    const double nominal = -reaction / area;
    worst_stress = std::max(worst_stress, std::abs(nominal - u.nominal_stress_pa) / std::abs(u.nominal_stress_pa));
    worst_volume = std::max(worst_volume, std::abs(m.total_volume(x) / v0 - u.volume_ratio));
  }
  std::printf("[ info ] cube to 60%% compression: nominal stress error %.2e, volume ratio error %.2e\n", worst_stress,
              worst_volume);
  EXPECT_LT(worst_stress, 0.02);  // the bar; the state is homogeneous, so the elements are exact
  EXPECT_LT(worst_volume, 0.01);
  EXPECT_LT(worst_stress, 1e-5);
  EXPECT_LT(worst_volume, 1e-6);
}

TEST(NeoHookean, static_solve_of_the_cube_under_an_end_force_converges_at_every_step_to_60_percent) {
  // Force control (the thesis's cube: frictionless rigid box on the top, run_cube_experiment):
  // the weight grows to the one that compresses the analytic cube by 60 %; every weight converges,
  // and each state's stretch and volume match the analytic state of that load.
  const double edge = 0.05, s_end = 0.4;
  const double max_weight = -analytic_uniaxial(s_end, kE, kNu).nominal_stress_pa * edge * edge;
  CubeExperimentOptions o;
  o.edge_m = edge;
  o.material = {kE, 1060};
  o.divisions = 4;
  o.max_weight_n = max_weight;
  o.num_weights = 13;
  o.load_substeps = 1;
  o.model.kind = TissueModelKind::NeoHookean;
  o.model.fe_poisson_ratio = kNu;
  const CubeExperimentResult r = run_cube_experiment(o);
  ASSERT_TRUE(r.converged) << r.message;
  ASSERT_EQ(static_cast<int>(r.rows.size()), o.num_weights);
  double worst_stress = 0.0, worst_volume = 0.0;
  for (const auto& row : r.rows) {
    EXPECT_TRUE(row.converged);
    if (row.weight_n <= 0) continue;
    const Uniaxial u = analytic_uniaxial(1.0 - row.displacement_ratio, kE, kNu);
    worst_stress = std::max(worst_stress, std::abs(-u.nominal_stress_pa - row.top_pressure_analytic_pa) /
                                              row.top_pressure_analytic_pa);
    worst_volume = std::max(worst_volume, std::abs(row.volume_ratio - u.volume_ratio));
    EXPECT_NEAR(row.displacement_ratio_reference, row.displacement_ratio, 1e-5);  // the library's reference
  }
  EXPECT_NEAR(r.rows.back().displacement_ratio, 1.0 - s_end, 1e-5);
  std::printf("[ info ] force-controlled cube to %.1f N (60%% strain): stress error %.2e, volume error %.2e, %.2f s\n",
              max_weight, worst_stress, worst_volume, r.wall_s);
  EXPECT_LT(worst_stress, 0.02);
  EXPECT_LT(worst_volume, 0.01);
  const CubeErrors err = cube_errors(r);
  EXPECT_LT(err.max_displacement_error_reference, 1e-4);
  EXPECT_LT(err.max_volume_error_reference, 1e-5);

  // From rest to the 60 % load in one call: the solver's own load continuation gets there too.
  RollerCube cube(3, edge);
  const MassSpringModel& m = *cube.model;
  const DofMap dofs(m.num_dofs(), cube.base);
  StaticSolver solver(m, dofs);
  Eigen::VectorXd x = m.rest_positions(), f = Eigen::VectorXd::Zero(m.num_dofs());
  const double h = edge / 3;
  for (int t : cube.top) {
    const auto w = [&](double q) { return (q < 1e-9 || q > edge - 1e-9) ? 0.5 * h : h; };
    f[dof(t, 2)] = -max_weight / (edge * edge) * w(cube.mesh.nodes[t].x()) * w(cube.mesh.nodes[t].y());
  }
  const StaticResult sr = solver.solve(f, x);
  ASSERT_TRUE(sr.converged) << sr.message;
  EXPECT_NEAR(x[dof(cube.top.back(), 2)], s_end * edge, 1e-5 * edge);
}

TEST(NeoHookean, cube_under_a_follower_pressure_reaches_the_analytic_true_stress) {
  // A pressure p that follows the top face (FollowerPressure) is a true (Cauchy) stress: at the
  // homogeneous state the nominal stress is P33 = −p t², t the lateral stretch. p is chosen so that
  // the analytic cube is compressed by 50 %; the solve starts from rest.
  const double edge = 0.05, s_end = 0.5;
  const Uniaxial u = analytic_uniaxial(s_end, kE, kNu);
  const double p = -u.nominal_stress_pa / (u.lateral_stretch * u.lateral_stretch);
  RollerCube cube(3, edge);
  volume::HexMesh skinned = cube.mesh;  // the top face is the only skin
  std::fill(skinned.node_tags.begin(), skinned.node_tags.end(), volume::kNodeNone);
  for (int t : cube.top) skinned.node_tags[t] = volume::kNodeSurface;
  const auto skin = volume::extract_skin_surface(skinned);
  ASSERT_EQ(skin.nodes.size(), cube.top.size());
  const MassSpringModel& m = *cube.model;
  const FollowerPressure load(skin, std::vector<double>(skin.nodes.size(), p), m.num_nodes());
  const DofMap dofs(m.num_dofs(), cube.base);
  StaticSolver solver(m, dofs);
  Eigen::VectorXd x = m.rest_positions();
  const StaticResult r = solver.solve(load, x);
  ASSERT_TRUE(r.converged) << r.message;
  const double s = x[dof(cube.top.back(), 2)] / edge;
  std::printf("[ info ] follower pressure %.1f kPa on the cube: stretch %.6f (analytic %.6f), %d Newton iterations\n",
              p / 1e3, s, s_end, r.iterations);
  EXPECT_NEAR(s, s_end, 1e-6);
  EXPECT_NEAR(m.total_volume(x) / m.total_volume(m.rest_positions()), u.volume_ratio, 1e-6);
}

// F-bar (HexFormulation::FBar): the deviatoric energy at the Gauss points, the volumetric one at
// the element centre. Its derivatives by finite differences, the patch test, and the locking it
// removes.
TEST(FBar, forces_and_tangent_match_finite_differences_at_large_strain) {
  const double a = 0.03;
  const auto mesh = distorted_lattice(a, 11);
  const HyperelasticHexElements fe(mesh, kE, kNu, HyperelasticLaw::NeoHookean, HexFormulation::FBar);
  MassSpringOptions o;
  o.kind = TissueModelKind::NeoHookean;
  o.fe_poisson_ratio = kNu;
  o.hex_formulation = HexFormulation::FBar;
  const MassSpringModel m(mesh, {kE, 1060}, o);
  for (const auto& [name, F] : large_strains()) {
    const Eigen::VectorXd x = mapped(mesh, F, 0.02 * a / 3, 3);
    ASSERT_GT(fe.min_gauss_jacobian(x), 0) << name;
    Eigen::VectorXd f;
    const double worst = force_fd_error(fe, x, 1e-7 * a, f);
    EXPECT_LT(worst, 1e-6 * f.cwiseAbs().maxCoeff()) << name;
    SparseMatrix J;
    m.jacobian(x, JacobianKind::Exact, J);
    const MatrixXd Jd(J);
    const MatrixXd fd = fd_jacobian([&](const Eigen::VectorXd& y) { return m.elastic_forces(y); }, x, 1e-7 * a);
    const double rel = (fd - Jd).norm() / Jd.norm();
    std::printf("[ info ] F-bar, %s: force vs energy FD %.2e of the largest force, tangent vs force FD %.2e\n", name,
                worst / f.cwiseAbs().maxCoeff(), rel);
    EXPECT_LT(rel, 1e-6) << name;
    EXPECT_LT((Jd - Jd.transpose()).norm(), 1e-12 * Jd.norm()) << name;
    // The PSD tangent: symmetric, no negative eigenvalue.
    m.jacobian(x, JacobianKind::SymmetricPsd, J);
    const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<MatrixXd>(-MatrixXd(J)).eigenvalues();
    EXPECT_GT(ev.minCoeff(), -1e-9 * ev.maxCoeff()) << name;
  }
}

TEST(FBar, one_brick_has_the_six_rigid_zero_modes_and_only_the_neo_hookean_law_has_it) {
  HyperelasticHexElements::ElementMatrix K;  // one brick: the six rigid modes and no other zero mode
  const auto brick = small_lattice(1, 0.01);
  const HyperelasticHexElements one(brick, kE, kNu, HyperelasticLaw::NeoHookean, HexFormulation::FBar);
  one.element_stiffness(0, mapped(brick, Matrix3d::Identity()), false, K);
  const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<HyperelasticHexElements::ElementMatrix>(K).eigenvalues();
  for (int k = 0; k < 6; ++k) EXPECT_LT(std::abs(ev[k]), 1e-9 * ev[23]);
  EXPECT_GT(ev[6], 1e-4 * ev[23]);
  EXPECT_THROW(HyperelasticHexElements(brick, kE, kNu, HyperelasticLaw::StVenantKirchhoff, HexFormulation::FBar),
               InvalidInputError);
  EXPECT_EQ(parse_hex_formulation(to_string(HexFormulation::FBar)), HexFormulation::FBar);
  EXPECT_THROW(parse_hex_formulation("c3d8r"), InvalidInputError);
}

/// A 4×4×4 block clamped at its base, a small shear force on its top: the top's mean sideways
/// move [m] at shear modulus 17.2 kPa and Poisson ratio @p nu.
double sheared_block(double nu, HexFormulation formulation) {
  const double edge = 0.04, mu = 17.24e3;
  volume::BoxMeshOptions bo;
  bo.size = volume::Vec3::Constant(edge);
  bo.divisions = {4, 4, 4};
  const auto mesh = volume::mesh_box(bo);
  MassSpringOptions o;
  o.kind = TissueModelKind::NeoHookean;
  o.fe_poisson_ratio = nu;
  o.hex_formulation = formulation;
  const MassSpringModel m(mesh, {2 * mu * (1 + nu), 1060}, o);
  DofConstraints c;
  std::vector<int> top;
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    if (mesh.nodes[i].z() < 1e-9)
      for (int d = 0; d < 3; ++d) c.fixed.push_back(dof(i, d));
    if (mesh.nodes[i].z() > edge - 1e-9) top.push_back(i);
  }
  const DofMap dofs(m.num_dofs(), c);
  StaticSolver solver(m, dofs);
  Eigen::VectorXd f = Eigen::VectorXd::Zero(m.num_dofs()), x = m.rest_positions();
  for (int i : top) f[3 * i] = 0.5 / static_cast<double>(top.size());  // 0.5 N: 1.5e-2 strain
  const StaticResult r = solver.solve(f, x);
  EXPECT_TRUE(r.converged) << r.message;
  double u = 0;
  for (int i : top) u += (x[3 * i] - m.rest_positions()[3 * i]) / static_cast<double>(top.size());
  return u;
}

// Volumetric locking: as ν → 0.5 the fully integrated hexahedron stiffens in a deformation that
// keeps the volume only on average over the element; F-bar, whose volume change is one number per
// element, does not. At the same shear modulus the block then barely notices ν with F-bar.
TEST(FBar, removes_the_volumetric_locking_of_the_fully_integrated_hexahedron) {
  const double full_03 = sheared_block(0.3, HexFormulation::Full), fbar_03 = sheared_block(0.3, HexFormulation::FBar);
  const double full_45 = sheared_block(0.45, HexFormulation::Full), fbar_45 = sheared_block(0.45, HexFormulation::FBar);
  const double full_499 = sheared_block(0.499, HexFormulation::Full),
               fbar_499 = sheared_block(0.499, HexFormulation::FBar);
  std::printf("[ info ] sheared block, top move full / F-bar [mm]: ν 0.3 %.4f / %.4f, ν 0.45 %.4f / %.4f, ν 0.499 %.4f / "
              "%.4f\n", 1e3 * full_03, 1e3 * fbar_03, 1e3 * full_45, 1e3 * fbar_45, 1e3 * full_499, 1e3 * fbar_499);
  EXPECT_GT(fbar_499, fbar_45 * 0.8);  // F-bar: ν from 0.45 to 0.499 costs little
  EXPECT_LT(full_499, 0.8 * fbar_499);  // the full element locks
  EXPECT_GT(fbar_45, full_45);          // and is stiffer at the default ν already
  EXPECT_NEAR(fbar_03, full_03, 0.1 * full_03);  // at ν 0.3 they nearly agree
}

}  // namespace
}  // namespace socketsmith::tissue
