#include "socketsmith/contact/contact_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <Eigen/CholmodSupport>
#include <Eigen/SparseLU>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/tissue/static_solver.h"

namespace socketsmith::contact {

using tissue::SparseMatrix;
using tissue::VectorXd;

constexpr double kRelagResidual = 100.0;  // friction lag refreshed in Newton once ‖r‖ ≤ this × tol

/// While alive, every OpenMP parallel region runs on the calling thread alone. CHOLMOD's supernodal
/// factorisation opens a region per supernode asking for 4 threads; with dynamic teams
/// (tissue::limit_solver_threads) each region still asks the kernel for the load and the affinity
/// and wakes the pool: a 7.5k-node donning made 209k sysinfo + sched_getaffinity and 814k futex
/// calls (≈ 10 % of its CPU in the kernel, strace -c / perf), for assembly loops too small to share.
class SerialParallelRegions {
 public:
  SerialParallelRegions() {
#ifdef _OPENMP
    levels_ = omp_get_max_active_levels();
    omp_set_max_active_levels(0);
#endif
  }
  ~SerialParallelRegions() {
#ifdef _OPENMP
    omp_set_max_active_levels(levels_);
#endif
  }
  SerialParallelRegions(const SerialParallelRegions&) = delete;
  SerialParallelRegions& operator=(const SerialParallelRegions&) = delete;

 private:
  int levels_ = 1;
};

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
  Vec3 last_t = Vec3::Zero();     // translation of the last converged solve (committed or not)
  std::vector<Vec3> last_hist;    // its tangential spring forces (hist once committed)
  std::vector<NodeContact> state;
  std::vector<NodeContact> conv_state;  // state of the last committed step
  bool stop_on_new_stick = false, stopped_on_stick = false;  // try_move_to(…, true)
  std::vector<char> was_active;  // active at the last converged step
  struct QueryCache {
    Vec3 p = Vec3::Zero(), t = Vec3::Zero();
    double clearance = -1.0;  // gap of the last query when the node was in the cavity, else −1
  };
  std::vector<QueryCache> qcache;  // per candidate node
  std::vector<Gap> gaps;           // scratch of evaluate()
  std::vector<double> conv_fn, lag_fn, prev_fn;  // normal force at the last converged step / friction lag
  std::vector<Vec3> conv_n, lag_n;      // wall normal at the last converged step / friction lag
  double force_floor = 1e-3;            // [N] scale of the residual tolerance when forces are small
  SparseMatrix K0;         // linear body: reduced stiffness at rest
  SparseMatrix K0c;        // K₀ with every candidate node's 3×3 block in its pattern
  std::vector<Eigen::Index> block_at;  // per candidate node, entry (a, b) at 9 i + 3 b + a: index in K0c's values, −1 fixed
  // Upper: CHOLMOD permutes an upper-stored matrix with one transpose, a lower-stored one with two.
  Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Upper> llt;
  Eigen::Index analysed_nnz = -1;
  bool factor_valid = false;
  long factorizations = 0, cg_iterations = 0;  // counters for ContactStep

  Impl(const tissue::MassSpringModel& m, const tissue::DofMap& d, std::vector<int> n, std::vector<double> a,
       Obstacle& o, const ContactOptions& op)
      : model(m), dofs(d), nodes(std::move(n)), areas(std::move(a)), obstacle(o), opt(op) {}

