// Newton on the contact equilibrium (ContactSolver::Impl, contact_solver_impl.h): its line search
// (its direction: contact_direction.cpp), a solve at one obstacle position with its friction passes, the path between positions,
// and the pushes with a force.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "socketsmith/contact/contact_solver_impl.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/tissue/newton_loop.h"
#include "socketsmith/tissue/static_solver.h"

namespace socketsmith::contact {

bool ContactSolver::Impl::try_step(const VectorXd& xs, const Vec3& t, const VectorXd& delta, double ds, double a,
                                   Trial& tr) {
  tr.x = xs;
  dofs.add_expanded(a * delta, tr.x);
  tr.t = t + a * ds * free_dir;
  VectorXd Ku;
  if (opt.linear_body) Ku = Ku0 + a * Kd;
  tr.r = evaluate(tr.x, tr.t, tr.st, tr.th, &tr.B, &tr.pi, opt.linear_body ? &Ku : nullptr, true);
  tr.rs = free_residual(tr.st);
  tr.pi -= free_force_n * tr.t.dot(free_dir);
  tr.rn = std::hypot(tr.r.norm(), tr.rs);
  tr.slope = -tr.r.dot(delta) - tr.rs * ds;
  return std::isfinite(tr.rn);
}

bool ContactSolver::Impl::line_search(VectorXd& xs, Vec3& t, const VectorXd& delta, double ds, VectorXd& r, double& rs,
                                      double& rn, double& pi, std::vector<NodeContact>& st, std::vector<Vec3>& th,
                                      std::vector<Eigen::Matrix3d>& B, bool conservative, double& step) {
  const double slope0 = -r.dot(delta) - rs * ds;
  if (opt.linear_body) {
    Ku0 = K0 * dofs.restrict_vector(xs - model.rest_positions());
    Kd = K0 * delta;
  }
  const auto sufficient = [&](const Trial& tr, double a) {
    return conservative ? (tr.pi <= pi + 1e-4 * a * slope0 ||
                           (std::abs(tr.pi - pi) <= 1e-12 * std::max(std::abs(pi), 1e-30) && tr.rn < rn))
                        : tr.rn < (1 - 1e-4 * a) * rn;
  };
  const auto take = [&](Trial& tr, double a) {
    xs = std::move(tr.x);
    r = std::move(tr.r);
    t = tr.t;
    rs = tr.rs;
    rn = tr.rn;
    pi = tr.pi;
    st = std::move(tr.st);
    th = std::move(tr.th);
    B = std::move(tr.B);
    step = a;
    return true;
  };
  Trial tr;
  if (conservative && opt.exact_line_search && slope0 < 0 && try_step(xs, t, delta, ds, 1.0, tr)) {
    if (sufficient(tr, 1.0) && tr.slope <= 0.5 * std::abs(slope0)) return take(tr, 1.0);
    if (tr.slope > 0) {
      // Π'(0) < 0 < Π'(1): a minimum in between. Illinois regula falsi on Π'.
      double lo = 0, s_lo = slope0, hi = 1, s_hi = tr.slope;
      int side = 0;
      Trial best;
      double a_best = -1;
      for (int trial = 0; trial < 12; ++trial) {
        double a = lo - s_lo * (hi - lo) / (s_hi - s_lo);
        a = std::clamp(a, lo + 0.02 * (hi - lo), hi - 0.02 * (hi - lo));
        Trial tm;
        if (!try_step(xs, t, delta, ds, a, tm)) break;
        const bool ok = sufficient(tm, a);
        if (ok && std::abs(tm.slope) <= opt.line_search_slope * std::abs(slope0)) return take(tm, a);
        if (tm.slope < 0) {
          lo = a;
          s_lo = tm.slope;
          if (side == -1) s_hi *= 0.5;
          side = -1;
        } else {
          hi = a;
          s_hi = tm.slope;
          if (side == 1) s_lo *= 0.5;
          side = 1;
        }
        if (ok && (a_best < 0 || tm.pi < best.pi)) {
          best = std::move(tm);
          a_best = a;
        }
      }
      if (a_best > 0) return take(best, a_best);
    }
  }
  // Backtracking.
  double a = 1.0;
  for (int ls = 0; ls < 30; ++ls, a *= 0.5) {
    if (!try_step(xs, t, delta, ds, a, tr)) continue;
    if (sufficient(tr, a)) return take(tr, a);
  }
  return false;
}

/// The contact solve's half of Newton (tissue/newton_loop.h), friction lag fixed: the iterate, its
/// residual and potential Π, direction, line search on Π, and what the loop cannot know (a kink of
/// the wall, the lag refreshed in the tail, a new stick, the Newton budget of a donning).
class ContactSolver::Impl::Newton final : public tissue::NewtonProblem {
 public:
  Newton(Impl& s, VectorXd& xs, Vec3& t, std::vector<NodeContact>& st, std::vector<Vec3>& th, int& iterations)
      : s_(s), xs_(xs), t_(t), st_(st), th_(th), iterations_(iterations) {
    residual();
    conservative_ = std::isfinite(pi_);
  }
  double residual_norm() const override { return rn_; }
  double tolerance() const override { return s_.tolerance(st_); }
  bool proceed(int it) override {
    if (log::level() <= log::Level::Debug) {
      const auto act = std::count_if(st_.begin(), st_.end(), [](const NodeContact& c) { return c.active; });
      log::debug("contact: Newton {}: |r| {:.3g} N (tol {:.3g}), {} active, potential {:.6g} J", it, rn_, tolerance(),
                 act, pi_);
    }
    if (!s_.out_of_budget()) return true;
    reason_ = fmt::format("the Newton iterations allowed ({}) are spent", s_.newton_limit);
    return false;
  }
  Result direction() override {
    if (!s_.step_direction(xs_, B_, K_, r_, rs_, s_.in_tail(st_, rn_), delta_, ds_)) {
      reason_ = s_.free_axis() ? "the tangent is singular, or nothing holds the obstacle along its push"
                               : "the tangent is singular";
      return Result::Failed;
    }
    s_.low_rank_step = false;
    if (!s_.chord_now) s_.predict_contacts(xs_, st_, B_, K_, r_, rs_, delta_, ds_);
    ++iterations_;
    ++s_.newton_spent;
    return Result::Done;
  }
  Result line_search() override {
    const double rn_before = rn_;
    const bool accepted = s_.line_search(xs_, t_, delta_, ds_, r_, rs_, rn_, pi_, st_, th_, B_, conservative_, step_);
    s_.chord_next = accepted && step_ == 1.0 && rn_ <= s_.opt.chord_ratio * rn_before && !s_.low_rank_step;
    return accepted ? Result::Done : Result::Failed;  // the loop's message says which
  }
  bool accept_short(tissue::NewtonStop) override { return kink_accepted() || s_.caught(r_, rs_, st_, reason_); }
  Next after_step() override {
    // A node on a kink of the wall (an edge or vertex where the closest face switches) has no
    // point of zero residual: Newton then crawls with tiny steps while Π stops decreasing. Its
    // residual is bounded by the force jump across the kink; accept it when it is small.
    log::debug("contact: step {:.3g} of the Newton step{}", step_, s_.chord_now ? " (chord: on the last factorisation)" : "");
    pi_history_.push_back(pi_);
    const double moved = step_ * std::max(delta_.cwiseAbs().maxCoeff(), std::abs(ds_));
    const size_t nh = pi_history_.size();
    const bool flat = nh > 5 && conservative_ && pi_history_[nh - 6] - pi_ <= 1e-6 * std::max(std::abs(pi_), 1e-30);
    if ((moved <= s_.opt.kink_step_tol_m || flat) && rn_ > tolerance() && kink_accepted()) return Next::Accept;
    // Stalled: the line search has cut the step to a sliver kStallSteps times in a row. Accepted
    // when a few nodes hold the residual (Impl::caught); else Newton only crawls until the search
    // fails (AmpScan: steps 0.008 → 2e-9 over 12 more iterations) and the caller refines the path.
    tiny_steps_ = step_ < kTinyStep ? tiny_steps_ + 1 : 0;
    if (tiny_steps_ >= kStallSteps && s_.caught(r_, rs_, st_, reason_)) return Next::Accept;
    if (tiny_steps_ >= kStallSteps && rn_ > s_.kink_tolerance(st_)) {
      reason_ = fmt::format("stalled: the line search cut the step below {:.3g} of Newton's {} times in a row (residual "
                            "{:.3g} N; {}{})", kTinyStep, kStallSteps, rn_, s_.residual_holders(xs_, r_, st_),
                            model_breaker());
      return Next::Stop;
    }
    if (s_.refresh_lag_in_newton(st_, rn_, relags_)) {
      pi_history_.clear();  // the potential changed
      residual();
    }
    if (s_.stop_on_new_stick && s_.in_tail(st_, rn_) && s_.count_new_sticks(st_) > 0) {
      s_.stopped_on_stick = true;
      reason_ = "a node started sticking";
      return Next::Stop;
    }
    return Next::Continue;
  }
  std::string stop_reason() const override { return reason_; }

