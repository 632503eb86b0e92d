#pragma once
/// @file contact_solver.h
/// Quasi-static contact between the stump and a rigid obstacle (a socket, a plane), with Coulomb
/// friction (thesis ch. 3.3, docs/method.md §2, in a stated different formulation):
///
/// - detection: every candidate node (the skin) against the obstacle's inner wall through a BVH
///   (CGAL AABB tree), never all pairs;
/// - normal response: a penalty pressure p = k (−g) for a gap g < 0, k = penalty [Pa/m] (default
///   200 E / h, h the mean skin node spacing: 15 kPa penetrates h·15/(200·E) ≈ 0.005 mm at
///   E = 100 kPa), force p A along the wall normal, Newton's third law on the obstacle;
/// - friction: incremental Coulomb (elastic stick with stiffness k A per unit slip, return
///   mapping to μ f_n when it slides), history kept between converged steps;
/// - quasi-static path: the obstacle moves in steps (displacement control) or is pushed until its
///   reaction reaches a force (force control by a safeguarded secant on its position); at each
///   position Newton solves the equilibrium of the body with the contact forces, with the exact
///   normal tangent and a symmetric friction tangent. No time step, so no stability limit (the
///   thesis needed 1 ms explicit steps).
///
/// The body is the linearised stump (K₀, like the design solve, default) or the nonlinear model.

#include <memory>
#include <string>
#include <vector>

#include "socketsmith/contact/rigid_socket.h"
#include "socketsmith/tissue/dof_map.h"
#include "socketsmith/tissue/mass_spring_model.h"