  /// Residual (reduced), the incremental potential Π (when the body has an energy) and, when
  /// @p blocks is given, each candidate node's 3×3 contact and friction stiffness (tangent()
  /// assembles K = −∂r/∂x = ∇²Π from them). Linear body: @p Ku, when given, is K₀ u at xs (a line
  /// search knows it as K₀u + a K₀δ without a product). Friction uses the lagged normal forces
  /// and normals (lag_fn, lag_n): with them fixed, the step is the minimum of a convex potential
  /// (elastic energy + ½ k A g² for each penetration + a Huber slip potential per node), so Newton
  /// with a line search on Π converges from any start.
  /// @p trial_point: a line search's trial point, which may have inverted an element (nonlinear body):
  /// then the residual is NaN (rejected), where elsewhere the body's forces throw naming it.
  VectorXd evaluate(const VectorXd& xs, const Vec3& t, std::vector<NodeContact>& st, std::vector<Vec3>& trial_hist,
                    std::vector<Eigen::Matrix3d>* blocks, double* energy, const VectorXd* Ku = nullptr,
                    bool trial_point = false) {
    obstacle.set_translation(t);
    const bool conservative = opt.linear_body || model.has_energy();
    VectorXd f_full = VectorXd::Zero(xs.size());
    double pi = 0.0;
    if (!opt.linear_body) {
      // The body's forces and energy in one pass (the continuum models), the inversion check in it.
      if (!conservative) {
        if (trial_point && model.has_inverted_element(xs))
          return VectorXd::Constant(dofs.num_reduced(), std::numeric_limits<double>::quiet_NaN());
        f_full = model.elastic_forces(xs);
      } else if (!model.forces_and_energy(xs, f_full, pi)) {
        if (trial_point) return VectorXd::Constant(dofs.num_reduced(), std::numeric_limits<double>::quiet_NaN());
        // Not a trial point: the continuum models throw SolverError naming the inverted element;
        // the lattices are defined there and keep their forces and energy.
        f_full = model.elastic_forces(xs);
        pi = model.energy(xs);
      }
    }
    if (blocks) blocks->assign(nodes.size(), Eigen::Matrix3d::Zero());
    st.assign(nodes.size(), NodeContact{});
    trial_hist.assign(nodes.size(), Vec3::Zero());
    // Gaps, in parallel. A node whose last query found it in the cavity with a clearance larger
    // than how far it and the obstacle have moved since cannot have reached the wall: no query.
    gaps.resize(nodes.size());
    const int n_nodes = static_cast<int>(nodes.size());
#pragma omp parallel for schedule(dynamic, 64)
    for (int i = 0; i < n_nodes; ++i) {
      const Vec3 p = xs.segment<3>(3 * nodes[i]);
      QueryCache& c = qcache[i];
      if (c.clearance > 0 && c.clearance > (p - c.p).norm() + (t - c.t).norm()) {
        gaps[i] = Gap{};
        gaps[i].gap_m = c.clearance;  // a lower bound; the node is not in contact
        continue;
      }
      gaps[i] = wall_gap(i, p);
      c.p = p;
      c.t = t;
      // (The smoothed wall's gap is not an exact distance: its slope |∇gap| may exceed 1 a little.)
      c.clearance = gaps[i].valid && gaps[i].gap_m > 0 ? gaps[i].gap_m / (1.5 * std::max(gaps[i].gradient_norm, 1.0)) : -1.0;
    }
    for (size_t i = 0; i < nodes.size(); ++i) {
      const int nd = nodes[i];
      const Vec3 p = xs.segment<3>(3 * nd);
      const Gap& g = gaps[i];
      const bool valid = g.valid;
      const double kA = k * areas[i];
      Eigen::Matrix3d B = Eigen::Matrix3d::Zero();
      Vec3 f = Vec3::Zero();
      if (valid && g.gap_m < 0) {
        auto& s = st[i];
        s.active = true;
        s.gap_m = g.gap_m;
        s.normal = g.normal;
        s.normal_force_n = kA * (-g.gap_m) * g.gradient_norm;
        s.pressure_pa = s.normal_force_n / areas[i];
        pi += 0.5 * kA * g.gap_m * g.gap_m;
        f += s.normal_force_n * g.normal;
        // Inside a face: stiffness along the normal only; on an edge or a vertex the force points to
        // a fixed point of the wall (f = kA (c − x)), stiff in every direction.
        B += kA * g.stiffness_shape;
      }
      // Friction: nodes that carried a normal force at the lag (μ f̄ > 0) resist slip relative to
      // the wall with an elastic stick (stiffness kT) capped at μ f̄ (return mapping).
      const double kT = opt.stick_stiffness_ratio * kA;
      const double limit = opt.friction * lag_fn[i];
      if (limit > 0) {
        const Vec3& nl = lag_n[i];
        const Eigen::Matrix3d Pt = Eigen::Matrix3d::Identity() - nl * nl.transpose();
        const Vec3 slip = Pt * ((p - x_conv.segment<3>(3 * nd)) - (t - t_conv));
        const Vec3 trial = Pt * hist[i] + kT * slip;
        const double mag = trial.norm();
        if (mag > limit) {
          st[i].sliding = true;
          trial_hist[i] = trial * (limit / mag);
          const Vec3 that = trial / mag;
          B += (limit / mag) * kT * (Pt - that * that.transpose());
          pi += limit * mag / kT - 0.5 * limit * limit / kT;
        } else {
          trial_hist[i] = trial;
          B += kT * Pt;
          pi += 0.5 * mag * mag / kT;
        }
        st[i].tangential_n = -trial_hist[i];
        f -= trial_hist[i];
      }
      if (f.squaredNorm() == 0.0 && B.isZero()) continue;
      f_full.segment<3>(3 * nd) += f;
      if (blocks) (*blocks)[i] = B;
    }
    VectorXd r = dofs.restrict_vector(f_full);
    if (opt.linear_body) {
      const VectorXd u = dofs.restrict_vector(xs - model.rest_positions());
      const VectorXd K0u = Ku ? *Ku : VectorXd(K0 * u);
      r -= K0u;
      pi += 0.5 * u.dot(K0u);
    }
    if (energy) *energy = conservative ? pi : std::numeric_limits<double>::quiet_NaN();
    return r;
  }