 private:
  /// "; " and the node whose contact energy departs most from Newton's model over the step the line
  /// search cut last (twice the sliver it took, from the iterate before it), if one does.
  std::string model_breaker() {
    if (pi_history_.size() < 2) return {};
    VectorXd before = xs_;
    s_.dofs.add_expanded(-step_ * delta_, before);
    const Vec3 t_before = t_ - step_ * ds_ * s_.free_dir;
    const double decrease = 2 * (pi_history_[pi_history_.size() - 2] - pi_);
    const std::string b = s_.model_breaker(before, t_before, delta_, ds_, 2 * step_, decrease);
    s_.obstacle.set_translation(t_);
    return b.empty() ? b : "; " + b;
  }
  /// The residual is within what a node on a kink of the wall leaves (ContactOptions::kink_rel_tol);
  /// then the message says so.
  bool kink_accepted() {
    if (rn_ > s_.kink_tolerance(st_)) return false;
    reason_ = fmt::format("a node on a kink of the wall (within {:.3g} N)", s_.kink_tolerance(st_));
    return true;
  }
  void residual() {
    r_ = s_.evaluate(xs_, t_, st_, th_, &B_, &pi_);
    rs_ = s_.free_residual(st_);
    pi_ -= s_.free_force_n * t_.dot(s_.free_dir);  // the push's work (0 unless free)
    rn_ = std::hypot(r_.norm(), rs_);
  }

