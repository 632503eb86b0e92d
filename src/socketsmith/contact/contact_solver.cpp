#include "socketsmith/contact/contact_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <Eigen/CholmodSupport>
#include <Eigen/SparseLU>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"

namespace socketsmith::contact {

using tissue::SparseMatrix;
using tissue::VectorXd;

struct ContactSolver::Impl {
  const tissue::MassSpringModel& model;
  const tissue::DofMap& dofs;
  std::vector<int> nodes;
  std::vector<double> areas;
  Obstacle& obstacle;
  ContactOptions opt;
  double k = 0;
  VectorXd x, x_conv;
  Vec3 t_conv = Vec3::Zero();
  std::vector<Vec3> hist;  // tangential spring force of the last converged step (opposes slip)
  std::vector<NodeContact> state;
  std::vector<char> was_active;  // active at the last converged step
  SparseMatrix K0;         // linear body: reduced stiffness at rest
  Eigen::CholmodSupernodalLLT<SparseMatrix> llt;
  Eigen::Index analysed_nnz = -1;

  Impl(const tissue::MassSpringModel& m, const tissue::DofMap& d, std::vector<int> n, std::vector<double> a,
       Obstacle& o, const ContactOptions& op)
      : model(m), dofs(d), nodes(std::move(n)), areas(std::move(a)), obstacle(o), opt(op) {}

  /// Residual (reduced) and, when @p K is given, the tangent K = −∂r/∂x (reduced) at x.
  VectorXd evaluate(const VectorXd& xs, const Vec3& t, std::vector<NodeContact>& st, std::vector<Vec3>& trial_hist,
                    SparseMatrix* K) {
    obstacle.set_translation(t);
    VectorXd f_full = opt.linear_body ? VectorXd::Zero(xs.size()) : model.elastic_forces(xs);
    std::vector<Eigen::Triplet<double>> trip;
    const auto& ri = dofs.reduced_index();
    st.assign(nodes.size(), NodeContact{});
    trial_hist.assign(nodes.size(), Vec3::Zero());
    for (size_t i = 0; i < nodes.size(); ++i) {
      const int nd = nodes[i];
      const Vec3 p = xs.segment<3>(3 * nd);
      const Gap g = obstacle.gap(p);
      // A node in contact at the last converged step keeps a wider acceptance cone, so that a node
      // at the wall's rim does not chatter in and out of contact between Newton iterations.
      bool valid = g.valid;
      if (!valid && was_active[i] && g.gap_m < 0) {
        const Vec3 dd = p - g.point;
        valid = (dd - g.gap_m * g.normal).norm() <= 2.0 * std::abs(g.gap_m) + 1e-4;
      }
      if (!valid || g.gap_m >= 0) continue;
      auto& s = st[i];
      s.active = true;
      s.gap_m = g.gap_m;
      s.normal = g.normal;
      const double kA = k * areas[i];
      s.normal_force_n = kA * (-g.gap_m);
      s.pressure_pa = s.normal_force_n / areas[i];
      // Inside a face: stiffness along the normal only; on an edge or a vertex the force points to
      // a fixed point of the wall (f = kA (c − x)), stiff in every direction.
      Eigen::Matrix3d Kn = kA * g.stiffness_shape;
      Eigen::Matrix3d Kt = Eigen::Matrix3d::Zero();
      Vec3 ft = Vec3::Zero();
      if (opt.friction > 0) {
        const Eigen::Matrix3d Pt = Eigen::Matrix3d::Identity() - g.normal * g.normal.transpose();
        const Vec3 slip = Pt * ((p - x_conv.segment<3>(3 * nd)) - (t - t_conv));
        const Vec3 trial = Pt * hist[i] + kA * slip;
        const double limit = opt.friction * s.normal_force_n;
        const double mag = trial.norm();
        if (mag > limit && mag > 0) {
          s.sliding = true;
          trial_hist[i] = trial * (limit / mag);
          const Vec3 that = trial / mag;
          // Consistent slip tangent (its symmetric part): no stiffness along the slip direction.
          Kt = (limit / mag) * kA * (Pt - that * that.transpose());
        } else {
          trial_hist[i] = trial;
          Kt = kA * Pt;
        }
        ft = -trial_hist[i];
      }
      s.tangential_n = ft;
      f_full.segment<3>(3 * nd) += s.normal_force_n * g.normal + ft;
      if (K) {
        const Eigen::Matrix3d B = Kn + Kt;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) {
            const int ra = ri[3 * nd + a], rb = ri[3 * nd + b];
            if (ra >= 0 && rb >= 0 && B(a, b) != 0.0) trip.emplace_back(ra, rb, B(a, b));
          }
      }
    }
    VectorXd r = dofs.restrict_vector(f_full);
    if (opt.linear_body) r -= K0 * dofs.restrict_vector(xs - model.rest_positions());
    if (K) {
      SparseMatrix C(dofs.num_reduced(), dofs.num_reduced());
      C.setFromTriplets(trip.begin(), trip.end());
      if (opt.linear_body) {
        *K = K0 + C;
      } else {
        SparseMatrix J, Kel;
        model.jacobian(xs, tissue::JacobianKind::Exact, J);
        dofs.reduce_matrix(J, Kel);
        *K = -Kel + C;
      }
      K->makeCompressed();
    }
    return r;
  }

