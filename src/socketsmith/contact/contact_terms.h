#pragma once
/// @file contact_terms.h
/// The two per-node terms the contact solver adds to the body's incremental potential Π, each as
/// energy, force and stiffness at one skin node — as IPC Toolkit writes its barrier and friction
/// potentials: a term knows nothing of the body, the mesh or Newton, so it is tested alone against
/// finite differences of its own energy (tests/contact/contact_terms_test.cpp) and a new contact
/// law is a new term.
///
/// Sign conventions (those of the solver's residual r = f − ∂Π_body/∂x):
///   energy      the term's share of Π [J];
///   force       −∂energy/∂p on the node [N];
///   stiffness   ∂²energy/∂p² = −∂force/∂p [N/m] (symmetric, positive semi-definite).

#include <Eigen/Core>

#include "socketsmith/contact/rigid_socket.h"

namespace socketsmith::contact {

/// Energy, force and stiffness of one node's term.
struct NodeTerm {
  double energy = 0.0;
  Vec3 force = Vec3::Zero();
  Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();
};

/// The penalty on penetration: ½ k A gap² where the node is inside the wall (gap < 0, the gap
/// valid), nothing elsewhere. Its force is k A (−gap) ∇gap = k A (−gap) |∇gap| n and its stiffness
/// k A · gap.stiffness_shape, i.e. k A ∇gap ∇gapᵀ inside a face: the Gauss–Newton part of the
/// Hessian k A (∇gap ∇gapᵀ + gap ∇²gap). The wall's curvature term gap ∇²gap is left out: it is
/// zero on a flat face, of relative size |gap| / radius on a curved wall (µm against cm), and
/// including it made the tangent indefinite at nodes deep in the brim's lip (CHANGELOG.md,
/// 2026-11-29: 132 fall-backs to the projected tangent in a 3k closed loop).
/// With a multiplier λ > 0 (augmented Lagrangian) the term is (λ − kA gap)² / (2 kA) where
/// λ − kA gap > 0: its normal force (λ − kA gap) |∇gap|, the same stiffness; λ = 0 is the penalty.
/// Raising λ to the normal force and solving again drives the penetration to zero with the
/// penalty's conditioning (ContactOptions::augmented_tol).
/// @param kA the penalty stiffness k times the node's area [N/m]
/// @param lambda_n the node's multiplier [N], ≥ 0
struct PenaltyTerm {
  NodeTerm term;
  bool active = false;         ///< the node presses on the wall: λ + k A (−gap) > 0 (with λ = 0, it penetrates)
  double normal_force_n = 0.0; ///< (λ + k A (−gap)) |∇gap|: the force along the wall's normal [N]
};
PenaltyTerm penalty_term(const Gap& gap, double kA, double lambda_n = 0.0);

/// One node's lagged friction (quasi-static, IPC's lagged Coulomb model in incremental form): an
/// elastic stick of stiffness kT between the node and the wall, capped at μ f̄ with f̄ the lagged
/// normal force (return mapping). With the lag (f̄, the wall normal n̄) fixed the term is the
/// convex potential of a Huber function of the tangential slip s:
///   stick (|q| ≤ μ f̄):  ½ |q|² / kT,
///   slip  (|q| > μ f̄):  μ f̄ |q| / kT − ½ (μ f̄)² / kT,
/// with q = P h + kT s the trial tangential force, P = I − n̄ n̄ᵀ, h the tangential force at the
/// last converged step and s = P((p − p_conv) − (t − t_conv)) the slip of the node relative to the
/// wall since then.
struct FrictionInput {
  double stick_stiffness = 0.0;    ///< kT [N/m]
  double limit_n = 0.0;            ///< μ f̄ [N]; ≤ 0: the node carried no normal force at the lag (no term)
  Vec3 lag_normal = Vec3::UnitZ(); ///< n̄, unit
  Vec3 history_n = Vec3::Zero();   ///< h: the tangential spring force of the last converged step [N]
  Vec3 displacement_m = Vec3::Zero();  ///< (p − p_conv) − (t − t_conv): the node's motion relative to the wall [m]
};

/// The friction term and what the solver keeps of it.
struct FrictionTerm {
  NodeTerm term;
  Vec3 spring_force_n = Vec3::Zero();  ///< the stick's force on the wall (−term.force): the next history
  bool sliding = false;                ///< the cap is reached
};

FrictionTerm friction_term(const FrictionInput& in);

}  // namespace socketsmith::contact