  Impl& s_;
  VectorXd& xs_;
  Vec3& t_;
  std::vector<NodeContact>& st_;
  std::vector<Vec3>& th_;
  int& iterations_;
  SparseMatrix K_;
  std::vector<Eigen::Matrix3d> B_;
  std::vector<double> pi_history_;
  VectorXd r_, delta_;
  double pi_ = 0, rs_ = 0, rn_ = 0, ds_ = 0, step_ = 0;
  bool conservative_ = false;
  RelagState relags_;
  int tiny_steps_ = 0;  // line-search steps below kTinyStep in a row
  std::string reason_;
};

bool ContactSolver::Impl::newton(VectorXd& xs, Vec3& t, std::vector<NodeContact>& st, std::vector<Vec3>& th,
                                 int& iterations, double& rn, bool& at_kink) {
  chord_next = false;
  tissue::limit_solver_threads();
  Newton problem(*this, xs, t, st, th, iterations);
  tissue::NewtonLoopOptions o;
  o.max_iterations = opt.max_newton;
  const tissue::NewtonOutcome out = tissue::run_newton(problem, o);
  rn = out.residual;
  at_kink = out.stop == tissue::NewtonStop::Accepted;
  newton_message = out.message;
  if (!out.ok()) log::debug("contact: Newton: {}", out.message);
  if (!out.ok() && !stopped_on_stick) predict_paused = kPredictPause;  // the retries go without predictions
  return out.ok();
}

bool ContactSolver::Impl::refresh_lag_in_newton(const std::vector<NodeContact>& st, double rn, RelagState& rs) {
  // Near convergence, when the normal forces have moved away from the lag by more than the
  // friction-pass tolerance, they become the new lag now instead of only after this Newton solve
  // has converged. Refreshing it far from convergence (any residual) doubled the iterations. Lag
  // and state can cycle (8k demo: |r| 0.497 ↔ 0.439 N, a refresh at every step, 48 Newton steps up
  // to max_newton): after kRelagStall refreshes in a row that did not halve the residual, the lag
  // stays until this solve converges and the friction pass after it takes the new one.
  if (!(opt.friction > 0 && opt.friction_in_newton && in_tail(st, rn) &&
        rs.stalled < kRelagStall && lag_change(st) > opt.friction_lag_tol))
    return false;
  rs.stalled = rn < kRelagProgress * rs.residual_n ? 0 : rs.stalled + 1;
  rs.residual_n = rn;
  update_lag(st);
  log::debug("contact: friction lag refreshed (normal forces moved {:.3g} of the largest)", last_lag_change);
  return true;
}

void ContactSolver::Impl::predict_start(const Vec3& t, VectorXd& xs) {
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
        // A trial point: the extrapolation may turn a strongly compressed element inside out
        // (AmpScan's limb, where the brim passes the tibial tuberosity); then it is not taken.
        const VectorXd r1 = evaluate(xp, t, s2, h2, nullptr, &p1, nullptr, true);
        const bool better = r1.allFinite() && (std::isfinite(p0) ? p1 < p0 : r1.norm() < r0.norm());
        if (better) xs = std::move(xp);
      }
    }
  }
}