  ContactStep solve(const Vec3& t, bool commit) {
    const auto t0 = std::chrono::steady_clock::now();
    ContactStep out;
    VectorXd xs = x;
    std::vector<NodeContact> st;
    std::vector<Vec3> th;
    SparseMatrix K;
    VectorXd r = evaluate(xs, t, st, th, &K);
    double rn = r.norm();
    for (int it = 0; it <= opt.max_newton; ++it) {
      double fsum = 0;
      for (const auto& s : st) fsum += s.normal_force_n + s.tangential_n.norm();
      const double tol = opt.rel_tol * std::max(fsum, 1e-3);
      out.residual_n = rn;
      if (rn <= tol) {
        out.converged = true;
        break;
      }
      {
        int act = 0;
        for (const auto& c : st) act += c.active ? 1 : 0;
        log::debug("contact: Newton {}: |r| {:.3g} N (tol {:.3g}), {} active", it, rn, tol, act);
      }
      if (it == opt.max_newton) break;
      VectorXd delta;
      if (opt.linear_body) {
        if (K.nonZeros() != analysed_nnz) {
          llt.analyzePattern(K);
          analysed_nnz = K.nonZeros();
        }
        llt.factorize(K);
        if (llt.info() != Eigen::Success) break;
        delta = llt.solve(r);
      } else {
        Eigen::SparseLU<SparseMatrix> lu;
        lu.compute(K);
        if (lu.info() != Eigen::Success) break;
        delta = lu.solve(r);
      }
      ++out.newton_iterations;
      // Backtracking on ‖r‖ (contact switches make the residual only piecewise smooth).
      double step = 1.0;
      bool accepted = false;
      for (int ls = 0; ls < 12; ++ls, step *= 0.5) {
        VectorXd xt = xs;
        dofs.add_expanded(step * delta, xt);
        if (!opt.linear_body && model.min_corner_jacobian(xt) <= 0) continue;
        std::vector<NodeContact> st2;
        std::vector<Vec3> th2;
        SparseMatrix K2;
        VectorXd r2 = evaluate(xt, t, st2, th2, &K2);
        const double rn2 = r2.norm();
        if (rn2 < (1 - 1e-4 * step) * rn || ls == 11) {
          if (rn2 >= rn && ls == 11) break;
          xs = std::move(xt);
          r = std::move(r2);
          rn = rn2;
          st = std::move(st2);
          th = std::move(th2);
          K = std::move(K2);
          accepted = true;
          break;
        }
      }
      if (!accepted) {
        log::debug("contact: line search failed at Newton {} (residual {:.3g} N)", it, rn);
        break;
      }
    }
    Vec3 F = Vec3::Zero(), T = Vec3::Zero();
    for (size_t i = 0; i < nodes.size(); ++i) {
      if (!st[i].active) continue;
      const Vec3 f = st[i].normal_force_n * st[i].normal + st[i].tangential_n;  // on the node
      F -= f;
      T -= (xs.segment<3>(3 * nodes[i]) - t).cross(f);
      ++out.contact_nodes;
      out.sliding_nodes += st[i].sliding ? 1 : 0;
      out.max_penetration_m = std::max(out.max_penetration_m, -st[i].gap_m);
    }
    out.force_on_obstacle_n = F;
    out.torque_on_obstacle_nm = T;
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (out.converged) {
      out.message = fmt::format("converged in {} Newton iterations, {} nodes in contact", out.newton_iterations,
                                out.contact_nodes);
      x = xs;
      state = st;
      if (commit) {
        x_conv = xs;
        t_conv = t;
        hist = th;
        for (size_t i = 0; i < st.size(); ++i) was_active[i] = st[i].active ? 1 : 0;
      }
    } else {
      out.message = fmt::format("contact solve did not converge after {} Newton iterations (residual {:.3g} N)",
                                out.newton_iterations, rn);
    }
    return out;
  }
};