  /// The tangent K = K_body + Σ the candidate nodes' 3×3 @p blocks (reduced). Every candidate
  /// node's block is in the pattern (explicit zeros where it is not in contact), so the pattern
  /// never changes and CHOLMOD orders it once. Linear body: K₀'s values are copied into that fixed
  /// pattern and the blocks added in place (block_at: where each block entry lives).
  void tangent(const VectorXd& xs, const std::vector<Eigen::Matrix3d>& blocks, SparseMatrix& K, bool psd_body = false) {
    if (opt.linear_body) {
      if (K.nonZeros() != K0c.nonZeros()) K = K0c;
      std::copy(K0c.valuePtr(), K0c.valuePtr() + K0c.nonZeros(), K.valuePtr());
      double* v = K.valuePtr();
      for (size_t i = 0; i < nodes.size(); ++i)
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b)
            if (block_at[9 * i + 3 * b + a] >= 0) v[block_at[9 * i + 3 * b + a]] += blocks[i](a, b);
      return;
    }
    // Nonlinear body: the body's tangent at xs plus every candidate node's block (explicit zeros
    // where it is not in contact), so the pattern stays the same from one Newton iteration to the
    // next and CHOLMOD analyses it once. `psd_body`: the body's tangent projected on its positive
    // part per element (when the exact one is not positive definite away from equilibrium).
    model.jacobian(xs, psd_body ? tissue::JacobianKind::SymmetricPsd : tissue::JacobianKind::Exact, J_body);
    dofs.reduce_matrix(J_body, K);  // the same pattern every time: DofMap maps the values
    double* v = K.valuePtr();
    for (Eigen::Index q = 0; q < K.nonZeros(); ++q) v[q] = -v[q];
    // Every candidate node's own 3×3 block lies in the body's pattern (the node is in an element).
    if (body_block_at.empty()) body_block_at = block_positions(K);
    for (size_t i = 0; i < nodes.size(); ++i)
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
          if (body_block_at[9 * i + 3 * b + a] >= 0) v[body_block_at[9 * i + 3 * b + a]] += blocks[i](a, b);
  }
  SparseMatrix J_body;               // the body's Jacobian (nonlinear body), its pattern reused
  std::vector<Eigen::Index> body_block_at;  // where each candidate block entry lives in K (nonlinear body)

  /// Where entry (a, b) of each candidate node's 3×3 block lives in @p K's values (index 9i + 3b + a;
  /// −1 for a fixed DOF).
  std::vector<Eigen::Index> block_positions(const SparseMatrix& K) const {
    const auto& ri = dofs.reduced_index();
    std::vector<Eigen::Index> at(9 * nodes.size(), -1);
    for (size_t i = 0; i < nodes.size(); ++i)
      for (int b = 0; b < 3; ++b) {
        const int col = ri[3 * nodes[i] + b];
        if (col < 0) continue;
        for (Eigen::Index q = K.outerIndexPtr()[col]; q < K.outerIndexPtr()[col + 1]; ++q)
          for (int a = 0; a < 3; ++a)
            if (ri[3 * nodes[i] + a] >= 0 && K.innerIndexPtr()[q] == ri[3 * nodes[i] + a]) at[9 * i + 3 * b + a] = q;
      }
    return at;
  }

  /// Gap against the wall. On the faceted wall, whose validity is all or nothing, a node in contact
  /// at the last converged step keeps a wider acceptance cone, so that a node at the wall's rim does
  /// not chatter in and out of contact (the smoothed wall hands over to the brim's lip there instead).
  Gap wall_gap(size_t i, const Vec3& p) const {
    Gap g = obstacle.gap(p);
    if (!g.valid && !g.graded && was_active[i] && g.gap_m < 0) {
      const Vec3 dd = p - g.point;
      g.valid = (dd - g.gap_m * g.normal).norm() <= 2.0 * std::abs(g.gap_m) + 1e-4;
    }
    return g;
  }
  /// CG on K d = b preconditioned by the last factorisation; false when it needs more than
  /// opt.max_reuse_cg iterations for a relative residual of 1e-8.
  bool pcg(const SparseMatrix& K, const VectorXd& b, VectorXd& d) {
    const SerialParallelRegions serial;
    const double bn = b.norm();
    d = llt.solve(b);
    VectorXd res = b - K * d;
    if (res.norm() <= 1e-8 * bn) return true;
    VectorXd z = llt.solve(res);
    VectorXd p = z;
    double rz = res.dot(z);
    for (int it = 0; it < opt.max_reuse_cg; ++it) {
      ++cg_iterations;
      const VectorXd Kp = K * p;
      const double pKp = p.dot(Kp);
      if (!(pKp > 0)) return false;
      const double alpha = rz / pKp;
      d += alpha * p;
      res -= alpha * Kp;
      if (res.norm() <= 1e-8 * bn) return true;
      z = llt.solve(res);
      const double rz_new = res.dot(z);
      p = z + (rz_new / rz) * p;
      rz = rz_new;
    }
    return false;
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

  /// Nodes of @p st sticking (in contact, friction below its limit and not zero) that were sliding
  /// or free at the last committed step.
  int count_new_sticks(const std::vector<NodeContact>& st) const {
    int n = 0;
    for (size_t i = 0; i < st.size(); ++i)
      if (st[i].active && !st[i].sliding && st[i].tangential_n.squaredNorm() > 0 &&
          (!conv_state[i].active || conv_state[i].sliding))
        ++n;
    return n;
  }

  /// Largest change of the normal forces of @p st from the friction lag, / the largest of them.
  double lag_change(const std::vector<NodeContact>& st) const {
    double change = 0, fmax = 0;
    for (size_t i = 0; i < st.size(); ++i) {
      change = std::max(change, std::abs(st[i].normal_force_n - lag_fn[i]));
      fmax = std::max(fmax, st[i].normal_force_n);
    }
    return fmax > 0 ? change / fmax : (change > 0 ? 1.0 : 0.0);
  }
  /// The friction lag takes the normal forces of @p st — half-way only when the last refresh did
  /// not shrink the change (a node at the socket's rim can otherwise flip in and out of contact
  /// with every refresh, its friction pushing it out and its absence letting it back: a 2-cycle).
  void update_lag(const std::vector<NodeContact>& st) {
    const double change = lag_change(st);
    const double w = last_lag_change > 0 && change > 0.8 * last_lag_change ? 0.5 : 1.0;
    last_lag_change = change;
    for (size_t i = 0; i < st.size(); ++i) {
      lag_fn[i] += w * (st[i].normal_force_n - lag_fn[i]);
      if (st[i].active) lag_n[i] = st[i].normal;
    }
  }
  double last_lag_change = 0;  // of the last refresh in this solve

  /// A trial point x + a·delta of the line search, with its residual, potential and slope.
  struct Trial {
    VectorXd x, r;
    double pi = 0, rn = 0;
    double slope = 0;  // dΠ/da = −r(x + a·delta)·delta
    std::vector<NodeContact> st;
    std::vector<Vec3> th;
    std::vector<Eigen::Matrix3d> B;
  };
  /// Linear body: K₀u at the line search's start and K₀δ (then K₀u at x + a·δ = Ku0 + a·Kd).
  VectorXd Ku0, Kd;
  bool try_step(const VectorXd& xs, const Vec3& t, const VectorXd& delta, double a, Trial& tr) {
    tr.x = xs;
    dofs.add_expanded(a * delta, tr.x);
    VectorXd Ku;
    if (opt.linear_body) Ku = Ku0 + a * Kd;
    tr.r = evaluate(tr.x, t, tr.st, tr.th, &tr.B, &tr.pi, opt.linear_body ? &Ku : nullptr, true);
    tr.rn = tr.r.norm();
    tr.slope = -tr.r.dot(delta);
    return std::isfinite(tr.rn);
  }

  /// Line search along the Newton direction @p delta from xs (residual r, potential pi); on
  /// success moves xs and its state to the accepted point and returns true.
  ///
  /// With a potential Π the search first tries the full step; when Π still decreases there
  /// (Armijo) and its slope has fallen to at most half the initial one (curvature), it is taken.
  /// Otherwise, when Π turns upwards before the full step (the usual case: a node crossed an
  /// edge of the faceted wall, where the quadratic model ends), the minimum of Π along delta is
  /// bracketed and found by regula falsi on the slope Π'(a) = −r(x + a·delta)·delta — each trial
  /// costs a residual (gap queries and K₀u), not a factorisation. Backtracking (halving; Armijo
  /// on Π, else on ‖r‖) is the fall-back. Near convergence Π's decrease drowns in round-off: a
  /// step that lowers ‖r‖ is then accepted too.
  bool line_search(VectorXd& xs, const Vec3& t, const VectorXd& delta, VectorXd& r, double& rn, double& pi,
                   std::vector<NodeContact>& st, std::vector<Vec3>& th, std::vector<Eigen::Matrix3d>& B,
                   bool conservative, double& step) {
    const double slope0 = -r.dot(delta);
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
      rn = tr.rn;
      pi = tr.pi;
      st = std::move(tr.st);
      th = std::move(tr.th);
      B = std::move(tr.B);
      step = a;
      return true;
    };
    Trial tr;
    if (conservative && opt.exact_line_search && slope0 < 0 && try_step(xs, t, delta, 1.0, tr)) {
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
          if (!try_step(xs, t, delta, a, tm)) break;
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
      if (!try_step(xs, t, delta, a, tr)) continue;
      if (sufficient(tr, a)) return take(tr, a);
    }
    return false;
  }

  /// The Newton step of the nonlinear body: CHOLMOD on the exact tangent @p K (symmetric for the
  /// hyperelastic models; positive definite near a stable equilibrium), else on the tangent with
  /// the body's part projected positive (a descent direction for the line search on Π), else
  /// sparse LU. The pattern is the same every iteration, so CHOLMOD orders it once.
  bool solve_nonlinear(const VectorXd& xs, const std::vector<Eigen::Matrix3d>& B, SparseMatrix& K, const VectorXd& r,
                       VectorXd& delta) {
    const SerialParallelRegions serial;
    const auto cholesky = [&](const SparseMatrix& A) {
      if (A.nonZeros() != analysed_nnz) {
        llt.analyzePattern(A);
        analysed_nnz = A.nonZeros();
      }
      llt.factorize(A);
      if (llt.info() != Eigen::Success) return false;
      ++factorizations;
      delta = llt.solve(r);
      return delta.allFinite();
    };
    if (model.has_energy() && cholesky(K)) return true;
    if (model.has_energy()) {
      SparseMatrix Kp;
      tangent(xs, B, Kp, true);
      if (cholesky(Kp)) return true;
    }
    Eigen::SparseLU<SparseMatrix> lu;
    lu.compute(K);
    if (lu.info() != Eigen::Success) return false;
    ++factorizations;
    delta = lu.solve(r);
    return delta.allFinite();
  }

  /// Newton on the equilibrium at translation t with the friction lag fixed; updates xs.
  bool newton(VectorXd& xs, const Vec3& t, std::vector<NodeContact>& st, std::vector<Vec3>& th, int& iterations,
              double& rn, bool& at_kink) {
    at_kink = false;
    tissue::limit_solver_threads();
    SparseMatrix K;
    std::vector<Eigen::Matrix3d> B;
    std::vector<double> pi_history;
    double pi = 0;
    VectorXd r = evaluate(xs, t, st, th, &B, &pi);
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
      // The tangent only when a Newton step is taken: a solve converged at its start (a step where
      // no node touches, the last friction pass) or stopped at max_newton costs no tangent.
      tangent(xs, B, K);
      VectorXd delta;
      if (opt.linear_body) {
        // The last factorisation (of a nearby contact state) preconditions CG on the new tangent;
        // a fresh factorisation only when CG does not converge quickly.
        if (!(factor_valid && opt.max_reuse_cg > 0 && pcg(K, r, delta))) {
          const SerialParallelRegions serial;
          if (K.nonZeros() != analysed_nnz) {
            llt.analyzePattern(K);
            analysed_nnz = K.nonZeros();
          }
          llt.factorize(K);
          if (llt.info() != Eigen::Success) return false;
          factor_valid = true;
          ++factorizations;
          delta = llt.solve(r);
        }
      } else if (!solve_nonlinear(xs, B, K, r, delta)) {
        return false;
      }
      ++iterations;
      double step = 0;
      const bool accepted = line_search(xs, t, delta, r, rn, pi, st, th, B, conservative, step);
      if (!accepted) {
        log::debug("contact: line search failed at Newton {} (residual {:.3g} N)", it, rn);
        at_kink = rn <= kink_tolerance(st);
        return at_kink;
      }
      // A node on a kink of the wall (an edge or vertex where the closest face switches) has no
      // point of zero residual: Newton then crawls with tiny steps while Π stops decreasing. Its
      // residual is bounded by the force jump across the kink; accept it when it is small.
      log::debug("contact: step {:.3g} of the Newton step", step);
      pi_history.push_back(pi);
      const double moved = step * delta.cwiseAbs().maxCoeff();
      const size_t nh = pi_history.size();
      const bool flat = nh > 5 && conservative &&
                        pi_history[nh - 6] - pi <= 1e-6 * std::max(std::abs(pi), 1e-30);
      if ((moved <= opt.kink_step_tol_m || flat) && rn > tolerance(st) && rn <= kink_tolerance(st)) {
        at_kink = true;
        return true;
      }
      // Friction lag inside Newton: near convergence, when the normal forces have moved away from
      // the lag by more than the friction-pass tolerance, take them as the new lag now (the
      // potential changes, so its history restarts) instead of only after this Newton solve has
      // converged. Refreshing it far from convergence (any residual) doubled the iterations.
      bool relagged = false;
      if (opt.friction > 0 && opt.friction_in_newton && rn <= kRelagResidual * tolerance(st) &&
          lag_change(st) > opt.friction_lag_tol) {
        update_lag(st);
        pi_history.clear();
        relagged = true;
      }
      if (relagged) {
        r = evaluate(xs, t, st, th, &B, &pi);
        rn = r.norm();
      }
      if (stop_on_new_stick && rn <= kRelagResidual * tolerance(st) && count_new_sticks(st) > 0) {
        stopped_on_stick = true;
        return false;
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
          // A trial point: the extrapolation may turn a strongly compressed element inside out
          // (AmpScan's limb, where the brim passes the tibial tuberosity); then it is not taken.
          const VectorXd r1 = evaluate(xp, t, s2, h2, nullptr, &p1, nullptr, true);
          const bool better = r1.allFinite() && (std::isfinite(p0) ? p1 < p0 : r1.norm() < r0.norm());
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
      bool kink = false;
      ok = newton(xs, t, st, th, out.newton_iterations, rn, kink);
      out.at_kink = kink;
      if (!ok || opt.friction == 0) break;
      out.friction_lag_change = lag_change(st);
      if (out.friction_lag_change <= opt.friction_lag_tol) break;
      if (pass + 1 == opt.max_friction_passes) break;  // keep the lag of the solved pass
      update_lag(st);
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
      last_hist = std::move(th);
      if (commit) commit_last();
    } else if (stopped_on_stick) {
      out.stopped_on_new_stick = true;
      out.message = fmt::format("stopped after {} Newton iterations: a node started sticking", out.newton_iterations);
    } else {
      out.message = fmt::format("contact solve did not converge after {} Newton iterations (residual {:.3g} N)",
                                out.newton_iterations, rn);
    }
    return out;
  }

  /// Makes the last converged solve (x, state at last_t) the converged step: the friction
  /// history, the lag and the predictor's states move on to it.
  void commit_last() {
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
    for (size_t i = 0; i < state.size(); ++i) {
      was_active[i] = state[i].active ? 1 : 0;
      conv_fn[i] = state[i].normal_force_n;
      if (state[i].active) conv_n[i] = state[i].normal;
    }
  }

  /// Starts the next solve at translation t from @p guess instead of the last solution when its
  /// potential there is lower (same friction lag as solve() starts with).
  void warm_start(const VectorXd& guess, const Vec3& t) {
    lag_fn = conv_fn;
    lag_n = conv_n;
    std::vector<NodeContact> s1, s2;
    std::vector<Vec3> h1, h2;
    double p0 = 0, p1 = 0;
    const VectorXd r0 = evaluate(x, t, s1, h1, nullptr, &p0);
    const VectorXd r1 = evaluate(guess, t, s2, h2, nullptr, &p1, nullptr, true);  // may be inverted
    if (r1.allFinite() && (std::isfinite(p0) ? p1 < p0 : r1.norm() < r0.norm())) x = guess;
  }

  /// solve(t), and when it fails, path continuation: reach t through 2, 4, … 64 equal sub-steps
  /// from the last converged translation (a stick–slip switch or a new contact front can be too
  /// much for one Newton solve). Sub-steps are committed only when @p commit.
  ContactStep solve_path(const Vec3& t, bool commit) {
    stopped_on_stick = false;
    ContactStep st = solve(t, commit);
    if (st.converged || st.stopped_on_new_stick) return st;
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
  require(std::isfinite(options.stick_stiffness_ratio) && options.stick_stiffness_ratio > 0,
          "contact: stick stiffness ratio {} must be positive", options.stick_stiffness_ratio);
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
  s.conv_state = s.state;
  s.qcache.assign(s.nodes.size(), Impl::QueryCache{});
  // One query before any parallel one (CGAL builds its distance-query structures lazily).
  (void)obstacle.gap(model.rest_positions().segment<3>(3 * s.nodes.front()));
  if (options.linear_body) {
    SparseMatrix J;
    model.jacobian(model.rest_positions(), tissue::JacobianKind::Exact, J);
    dofs.reduce_matrix(J, s.K0);
    s.K0 *= -1.0;
    s.K0 = 0.5 * (SparseMatrix(s.K0.transpose()) + s.K0);
    s.K0.makeCompressed();
    // The tangent's fixed pattern: K₀ plus every candidate node's 3×3 block.
    const auto& ri = dofs.reduced_index();
    std::vector<Eigen::Triplet<double>> trip;
    for (const int nd : s.nodes)
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
          if (ri[3 * nd + a] >= 0 && ri[3 * nd + b] >= 0) trip.emplace_back(ri[3 * nd + a], ri[3 * nd + b], 0.0);
    SparseMatrix Z(s.K0.rows(), s.K0.cols());
    Z.setFromTriplets(trip.begin(), trip.end());
    s.K0c = s.K0 + Z;
    s.K0c.makeCompressed();
    s.block_at = s.block_positions(s.K0c);
  }
}