ContactStep ContactSolver::Impl::solve(const Vec3& t_start, bool commit) {
  Vec3 t = t_start;  // moves when the obstacle is free along free_dir
  const auto t0 = std::chrono::steady_clock::now();
  ContactStep out;
  VectorXd xs = x;
  alm = conv_alm;  // the multipliers of the last committed step (a discarded solve's are not kept)
  predict_start(t, xs);
  std::vector<NodeContact> st;
  std::vector<Vec3> th;
  // Friction lag: start from the normal forces of the last converged state, then update them
  // until they agree with the solution's (a fixed point; usually 1–3 passes).
  lag_fn = conv_fn;
  lag_n = conv_n;
  last_lag_change = 0;
  // The friction lag of the nodes that touched at the last two steps is extrapolated like the
  // positions (the normal forces grow steadily along a donning path), so that fewer refreshes
  // are needed (7.5k demo: 118 → 104 factorisations, the same state).
  if (opt.extrapolate_friction_lag && have_prev && prev_fn.size() == conv_fn.size()) {
    const Vec3 dprev = t_conv - t_prev;
    const double len2 = dprev.squaredNorm();
    const double ratio = len2 > 0 ? std::clamp((t - t_conv).dot(dprev) / len2, 0.0, 2.0) : 0.0;
    for (size_t i = 0; i < lag_fn.size(); ++i)
      if (conv_fn[i] > 0 && prev_fn[i] > 0) lag_fn[i] = std::max(0.0, conv_fn[i] + ratio * (conv_fn[i] - prev_fn[i]));
  }
  double rn = 0;
  bool ok = false;
  for (int pass = 0; pass < opt.max_friction_passes; ++pass) {
    ++out.friction_passes;
    out.at_kink = false;
    ok = newton(xs, t, st, th, out.newton_iterations, rn, out.at_kink);
    if (!ok) break;
    out.friction_lag_change = opt.friction > 0 ? lag_change(st) : 0.0;
    const bool relag = out.friction_lag_change > opt.friction_lag_tol;
    const bool augment = opt.augmented_tol > 0 && augmentation_change(st) > opt.augmented_tol;
    if ((!relag && !augment) || pass + 1 == opt.max_friction_passes) break;  // keep the lag of the solved pass
    if (relag) update_lag(st);
    if (augment) update_augmentation(st);
  }
  out.converged = ok;
  out.out_of_budget = !ok && out_of_budget();
  out.residual_n = rn;
  out.tolerance_n = tolerance(st);
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
  out.factorizations = factorizations;
  out.cg_iterations = cg_iterations;
  if (out.converged) {
    out.message = fmt::format("converged in {} Newton iterations ({} friction passes), {} nodes in contact{}",
                              out.newton_iterations, out.friction_passes, out.contact_nodes,
                              out.at_kink ? fmt::format(", residual {:.3g} N left at a kink of the wall", rn) : "");
    out.new_sticks = count_new_sticks(st);
    x = xs;
    state = st;
    last_t = t;
    obstacle.set_translation(t);
    last_hist = std::move(th);
    if (commit) commit_last();
  } else if (out.out_of_budget) {
    out.message = fmt::format("gave up after {} Newton iterations in all (the limit; residual {:.3g} N)", newton_spent, rn);
  } else if (stopped_on_stick) {
    out.stopped_on_new_stick = true;
    out.message = fmt::format("stopped after {} Newton iterations: a node started sticking", out.newton_iterations);
  } else {
    out.message = fmt::format("contact solve did not converge after {} Newton iterations in {} friction pass(es): {}",
                              out.newton_iterations, out.friction_passes, newton_message);
  }
  return out;
}

