// Newton's direction in a contact solve (ContactSolver::Impl, contact_solver_impl.h): the tangent's
// factorisation (projected, or LU, when it is not positive definite), chord steps on the last
// factorisation, a free obstacle's bordered system, and the predicted contacts — the penalties of
// the free nodes the step would take through the wall, solved through the factorisation (Woodbury).
#include <array>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <Eigen/SparseLU>

#include "socketsmith/contact/contact_solver_impl.h"
#include "socketsmith/core/log.h"

namespace socketsmith::contact {

bool ContactSolver::Impl::solve_nonlinear(const VectorXd& xs, const std::vector<Eigen::Matrix3d>& B, SparseMatrix& K,
                                          const Eigen::MatrixXd& r, Eigen::MatrixXd& delta) {
  const SerialParallelRegions serial;
  const auto cholesky = [&](const SparseMatrix& A) {
    if (!llt.factorize(A)) return false;
    ++factorizations;
    delta = llt.solve(r);
    return delta.allFinite();
  };
  llt_of_tangent = model.has_energy() && cholesky(K);
  if (llt_of_tangent) return true;
  if (model.has_energy()) {
    log::debug("contact: the exact tangent is not positive definite: the per-element projected one");
    SparseMatrix Kp;
    tangent(xs, B, Kp, true);
    if (cholesky(Kp)) return true;
  }
  llt.invalidate();  // no chord step on an older factor
  Eigen::SparseLU<SparseMatrix> lu;
  lu.compute(K);
  if (lu.info() != Eigen::Success) return false;
  ++factorizations;
  delta = lu.solve(r);
  return delta.allFinite();
}

bool ContactSolver::Impl::newton_direction(const VectorXd& xs, const std::vector<Eigen::Matrix3d>& B, SparseMatrix& K,
                                           const VectorXd& r, double rs, VectorXd& delta, double& ds) {
  Eigen::MatrixXd rhs = r, sol;  // a free obstacle's column c beside r
  double h = 0;
  ds = 0;
  if (free_axis()) {
    rhs.conservativeResize(Eigen::NoChange, 2);
    rhs.col(1) = free_border(B, h);
  }
  if (opt.linear_body) {
    // The last factorisation (of a nearby contact state) preconditions CG on the new tangent;
    // a fresh factorisation only when CG does not converge quickly.
    if (!free_axis() && llt.valid() && opt.max_reuse_cg > 0 && pcg(K, r, delta)) return true;
    if (!llt.factorize(K)) return false;
    ++factorizations;
    sol = llt.solve(rhs);
  } else if (chord_now) {
    const SerialParallelRegions serial;
    sol = llt.solve(rhs);
    if (!sol.allFinite()) return false;
  } else if (!solve_nonlinear(xs, B, K, rhs, sol)) {
    return false;
  }
  delta = sol.col(0);
  return !free_axis() || eliminate_free(rhs, sol, h, rs, delta, ds);
}

bool ContactSolver::Impl::step_direction(const VectorXd& xs, const std::vector<Eigen::Matrix3d>& B, SparseMatrix& K,
                                         const VectorXd& r, double rs, bool in_tail, VectorXd& delta, double& ds) {
  // The tangent only when a Newton step is taken: a solve converged at its start (a step where no
  // node touches, the last friction pass) or stopped at max_newton costs no tangent. In the tail, a
  // chord step on the last factorisation (ContactOptions::chord_ratio); a fresh tangent when it
  // gives no direction.
  chord_now = chord_next && in_tail && !opt.linear_body && llt.valid();
  if (!chord_now) tangent(xs, B, K);
  if (newton_direction(xs, B, K, r, rs, delta, ds)) return true;
  if (!chord_now) return false;
  chord_now = false;
  tangent(xs, B, K);
  return newton_direction(xs, B, K, r, rs, delta, ds);
}

std::vector<char> ContactSolver::Impl::nodes_through_wall(const VectorXd& xs, const std::vector<NodeContact>& st,
                                                          const VectorXd& d, double ds, const std::vector<char>& added,
                                                          std::vector<Gap>& here) const {
  const Vec3 wall_step = ds * free_dir;  // the obstacle's own step (0 unless free)
  const std::vector<int>& ri = dofs.reduced_index();
  const int n_nodes = static_cast<int>(nodes.size());
  std::vector<char> hit(nodes.size(), 0);
#pragma omp parallel for schedule(dynamic, 64)
  for (int i = 0; i < n_nodes; ++i) {
    if (st[i].active || added[i]) continue;
    const int nd = nodes[i];
    Vec3 step = -wall_step;  // relative to the wall
    for (int c = 0; c < 3; ++c)
      if (ri[3 * nd + c] >= 0) step[c] += d[ri[3 * nd + c]];
    const Vec3 p = xs.segment<3>(3 * nd);
    const QueryCache& qc = qcache[i];
    if (qc.clearance > 0 && qc.clearance > (p - qc.p).norm() + step.norm()) continue;  // cannot reach it
    const Gap g1 = wall_gap(i, p + step);
    if (!g1.valid || g1.gap_m >= -opt.predict_contact_m) continue;
    // Only where the gap linearised at the node foresees the penetration (not across the brim's
    // lip or a fold of the wall, where the linearised penalty would pull the node the wrong way).
    const Gap g0 = wall_gap(i, p);
    const double g_lin = g0.gap_m + g0.gradient_norm * g0.normal.dot(step);
    if (!g0.valid || std::abs(g_lin - g1.gap_m) > 0.5 * std::abs(g1.gap_m)) continue;
    here[i] = g0;
    hit[i] = 1;
  }
  return hit;
}

bool ContactSolver::Impl::solve_low_rank(const std::vector<PenaltyColumn>& U, const Eigen::MatrixXd& r2,
                                         Eigen::MatrixXd& d) {
  // (K + U Uᵀ)⁻¹ r = y − Z (I + Uᵀ Z)⁻¹ Uᵀ y with y = K⁻¹ r, Z = K⁻¹ U: one solve with m + n
  // right-hand sides (n: r2's columns) and an m × m system instead of a factorisation.
  const int m = static_cast<int>(U.size());
  const int n = static_cast<int>(r2.cols());
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(r2.rows(), m + n);
  rhs.leftCols(n) = r2;
  for (int j = 0; j < m; ++j)
    for (int c = 0; c < 3; ++c)
      if (U[j].row[c] >= 0) rhs(U[j].row[c], j + n) = U[j].value[c];
  Eigen::MatrixXd X;
  {
    const SerialParallelRegions serial;
    X = llt.solve(rhs);
  }
  const auto ut = [&](int j, int col) {  // u_jᵀ X(:, col)
    double sum = 0;
    for (int c = 0; c < 3; ++c)
      if (U[j].row[c] >= 0) sum += U[j].value[c] * X(U[j].row[c], col);
    return sum;
  };
  Eigen::MatrixXd S = Eigen::MatrixXd::Identity(m, m);
  Eigen::MatrixXd uy(m, n);
  for (int j = 0; j < m; ++j) {
    for (int q = 0; q < n; ++q) uy(j, q) = ut(j, q);
    for (int q = 0; q < m; ++q) S(j, q) += ut(j, q + n);
  }
  Eigen::MatrixXd d2 = X.leftCols(n) - X.rightCols(m) * S.ldlt().solve(uy);
  if (!d2.allFinite()) return false;
  d = std::move(d2);
  return true;
}

bool ContactSolver::Impl::low_rank_step_with(const std::vector<PenaltyColumn>& U, const VectorXd& r2,
                                             const std::vector<Eigen::Matrix3d>& B_all, double rs2, VectorXd& d,
                                             double& d_s) {
  Eigen::MatrixXd rhs = r2, sol;
  double h = 0;
  if (free_axis()) {
    rhs.conservativeResize(Eigen::NoChange, 2);
    rhs.col(1) = free_border(B_all, h);
  }
  if (!solve_low_rank(U, rhs, sol)) return false;
  VectorXd d2 = sol.col(0);
  double ds2 = 0;
  if (free_axis() && (!eliminate_free(rhs, sol, h, rs2, d2, ds2) || free_step_cut(ds2))) return false;
  d = std::move(d2);
  d_s = ds2;
  return true;
}

bool ContactSolver::Impl::predict_contacts(const VectorXd& xs, const std::vector<NodeContact>& st,
                                           const std::vector<Eigen::Matrix3d>& B, SparseMatrix& K, const VectorXd& r,
                                           double rs, VectorXd& delta, double& ds) {
  if (opt.linear_body || !(opt.predict_contact_m > 0) || predict_paused > 0) return false;
  const bool free = free_axis();
  if (free && free_step_cut(ds)) return false;
  const std::vector<int>& ri = dofs.reduced_index();
  const int n_nodes = static_cast<int>(nodes.size());
  // The added penalties k A ∇g∇gᵀ (rank one on the smoothed wall; up to three on a facet's edge) as
  // the columns U of K' = K + U Uᵀ, their forces −k A g ∇g in r'.
  std::vector<PenaltyColumn> U;
  std::vector<Eigen::Matrix3d> extra(nodes.size(), Eigen::Matrix3d::Zero());
  std::vector<char> added(nodes.size(), 0);
  std::vector<Gap> here(nodes.size());
  // B with every added penalty: a free obstacle's border column and diagonal take them from the
  // start, a refactorised tangent (its projected form built from the blocks) from its first round.
  std::vector<Eigen::Matrix3d> B_all = free ? B : std::vector<Eigen::Matrix3d>{};
  VectorXd r2 = r, d = delta;
  double rs2 = rs, d_s = ds;  // the free obstacle's balance with the added forces, and its step
  bool any = false;
  for (int round = 0; round < 2; ++round) {
    const std::vector<char> hit = nodes_through_wall(xs, st, d, d_s, added, here);
    int n_hit = 0;
    for (int i = 0; i < n_nodes; ++i) {
      if (!hit[i]) continue;
      const Gap& g0 = here[i];
      const double kA = k * areas[i];
      extra[i] = kA * g0.stiffness_shape;
      const Vec3 f = -kA * g0.gap_m * g0.gradient_norm * g0.normal;
      if (free) rs2 -= free_dir.dot(f);  // the node's added force, pressed back onto the obstacle
      if (!B_all.empty()) B_all[i] += extra[i];
      PenaltyColumn col;
      for (int c = 0; c < 3; ++c) {
        col.row[c] = ri[3 * nodes[i] + c];
        if (col.row[c] >= 0) r2[col.row[c]] += f[c];
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(extra[i]);
      for (int j = 0; j < 3; ++j)
        if (eig.eigenvalues()[j] > 1e-9 * eig.eigenvalues()[2]) {
          col.value = std::sqrt(eig.eigenvalues()[j]) * eig.eigenvectors().col(j);
          U.push_back(col);
        }
      added[i] = 1;
      ++n_hit;
    }
    if (n_hit == 0) break;
    if (llt_of_tangent && static_cast<int>(U.size()) <= opt.predict_low_rank_max) {
      if (!low_rank_step_with(U, r2, B_all, rs2, d, d_s)) break;
      low_rank_step = true;  // the factorisation lacks the added penalties: no chord step on it next
    } else {
      // Too many, or the factor is not K's: K' factorised (its values added in place).
      add_node_blocks(extra, K);
      if (B_all.empty()) {  // extra still holds every round's penalties
        B_all = B;
        for (int i = 0; i < n_nodes; ++i) B_all[i] += extra[i];
      }
      VectorXd d2;
      double ds2 = 0;
      if (!newton_direction(xs, B_all, K, r2, rs2, d2, ds2) || (free && free_step_cut(ds2))) break;
      for (int i = 0; i < n_nodes; ++i) extra[i].setZero();  // in K and its factorisation now
      U.clear();
      d = std::move(d2);
      d_s = ds2;
    }
    log::debug("contact: {} free nodes the step takes through the wall: solved again with them", n_hit);
    any = true;
  }
  if (!any || !(-r.dot(d) - rs * d_s < 0)) return false;  // no descent direction of Π: Newton's own step
  delta = std::move(d);
  ds = d_s;
  return true;
}

}  // namespace socketsmith::contact