ContactSolver::ContactSolver(const tissue::MassSpringModel& model, const tissue::DofMap& dofs, std::vector<int> nodes,
                             std::vector<double> areas, Obstacle& obstacle, const ContactOptions& options) {
  require(nodes.size() == areas.size() && !nodes.empty(), "contact: {} candidate nodes for {} areas", nodes.size(),
          areas.size());
  require(std::isfinite(options.friction) && options.friction >= 0, "contact: friction {} must be ≥ 0",
          options.friction);
  impl_ = std::make_unique<Impl>(model, dofs, std::move(nodes), std::move(areas), obstacle, options);
  auto& s = *impl_;
  double spacing = 0;
  for (double a : s.areas) {
    require(std::isfinite(a) && a > 0, "contact: a nodal area is not positive ({} m^2)", a);
    spacing += std::sqrt(a) / static_cast<double>(s.areas.size());
  }
  s.k = options.penalty_pa_per_m > 0 ? options.penalty_pa_per_m
                                     : 200.0 * model.material().youngs_modulus_pa / spacing;
  s.x = s.x_conv = model.rest_positions();
  s.t_conv = obstacle.translation();
  s.hist.assign(s.nodes.size(), Vec3::Zero());
  s.was_active.assign(s.nodes.size(), 0);
  s.state.assign(s.nodes.size(), NodeContact{});
  if (options.linear_body) {
    SparseMatrix J;
    model.jacobian(model.rest_positions(), tissue::JacobianKind::Exact, J);
    dofs.reduce_matrix(J, s.K0);
    s.K0 *= -1.0;
    s.K0 = 0.5 * (SparseMatrix(s.K0.transpose()) + s.K0);
    s.K0.makeCompressed();
  }
}

ContactSolver::~ContactSolver() = default;

ContactStep ContactSolver::move_to(const Vec3& translation) {
  auto& s = *impl_;
  ContactStep st = s.solve(translation, true);
  if (st.converged) return st;
  // Path continuation: reach the target through sub-steps from the last converged translation
  // (a stick–slip switch or a new contact front can be too much for one Newton solve).
  int pieces = 2;
  int total_newton = st.newton_iterations;
  for (int depth = 0; depth < 8 && !st.converged; ++depth, pieces *= 2) {
    const Vec3 from = s.t_conv;  // continue from the last converged sub-step
    for (int k = 1; k <= pieces; ++k) {
      st = s.solve(from + (translation - from) * (static_cast<double>(k) / pieces), true);
      total_newton += st.newton_iterations;
      if (!st.converged) break;
    }
  }
  st.newton_iterations = total_newton;
  if (st.converged) st.message += fmt::format(" (reached through {} sub-steps)", pieces);
  return st;
}

