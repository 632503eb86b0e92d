// The contact solver's two per-node terms (contact_terms.h) against central finite differences of
// their own energy: the force is −∂E/∂p and the stiffness ∂²E/∂p², on a flat wall, on a curved
// one (where the penalty's stiffness leaves out exactly the wall's curvature term), and for the
// lagged friction both sticking and sliding.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>

#include "socketsmith/contact/contact_terms.h"

namespace socketsmith::contact {
namespace {

using Mat3 = Eigen::Matrix3d;

/// Gap to a flat wall through @p origin with unit normal @p n pointing into the cavity.
Gap plane_gap(const Vec3& p, const Vec3& origin, const Vec3& n) {
  Gap g;
  g.valid = true;
  g.gap_m = n.dot(p - origin);
  g.normal = n;
  g.point = p - g.gap_m * n;
  g.stiffness_shape = n * n.transpose();
  return g;
}

/// Gap inside a spherical cavity of radius @p R about the origin (a curved wall: ∇²gap ≠ 0).
Gap sphere_gap(const Vec3& p, double R) {
  Gap g;
  const double r = p.norm();
  g.valid = true;
  g.gap_m = R - r;
  g.normal = -p / r;
  g.point = R * p / r;
  g.stiffness_shape = g.normal * g.normal.transpose();
  return g;
}

/// Central differences of @p energy's gradient and of @p force's Jacobian at @p p.
template <class E, class F>
void finite_differences(const E& energy, const F& force, const Vec3& p, double h, Vec3& grad, Mat3& jac) {
  for (int a = 0; a < 3; ++a) {
    const Vec3 d = h * Vec3::Unit(a);
    grad[a] = (energy(p + d) - energy(p - d)) / (2 * h);
    jac.col(a) = (force(p + d) - force(p - d)) / (2 * h);
  }
}

TEST(ContactTerms, penalty_force_and_stiffness_are_the_derivatives_of_its_energy_on_a_flat_wall) {
  const double kA = 3e4;  // e.g. k = 1e8 N/m³ on 3 cm² (the demo's skin nodes)
  const Vec3 n = Vec3(0.3, -0.5, 0.8).normalized(), o(0.01, 0.02, -0.03);
  const auto term = [&](const Vec3& p) { return penalty_term(plane_gap(p, o, n), kA); };
  for (const double depth : {1e-5, 2e-4, 1e-3}) {
    const Vec3 p = o - depth * n + Vec3(0.004, 0.002, 0.001).cross(n);
    const PenaltyTerm t = term(p);
    ASSERT_TRUE(t.active);
    EXPECT_NEAR(t.normal_force_n, kA * depth, 1e-9 * kA * depth);
    Vec3 grad;
    Mat3 jac;
    finite_differences([&](const Vec3& q) { return term(q).term.energy; }, [&](const Vec3& q) { return term(q).term.force; },
                       p, 0.1 * depth, grad, jac);
    EXPECT_LT((grad + t.term.force).norm(), 1e-7 * t.term.force.norm()) << depth;
    EXPECT_LT((jac + t.term.stiffness).norm(), 1e-7 * t.term.stiffness.norm()) << depth;
    EXPECT_LT((t.term.stiffness - t.term.stiffness.transpose()).norm(), 1e-12 * kA);
  }
  // Outside the wall, or where the gap is not valid (beyond the rim): no term at all.
  EXPECT_FALSE(term(o + 1e-4 * n).active);
  EXPECT_EQ(term(o + 1e-4 * n).term.energy, 0.0);
  Gap beyond = plane_gap(o - 1e-4 * n, o, n);
  beyond.valid = false;
  EXPECT_FALSE(penalty_term(beyond, kA).active);
  EXPECT_EQ(penalty_term(beyond, kA).term.force, Vec3::Zero());
}

TEST(ContactTerms, penalty_stiffness_leaves_out_only_the_curved_walls_term) {
  const double kA = 3e4, R = 0.05;  // a 5 cm radius: a socket's wall around the shank
  const auto term = [&](const Vec3& p) { return penalty_term(sphere_gap(p, R), kA); };
  const Vec3 u = Vec3(1, 2, -2).normalized();
  for (const double depth : {1e-5, 1e-4, 5e-4}) {
    const Vec3 p = (R + depth) * u;
    const PenaltyTerm t = term(p);
    ASSERT_TRUE(t.active);
    Vec3 grad;
    Mat3 jac;
    finite_differences([&](const Vec3& q) { return term(q).term.energy; }, [&](const Vec3& q) { return term(q).term.force; },
                       p, 1e-3 * depth, grad, jac);
    // The force is the exact gradient on any wall whose gap reports its own gradient.
    EXPECT_LT((grad + t.term.force).norm(), 1e-6 * t.term.force.norm()) << depth;
    // The Hessian is k A (∇g ∇gᵀ + g ∇²g) with ∇²g = −(I − u uᵀ) / r here; the term keeps the first part.
    const double r = p.norm(), g = R - r;
    const Mat3 curvature = kA * g * (-(Mat3::Identity() - u * u.transpose()) / r);
    EXPECT_LT((-jac - t.term.stiffness - curvature).norm(), 1e-5 * kA) << depth;
    // What it leaves out is |g| / r of the normal stiffness: 0.2 % at 0.1 mm on a 5 cm wall.
    EXPECT_NEAR(curvature.norm() / t.term.stiffness.norm(), std::sqrt(2.0) * depth / r, 1e-9);
  }
}

TEST(ContactTerms, friction_force_and_stiffness_are_the_derivatives_of_its_energy_sticking_and_sliding) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1, 1);
  const auto random_vec = [&] { return Vec3(U(rng), U(rng), U(rng)); };
  int sticking = 0, sliding = 0;
  for (int trial = 0; trial < 200; ++trial) {
    FrictionInput in;
    in.stick_stiffness = 1.5e4;  // kT: stick_stiffness_ratio × k A
    in.limit_n = 0.5 * 2.0;      // μ f̄: μ 0.5 on a node that carried 2 N
    in.lag_normal = random_vec().normalized();
    in.history_n = 0.8 * in.limit_n * random_vec();
    const Vec3 p = 1.2e-4 * random_vec();  // the node's motion relative to the wall since the last step
    const auto at = [&](const Vec3& q) {
      FrictionInput i = in;
      i.displacement_m = q;
      return friction_term(i);
    };
    const FrictionTerm f = at(p);
    // Near the cap the Huber potential's second derivative jumps: finite differences straddling it
    // measure neither side.
    const Eigen::Matrix3d Pt = Eigen::Matrix3d::Identity() - in.lag_normal * in.lag_normal.transpose();
    const double q = (Pt * in.history_n + in.stick_stiffness * Pt * p).norm();
    if (std::abs(q - in.limit_n) < 0.02 * in.limit_n) continue;
    (f.sliding ? sliding : sticking) += 1;
    EXPECT_LE(f.spring_force_n.norm(), in.limit_n * (1 + 1e-12));
    EXPECT_LT(std::abs(f.spring_force_n.dot(in.lag_normal)), 1e-12) << "tangential only";
    EXPECT_EQ(f.term.force, -f.spring_force_n);
    Vec3 grad;
    Mat3 jac;
    finite_differences([&](const Vec3& x) { return at(x).term.energy; }, [&](const Vec3& x) { return at(x).term.force; }, p,
                       1e-9, grad, jac);
    EXPECT_LT((grad + f.term.force).norm(), 1e-6 * in.limit_n) << trial;
    EXPECT_LT((jac + f.term.stiffness).norm(), 1e-5 * in.stick_stiffness) << trial << (f.sliding ? " sliding" : " sticking");
    // Convex: the stiffness is symmetric positive semi-definite.
    EXPECT_LT((f.term.stiffness - f.term.stiffness.transpose()).norm(), 1e-9 * in.stick_stiffness);
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Mat3>(f.term.stiffness).eigenvalues().minCoeff(), -1e-9 * in.stick_stiffness);
  }
  EXPECT_GT(sticking, 20);
  EXPECT_GT(sliding, 20);
}

TEST(ContactTerms, friction_sliding_carries_exactly_its_cap_against_the_slip) {
  FrictionInput in;
  in.stick_stiffness = 1e4;
  in.limit_n = 0.75;
  in.lag_normal = Vec3::UnitZ();
  in.displacement_m = Vec3(1e-3, 0, 5e-4);  // 1 mm along x (and a normal motion friction ignores)
  const FrictionTerm f = friction_term(in);
  EXPECT_TRUE(f.sliding);
  EXPECT_NEAR(f.term.force.x(), -0.75, 1e-12);
  EXPECT_NEAR(f.term.force.tail<2>().norm(), 0.0, 1e-15);
  // No normal force at the lag: no friction.
  in.limit_n = 0;
  EXPECT_EQ(friction_term(in).term.energy, 0.0);
  EXPECT_EQ(friction_term(in).term.stiffness, Mat3::Zero());
}

}  // namespace
}  // namespace socketsmith::contact