namespace socketsmith::contact {

struct ContactOptions {
  double penalty_pa_per_m = 0.0;  ///< k [Pa/m]; 0: penalty_factor · E / (mean node spacing of the candidates)
  /// k = penalty_factor · E / h when penalty_pa_per_m is 0: a pressure p penetrates p h / (factor E)
  /// (15 kPa at E = 100 kPa, h = 6 mm: 5 µm at 200, 45 µm at 20).
  double penalty_factor = 200.0;
  double friction = 0.5;          ///< Coulomb μ [-], ≥ 0
  /// Stiffness of the elastic stick, k_t = stick_stiffness_ratio · k per unit area: a node sticks
  /// until it has slipped μ p / k_t, then slides (the regularisation of Coulomb's law every penalty
  /// code has; Abaqus's default elastic slip is 0.5 % of the element length). 1: k_t = k (15 kPa,
  /// μ 0.5 at E = 100 kPa, h = 6 mm, factor 20: 23 µm of elastic slip). A softer stick makes the
  /// stick/slip switches milder for Newton (the donning's default is 0.2: DonningOptions, docs/contact.md).
  double stick_stiffness_ratio = 1.0;
  bool linear_body = true;        ///< linearised body (K₀ at rest) or the nonlinear model
  int max_newton = 60;
  double rel_tol = 1e-5;          ///< ‖r‖ ≤ rel_tol · max(Σ |f_contact|, floor), h the mean node spacing
  /// The floor of that force scale, in E h² (the force that strains one element of the skin by one):
  /// when only a few nodes touch, Σ |f_contact| is tiny and Newton would chase a residual of a
  /// fraction of a millinewton while the contact set flips among those nodes (transfemoral check
  /// donning: 5,200 Newton iterations with 3–7 nodes in contact at 1e-4 · E h² ≈ 1.4 mN). The
  /// friction lag's refresh, the chord steps and the stop on a new stick keep E h² as their floor.
  double residual_floor_ratio = 30.0;
  /// Friction uses the normal forces of a lag (Tresca-like, convex step); the lag is updated until
  /// the normal forces change by less than friction_lag_tol of the largest one, at most
  /// max_friction_passes times.
  int max_friction_passes = 6;
  double friction_lag_tol = 0.01;
  /// Augmented Lagrangian: after a converged pass each node's multiplier λ takes its normal force
  /// (the penalty's force becomes (λ + k A (−gap)) |∇gap|), and passes repeat — with the friction
  /// lag's, within max_friction_passes — until the penalty part k A |gap| of every normal force is
  /// at most this share of the largest: the penetration p / k, compliance in series with the
  /// tissue, goes to zero with the penalty's conditioning. 0: a pure penalty.
  double augmented_tol = 0.0;
  /// Also refresh the friction lag inside Newton: once the residual is within 100× the tolerance
  /// and the normal forces have moved from the lag by more than friction_lag_tol, they become the
  /// lag at once, instead of only after a converged Newton solve (false: only the friction passes).
  bool friction_in_newton = true;
  /// Start each step's friction lag from the normal forces of the last two committed steps
  /// extrapolated to the new obstacle position (nodes that touched at both), not from the last's.
  bool extrapolate_friction_lag = true;
  /// A node resting on a kink of the socket wall (an edge or vertex of its triangles where the
  /// closest face switches) has no position of zero residual; Newton then crawls. When its steps
  /// have become shorter than kink_step_tol_m (or the potential has stopped decreasing), a residual
  /// ≤ kink_rel_tol · max(Σ |f_contact|, floor) is accepted and reported (ContactStep::at_kink).
  double kink_rel_tol = 2e-3;
  double kink_step_tol_m = 1e-6;
  /// Nonlinear body, near convergence (‖r‖ within 100× the tolerance, where the friction lag is
  /// refreshed): after a full Newton step that cut the residual to at most this share, the next
  /// step reuses the last factorisation (a chord step: no tangent, no factorisation), and so on
  /// while the steps keep doing so; 0: a fresh tangent every step. In the tail the tangent hardly
  /// changes while the friction lag does (8k closed loop: 31 of 182 Newton steps on the last factor,
  /// the pressures within 6 Pa on average of fresh tangents').
  double chord_ratio = 0.5;
  /// Linear body: Newton's linear systems are solved by CG preconditioned with the last
  /// factorisation of the tangent, refactorised only when CG needs more than this many iterations
  /// (0: factorise every Newton iteration, what the donning does: DonningOptions).
  int max_reuse_cg = 12;
  /// Line search: when Π turns upwards before the full Newton step, find its minimum along the
  /// step (regula falsi on the slope, until |Π'| ≤ line_search_slope · |Π'(0)|) instead of halving
  /// the step until Π decreases enough (false: halving only).
  bool exact_line_search = true;
  double line_search_slope = 0.1;  ///< (0, 1)
  /// push_with_force: start each solve inside the bracket from the interpolation of the solutions
  /// at its ends (false: from the last solution).
  bool interpolate_bracket = true;
  /// push_with_force: first one solve with the obstacle's position along the push as one more
  /// unknown of Newton (its equilibrium under the force, the tangent bordered by the contact's
  /// ∂²Π/∂x∂s), the bracket of displacement-driven solves only when that does not converge.
  /// Nonlinear body only: on the linearised body the free solve crawled at the wall's kinks (7.5k
  /// demo, the thesis's donning: 120 Newton iterations, then the bracket anyway — 30.6 s instead of
  /// 9.9 s), so that body keeps the bracket.
  bool free_push = true;
  /// Nonlinear body: when Newton's step would take free nodes through the wall by more than this
  /// [m], their penalties (linearised where they are) join its system and the step is solved again
  /// (at most twice): the line search no longer cuts the step to a sliver each time the wall reaches
  /// new nodes. The added penalties are a low-rank change of the factorised tangent, solved through
  /// that factorisation (Woodbury: one solve with a column per added node's penalty, one on the
  /// smoothed wall, up to three on a facet's edge) up to predict_low_rank_max columns, by a new
  /// factorisation beyond. 0: off.
  double predict_contact_m = 2e-5;
  int predict_low_rank_max = 96;
};

/// Contact state of one candidate node.
struct NodeContact {
  bool active = false;
  bool sliding = false;
  double gap_m = 0.0;
  double normal_force_n = 0.0;
  double pressure_pa = 0.0;         ///< normal force / nodal area
  Vec3 normal = Vec3::Zero();       ///< wall normal (into the cavity)
  Vec3 tangential_n = Vec3::Zero(); ///< friction force on the node [N]
};

struct ContactStep {
  bool converged = false;
  int newton_iterations = 0;
  double residual_n = 0.0;
  /// The residual Newton had to reach at the end: rel_tol · max(Σ |f_contact|, residual_floor_ratio · E h²) [N]
  double tolerance_n = 0.0;
  Vec3 force_on_obstacle_n = Vec3::Zero();   ///< Σ of the contact forces on the obstacle (third law)
  Vec3 torque_on_obstacle_nm = Vec3::Zero(); ///< about the obstacle's translation origin
  int contact_nodes = 0;
  int sliding_nodes = 0;
  double max_penetration_m = 0.0;
  int friction_passes = 0;
  bool at_kink = false;
  bool stopped_on_new_stick = false;  ///< try_move_to(…, true) gave up: a node started sticking
  bool out_of_budget = false;  ///< gave up: the Newton iterations allowed by limit_newton() are spent
  int new_sticks = 0;  ///< nodes sticking at the end that were sliding or free at the previous committed step
  long factorizations = 0;           ///< tangent factorisations so far (whole solver life)
  long cg_iterations = 0;            ///< CG iterations on a reused factorisation so far              ///< converged to the kink tolerance (ContactOptions::kink_rel_tol)
  double friction_lag_change = 0.0;  ///< last change of the normal forces between friction passes / max
  double seconds = 0.0;
  std::string message;
};

/// A stalled Newton solve whose residual sits on a few nodes in contact: nodes caught on the
/// socket's rim (skin wrapped over the brim's lip during donning, where the lip's normal turns
/// through a right angle within its radius) or on a kink of the wall, everything else in
/// equilibrium. Returns those nodes, the largest residual first, when they are at most
/// @p max_nodes, the residual of every other node together is within @p rest_tol_n and each one's
/// own is at most its contact force plus @p rest_tol_n (the imbalance is its contact force turning,
/// not a missing load); empty otherwise.
/// @param node_residual_n |r| per mesh node [N]
/// @param node_normal_force_n the contact force per mesh node [N], friction included (0: not in
///        contact; ContactSolver passes f_n + |f_t|: the friction of the lagged normal force may
///        exceed μ times the current one, and the node's imbalance is then bounded by it)
std::vector<int> caught_nodes(const std::vector<double>& node_residual_n, const std::vector<double>& node_normal_force_n,
                              double rest_tol_n, int max_nodes);

class ContactSolver {
 public:
  /// @param nodes candidate nodes (e.g. the skin nodes) and their nodal areas [m²]
  ContactSolver(const tissue::MassSpringModel& model, const tissue::DofMap& dofs, std::vector<int> nodes,
                std::vector<double> areas, Obstacle& obstacle, const ContactOptions& options = {});
  ~ContactSolver();
  ContactSolver(const ContactSolver&) = delete;
  ContactSolver& operator=(const ContactSolver&) = delete;

