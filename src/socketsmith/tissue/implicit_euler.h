#pragma once
/// @file implicit_euler.h
/// Linearised implicit (backward) Euler for M ẍ = f(x, ẋ) + f_ext (thesis eq. 9), as in
/// Baraff & Witkin 1998: one linear solve per step,
///   (M + h D + h² K) Δv = h (f(x₀, v₀) + f_ext − h K v₀),  v₁ = v₀ + Δv,  x₁ = x₀ + h v₁,
/// with K the symmetric positive semi-definite part of the stiffness and D the damping matrix,
/// solved by conjugate gradient (Eigen, Jacobi preconditioner, warm-started with the previous
/// Δv). The MSS-CS corrective springs' volume coupling enters K through its symmetric PSD
/// surrogate (MassSpringModel::jacobian; the thesis integrated it explicitly). Fixed DOFs keep
/// zero velocity; tied DOFs share one.
///
/// With `frozen_matrix`, A = M + h D + h² K is assembled and factorised (CHOLMOD) once, at the
/// state of the first step, and every later step is one back-substitution with it: the forces
/// stay exact (f(x₀, v₀) is evaluated in full), only the implicit part lags (a linearly implicit
/// Euler with a frozen Jacobian). When a frozen step diverges — the tissue has moved far enough
/// from where A was factorised that its stiffness outgrew it — A is refactorised at the current
/// state and the step retried, so a frozen run is never less robust than the default; it is also
/// refactorised once the tissue has moved a fraction of an element since (`refactor_move_in_edges`).
///
/// MSS-CS's corrective law with a dead zone (cube-targets) is flat up to a volume loss d and steep
/// beyond (k' = C E l_e (−δv − d)^β, C = 1e5): an element that crosses d after the factorisation
/// gains a volumetric stiffness the frozen A does not have, and the lagged remainder then grows
/// (measured: divergence within 2–9 steps). So A holds, per element, the law's slope a little
/// further on — after `corrective_lookahead` more volume loss — and is refactorised before a step
/// when an element's law has become steeper than that (by `refactor_corrective_slope`), or after a
/// step that took an element there, which is then redone (A then holds the law where it went). The per-step scheme takes the law's slope
/// at the state; when the law got much steeper within a step (`redo_corrective_slope`; a sudden
/// load on a fine lattice), the step is redone with the law's slope where it went.
///
#include <memory>
#include <string>

#include "socketsmith/tissue/dof_map.h"
#include "socketsmith/tissue/mass_spring_model.h"

