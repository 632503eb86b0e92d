#include "socketsmith/tissue/implicit_euler.h"

#include <cmath>

#include <Eigen/IterativeLinearSolvers>

#include "socketsmith/core/errors.h"
#include "socketsmith/tissue/sparse_cholesky.h"
#include "socketsmith/tissue/static_solver.h"

namespace socketsmith::tissue {

struct ImplicitEuler::Frozen {
  SparseCholesky<Eigen::Lower> llt;
  SparseMatrix K_red;  ///< −K at the factorised state (reduced)
  /// MSS-CS: per element, the corrective law's slope dk'/dδv that A holds [N/m] (empty otherwise).
  VectorXd corrective_slopes;
  bool factorised = false;
};

ImplicitEuler::~ImplicitEuler() = default;

ImplicitEuler::ImplicitEuler(const MassSpringModel& model, const DofMap& dofs, const ImplicitEulerOptions& options)
    : model_(model), dofs_(dofs), options_(options) {
  require(dofs.num_full() == model.num_dofs(), "ImplicitEuler: DofMap has {} DOFs, model has {}", dofs.num_full(),
          model.num_dofs());
  require(std::isfinite(options.time_step_s) && options.time_step_s > 0,
          "ImplicitEuler: time step {} s (expected > 0)", options.time_step_s);
  require(options.cg_rel_tol > 0 && options.cg_max_iterations >= 1,
          "ImplicitEuler: CG tolerance {} (> 0) and iterations {} (≥ 1)", options.cg_rel_tol, options.cg_max_iterations);
  require(options.max_step_in_edges > 0, "ImplicitEuler: max_step_in_edges {} (expected > 0)", options.max_step_in_edges);
  mass_red_ = dofs.restrict_vector(model.dof_masses());
  const double mean_edge = std::cbrt(model.total_volume(model.rest_positions()) / model.num_elements());
  max_step_m_ = options.max_step_in_edges * mean_edge;
  mean_edge_m_ = mean_edge;
  dv_prev_ = VectorXd::Zero(dofs.num_reduced());
  require(options.refactor_every_steps >= 0 && options.refactor_move_in_edges > 0,
          "ImplicitEuler: refactor_every_steps {} (expected ≥ 0), refactor_move_in_edges {} (expected > 0)",
          options.refactor_every_steps, options.refactor_move_in_edges);
  require(std::isfinite(options.corrective_lookahead) && options.corrective_lookahead >= 0 &&
              options.corrective_lookahead < 0.5,
          "ImplicitEuler: corrective_lookahead {} (expected in [0, 0.5), a fraction of the volume)",
          options.corrective_lookahead);
  require(options.refactor_corrective_slope > 0,
          "ImplicitEuler: refactor_corrective_slope {} (expected > 0, in units of E l_e)", options.refactor_corrective_slope);
  require(options.redo_corrective_slope > 0,
          "ImplicitEuler: redo_corrective_slope {} (expected > 0, in units of E l_e)", options.redo_corrective_slope);
  if (options.frozen_matrix) {
    limit_solver_threads();
    frozen_ = std::make_unique<Frozen>();
  }
}

void ImplicitEuler::assemble_system(const VectorXd& x, const VectorXd* corrective_slopes) {
  const double h = options_.time_step_s;
  model_.jacobian(x, JacobianKind::SymmetricPsd, K_, corrective_slopes);  // = −K
  model_.damping_matrix(x, D_);
  dofs_.reduce_matrix(K_, K_red_);
  dofs_.reduce_matrix(D_, D_red_);
  // K and D come from the same model pattern through the same reduction, so A = M + hD + h²K is
  // an element-wise combination of their value arrays (no sparse addition).
  if (A_.nonZeros() != K_red_.nonZeros()) A_ = K_red_;
  const double* kv = K_red_.valuePtr();  // holds −K
  const double* dv = D_red_.valuePtr();
  double* av = A_.valuePtr();
  for (Eigen::Index k = 0; k < A_.nonZeros(); ++k) av[k] = -(h * h) * kv[k] + h * dv[k];
  A_.diagonal() += mass_red_;  // the pattern holds every diagonal entry
}

void ImplicitEuler::advance(const DynamicState& s, const VectorXd& v_red, const VectorXd& dv, VectorXd& x_new,
                            VectorXd& v_new) const {
  v_new = VectorXd::Zero(model_.num_dofs());
  dofs_.add_expanded(v_red + dv, v_new);
  x_new = s.x + options_.time_step_s * v_new;
}

void ImplicitEuler::accept(DynamicState& s, const VectorXd& dv, VectorXd& x_new, VectorXd& v_new, StepResult& res) {
  const double h = options_.time_step_s;
  if (!dv.allFinite() || !v_new.allFinite()) {
    res.message = fmt::format("diverged at t = {:.4g} s: the velocity update is not finite (reduce the time step)", s.time_s);
    return;
  }
  const double moved = (h * v_new).cwiseAbs().maxCoeff();
  if (moved > max_step_m_) {
    res.message = fmt::format("diverged at t = {:.4g} s: a node moved {:.3g} m in one step (more than {:.3g} m; reduce the "
                              "time step {:.3g} s or the load)", s.time_s, moved, max_step_m_, h);
    return;
  }
  if (model_.has_inverted_element(x_new)) {
    res.message = fmt::format("diverged at t = {:.4g} s: an element inverted (reduce the time step {:.3g} s)", s.time_s, h);
    return;
  }
  dv_prev_ = dv;
  s.x = std::move(x_new);
  s.v = std::move(v_new);
  s.time_s += h;
  res.ok = true;
}

VectorXd ImplicitEuler::law_slopes(const VectorXd& dv_now, const VectorXd* dv_reached, double lookahead) const {
  VectorXd slopes(model_.num_elements());
  for (int e = 0; e < model_.num_elements(); ++e) {
    // The law stiffens with compression (its slope dk'/dδv is negative there, and more negative
    // further on); the symmetric law also stiffens in expansion, which the PSD matrix leaves out.
    double now = 0.0, ahead = 0.0;
    model_.corrective_stiffness(e, dv_now[e], &now);
    const double point = dv_reached ? std::min(dv_now[e], (*dv_reached)[e]) : dv_now[e];
    model_.corrective_stiffness(e, point - lookahead, &ahead);
    slopes[e] = std::min(now, ahead);
  }
  return slopes;
}

bool ImplicitEuler::law_steeper_than(const VectorXd& dv, const VectorXd& held, double tolerance) const {
  for (int e = 0; e < model_.num_elements(); ++e) {
    double slope = 0.0;
    model_.corrective_stiffness(e, dv[e], &slope);
    if (slope < held[e] - tolerance * model_.material().youngs_modulus_pa * model_.element_edge_length(e)) return true;
  }
  return false;
}

StepResult ImplicitEuler::frozen_step(DynamicState& s, const VectorXd& f_ext) {
  const double h = options_.time_step_s;
  VectorXd f = model_.elastic_forces(s.x) + f_ext;
  model_.add_damping_forces(s.x, s.v, f);
  const VectorXd f_red = dofs_.restrict_vector(f);
  const VectorXd v_red = dofs_.restrict_vector(s.v.cwiseProduct(model_.dof_masses())).cwiseQuotient(mass_red_);
  Frozen& fz = *frozen_;
  StepResult res;
  const bool has_law = model_.options().kind == TissueModelKind::MssCs;
  const VectorXd dv_now = has_law ? model_.element_volume_changes(s.x) : VectorXd();
  bool due = fz.factorised &&
             ((options_.refactor_every_steps > 0 && steps_since_factorisation_ >= options_.refactor_every_steps) ||
              (s.x - x_factorised_).cwiseAbs().maxCoeff() > options_.refactor_move_in_edges * mean_edge_m_ ||
              (has_law && law_steeper_than(dv_now, fz.corrective_slopes, options_.refactor_corrective_slope)));
  VectorXd dv_reached;  // volume changes a step with too soft a matrix reached (the next A holds the law there)
  VectorXd x_new, v_new;
  for (int attempt = 0; attempt < 3; ++attempt) {
    const bool fresh = !fz.factorised || due;
    if (fresh) {
      if (has_law)
        fz.corrective_slopes = law_slopes(dv_now, dv_reached.size() ? &dv_reached : nullptr, options_.corrective_lookahead);
      assemble_system(s.x, has_law ? &fz.corrective_slopes : nullptr);
      if (!fz.llt.factorize(A_)) {
        res.message = fmt::format("diverged at t = {:.4g} s: the system matrix is not positive definite (reduce the time "
                                  "step {:.3g} s)", s.time_s, h);
        return res;
      }
      fz.K_red = K_red_;
      x_factorised_ = s.x;
      fz.factorised = true;
      steps_since_factorisation_ = 0;
      res.refactorised = true;
      due = false;
    }
    // fz.K_red holds −K: rhs = h (f + h (−K) v).
    const VectorXd dv = fz.llt.solve(h * (f_red + h * (fz.K_red * v_red)));
    advance(s, v_red, dv, x_new, v_new);
    if (has_law && attempt < 2 && x_new.allFinite()) {
      // An element compressed past the point whose law slope A holds, within this step: the lagged
      // stiffness would grow unstable; refactorise holding the law where the step went, and retry.
      // (Volume losses beyond 50 % — inverted elements — are held at 50 %.)
      const VectorXd reached = model_.element_volume_changes(x_new).cwiseMax(-0.5);
      if (law_steeper_than(reached, fz.corrective_slopes, options_.refactor_corrective_slope)) {
        dv_reached = dv_reached.size() ? VectorXd(dv_reached.cwiseMin(reached)) : reached;
        due = true;
        continue;
      }
    }
    accept(s, dv, x_new, v_new, res);
    if (res.ok || fresh) break;  // a step that diverges with a fresh factorisation is a genuine divergence
    due = true;
  }
  if (!res.ok) return res;
  ++steps_since_factorisation_;
  res.message = "ok";
  return res;
}

DynamicState rest_state(const MassSpringModel& model) {
  return {model.rest_positions(), VectorXd::Zero(model.num_dofs()), 0.0};
}

double ImplicitEuler::kinetic_energy(const VectorXd& v) const {
  return 0.5 * v.cwiseProduct(v).dot(model_.dof_masses());
}

StepResult ImplicitEuler::step(DynamicState& s, const VectorXd& f_ext) {
  require(s.x.size() == model_.num_dofs() && s.v.size() == model_.num_dofs() && f_ext.size() == model_.num_dofs(),
          "ImplicitEuler::step: state/force sizes do not match the model (3N = {})", model_.num_dofs());
  require(s.x.allFinite() && s.v.allFinite() && f_ext.allFinite(), "ImplicitEuler::step: NaN or infinite state or force");
  if (frozen_) return frozen_step(s, f_ext);
  const double h = options_.time_step_s;
  StepResult res;
  VectorXd f = model_.elastic_forces(s.x) + f_ext;
  model_.add_damping_forces(s.x, s.v, f);
  const VectorXd f_red = dofs_.restrict_vector(f);
  const VectorXd v_red = dofs_.restrict_vector(s.v.cwiseProduct(model_.dof_masses())).cwiseQuotient(mass_red_);
  const bool has_law = model_.options().kind == TissueModelKind::MssCs;
  const VectorXd dv_now = has_law ? model_.element_volume_changes(s.x) : VectorXd();
  VectorXd slopes;  // empty: each element's law slope at x
  VectorXd dv, x_new, v_new;
  Eigen::ComputationInfo cg_info = Eigen::Success;
  for (int attempt = 0; attempt < 2; ++attempt) {
    assemble_system(s.x, slopes.size() ? &slopes : nullptr);
    // K_red_ holds −K: rhs = h (f + h (−K) v).
    const VectorXd rhs = h * (f_red + h * (K_red_ * v_red));
    // A is symmetric: its column-major arrays read as row-major are A itself. Row-major lets
    // Eigen's CG run the sparse product on all OpenMP threads, without a copy.
    const Eigen::Map<const Eigen::SparseMatrix<double, Eigen::RowMajor>> A_rows(
        A_.rows(), A_.cols(), A_.nonZeros(), A_.outerIndexPtr(), A_.innerIndexPtr(), A_.valuePtr());
    Eigen::ConjugateGradient<Eigen::SparseMatrix<double, Eigen::RowMajor>, Eigen::Lower | Eigen::Upper> cg;
    cg.setTolerance(options_.cg_rel_tol);
    cg.setMaxIterations(options_.cg_max_iterations);
    cg.compute(A_rows);
    dv = cg.solveWithGuess(rhs, dv_prev_);
    res.cg_iterations += static_cast<int>(cg.iterations());
    res.cg_error = cg.error();
    cg_info = cg.info();
    advance(s, v_red, dv, x_new, v_new);
    if (!has_law || attempt > 0 || !x_new.allFinite()) break;
    // An element whose law got much steeper within the step than the slope the matrix held: the
    // dead-zone law steepens so fast that on a fine lattice under a sudden load the semi-implicit
    // law lets the top layer overshoot past the element's stable range and the lattice collapses
    // (measured: 4k and 8k nodes, the bench's load, divergence at steps 5 and 3). Redo the step with
    // each element's law slope where the step went (a backward-Euler law).
    const VectorXd reached = model_.element_volume_changes(x_new).cwiseMax(-0.5);
    if (!law_steeper_than(reached, law_slopes(dv_now, nullptr, 0.0), options_.redo_corrective_slope)) break;
    slopes = law_slopes(dv_now, &reached, 0.0);
    res.law_retried = true;
  }
  accept(s, dv, x_new, v_new, res);
  if (res.ok)
    res.message = cg_info == Eigen::Success ? "ok" : "CG reached its iteration cap (step taken with the inexact update)";
  return res;
}

}  // namespace socketsmith::tissue
