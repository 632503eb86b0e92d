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
/// `continuation_newton_iterations`, or stalls (`stall_iterations`), the load is applied by adaptive
/// continuation from the load the initial state already balances (f₀ = −f_int(x₀)), halving the
/// load step on failure.
///
/// Convergence: ‖r‖₂ ≤ rel_tol · max(‖Pᵀ f_ext‖₂, force_scale_n) + abs_tol_n.
///
/// When the continuation stalls, the result says why (docs/tissue.md, "Static solves on limb
/// meshes"): the element closest to inversion, whether inverting it blocked the line searches,
/// the range of element volume changes, how much the load–displacement path has softened, and
/// (up to `stability_check_max_dofs`) the tangent's determinant sign and softest eigenvalue at
/// the last equilibrium. A stall of these lattices is usually a genuine loss of stability of the
/// model (e.g. MSS-CS elements compressed by more than ≈ 3 % with the recommended constants, or
/// expanded by more than ≈ 0.3 % with the thesis's), not an inaccurate linear solve.

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
  /// The direct attempt is handed over to load continuation once its residual has fallen by less
  /// than `stall_reduction` over this many iterations, instead of crawling on to
  /// `continuation_newton_iterations` (0: never). Measured with the cube-targets law from rest:
  /// line-search steps of 1/16–1/32 and 14–25 % of the residual gone after 6 iterations on the
  /// bench lattices and the sheared cube at 5–7.5 kPa (handed over: 9 iterations saved), 40–49 %
  /// on milder loads that direct Newton then finishes in 14 (handed over when the bar was a half:
  /// 28–29 iterations). Load steps keep the full budget: giving them up as early halves steps until
  /// the sheared cube's continuation budget runs out.
  int stall_iterations = 6;
  double stall_reduction = 1.0 / 3;  ///< see stall_iterations, in (0, 1)
  double min_load_step = 1.0 / 1024;    ///< smallest load-continuation step before giving up [-]
  double max_step_m = 0.0;        ///< cap on the largest nodal move per iteration [m] (0: none)
  /// Gives up the load continuation when a load step fails while the secant stiffness of the
  /// path (Δλ/‖Δx‖ of the last accepted load step) is below this fraction of the first step's:
  /// the load–displacement path is nearly flat (a limit point or a collapse), where continuation
  /// in the load only crawls (measured: 25 Newton iterations per 0.1 % of the load at 8k nodes).
  /// 0: crawl on until min_load_step.
  double collapse_stiffness_ratio = 0.01;
  /// Checks the tangent's stability (sparse LU of the exact reduced tangent: determinant sign and
  /// softest eigenvalue) after a converged solve; a negative determinant (an odd number of real
  /// negative eigenvalues: the equilibrium is unstable) is then reported as not converged.
  /// Costs about one LU factorisation (0.5 s at 3k nodes, 3 s at 8k): off by default.
  bool check_stability = false;
  /// Largest reduced system for which a stalled solve (or check_stability) computes the tangent
  /// stability by sparse LU [DOFs] (0: never). The LU's fill is ~ 20 M entries at 18k DOFs.
  int stability_check_max_dofs = 30000;
};

/// Stability of the tangent K = −Pᵀ J P at a state (computed by sparse LU of the exact tangent).
/// det K < 0 proves the state unstable (an odd number of real negative eigenvalues: a static
/// divergence mode exists whatever the masses); det K > 0 does not prove it stable.
struct TangentStability {
  bool computed = false;
  int determinant_sign = 0;          ///< sign of det K (−1: unstable), 0 when not computed or singular
  double softest_eigenvalue = 0.0;   ///< eigenvalue of K of smallest magnitude (inverse iteration) [N/m]
  bool softest_converged = false;    ///< inverse iteration converged (else a complex pair may be softest)
  double max_diagonal = 0.0;         ///< largest diagonal entry of K [N/m] (scale of the eigenvalue)
  int softest_mode_node = -1;        ///< node with the largest amplitude in the softest mode
};

/// Volume changes (V − V0)/V0 between which one cube element of a model, scaled uniformly (a
/// hydrostatic state), has a positive definite tangent on its 18 deformation modes. Outside this
/// range the element alone is unstable (MSS-CS: the pre-compressed corrective springs' negative
/// transverse stiffness beats the Golec springs in compression; the thesis's symmetric law
/// inflates expanding elements). Distorted or sheared elements, and their neighbours, move the
/// threshold: an indication for diagnosis, not a proof.
struct ElementStabilityRange {
  double min_volume_change = -0.5;  ///< lower end; −0.5 when stable down to −50 %
  double max_volume_change = 0.5;   ///< upper end; +0.5 when stable up to +50 %
};
ElementStabilityRange element_stability_range(const MassSpringModel& model);

/// Tangent stability at positions @p x (3N). Factorises the exact reduced tangent with Eigen's
/// SparseLU: memory and time of a direct solve; meant for diagnosis, not every solve.
TangentStability tangent_stability(const MassSpringModel& model, const DofMap& dofs, const VectorXd& x);