namespace socketsmith::tissue {

struct ImplicitEulerOptions {
  double time_step_s = 1e-3;     ///< h [s], > 0
  double cg_rel_tol = 1e-6;      ///< CG relative residual tolerance [-]
  int cg_max_iterations = 500;   ///< CG iterations per step
  /// A step that moves any node further than this many mean element edges is declared
  /// diverged (a stable step at a sensible h moves nodes by a fraction of an element) [-], > 0.
  double max_step_in_edges = 1.0;
  /// Factorise the system matrix once and reuse it (see the file comment); refactorised on divergence,
  /// when a node has moved more than `refactor_move_in_edges` mean element edges since the last
  /// factorisation (the lag of K grows with the motion; measured: a frozen matrix left for ~1 edge of
  /// motion lets the explicit remainder grow, docs/PERFORMANCE.md), and every `refactor_every_steps`
  /// steps (0: never on a count).
  bool frozen_matrix = false;
  double refactor_move_in_edges = 0.25;
  int refactor_every_steps = 0;
  /// frozen_matrix, MSS-CS: the volume loss ahead of each element's state at which its corrective
  /// law's slope dk'/dδv is taken for A [-], in [0, 0.5) (0: the slope at the state).
  double corrective_lookahead = 0.002;
  /// frozen_matrix, MSS-CS: A is refactorised (before a step) or the step redone (after it) when an
  /// element's law slope is steeper than the one A holds by more than this, in E l_e per unit
  /// volume change [-], > 0. Small: refactorised for every change of the law; large: the law's
  /// stiffness may outgrow A (see the file comment).
  double refactor_corrective_slope = 1.0;
  /// Per-step scheme, MSS-CS: a step is redone with each element's law slope where the step went
  /// when that slope is steeper than the one at the state (which the matrix holds) by more than
  /// this, in E l_e per unit volume change [-], > 0. Measured on the bench's sudden load: 100
  /// carries 4k and 8k nodes, 300 does not; 10–100 cost the same at 1k.
  double redo_corrective_slope = 30.0;
};

/// Positions and velocities (3N each) and time.
struct DynamicState {
  VectorXd x;  ///< [m]
  VectorXd v;  ///< [m/s]
  double time_s = 0.0;
};

struct StepResult {
  bool ok = false;          ///< false: diverged (state left unchanged)
  int cg_iterations = 0;     ///< 0 with frozen_matrix
  bool refactorised = false; ///< frozen_matrix: the matrix was (re)factorised in this step
  bool law_retried = false;  ///< per-step scheme: redone with the corrective law where the step went
  double cg_error = 0.0;    ///< CG's final relative residual
  std::string message;
};

class ImplicitEuler {
 public:
  ImplicitEuler(const MassSpringModel& model, const DofMap& dofs, const ImplicitEulerOptions& options = {});
  ~ImplicitEuler();
  ImplicitEuler(const ImplicitEuler&) = delete;
  ImplicitEuler& operator=(const ImplicitEuler&) = delete;

  /// Advances @p state by one step under external forces @p f_ext (3N) [N].
  /// On divergence (non-finite values or an inverted element) returns ok = false and leaves
  /// @p state unchanged.
  StepResult step(DynamicState& state, const VectorXd& f_ext);

  /// Kinetic energy ½ vᵀ M v [J].
  double kinetic_energy(const VectorXd& v) const;

  const ImplicitEulerOptions& options() const { return options_; }

 private:
  struct Frozen;
  /// Assembles A = M + h D + h² K at x into A_ (K_red_ keeps −K); @p corrective_slopes as in
  /// MassSpringModel::jacobian.
  void assemble_system(const VectorXd& x, const VectorXd* corrective_slopes = nullptr);
  /// MSS-CS: per element, the corrective law's slope for the system matrix: the steepest of its
  /// slope at @p dv_now and at (the lesser of dv_now and @p dv_reached) − @p lookahead.
  VectorXd law_slopes(const VectorXd& dv_now, const VectorXd* dv_reached, double lookahead) const;
  /// True when some element's law slope at volume changes @p dv is steeper than @p held by more
  /// than @p tolerance E l_e.
  bool law_steeper_than(const VectorXd& dv, const VectorXd& held, double tolerance) const;
  StepResult frozen_step(DynamicState& state, const VectorXd& f_ext);
  /// The state a velocity update leads to: v₁ = v₀ + Δv (expanded), x₁ = x₀ + h v₁.
  void advance(const DynamicState& state, const VectorXd& v_red, const VectorXd& dv, VectorXd& x_new,
               VectorXd& v_new) const;
  /// Checks the update and, when it is sound, applies it (res.ok) or says why not.
  void accept(DynamicState& state, const VectorXd& dv, VectorXd& x_new, VectorXd& v_new, StepResult& res);
  const MassSpringModel& model_;
  const DofMap& dofs_;
  ImplicitEulerOptions options_;
  VectorXd mass_red_;
  VectorXd dv_prev_;
  double max_step_m_ = 0.0;
  SparseMatrix K_, D_, K_red_, D_red_, A_;
  std::unique_ptr<Frozen> frozen_;
  int steps_since_factorisation_ = 0;
  double mean_edge_m_ = 0.0;
  VectorXd x_factorised_;
};

/// Makes a state at rest at the model's rest positions.
DynamicState rest_state(const MassSpringModel& model);

}  // namespace socketsmith::tissue