void ContactSolver::Impl::commit_last() {
  if (predict_paused > 0) --predict_paused;
  if ((last_t - t_conv).squaredNorm() > 0) {
    x_prev = x_conv;
    t_prev = t_conv;
    have_prev = true;
  }
  x_conv = x;
  t_conv = last_t;
  hist = last_hist;
  conv_state = state;
  prev_fn = conv_fn;
  conv_alm = alm;
  for (size_t i = 0; i < state.size(); ++i) {
    was_active[i] = state[i].active ? 1 : 0;
    conv_fn[i] = state[i].normal_force_n;
    if (state[i].active) conv_n[i] = state[i].normal;
  }
}

bool ContactSolver::Impl::warm_start(const VectorXd& guess, const Vec3& t) {
  lag_fn = conv_fn;
  lag_n = conv_n;
  std::vector<NodeContact> s1, s2;
  std::vector<Vec3> h1, h2;
  double p0 = 0, p1 = 0;
  const VectorXd r0 = evaluate(x, t, s1, h1, nullptr, &p0);
  const VectorXd r1 = evaluate(guess, t, s2, h2, nullptr, &p1, nullptr, true);  // may be inverted
  if (!(r1.allFinite() && (std::isfinite(p0) ? p1 < p0 : r1.norm() < r0.norm()))) return false;
  x = guess;
  return true;
}

bool ContactSolver::Impl::push_free(const Vec3& d, double force_n, double rel_tol, ContactStep& out, double start_m) {
  const Vec3 base = obstacle.translation();
  free_dir = d;
  free_force_n = force_n;
  out = solve(base + start_m * d, false);
  free_dir.setZero();
  free_force_n = 0;
  if (out.converged && std::abs(-out.force_on_obstacle_n.dot(d) - force_n) <= rel_tol * std::max(force_n, 1e-3)) {
    commit_last();
    return true;
  }
  obstacle.set_translation(base);
  log::debug("contact: the push with the obstacle free along its direction did not converge ({}); bracketing it",
             out.message);
  return false;
}

ContactStep ContactSolver::Impl::solve_path(const Vec3& t, bool commit) {
  stopped_on_stick = false;
  ContactStep st = solve(t, commit);
  if (st.converged || st.stopped_on_new_stick || st.out_of_budget) return st;
  int pieces = 2;
  int total_newton = st.newton_iterations;
  for (int depth = 0; depth < 6 && !st.converged; ++depth, pieces *= 2) {
    const Vec3 from = t_conv;
    x = x_conv;
    for (int piece = 1; piece <= pieces; ++piece) {
      st = solve(from + (t - from) * (static_cast<double>(piece) / pieces), commit);
      total_newton += st.newton_iterations;
      if (!st.converged) break;
    }
    if (st.out_of_budget) break;
  }
  st.newton_iterations = total_newton;
  if (st.converged) st.message += fmt::format(" (reached through {} sub-steps)", pieces / 2);
  return st;
}

ContactStep ContactSolver::push_with_force(const Vec3& direction, double force_n, double rel_tol, double max_step_m,
                                           double first_step_m, double free_start_m) {
  require(std::isfinite(force_n) && force_n >= 0, "contact: push force {} N must be ≥ 0", force_n);
  require(std::isfinite(free_start_m), "contact: the free push's start {} m must be finite", free_start_m);
  const Vec3 d = direction.normalized();
  auto& s = *impl_;
  ContactStep st;
  if (s.opt.free_push && !s.opt.linear_body && s.push_free(d, force_n, rel_tol, st, free_start_m)) return st;
  const Vec3 base = s.obstacle.translation();
  return s.refine_push(base, d, force_n, rel_tol, s.bracket_push(base, d, force_n, max_step_m, first_step_m));
}

ContactStep ContactSolver::push_free(const Vec3& direction, double force_n, double rel_tol) {
  require(std::isfinite(force_n) && force_n >= 0, "contact: push force {} N must be ≥ 0", force_n);
  require(!impl_->opt.linear_body, "contact: the free push needs the nonlinear body (a linearised one: push_with_force)");
  ContactStep st;
  if (impl_->push_free(direction.normalized(), force_n, rel_tol, st)) return st;
  st.converged = false;  // converged at another force counts as not converged
  discard();
  return st;
}