  /// Moves the obstacle to @p translation and solves the equilibrium (warm start from the last
  /// converged state; friction history updated when converged).
  ContactStep move_to(const Vec3& translation);

  /// move_to without committing: the solved state is what positions() and contacts() show, but
  /// the friction history stays at the last committed step until commit(); discard() goes back
  /// to that step (an adaptive path tries a step and keeps or refines it).
  /// @p stop_on_new_stick: give up (not converged, ContactStep::stopped_on_new_stick) as soon as,
  /// near convergence, a node that was sliding or free at the last committed step sticks — the
  /// caller is going to refine such a step anyway.
  ContactStep try_move_to(const Vec3& translation, bool stop_on_new_stick = false);
  void commit();
  void discard();

  /// Moves the obstacle along unit @p direction (from its current translation) until the force
  /// the body exerts on it along −direction equals @p force_n [N] (the obstacle pushed with
  /// that force), within @p rel_tol. Displacement steps of at most @p max_step_m.
  /// @p first_step_m > 0: the first displacement step (e.g. predicted from the reaction's slope
  /// along the path so far; ≤ max_step_m), else max_step_m.
  /// @p free_start_m: where along @p direction the free solve (ContactOptions::free_push) starts
  /// its Newton iterations — the predicted position of the load (the solve finds the position
  /// itself; a good start saves iterations); 0: the current translation.
  ContactStep push_with_force(const Vec3& direction, double force_n, double rel_tol = 1e-3,
                              double max_step_m = 0.002, double first_step_m = 0.0, double free_start_m = 0.0);

  /// push_with_force's first attempt alone: one Newton solve with the obstacle free along
  /// @p direction under @p force_n (nonlinear body; ContactOptions::free_push). Converged: the
  /// state is committed. Not converged: nothing changed (the obstacle and the state are where they
  /// were), no bracket is tried — the caller chooses its fall-back.
  /// @throws InvalidInputError on a linearised body (its free solve crawls at the wall's kinks).
  ContactStep push_free(const Vec3& direction, double force_n, double rel_tol = 1e-3);

  /// From now on, at most @p iterations more Newton iterations in all (every solve, committed or
  /// not, sub-steps included); 0: no limit. A solve that reaches the limit stops unconverged with
  /// ContactStep::out_of_budget, without refining its path — a grinding path (the contact set
  /// flipping among a few nodes for thousands of iterations) ends with a message instead of minutes.
  void limit_newton(long iterations);
  /// Newton iterations of every solve so far (whole solver life, failed ones included).
  long newton_iterations_spent() const;

  /// The obstacle's geometry changed (e.g. RigidSocket::replace_solid): forget the gap queries
  /// cached per node. The contact state and friction history stay; the next solve sees the new wall.
  void obstacle_changed();
  /// After obstacle_changed(), a start for the next solve: every node in contact at the last
  /// committed step follows the wall's move along its normal, the body answering through the last
  /// factorised tangent (one back-substitution: the change of the contact forces with the old
  /// contact set held, k A Δgap n, on K⁻¹). Taken when it lowers the potential (as any warm start).
  /// A new wall a fraction of a millimetre from the worn one otherwise starts Newton with half of
  /// the nodes out of contact and the others pressed in by the whole move (8k closed loop: a
  /// refit's first steps cut to 5–25 % by the line search). @return whether the start was taken.
  bool predict_wall_change();

  const tissue::VectorXd& positions() const;
  const std::vector<NodeContact>& contacts() const;
  const std::vector<int>& nodes() const;
  double penalty() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The penalty k [Pa/m] a ContactSolver with @p options uses on a body of Young's modulus
/// @p youngs_pa whose candidate nodes have the nodal areas @p areas [m²]: options.penalty_pa_per_m
/// when set, else penalty_factor · E / h, h the mean √area (CalculiX's check can use the same: `validate
/// design --penalty 0`). @throws InvalidInputError for an area that is not positive.
double contact_penalty_pa_per_m(const ContactOptions& options, double youngs_pa, const std::vector<double>& areas);

}  // namespace socketsmith::contact