/// External forces that depend on the positions, e.g. a pressure that follows the deformed skin:
/// f(x) and its Jacobian, which the Newton tangent then includes (a follower load is not a dead
/// load: its load stiffness can hold a body that a dead load of the same forces would buckle).
class PositionDependentLoad {
 public:
  virtual ~PositionDependentLoad() = default;
  /// Forces at positions @p x (3N) [N].
  virtual VectorXd forces(const VectorXd& x) const = 0;
  /// Adds @p scale · ∂f/∂x at @p x to @p J (3N × 3N, MassSpringModel::jacobian's pattern: entries
  /// only between nodes that share an element) [N/m].
  virtual void add_jacobian(const VectorXd& x, double scale, SparseMatrix& J) const = 0;
};

struct StaticResult {
  bool converged = false;
  int iterations = 0;          ///< Newton iterations
  int krylov_iterations = 0;   ///< total BiCGSTAB iterations
  int factorizations = 0;      ///< CHOLMOD numeric factorisations in this solve
  int load_steps = 0;          ///< load-continuation steps taken (0: direct Newton converged)
  double residual_n = 0.0;     ///< final ‖r‖₂ [N]
  double reference_force_n = 0.0;  ///< the reference of the relative tolerance [N]
  double load_fraction = 0.0;  ///< fraction of the load (from the one x₀ balances) that x balances [-]
  int direct_solves = 0;       ///< Newton steps solved by sparse LU because BiCGSTAB failed
  /// Element closest to inversion in the returned state: its smallest corner scaled Jacobian
  /// (1 for a cube, ≤ 0 inverted) and its volume change (V − V0)/V0.
  int worst_element = -1;
  double worst_scaled_jacobian = 1.0;
  double min_volume_change = 0.0;  ///< smallest (V − V0)/V0 over the elements
  double max_volume_change = 0.0;  ///< largest (V − V0)/V0 over the elements
  /// Elements whose volume change lies outside element_stability_range (filled with the stall
  /// diagnosis and by check_stability; −1 when not computed).
  int elements_outside_stable_range = -1;
  TangentStability stability;  ///< filled when the solve stalled or check_stability is set
  std::string message;         ///< why it stopped
};

/// Static equilibrium solver (expensive set-up once, cheap repeated solves).
class StaticSolver {
 public:
  StaticSolver(const MassSpringModel& model, const DofMap& dofs, const StaticSolverOptions& options = {});
  ~StaticSolver();
  StaticSolver(const StaticSolver&) = delete;
  StaticSolver& operator=(const StaticSolver&) = delete;
  StaticSolver(StaticSolver&&) = delete;  // its Impl refers to options_: not movable

  /// Solves for the positions x (3N) under external nodal forces @p f_ext (3N) [N].
  /// @param x in: initial guess and the values of fixed DOFs; out: the solution (or the last
  ///          iterate when not converged). Never returns a state with inverted elements.
  /// @throws InvalidInputError for wrong sizes or non-finite input.
  StaticResult solve(const VectorXd& f_ext, VectorXd& x);
  /// The same under forces that depend on the positions (@p load, kept alive by the caller): Newton
  /// on f_int(x) + f(x) = 0 with the tangent ∂f_int/∂x + ∂f/∂x; load continuation scales f.
  StaticResult solve(const PositionDependentLoad& load, VectorXd& x);

  const StaticSolverOptions& options() const { return options_; }

 private:
  struct Impl;
  class Newton;  // the static solve's half of Newton (newton_loop.h)
  /// The load of one Newton solve: constant + scale · moving(x).
  struct AppliedLoad {
    VectorXd constant;
    const PositionDependentLoad* moving = nullptr;
    double scale = 0.0;
    VectorXd at(const VectorXd& x) const { return moving ? VectorXd(constant + scale * moving->forces(x)) : constant; }
  };
  StaticResult solve_load(const AppliedLoad& load, VectorXd& x);
  /// Load continuation after plain Newton failed: f(λ) = f₀ + λ (f_ext − f₀) with f₀ = −f_int(x₀),
  /// λ: 0 → 1 in adaptive steps, into @p x (from @p x0); true when the whole load is reached.
  bool continue_load(const AppliedLoad& load, const VectorXd& x0, double tol, VectorXd& x, StaticResult& res);
  /// The converged state's stability: the tangent's determinant sign (unstable: not converged)
  /// and the elements beyond the volume change at which one element is stable.
  void check_stability(const VectorXd& x, StaticResult& res) const;
  /// @param stall_iterations give up when ‖r‖ has not halved over this many iterations (0: never).
  bool newton(const AppliedLoad& load, VectorXd& x, int max_iterations, double tol, StaticResult& res,
              int stall_iterations = 0);
  void describe_state(const VectorXd& x, StaticResult& res) const;
  std::string stall_diagnosis(const VectorXd& x, StaticResult& res, double path_stiffness_ratio) const;
  int count_outside_stable_range(const VectorXd& x, ElementStabilityRange& range) const;
  const MassSpringModel& model_;
  const DofMap& dofs_;
  StaticSolverOptions options_;
  std::unique_ptr<Impl> impl_;
};

/// Keeps the solvers from oversubscribing the cores: OpenBLAS single-threaded, and the calling
/// thread's OpenMP teams sized to the cores the load average leaves free (this process counted
/// out), at most what the thread allowed before (OMP_NUM_THREADS). Cheap; call it on every thread
/// that solves (solvers do it themselves).
void limit_solver_threads();

/// Residual Pᵀ(f_int(x) + f_ext) (for tests and reports).
VectorXd static_residual(const MassSpringModel& model, const DofMap& dofs, const VectorXd& f_ext, const VectorXd& x);

}  // namespace socketsmith::tissue