ContactSolver::Impl::PushBracket ContactSolver::Impl::bracket_push(const Vec3& base, const Vec3& d, double force_n,
                                                                   double max_step_m, double first_step_m) {
  const auto reaction = [&](const ContactStep& st) { return -st.force_on_obstacle_n.dot(d); };
  // Current reaction.
  ContactStep cur = solve_path(base, false);
  require<SolverError>(cur.converged, "contact: {}", cur.message);
  PushBracket b;
  b.r_lo = reaction(cur);
  bool bracket = b.r_lo >= force_n;
  // The solutions at the bracket's ends: the solve inside it starts from their interpolation
  // (the reaction and the tissue follow the socket's position nearly linearly over one step).
  b.x_lo = b.x_hi = x;
  if (bracket) {
    b.s_hi = 0;
    b.r_hi = b.r_lo;
    b.s_lo = -max_step_m;  // back off until below the force
    for (int n = 0; n < 200; ++n) {
      cur = solve_path(base + b.s_lo * d, false);
      require<SolverError>(cur.converged, "contact: {}", cur.message);
      b.r_lo = reaction(cur);
      b.x_lo = x;
      if (b.r_lo < force_n) break;
      b.s_hi = b.s_lo;
      b.r_hi = b.r_lo;
      b.x_hi = b.x_lo;
      b.s_lo -= max_step_m;
    }
    return b;
  }
  // March forward in steps (secant-predicted, at most max_step) until the reaction exceeds the
  // force. A step that stays below the force is committed (the load grows monotonically); the
  // one that overshoots is not: the solves inside the bracket start from the last step below the
  // force, as a standing patient loads the socket once (committing the overshoot made the
  // bracket's solves pull the socket back against friction that had already slid the other way).
  double stiff = 0;
  for (int n = 0; n < 2000 && !bracket; ++n) {
    double step = n == 0 && first_step_m > 0 ? std::min(first_step_m, max_step_m) : max_step_m;
    if (stiff > 0) step = std::clamp((force_n - b.r_lo) / stiff * 1.2, 1e-6, max_step_m);
    const double s_new = b.s_lo + step;
    b.x_lo = x;
    cur = solve_path(base + s_new * d, false);
    require<SolverError>(cur.converged, "contact: while pushing with {:.1f} N: {}", force_n, cur.message);
    const double r_new = reaction(cur);
    if (r_new < force_n) commit_last();
    if (r_new > b.r_lo) stiff = (r_new - b.r_lo) / step;
    if (r_new >= force_n) {
      b.s_hi = s_new;
      b.r_hi = r_new;
      b.x_hi = x;
      bracket = true;
    } else {
      b.s_lo = s_new;
      b.r_lo = r_new;
    }
  }
  require<SolverError>(bracket, "contact: the obstacle could not be pushed to {:.1f} N (reaction {:.1f} N)", force_n,
                       b.r_lo);
  return b;
}

ContactStep ContactSolver::Impl::refine_push(const Vec3& base, const Vec3& d, double force_n, double rel_tol,
                                             PushBracket b) {
  // Illinois regula falsi inside the bracket.
  int side = 0;
  for (int n = 0; n < 60; ++n) {
    const double sm = (b.r_hi - b.r_lo) > 0 ? b.s_lo + (force_n - b.r_lo) * (b.s_hi - b.s_lo) / (b.r_hi - b.r_lo)
                                            : 0.5 * (b.s_lo + b.s_hi);
    if (opt.interpolate_bracket && b.s_hi > b.s_lo) {
      const double w = (sm - b.s_lo) / (b.s_hi - b.s_lo);
      warm_start((1 - w) * b.x_lo + w * b.x_hi, base + sm * d);
    }
    const ContactStep cur = solve_path(base + sm * d, false);
    require<SolverError>(cur.converged, "contact: {}", cur.message);
    const double rm = -cur.force_on_obstacle_n.dot(d);
    if (std::abs(rm - force_n) <= rel_tol * std::max(force_n, 1e-3)) {
      // The solve that reached the force is the step: commit it rather than solve it again.
      commit_last();
      return cur;
    }
    if (rm < force_n) {
      b.s_lo = sm;
      b.r_lo = rm;
      b.x_lo = x;
      if (side == -1) b.r_hi = force_n + 0.5 * (b.r_hi - force_n);
      side = -1;
    } else {
      b.s_hi = sm;
      b.r_hi = rm;
      b.x_hi = x;
      if (side == 1) b.r_lo = force_n + 0.5 * (b.r_lo - force_n);
      side = 1;
    }
  }
  fail<SolverError>("contact: the push force {:.1f} N was not reached within tolerance", force_n);
}

}  // namespace socketsmith::contact
