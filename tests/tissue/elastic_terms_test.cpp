#include "socketsmith/tissue/elastic_terms.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "socketsmith/core/errors.h"
#include "test_models.h"

namespace socketsmith::tissue {
namespace {
using namespace testing;

struct Kind {
  TissueModelKind kind;
  const char* name;
  std::vector<const char*> terms;  // the terms' types, in order
};
const Kind kKinds[] = {{TissueModelKind::Mss, "mss", {"spring"}},
                       {TissueModelKind::MssCs, "mss-cs", {"spring", "corrective"}},
                       {TissueModelKind::MssCf, "mss-cf", {"spring", "volume"}},
                       {TissueModelKind::StVenantKirchhoff, "fe", {"hyperelastic"}},
                       {TissueModelKind::NeoHookean, "neo-hookean", {"hyperelastic"}}};

const char* type_of(const ElasticTerm& t) {
  if (dynamic_cast<const SpringTerm*>(&t)) return "spring";
  if (dynamic_cast<const CorrectiveSpringTerm*>(&t)) return "corrective";
  if (dynamic_cast<const VolumeEnergyTerm*>(&t)) return "volume";
  if (dynamic_cast<const HyperelasticTerm*>(&t)) return "hyperelastic";
  return "?";
}

/// K = ∂²W/∂x² of one term, dense.
Eigen::MatrixXd term_stiffness(const MassSpringModel& m, const ElasticTerm& t, const VectorXd& x, bool psd) {
  const BlockPattern pattern(m.num_nodes(), [&] {
    HexesAtRest e;
    for (const auto& hex : m.mesh().hexahedra) e.push_back({hex, 1.0, 1.0});
    return e;
  }());
  SparseMatrix K = pattern.matrix();
  t.add_stiffness(x, {psd, nullptr}, pattern, K.valuePtr());
  return Eigen::MatrixXd(K);
}

VectorXd term_forces(const ElasticTerm& t, const VectorXd& x) {
  VectorXd f = VectorXd::Zero(x.size());
  t.add_forces(x, f);
  return f;
}

TEST(ElasticTerms, each_model_is_the_sum_of_its_terms) {
  const auto mesh = distorted_lattice(0.02, 3);
  for (const auto& k : kKinds) {
    MassSpringModel m(mesh, {50e3, 1060}, options_for(k.kind, CorrectiveLaw::CompressionOnly));
    ASSERT_EQ(m.terms().size(), k.terms.size()) << k.name;
    for (size_t i = 0; i < k.terms.size(); ++i) EXPECT_STREQ(type_of(*m.terms()[i]), k.terms[i]) << k.name;
    const VectorXd x = deformed(m, 11);
    VectorXd f = VectorXd::Zero(m.num_dofs());
    Eigen::MatrixXd K = Eigen::MatrixXd::Zero(m.num_dofs(), m.num_dofs());
    for (const auto& t : m.terms()) {
      f += term_forces(*t, x);
      K += term_stiffness(m, *t, x, false);
    }
    SparseMatrix J;
    m.jacobian(x, JacobianKind::Exact, J);
    EXPECT_LT((m.elastic_forces(x) - f).norm(), 1e-12 * f.norm()) << k.name;
    EXPECT_LT((Eigen::MatrixXd(J) + K).norm(), 1e-12 * K.norm()) << k.name;
    EXPECT_EQ(m.has_energy(), k.kind != TissueModelKind::MssCs) << k.name;
  }
}

TEST(ElasticTerms, every_terms_forces_and_stiffness_match_finite_differences_of_its_own_energy_and_forces) {
  const auto mesh = distorted_lattice(0.02, 5);
  for (const auto& k : kKinds) {
    MassSpringModel m(mesh, {50e3, 1060}, options_for(k.kind, CorrectiveLaw::Symmetric));
    const VectorXd x = deformed(m, 13);
    for (const auto& t : m.terms()) {
      const std::string what = std::string(k.name) + " " + type_of(*t);
      const VectorXd f = term_forces(*t, x);
      ASSERT_GT(f.norm(), 0) << what;  // deformed: every term carries load
      if (t->has_energy()) {
        const double eps = 1e-9;
        for (Eigen::Index c = 0; c < x.size(); ++c) {
          VectorXd p = x, q = x;
          p[c] += eps;
          q[c] -= eps;
          double wp = 0, wq = 0;
          t->add_energy(p, wp);
          t->add_energy(q, wq);
          EXPECT_NEAR(-(wp - wq) / (2 * eps), f[c], 1e-6 * f.cwiseAbs().maxCoeff()) << what << " dof " << c;
        }
      } else {
        double w = 0;
        EXPECT_THROW(t->add_energy(x, w), Error) << what;
      }
      const Eigen::MatrixXd K = term_stiffness(m, *t, x, false);
      const Eigen::MatrixXd fd = fd_jacobian([&](const VectorXd& y) { return term_forces(*t, y); }, x, 1e-9);
      EXPECT_LT((fd + K).norm(), 1e-6 * K.norm()) << what;
      // The surrogate: symmetric positive semi-definite.
      const Eigen::MatrixXd P = term_stiffness(m, *t, x, true);
      EXPECT_LT((P - P.transpose()).norm(), 1e-10 * P.norm()) << what;
      EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(P).eigenvalues().minCoeff(), -1e-8 * P.norm()) << what;
    }
  }
}

TEST(ElasticTerms, forces_and_energy_in_one_pass_equal_the_two_and_refuse_an_inverted_state_untouched) {
  const auto mesh = small_lattice(2);
  for (const auto& k : kKinds) {
    if (k.kind == TissueModelKind::MssCs) continue;  // no energy
    MassSpringModel m(mesh, {50e3, 1060}, options_for(k.kind));
    const VectorXd x = deformed(m, 17);
    for (const auto& t : m.terms()) {
      VectorXd f = VectorXd::Constant(x.size(), 1.0);
      double w = 2.0, w2 = 2.0;
      ASSERT_TRUE(t->add_forces_and_energy(x, f, w)) << k.name;
      t->add_energy(x, w2);
      EXPECT_NEAR(w, w2, 1e-12 * std::abs(w2)) << k.name;  // added to what was there
      EXPECT_LT((f - VectorXd::Constant(x.size(), 1.0) - term_forces(*t, x)).norm(), 1e-12 * f.norm()) << k.name;
    }
    // The first brick's corner 0 pushed through its opposite corner.
    const int a = mesh.hexahedra[0][0], b = mesh.hexahedra[0][6];
    VectorXd inv = m.rest_positions();
    inv.segment<3>(3 * a) += 1.5 * (inv.segment<3>(3 * b) - inv.segment<3>(3 * a));
    ASSERT_TRUE(m.has_inverted_element(inv)) << k.name;
    VectorXd f = VectorXd::Zero(x.size());
    double w = 0;
    EXPECT_FALSE(m.forces_and_energy(inv, f, w)) << k.name;
    EXPECT_EQ(f.norm(), 0.0) << k.name;
  }
}

TEST(BlockPattern, puts_each_block_where_the_dense_matrix_has_it) {
  const auto mesh = small_lattice(2);
  HexesAtRest elements;
  for (const auto& hex : mesh.hexahedra) elements.push_back({hex, 1.0, 1.0});
  const BlockPattern pattern(mesh.num_nodes(), elements);
  SparseMatrix K = pattern.matrix();
  Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(K.rows(), K.cols());
  for (size_t e = 0; e < elements.size(); ++e)
    for (int a = 0; a < 8; ++a)
      for (int b = 0; b < 8; ++b) {
        const int i = elements[e].nodes[a], j = elements[e].nodes[b];
        Eigen::Matrix3d B;
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) B(r, c) = 1000.0 * static_cast<double>(e + 1) + 100 * a + 10 * b + 3 * r + c;
        pattern.add_element(K.valuePtr(), e, elements[e].nodes, a, b, B);
        expected.block<3, 3>(3 * i, 3 * j) += B;
        EXPECT_EQ(pattern.offset(i, j), pattern.element_offset(e, a, b));
      }
  EXPECT_EQ((Eigen::MatrixXd(K) - expected).norm(), 0.0);
}

}  // namespace
}  // namespace socketsmith::tissue
