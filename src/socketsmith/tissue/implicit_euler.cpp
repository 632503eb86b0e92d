#include "socketsmith/tissue/implicit_euler.h"

#include <cmath>

#include <Eigen/CholmodSupport>
#include <Eigen/IterativeLinearSolvers>

#include "socketsmith/core/errors.h"
#include "socketsmith/tissue/static_solver.h"

namespace socketsmith::tissue {

struct ImplicitEuler::Frozen {
  Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower> llt;
  SparseMatrix K_red;  ///< −K at the factorised state (reduced)
  bool analysed = false;
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
  if (options.frozen_matrix) {
    limit_solver_threads();
    frozen_ = std::make_unique<Frozen>();
  }
}

void ImplicitEuler::assemble_system(const VectorXd& x) {
  const double h = options_.time_step_s;
  model_.jacobian(x, JacobianKind::SymmetricPsd, K_);  // = −K
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

void ImplicitEuler::accept(DynamicState& s, const VectorXd& v_red, const VectorXd& dv, StepResult& res) {
  const double h = options_.time_step_s;
  if (!dv.allFinite()) {
    res.message = fmt::format("diverged at t = {:.4g} s: the velocity update is not finite (reduce the time step)", s.time_s);
    return;
  }
  VectorXd v_new = VectorXd::Zero(model_.num_dofs());
  dofs_.add_expanded(v_red + dv, v_new);
  VectorXd x_new = s.x + h * v_new;
  const double moved = (h * v_new).cwiseAbs().maxCoeff();
  if (moved > max_step_m_) {
    res.message = fmt::format("diverged at t = {:.4g} s: a node moved {:.3g} m in one step (more than {:.3g} m; reduce the "
                              "time step {:.3g} s or the load)", s.time_s, moved, max_step_m_, h);
    return;
  }
  if (model_.min_corner_jacobian(x_new) <= 0) {
    res.message = fmt::format("diverged at t = {:.4g} s: an element inverted (reduce the time step {:.3g} s)", s.time_s, h);
    return;
  }
  dv_prev_ = dv;
  s.x = std::move(x_new);
  s.v = std::move(v_new);
  s.time_s += h;
  res.ok = true;
}

StepResult ImplicitEuler::frozen_step(DynamicState& s, const VectorXd& f_ext) {
  const double h = options_.time_step_s;
  VectorXd f = model_.elastic_forces(s.x) + f_ext;
  model_.add_damping_forces(s.x, s.v, f);
  const VectorXd f_red = dofs_.restrict_vector(f);
  const VectorXd v_red = dofs_.restrict_vector(s.v.cwiseProduct(model_.dof_masses())).cwiseQuotient(mass_red_);
  Frozen& fz = *frozen_;
  StepResult res;
  const bool due = fz.factorised &&
                   ((options_.refactor_every_steps > 0 && steps_since_factorisation_ >= options_.refactor_every_steps) ||
                    (s.x - x_factorised_).cwiseAbs().maxCoeff() > options_.refactor_move_in_edges * mean_edge_m_);
  for (int attempt = 0; attempt < 2; ++attempt) {
    if (!fz.factorised || due || attempt == 1) {
      assemble_system(s.x);
      if (!fz.analysed) {
        fz.llt.analyzePattern(A_);
        fz.analysed = true;
      }
      fz.llt.factorize(A_);
      if (fz.llt.info() != Eigen::Success) {
        res.message = fmt::format("diverged at t = {:.4g} s: the system matrix is not positive definite (reduce the time "
                                  "step {:.3g} s)", s.time_s, h);
        return res;
      }
      fz.K_red = K_red_;
      x_factorised_ = s.x;
      fz.factorised = true;
      steps_since_factorisation_ = 0;
      res.refactorised = true;
    }
    // fz.K_red holds −K: rhs = h (f + h (−K) v).
    const VectorXd dv = fz.llt.solve(h * (f_red + h * (fz.K_red * v_red)));
    accept(s, v_red, dv, res);
    if (res.ok) break;
    if (res.refactorised) return res;  // diverged with a fresh factorisation: a genuine divergence
  }
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
  assemble_system(s.x);
  const VectorXd v_red = dofs_.restrict_vector(s.v.cwiseProduct(model_.dof_masses())).cwiseQuotient(mass_red_);
  // K_red_ holds −K: rhs = h (f + h (−K) v).
  const VectorXd rhs = h * (dofs_.restrict_vector(f) + h * (K_red_ * v_red));
  // A is symmetric: its column-major arrays read as row-major are A itself. Row-major lets
  // Eigen's CG run the sparse product on all OpenMP threads, without a copy.
  const Eigen::Map<const Eigen::SparseMatrix<double, Eigen::RowMajor>> A_rows(
      A_.rows(), A_.cols(), A_.nonZeros(), A_.outerIndexPtr(), A_.innerIndexPtr(), A_.valuePtr());
  Eigen::ConjugateGradient<Eigen::SparseMatrix<double, Eigen::RowMajor>, Eigen::Lower | Eigen::Upper> cg;
  cg.setTolerance(options_.cg_rel_tol);
  cg.setMaxIterations(options_.cg_max_iterations);
  cg.compute(A_rows);
  const VectorXd dv = cg.solveWithGuess(rhs, dv_prev_);
  res.cg_iterations = static_cast<int>(cg.iterations());
  res.cg_error = cg.error();
  accept(s, v_red, dv, res);
  if (res.ok)
    res.message = cg.info() == Eigen::Success ? "ok" : "CG reached its iteration cap (step taken with the inexact update)";
  return res;
}

}  // namespace socketsmith::tissue
