#include "socketsmith/contact/contact_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

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
  VectorXd x, x_conv, x_prev;        // current, last converged and the one before (predictor)
  Vec3 t_conv = Vec3::Zero(), t_prev = Vec3::Zero();
  bool have_prev = false;
  std::vector<Vec3> hist;  // tangential spring force of the last converged step (opposes slip)
  std::vector<NodeContact> state;
  std::vector<char> was_active;  // active at the last converged step
  std::vector<double> conv_fn, lag_fn;  // normal force at the last converged step / friction lag
  std::vector<Vec3> conv_n, lag_n;      // wall normal at the last converged step / friction lag
  double force_floor = 1e-3;            // [N] scale of the residual tolerance when forces are small
  SparseMatrix K0;         // linear body: reduced stiffness at rest
  Eigen::CholmodSupernodalLLT<SparseMatrix> llt;
  Eigen::Index analysed_nnz = -1;

  Impl(const tissue::MassSpringModel& m, const tissue::DofMap& d, std::vector<int> n, std::vector<double> a,
       Obstacle& o, const ContactOptions& op)
      : model(m), dofs(d), nodes(std::move(n)), areas(std::move(a)), obstacle(o), opt(op) {}

  /// Residual (reduced), the incremental potential Π (when the body has an energy) and, when @p K
  /// is given, the tangent K = −∂r/∂x = ∇²Π (reduced) at x. Friction uses the lagged normal forces
  /// and normals (lag_fn, lag_n): with them fixed, the step is the minimum of a convex potential
  /// (elastic energy + ½ k A g² for each penetration + a Huber slip potential per node), so Newton
  /// with a line search on Π converges from any start.
  VectorXd evaluate(const VectorXd& xs, const Vec3& t, std::vector<NodeContact>& st, std::vector<Vec3>& trial_hist,
                    SparseMatrix* K, double* energy) {
    obstacle.set_translation(t);
    const bool conservative = opt.linear_body || model.has_energy();
    VectorXd f_full = opt.linear_body ? VectorXd::Zero(xs.size()) : model.elastic_forces(xs);
    double pi = 0.0;
    std::vector<Eigen::Triplet<double>> trip;
    const auto& ri = dofs.reduced_index();
    st.assign(nodes.size(), NodeContact{});
    trial_hist.assign(nodes.size(), Vec3::Zero());
    for (size_t i = 0; i < nodes.size(); ++i) {
      const int nd = nodes[i];
      const Vec3 p = xs.segment<3>(3 * nd);
      const Gap g = wall_gap(i, p);
      const bool valid = g.valid;
      const double kA = k * areas[i];
      Eigen::Matrix3d B = Eigen::Matrix3d::Zero();
      Vec3 f = Vec3::Zero();
      if (valid && g.gap_m < 0) {
        auto& s = st[i];
        s.active = true;
        s.gap_m = g.gap_m;
        s.normal = g.normal;
        s.normal_force_n = kA * (-g.gap_m);
        s.pressure_pa = s.normal_force_n / areas[i];
        pi += 0.5 * kA * g.gap_m * g.gap_m;
        f += s.normal_force_n * g.normal;
        // Inside a face: stiffness along the normal only; on an edge or a vertex the force points to
        // a fixed point of the wall (f = kA (c − x)), stiff in every direction.
        B += kA * g.stiffness_shape;
      }
      // Friction: nodes that carried a normal force at the lag (μ f̄ > 0) resist slip relative to
      // the wall with an elastic stick (stiffness kA) capped at μ f̄ (return mapping).
      const double limit = opt.friction * lag_fn[i];
      if (limit > 0) {
        const Vec3& nl = lag_n[i];
        const Eigen::Matrix3d Pt = Eigen::Matrix3d::Identity() - nl * nl.transpose();
        const Vec3 slip = Pt * ((p - x_conv.segment<3>(3 * nd)) - (t - t_conv));
        const Vec3 trial = Pt * hist[i] + kA * slip;
        const double mag = trial.norm();
        if (mag > limit) {
          st[i].sliding = true;
          trial_hist[i] = trial * (limit / mag);
          const Vec3 that = trial / mag;
          B += (limit / mag) * kA * (Pt - that * that.transpose());
          pi += limit * mag / kA - 0.5 * limit * limit / kA;
        } else {
          trial_hist[i] = trial;
          B += kA * Pt;
          pi += 0.5 * mag * mag / kA;
        }
        st[i].tangential_n = -trial_hist[i];
        f -= trial_hist[i];
      }
      if (f.squaredNorm() == 0.0 && B.isZero()) continue;
      f_full.segment<3>(3 * nd) += f;
      if (K) {
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) {
            const int ra = ri[3 * nd + a], rb = ri[3 * nd + b];
            if (ra >= 0 && rb >= 0 && B(a, b) != 0.0) trip.emplace_back(ra, rb, B(a, b));
          }
      }
    }
    VectorXd r = dofs.restrict_vector(f_full);
    if (opt.linear_body) {
      const VectorXd u = dofs.restrict_vector(xs - model.rest_positions());
      const VectorXd Ku = K0 * u;
      r -= Ku;
      pi += 0.5 * u.dot(Ku);
    } else if (conservative) {
      pi += model.energy(xs);
    }
    if (energy) *energy = conservative ? pi : std::numeric_limits<double>::quiet_NaN();
    if (K) {
      // Every candidate node's 3×3 block is in the pattern (explicit zeros where it is not in
      // contact), so the tangent's pattern never changes and CHOLMOD orders it once.
      for (const int nd : nodes)
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) {
            const int ra = ri[3 * nd + a], rb = ri[3 * nd + b];
            if (ra >= 0 && rb >= 0) trip.emplace_back(ra, rb, 0.0);
          }
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

  /// Gap against the wall. A node in contact at the last converged step keeps a wider acceptance
  /// cone, so that a node at the wall's rim does not chatter in and out of contact.
  Gap wall_gap(size_t i, const Vec3& p) const {
    Gap g = obstacle.gap(p);
    if (!g.valid && was_active[i] && g.gap_m < 0) {
      const Vec3 dd = p - g.point;
      g.valid = (dd - g.gap_m * g.normal).norm() <= 2.0 * std::abs(g.gap_m) + 1e-4;
    }
    return g;
  }
  double tolerance(const std::vector<NodeContact>& st) const {
    double fsum = 0;
    for (const auto& s : st) fsum += s.normal_force_n + s.tangential_n.norm();
    return opt.rel_tol * std::max(fsum, force_floor);
  }
  /// The residual accepted at a kink of the wall (see ContactOptions::kink_rel_tol).
  double kink_tolerance(const std::vector<NodeContact>& st) const {
    return opt.kink_rel_tol / opt.rel_tol * tolerance(st);
  }

  /// Newton on the equilibrium at translation t with the friction lag fixed; updates xs.
  bool newton(VectorXd& xs, const Vec3& t, std::vector<NodeContact>& st, std::vector<Vec3>& th, int& iterations,
              double& rn, bool& at_kink) {
    at_kink = false;
    SparseMatrix K;
    std::vector<double> pi_history;
    double pi = 0;
    VectorXd r = evaluate(xs, t, st, th, &K, &pi);
    rn = r.norm();
    const bool conservative = std::isfinite(pi);
    for (int it = 0; it <= opt.max_newton; ++it) {
      const double tol = tolerance(st);
      if (rn <= tol) return true;
      if (log::level() <= log::Level::Debug) {
        int act = 0;
        for (const auto& c : st) act += c.active ? 1 : 0;
        log::debug("contact: Newton {}: |r| {:.3g} N (tol {:.3g}), {} active, potential {:.6g} J", it, rn, tol, act,
                   pi);
      }
      if (it == opt.max_newton) {
        at_kink = rn <= kink_tolerance(st);
        return at_kink;
      }
      VectorXd delta;
      if (opt.linear_body) {
        if (K.nonZeros() != analysed_nnz) {
          llt.analyzePattern(K);
          analysed_nnz = K.nonZeros();
        }
        llt.factorize(K);
        if (llt.info() != Eigen::Success) return false;
        delta = llt.solve(r);
      } else {
        Eigen::SparseLU<SparseMatrix> lu;
        lu.compute(K);
        if (lu.info() != Eigen::Success) return false;
        delta = lu.solve(r);
      }
      ++iterations;
      // Backtracking: Armijo on the potential Π when there is one (∇Π = −r, so the slope along
      // delta is −rᵀdelta < 0), else on ‖r‖. Near convergence Π's decrease drowns in round-off:
      // a step that lowers ‖r‖ is then accepted too.
      const double slope = -r.dot(delta);
      double step = 1.0;
      bool accepted = false;
      for (int ls = 0; ls < 30; ++ls, step *= 0.5) {
        VectorXd xt = xs;
        dofs.add_expanded(step * delta, xt);
        if (!opt.linear_body && model.min_corner_jacobian(xt) <= 0) continue;
        std::vector<NodeContact> st2;
        std::vector<Vec3> th2;
        double pi2 = 0;
        VectorXd r2 = evaluate(xt, t, st2, th2, nullptr, &pi2);
        const double rn2 = r2.norm();
        const bool ok = conservative
                            ? (pi2 <= pi + 1e-4 * step * slope ||
                               (std::abs(pi2 - pi) <= 1e-12 * std::max(std::abs(pi), 1e-30) && rn2 < rn))
                            : rn2 < (1 - 1e-4 * step) * rn;
        if (ok) {
          xs = std::move(xt);
          r = std::move(r2);
          rn = rn2;
          pi = pi2;
          st = std::move(st2);
          th = std::move(th2);
          accepted = true;
          break;
        }
      }
      if (!accepted) {
        log::debug("contact: line search failed at Newton {} (residual {:.3g} N)", it, rn);
        at_kink = rn <= kink_tolerance(st);
        return at_kink;
      }
      // A node on a kink of the wall (an edge or vertex where the closest face switches) has no
      // point of zero residual: Newton then crawls with tiny steps while Π stops decreasing. Its
      // residual is bounded by the force jump across the kink; accept it when it is small.
      pi_history.push_back(pi);
      const double moved = step * delta.cwiseAbs().maxCoeff();
      const size_t nh = pi_history.size();
      const bool flat = nh > 5 && conservative &&
                        pi_history[nh - 6] - pi <= 1e-6 * std::max(std::abs(pi), 1e-30);
      if ((moved <= opt.kink_step_tol_m || flat) && rn > tolerance(st) && rn <= kink_tolerance(st)) {
        at_kink = true;
        return true;
      }
      if (rn > tolerance(st)) {
        std::vector<NodeContact> st3;
        std::vector<Vec3> th3;
        evaluate(xs, t, st3, th3, &K, nullptr);
      }
    }
    return false;
  }

  ContactStep solve(const Vec3& t, bool commit) {
    const auto t0 = std::chrono::steady_clock::now();
    ContactStep out;
    VectorXd xs = x;
    // Predictor: extrapolate the last converged increment along the obstacle's path (donning moves
    // the socket in equal steps and the tissue follows smoothly); kept when it lowers the potential.
    if (have_prev) {
      const Vec3 dprev = t_conv - t_prev;
      const double len2 = dprev.squaredNorm();
      if (len2 > 0) {
        const double ratio = std::clamp((t - t_conv).dot(dprev) / len2, 0.0, 2.0);
        if (ratio > 0) {
          lag_fn = conv_fn;
          lag_n = conv_n;
          VectorXd xp = x_conv + ratio * (x_conv - x_prev);
          std::vector<NodeContact> s1, s2;
          std::vector<Vec3> h1, h2;
          double p0 = 0, p1 = 0;
          const VectorXd r0 = evaluate(xs, t, s1, h1, nullptr, &p0);
          const VectorXd r1 = evaluate(xp, t, s2, h2, nullptr, &p1);
          const bool better = std::isfinite(p0) ? p1 < p0 : r1.norm() < r0.norm();
          if (better) xs = std::move(xp);
        }
      }
    }
    std::vector<NodeContact> st;
    std::vector<Vec3> th;
    // Friction lag: start from the normal forces of the last converged state, then update them
    // until they agree with the solution's (a fixed point; usually 1–3 passes).
    lag_fn = conv_fn;
    lag_n = conv_n;
    double rn = 0;
    bool ok = false;
    for (int pass = 0; pass < opt.max_friction_passes; ++pass) {
      ++out.friction_passes;
      bool kink = false;
      ok = newton(xs, t, st, th, out.newton_iterations, rn, kink);
      out.at_kink = kink;
      if (!ok || opt.friction == 0) break;
      double change = 0, fmax = 0;
      for (size_t i = 0; i < st.size(); ++i) {
        change = std::max(change, std::abs(st[i].normal_force_n - lag_fn[i]));
        fmax = std::max(fmax, st[i].normal_force_n);
      }
      out.friction_lag_change = fmax > 0 ? change / fmax : 0.0;
      if (change <= opt.friction_lag_tol * std::max(fmax, 1e-12)) break;
      if (pass + 1 == opt.max_friction_passes) break;  // keep the lag of the solved pass
      for (size_t i = 0; i < st.size(); ++i) {
        lag_fn[i] = st[i].normal_force_n;
        if (st[i].active) lag_n[i] = st[i].normal;
      }
    }
    out.converged = ok;
    out.residual_n = rn;
    Vec3 F = Vec3::Zero(), T = Vec3::Zero();
    for (size_t i = 0; i < nodes.size(); ++i) {
      if (!st[i].active && st[i].tangential_n.squaredNorm() == 0) continue;
      const Vec3 f = st[i].normal_force_n * st[i].normal + st[i].tangential_n;  // on the node
      F -= f;
      T -= (xs.segment<3>(3 * nodes[i]) - t).cross(f);
      if (!st[i].active) continue;
      ++out.contact_nodes;
      out.sliding_nodes += st[i].sliding ? 1 : 0;
      out.max_penetration_m = std::max(out.max_penetration_m, -st[i].gap_m);
    }
    out.force_on_obstacle_n = F;
    out.torque_on_obstacle_nm = T;
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (out.converged) {
      out.message = fmt::format("converged in {} Newton iterations ({} friction passes), {} nodes in contact{}",
                                out.newton_iterations, out.friction_passes, out.contact_nodes,
                                out.at_kink ? fmt::format(", residual {:.3g} N left at a kink of the wall", rn) : "");
      x = xs;
      state = st;
      if (commit) {
        if ((t - t_conv).squaredNorm() > 0) {
          x_prev = x_conv;
          t_prev = t_conv;
          have_prev = true;
        }
        x_conv = xs;
        t_conv = t;
        hist = th;
        for (size_t i = 0; i < st.size(); ++i) {
          was_active[i] = st[i].active ? 1 : 0;
          conv_fn[i] = st[i].normal_force_n;
          if (st[i].active) conv_n[i] = st[i].normal;
        }
      }
    } else {
      out.message = fmt::format("contact solve did not converge after {} Newton iterations (residual {:.3g} N)",
                                out.newton_iterations, rn);
    }
    return out;
  }

  /// solve(t), and when it fails, path continuation: reach t through 2, 4, … 64 equal sub-steps
  /// from the last converged translation (a stick–slip switch or a new contact front can be too
  /// much for one Newton solve). Sub-steps are committed only when @p commit.
  ContactStep solve_path(const Vec3& t, bool commit) {
    ContactStep st = solve(t, commit);
    if (st.converged) return st;
    int pieces = 2;
    int total_newton = st.newton_iterations;
    for (int depth = 0; depth < 6 && !st.converged; ++depth, pieces *= 2) {
      const Vec3 from = t_conv;
      x = x_conv;
      for (int k = 1; k <= pieces; ++k) {
        st = solve(from + (t - from) * (static_cast<double>(k) / pieces), commit);
        total_newton += st.newton_iterations;
        if (!st.converged) break;
      }
    }
    st.newton_iterations = total_newton;
    if (st.converged) st.message += fmt::format(" (reached through {} sub-steps)", pieces / 2);
    return st;
  }
};