ContactSolver::~ContactSolver() = default;

ContactStep ContactSolver::move_to(const Vec3& translation) { return impl_->solve_path(translation, true); }
ContactStep ContactSolver::try_move_to(const Vec3& translation, bool stop_on_new_stick) {
  impl_->stop_on_new_stick = stop_on_new_stick;
  ContactStep st = impl_->solve_path(translation, false);
  impl_->stop_on_new_stick = false;
  return st;
}
void ContactSolver::commit() { impl_->commit_last(); }
void ContactSolver::discard() {
  auto& s = *impl_;
  s.x = s.x_conv;
  s.state = s.conv_state;
  s.last_t = s.t_conv;
  s.last_hist = s.hist;
  s.obstacle.set_translation(s.t_conv);
}

ContactStep ContactSolver::push_with_force(const Vec3& direction, double force_n, double rel_tol, double max_step_m,
                                           double first_step_m) {
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
  // The solutions at the bracket's ends: the solve inside it starts from their interpolation
  // (the reaction and the tissue follow the socket's position nearly linearly over one step).
  VectorXd x_lo = s.x, x_hi = s.x;
  if (bracket) {
    s_hi = 0;
    r_hi = r_lo;
    s_lo = -max_step_m;  // back off until below the force
    for (int k = 0; k < 200; ++k) {
      cur = s.solve_path(base + s_lo * d, false);
      require<SolverError>(cur.converged, "contact: {}", cur.message);
      r_lo = reaction(cur);
      x_lo = s.x;
      if (r_lo < force_n) break;
      s_hi = s_lo;
      r_hi = r_lo;
      x_hi = x_lo;
      s_lo -= max_step_m;
    }
  } else {
    // March forward in steps (secant-predicted, at most max_step) until the reaction exceeds the
    // force. A step that stays below the force is committed (the load grows monotonically); the
    // one that overshoots is not: the solves inside the bracket start from the last step below the
    // force, as a standing patient loads the socket once (committing the overshoot made the
    // bracket's solves pull the socket back against friction that had already slid the other way).
    double stiff = 0;
    for (int k = 0; k < 2000 && !bracket; ++k) {
      double step = k == 0 && first_step_m > 0 ? std::min(first_step_m, max_step_m) : max_step_m;
      if (stiff > 0) step = std::clamp((force_n - r_lo) / stiff * 1.2, 1e-6, max_step_m);
      const double s_new = s_lo + step;
      x_lo = s.x;
      cur = s.solve_path(base + s_new * d, false);
      require<SolverError>(cur.converged, "contact: while pushing with {:.1f} N: {}", force_n, cur.message);
      const double r_new = reaction(cur);
      if (r_new < force_n) s.commit_last();
      if (r_new > r_lo) stiff = (r_new - r_lo) / step;
      if (r_new >= force_n) {
        s_hi = s_new;
        r_hi = r_new;
        x_hi = s.x;
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
    if (s.opt.interpolate_bracket && s_hi > s_lo) {
      const double w = (sm - s_lo) / (s_hi - s_lo);
      s.warm_start((1 - w) * x_lo + w * x_hi, base + sm * d);
    }
    cur = s.solve_path(base + sm * d, false);
    require<SolverError>(cur.converged, "contact: {}", cur.message);
    const double rm = reaction(cur);
    if (std::abs(rm - force_n) <= rel_tol * std::max(force_n, 1e-3)) {
      // The solve that reached the force is the step: commit it rather than solve it again.
      s.commit_last();
      return cur;
    }
    if (rm < force_n) {
      s_lo = sm;
      r_lo = rm;
      x_lo = s.x;
      if (side == -1) r_hi = force_n + 0.5 * (r_hi - force_n);
      side = -1;
    } else {
      s_hi = sm;
      r_hi = rm;
      x_hi = s.x;
      if (side == 1) r_lo = force_n + 0.5 * (r_lo - force_n);
      side = 1;
    }
  }
  fail<SolverError>("contact: the push force {:.1f} N was not reached within tolerance", force_n);
}

void ContactSolver::obstacle_changed() {
  auto& s = *impl_;
  s.qcache.assign(s.nodes.size(), Impl::QueryCache{});
  // One query before any parallel one (CGAL builds its distance-query structures lazily).
  (void)s.obstacle.gap(s.x.segment<3>(3 * s.nodes.front()));
}

const VectorXd& ContactSolver::positions() const { return impl_->x; }
const std::vector<NodeContact>& ContactSolver::contacts() const { return impl_->state; }
const std::vector<int>& ContactSolver::nodes() const { return impl_->nodes; }
double ContactSolver::penalty() const { return impl_->k; }

}  // namespace socketsmith::contact
