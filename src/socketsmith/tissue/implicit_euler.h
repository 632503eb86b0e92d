#pragma once
/// @file implicit_euler.h
/// Linearised implicit (backward) Euler for M ẍ = f(x, ẋ) + f_ext (thesis eq. 9), as in
/// Baraff & Witkin 1998: one linear solve per step,
///   (M + h D + h² K) Δv = h (f(x₀, v₀) + f_ext − h K v₀),  v₁ = v₀ + Δv,  x₁ = x₀ + h v₁,
/// with K the symmetric positive semi-definite part of the stiffness and D the damping matrix,
/// solved by conjugate gradient (Eigen, Jacobi preconditioner, warm-started with the previous
/// Δv). As in the thesis, the MSS-CS corrective springs' volume coupling is explicit (their
/// spring part is implicit). Fixed DOFs keep zero velocity; tied DOFs share one.

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
};

/// Positions and velocities (3N each) and time.
struct DynamicState {
  VectorXd x;  ///< [m]
  VectorXd v;  ///< [m/s]
  double time_s = 0.0;
};

struct StepResult {
  bool ok = false;          ///< false: diverged (state left unchanged)
  int cg_iterations = 0;
  double cg_error = 0.0;    ///< CG's final relative residual
  std::string message;
};

class ImplicitEuler {
 public:
  ImplicitEuler(const MassSpringModel& model, const DofMap& dofs, const ImplicitEulerOptions& options = {});

  /// Advances @p state by one step under external forces @p f_ext (3N) [N].
  /// On divergence (non-finite values or an inverted element) returns ok = false and leaves
  /// @p state unchanged.
  StepResult step(DynamicState& state, const VectorXd& f_ext);

  /// Kinetic energy ½ vᵀ M v [J].
  double kinetic_energy(const VectorXd& v) const;

  const ImplicitEulerOptions& options() const { return options_; }

 private:
  const MassSpringModel& model_;
  const DofMap& dofs_;
  ImplicitEulerOptions options_;
  VectorXd mass_red_;
  VectorXd dv_prev_;
  double max_step_m_ = 0.0;
  SparseMatrix K_, D_, K_red_, D_red_, A_;
};

/// Makes a state at rest at the model's rest positions.
DynamicState rest_state(const MassSpringModel& model);

}  // namespace socketsmith::tissue
