#pragma once
/// @file implicit_euler.h
/// Linearised implicit (backward) Euler for M ẍ = f(x, ẋ) + f_ext (thesis eq. 9), as in
/// Baraff & Witkin 1998: one linear solve per step,
///   (M + h D + h² K) Δv = h (f(x₀, v₀) + f_ext − h K v₀),  v₁ = v₀ + Δv,  x₁ = x₀ + h v₁,
/// with K the symmetric positive semi-definite part of the stiffness and D the damping matrix,
/// solved by conjugate gradient (Eigen, Jacobi preconditioner, warm-started with the previous
/// Δv). As in the thesis, the MSS-CS corrective springs' volume coupling is explicit (their
/// spring part is implicit). Fixed DOFs keep zero velocity; tied DOFs share one.
///
/// With `frozen_matrix`, A = M + h D + h² K is assembled and factorised (CHOLMOD) once, at the
/// state of the first step, and every later step is one back-substitution with it: the forces
/// stay exact (f(x₀, v₀) is evaluated in full), only the implicit part lags (a linearly implicit
/// Euler with a frozen Jacobian). When a frozen step diverges — the tissue has moved far enough
/// from where A was factorised that its stiffness outgrew it — A is refactorised at the current
/// state and the step retried, so a frozen run is never less robust than the default; it is also
/// refactorised once the tissue has moved a fraction of an element since (`refactor_move_in_edges`).

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
  /// Assembles A = M + h D + h² K at x into A_ (K_red_ keeps −K).
  void assemble_system(const VectorXd& x);
  StepResult frozen_step(DynamicState& state, const VectorXd& f_ext);
  /// Checks the update and, when it is sound, applies it (res.ok) or says why not.
  void accept(DynamicState& state, const VectorXd& v_red, const VectorXd& dv, StepResult& res);
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