ContactSolver::ContactSolver(const tissue::MassSpringModel& model, const tissue::DofMap& dofs, std::vector<int> nodes,
                             std::vector<double> areas, Obstacle& obstacle, const ContactOptions& options) {
  require(nodes.size() == areas.size() && !nodes.empty(), "contact: {} candidate nodes for {} areas", nodes.size(),
          areas.size());
  require(std::isfinite(options.friction) && options.friction >= 0, "contact: friction {} must be ≥ 0",
          options.friction);
  require(std::isfinite(options.penalty_factor) && options.penalty_factor > 0 && options.penalty_pa_per_m >= 0,
          "contact: penalty factor {} must be positive", options.penalty_factor);
  impl_ = std::make_unique<Impl>(model, dofs, std::move(nodes), std::move(areas), obstacle, options);
  auto& s = *impl_;
  double spacing = 0;
  for (double a : s.areas) {
    require(std::isfinite(a) && a > 0, "contact: a nodal area is not positive ({} m^2)", a);
    spacing += std::sqrt(a) / static_cast<double>(s.areas.size());
  }
  s.k = options.penalty_pa_per_m > 0 ? options.penalty_pa_per_m
                                     : options.penalty_factor * model.material().youngs_modulus_pa / spacing;
  s.x = s.x_conv = model.rest_positions();
  s.t_conv = obstacle.translation();
  s.hist.assign(s.nodes.size(), Vec3::Zero());
  s.was_active.assign(s.nodes.size(), 0);
  s.conv_fn.assign(s.nodes.size(), 0.0);
  s.conv_n.assign(s.nodes.size(), Vec3::Zero());
  // Residual floor: the force that strains one element of the skin by one (E h²) — a tolerance
  // of rel_tol of it is far below anything a pressure map shows.
  s.force_floor = model.material().youngs_modulus_pa * spacing * spacing;
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

ContactStep ContactSolver::move_to(const Vec3& translation) { return impl_->solve_path(translation, true); }

ContactStep ContactSolver::push_with_force(const Vec3& direction, double force_n, double rel_tol, double max_step_m) {
  require(std::isfinite(force_n) && force_n >= 0, "contact: push force {} N must be ≥ 0", force_n);
  const Vec3 d = direction.normalized();
  auto& s = *impl_;
  const Vec3 base = s.obstacle.translation();
  const auto reaction = [&](const ContactStep& st) { return -st.force_on_obstacle_n.dot(d); };
  // Current reaction.
  ContactStep cur = s.solve_path(base, false);
  require<SolverError>(cur.converged, "contact: {}", cur.message);
  double s_lo = 0, r_lo = reaction(cur), s_hi = 0, r_hi = 0;
  bool bracket = r_lo >= force_n;
  if (bracket) {
    s_hi = 0;
    r_hi = r_lo;
    s_lo = -max_step_m;  // back off until below the force
    for (int k = 0; k < 200; ++k) {
      cur = s.solve_path(base + s_lo * d, false);
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
      cur = s.solve_path(base + s_new * d, true);
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
    cur = s.solve_path(base + sm * d, false);
    require<SolverError>(cur.converged, "contact: {}", cur.message);
    const double rm = reaction(cur);
    if (std::abs(rm - force_n) <= rel_tol * std::max(force_n, 1e-3)) {
      cur = s.solve_path(base + sm * d, true);
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