ContactStep ContactSolver::push_with_force(const Vec3& direction, double force_n, double rel_tol, double max_step_m) {
  require(std::isfinite(force_n) && force_n >= 0, "contact: push force {} N must be ≥ 0", force_n);
  const Vec3 d = direction.normalized();
  auto& s = *impl_;
  const Vec3 base = s.obstacle.translation();
  const auto reaction = [&](const ContactStep& st) { return -st.force_on_obstacle_n.dot(d); };
  // Current reaction.
  ContactStep cur = s.solve(base, false);
  require<SolverError>(cur.converged, "contact: {}", cur.message);
  double s_lo = 0, r_lo = reaction(cur), s_hi = 0, r_hi = 0;
  bool bracket = r_lo >= force_n;
  if (bracket) {
    s_hi = 0;
    r_hi = r_lo;
    s_lo = -max_step_m;  // back off until below the force
    for (int k = 0; k < 200; ++k) {
      cur = s.solve(base + s_lo * d, false);
      require<SolverError>(cur.converged, "contact: {}", cur.message);
      r_lo = reaction(cur);
      if (r_lo < force_n) break;
      s_hi = s_lo;
      r_hi = r_lo;
      s_lo -= max_step_m;
    }
  } else {
    // March forward in steps (secant-predicted, at most max_step) until the reaction exceeds the force.
    double stiff = 0;
    for (int k = 0; k < 2000 && !bracket; ++k) {
      double step = max_step_m;
      if (stiff > 0) step = std::clamp((force_n - r_lo) / stiff * 1.2, 1e-6, max_step_m);
      const double s_new = s_lo + step;
      cur = s.solve(base + s_new * d, true);
      require<SolverError>(cur.converged, "contact: while pushing with {:.1f} N: {}", force_n, cur.message);
      const double r_new = reaction(cur);
      if (r_new > r_lo) stiff = (r_new - r_lo) / step;
      if (r_new >= force_n) {
        s_hi = s_new;
        r_hi = r_new;
        bracket = true;
      } else {
        s_lo = s_new;
        r_lo = r_new;
      }
    }
    require<SolverError>(bracket, "contact: the obstacle could not be pushed to {:.1f} N (reaction {:.1f} N)", force_n,
                         r_lo);
  }
  // Illinois regula falsi inside the bracket.
  int side = 0;
  for (int k = 0; k < 60; ++k) {
    const double sm = (r_hi - r_lo) > 0 ? s_lo + (force_n - r_lo) * (s_hi - s_lo) / (r_hi - r_lo) : 0.5 * (s_lo + s_hi);
    cur = s.solve(base + sm * d, false);
    require<SolverError>(cur.converged, "contact: {}", cur.message);
    const double rm = reaction(cur);
    if (std::abs(rm - force_n) <= rel_tol * std::max(force_n, 1e-3)) {
      cur = s.solve(base + sm * d, true);
      return cur;
    }
    if (rm < force_n) {
      s_lo = sm;
      r_lo = rm;
      if (side == -1) r_hi = force_n + 0.5 * (r_hi - force_n);
      side = -1;
    } else {
      s_hi = sm;
      r_hi = rm;
      if (side == 1) r_lo = force_n + 0.5 * (r_lo - force_n);
      side = 1;
    }
  }
  fail<SolverError>("contact: the push force {:.1f} N was not reached within tolerance", force_n);
}

const VectorXd& ContactSolver::positions() const { return impl_->x; }
const std::vector<NodeContact>& ContactSolver::contacts() const { return impl_->state; }
const std::vector<int>& ContactSolver::nodes() const { return impl_->nodes; }
double ContactSolver::penalty() const { return impl_->k; }

}  // namespace socketsmith::contact
