#pragma once
/// @file static_solver.h
/// Static equilibrium f_int(x) + f_ext = 0 of a MassSpringModel under kinematic constraints.
///
/// Newton's method on the reduced residual r = Pᵀ (f_int(x) + f_ext) with the exact Jacobian
/// (non-symmetric for MSS-CS), solved by BiCGSTAB preconditioned with a sparse Cholesky
/// (CHOLMOD) factorisation of the symmetric positive definite part K_psd. The factorisation is
/// kept between Newton iterations and between solves, and renewed only when the Krylov solver
/// needs too many iterations: repeated solves with changing loads cost little, and the previous
/// solution is the warm start. A backtracking line search on ‖r‖ that also rejects inverted
/// elements globalises the iteration. When Newton from the warm start does not converge within
/// `continuation_newton_iterations`, the load is applied by adaptive continuation from the load
/// the initial state already balances (f₀ = −f_int(x₀)), halving the load step on failure.
///
/// Convergence: ‖r‖₂ ≤ rel_tol · max(‖Pᵀ f_ext‖₂, force_scale_n) + abs_tol_n.

#include <memory>
#include <string>

#include "socketsmith/core/progress.h"
#include "socketsmith/tissue/dof_map.h"
#include "socketsmith/tissue/mass_spring_model.h"

namespace socketsmith::tissue {

struct StaticSolverOptions {
  double rel_tol = 1e-7;          ///< relative residual tolerance [-], > 0
  double abs_tol_n = 1e-12;       ///< absolute residual tolerance [N], ≥ 0
  double force_scale_n = 0.0;     ///< floor of the reference force [N] (0: E · l_mean², set by the solver)
  int max_iterations = 80;        ///< Newton iterations per solve, ≥ 1
  int max_line_search = 12;       ///< halvings of the step before giving up (t ≥ 2⁻¹¹), ≥ 1
  int max_krylov_iterations = 300;  ///< BiCGSTAB iterations per Newton step
  double krylov_rel_tol = 1e-6;   ///< BiCGSTAB relative tolerance (inexact Newton)
  int refactor_krylov_iterations = 25;  ///< refactorise K_psd when BiCGSTAB needs more than this and more
                                        ///< than twice what it needed right after the last factorisation
  int continuation_newton_iterations = 15;  ///< Newton cap of the direct attempt and of each load step
  double min_load_step = 1.0 / 1024;    ///< smallest load-continuation step before giving up [-]
  double max_step_m = 0.0;        ///< cap on the largest nodal move per iteration [m] (0: none)
};

struct StaticResult {
  bool converged = false;
  int iterations = 0;          ///< Newton iterations
  int krylov_iterations = 0;   ///< total BiCGSTAB iterations
  int factorizations = 0;      ///< CHOLMOD numeric factorisations in this solve
  int load_steps = 0;          ///< load-continuation steps taken (0: direct Newton converged)
  double residual_n = 0.0;     ///< final ‖r‖₂ [N]
  double reference_force_n = 0.0;  ///< the reference of the relative tolerance [N]
  std::string message;         ///< why it stopped
};

/// Static equilibrium solver (expensive set-up once, cheap repeated solves).
class StaticSolver {
 public:
  StaticSolver(const MassSpringModel& model, const DofMap& dofs, const StaticSolverOptions& options = {});
  ~StaticSolver();
  StaticSolver(const StaticSolver&) = delete;
  StaticSolver& operator=(const StaticSolver&) = delete;

  /// Solves for the positions x (3N) under external nodal forces @p f_ext (3N) [N].
  /// @param x in: initial guess and the values of fixed DOFs; out: the solution (or the last
  ///          iterate when not converged). Never returns a state with inverted elements.
  /// @throws InvalidInputError for wrong sizes or non-finite input.
  StaticResult solve(const VectorXd& f_ext, VectorXd& x);

  const StaticSolverOptions& options() const { return options_; }

 private:
  struct Impl;
  bool newton(const VectorXd& f_ext, VectorXd& x, int max_iterations, double tol, StaticResult& res);
  const MassSpringModel& model_;
  const DofMap& dofs_;
  StaticSolverOptions options_;
  std::unique_ptr<Impl> impl_;
};

/// Residual Pᵀ(f_int(x) + f_ext) (for tests and reports).
VectorXd static_residual(const MassSpringModel& model, const DofMap& dofs, const VectorXd& f_ext, const VectorXd& x);

}  // namespace socketsmith::tissue
