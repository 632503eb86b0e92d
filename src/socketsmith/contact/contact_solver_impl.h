#pragma once
/// @file contact_solver_impl.h
/// The state and the methods of ContactSolver (private to the contact module): the contact and
/// friction terms, their tangent and the CG reuse in contact_solver.cpp; Newton, its line search,
/// the steps along a path and the pushes in contact_newton.cpp.

#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "socketsmith/contact/contact_solver.h"
#include "socketsmith/tissue/sparse_cholesky.h"

namespace socketsmith::contact {

using tissue::SparseMatrix;
using tissue::VectorXd;

constexpr double kRelagResidual = 100.0;  // friction lag refreshed in Newton once ‖r‖ ≤ this × tol
constexpr double kRelagProgress = 0.5;    // a refresh made progress when ‖r‖ < this × ‖r‖ at the last one
constexpr int kRelagStall = 4;            // refreshes in a row without progress before they stop
constexpr double kTinyStep = 1.0 / 64;    // a line-search step below this share of Newton's is a sliver
constexpr int kStallSteps = 3;            // slivers in a row: Newton has stalled (ContactSolver::Impl::newton)
/// At most this many nodes caught on the rim at a stall (caught_nodes). The AmpScan scan's 8k
/// donning stalled nine times on two to four nodes wrapped over the anterior lip; accepting them
/// took it from 959 to 592 Newton iterations with the delivered pressures within 0.07 kPa.
constexpr int kMaxCaughtNodes = 6;
/// After a Newton solve that fails (a stall, its iterations spent), the next this many committed
/// steps go without predicted contacts (predict_contacts): the path's retries, where a node caught
/// at the brim decides, take the steps they took before the prediction (the generated
/// transfemoral limb of seed 10, 3k, whose open-loop donning stalls at its brim again and again:
/// 2,498 Newton iterations without predictions, 4,962 with them in the retries too, 3,303 with
/// this pause).
constexpr int kPredictPause = 4;

using tissue::SerialParallelRegions;

struct ContactSolver::Impl {
  const tissue::MassSpringModel& model;
  const tissue::DofMap& dofs;
  std::vector<int> nodes;
  std::vector<double> areas;
  Obstacle& obstacle;
  ContactOptions opt;
  /// Newton's next direction may use the last factorisation (ContactOptions::chord_ratio), and
  /// the current one does.
  bool chord_next = false, chord_now = false;
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
  long newton_spent = 0, newton_limit = 0;  // Newton iterations so far / the limit on them (0: none; limit_newton)
  bool out_of_budget() const { return newton_limit > 0 && newton_spent >= newton_limit; }
  std::vector<char> was_active;  // active at the last converged step
  struct QueryCache {
    Vec3 p = Vec3::Zero(), t = Vec3::Zero();
    double clearance = -1.0;  // the facets' gap (a distance) / 1.5 of the last query in the cavity, else −1
  };
  std::vector<QueryCache> qcache;  // per candidate node
  std::vector<Gap> gaps;           // scratch of evaluate()
  std::vector<double> conv_fn, lag_fn, prev_fn;  // normal force at the last converged step / friction lag
  std::vector<Vec3> conv_n, lag_n;      // wall normal at the last converged step / friction lag
  std::vector<double> alm, conv_alm;    // augmented Lagrangian multipliers [N]: this solve's / the last committed step's
  double force_floor = 1e-3;            // [N] scale of the residual tolerance when forces are small
  double tail_floor = 1e-3;             // [N] the same for the tail's thresholds (E h², ContactOptions::residual_floor_ratio)
  SparseMatrix K0;         // linear body: reduced stiffness at rest
  SparseMatrix K0c;        // K₀ with every candidate node's 3×3 block in its pattern
  std::vector<Eigen::Index> block_at;  // per candidate node, entry (a, b) at 9 i + 3 b + a: index in K0c's values, −1 fixed
  tissue::SparseCholesky<Eigen::Upper> llt;
  long factorizations = 0, cg_iterations = 0;  // counters for ContactStep (sparse LU included)
  // push_with_force: the obstacle free along free_dir under free_force_n, its translation along
  // free_dir one more unknown of Newton (free_dir zero: the obstacle's translation is given).
  Vec3 free_dir = Vec3::Zero();
  double free_force_n = 0;
  bool free_axis() const { return free_dir.squaredNorm() > 0; }
  /// The obstacle's equilibrium along free_dir in state @p st: the push minus what the nodes take.
  double free_residual(const std::vector<NodeContact>& st) const;

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
                    bool trial_point = false);

  /// The gap of every candidate node at @p xs against the obstacle at @p t (in `gaps`), in
  /// parallel. A node whose last query found it in the cavity, beyond the smoothed wall and the lip
  /// (the facets' gap, a distance), with a clearance larger than how far it and the obstacle have
  /// moved since cannot have reached the wall: no query.
  void query_gaps(const VectorXd& xs, const Vec3& t);
  /// Friction of candidate node @p i at @p p: a node that carried a normal force at the lag
  /// (μ f̄ > 0) resists slip relative to the wall with an elastic stick (stiffness kT) capped at μ f̄
  /// (return mapping). Adds its force to @p f and its stiffness to @p B, sets @p s's sliding and
  /// tangential force and @p trial_hist; returns its potential.
  double friction_term(size_t i, const Vec3& p, const Vec3& t, NodeContact& s, Vec3& trial_hist, Vec3& f,
                       Eigen::Matrix3d& B) const;

  /// The tangent K = K_body + Σ the candidate nodes' 3×3 @p blocks (reduced). Every candidate
  /// node's block is in the pattern (explicit zeros where it is not in contact), so the pattern
  /// never changes and CHOLMOD orders it once. Linear body: K₀'s values are copied into that fixed
  /// pattern and the blocks added in place (block_at: where each block entry lives).
  void tangent(const VectorXd& xs, const std::vector<Eigen::Matrix3d>& blocks, SparseMatrix& K, bool psd_body = false);
  /// Adds each candidate node's 3×3 block of @p blocks into the nonlinear body's tangent @p K (in
  /// place, at body_block_at).
  void add_node_blocks(const std::vector<Eigen::Matrix3d>& blocks, SparseMatrix& K) const;
  SparseMatrix J_body;               // the body's Jacobian (nonlinear body), its pattern reused
  std::vector<Eigen::Index> body_block_at;  // where each candidate block entry lives in K (nonlinear body)

  /// Where entry (a, b) of each candidate node's 3×3 block lives in @p K's values (index 9i + 3b + a;
  /// −1 for a fixed DOF).
  std::vector<Eigen::Index> block_positions(const SparseMatrix& K) const;

  /// Gap against the wall. On the faceted wall, whose validity is all or nothing, a node in contact
  /// at the last converged step keeps a wider acceptance cone, so that a node at the wall's rim does
  /// not chatter in and out of contact (the smoothed wall hands over to the brim's lip there instead).
  Gap wall_gap(size_t i, const Vec3& p) const;
  /// CG on K d = b preconditioned by the last factorisation; false when it needs more than
  /// opt.max_reuse_cg iterations for a relative residual of 1e-8.
  bool pcg(const SparseMatrix& K, const VectorXd& b, VectorXd& d);

  double tolerance(const std::vector<NodeContact>& st) const { return opt.rel_tol * std::max(force_sum(st), force_floor); }
  /// Newton's tail, where the friction lag is refreshed, chord steps are taken and a new stick
  /// stops a try_move_to: ‖r‖ ≤ kRelagResidual · rel_tol · max(Σ |f_contact|, E h²).
  bool in_tail(const std::vector<NodeContact>& st, double rn) const {
    return rn <= kRelagResidual * opt.rel_tol * std::max(force_sum(st), tail_floor);
  }
  static double force_sum(const std::vector<NodeContact>& st);
  /// The residual accepted at a kink of the wall (see ContactOptions::kink_rel_tol).
  double kink_tolerance(const std::vector<NodeContact>& st) const {
    return opt.kink_rel_tol / opt.rel_tol * tolerance(st);
  }
  /// The residual @p r (and the obstacle's @p rs) sits on a few nodes in contact (at most
  /// kMaxCaughtNodes), caught on the rim or a kink (caught_nodes), the rest within the kink's
  /// tolerance; @p why then says which nodes. The AmpScan limb at 8k: a skin node wrapped over the
  /// anterior lip 49 mm before the pose, 1.0 N of its 1.5 N contact force unbalanced, 0.03 N on all
  /// the others, stalled every path refinement and the corrected socket's donning; two to four
  /// such nodes stalled the open-loop socket's donning nine times.
  bool caught(const VectorXd& r, double rs, const std::vector<NodeContact>& st, std::string& why) const;

  /// |r| per mesh node of the reduced residual @p r (0 at a node whose DOFs are all fixed).
  std::vector<double> node_residuals(const VectorXd& r) const;
  /// The three candidate nodes holding most of the residual @p r, with their contact state in @p st:
  /// what a stalled Newton is stuck on (its message names them).
  std::string residual_holders(const VectorXd& xs, const VectorXd& r, const std::vector<NodeContact>& st) const;
  /// The candidate node whose contact energy (penalty and friction) at the step @p a along
  /// (@p delta, @p ds) from (@p xs, @p t) is furthest from Newton's quadratic model of it at
  /// (xs, t) — its force and stiffness there: what blocks a line search that cuts its steps to
  /// slivers (a jump or a steep ramp of the gap; the nodes holding the residual are often others).
  /// Empty when no node's term departs from its model by more than 1 % of @p scale_j (the caller
  /// passes the potential's decrease over the step). The obstacle is left at @p t.
  std::string model_breaker(const VectorXd& xs, const Vec3& t, const VectorXd& delta, double ds, double a,
                            double scale_j);

  /// Nodes of @p st sticking (in contact, friction below its limit and not zero) that were sliding
  /// or free at the last committed step.
  int count_new_sticks(const std::vector<NodeContact>& st) const;

  /// The friction lag refreshes of one Newton solve: the residual at the last one and how many in
  /// a row did not halve it.
  struct RelagState {
    double residual_n = std::numeric_limits<double>::infinity();
    int stalled = 0;
  };
  /// Inside Newton: the lag refreshed from @p st when it is due (true: the potential changed).
  bool refresh_lag_in_newton(const std::vector<NodeContact>& st, double rn, RelagState& rs);
  /// Largest change of the normal forces of @p st from the friction lag, / the largest of them.
  double lag_change(const std::vector<NodeContact>& st) const;
  /// The friction lag takes the normal forces of @p st — half-way only when the last refresh did
  /// not shrink the change (a node at the socket's rim can otherwise flip in and out of contact
  /// with every refresh, its friction pushing it out and its absence letting it back: a 2-cycle).
  void update_lag(const std::vector<NodeContact>& st);
  /// Augmented Lagrangian (ContactOptions::augmented_tol): the largest penalty part k A |gap| of
  /// the normal forces of @p st (the penetration's share, what a multiplier update removes) / the
  /// largest normal force; and the update, each multiplier taking its node's λ + k A (−gap).
  double augmentation_change(const std::vector<NodeContact>& st) const;
  void update_augmentation(const std::vector<NodeContact>& st);
  double last_lag_change = 0;  // of the last refresh in this solve

  /// A trial point x + a·delta of the line search, with its residual, potential and slope.
  struct Trial {
    VectorXd x, r;
    Vec3 t = Vec3::Zero();
    double pi = 0, rn = 0, rs = 0;  // rs: free_residual
    double slope = 0;  // dΠ/da = −r(x + a·delta)·delta − rs·ds
    std::vector<NodeContact> st;
    std::vector<Vec3> th;
    std::vector<Eigen::Matrix3d> B;
  };
  /// Linear body: K₀u at the line search's start and K₀δ (then K₀u at x + a·δ = Ku0 + a·Kd).
  VectorXd Ku0, Kd;
  bool try_step(const VectorXd& xs, const Vec3& t, const VectorXd& delta, double ds, double a, Trial& tr);

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
  bool line_search(VectorXd& xs, Vec3& t, const VectorXd& delta, double ds, VectorXd& r, double& rs, double& rn,
                   double& pi, std::vector<NodeContact>& st, std::vector<Vec3>& th, std::vector<Eigen::Matrix3d>& B,
                   bool conservative, double& step);

  /// The Newton step of the nonlinear body: CHOLMOD on the exact tangent @p K (symmetric for the
  /// hyperelastic models; positive definite near a stable equilibrium), else on the tangent with
  /// the body's part projected positive (a descent direction for the line search on Π), else
  /// sparse LU. The pattern is the same every iteration, so CHOLMOD orders it once.
  bool solve_nonlinear(const VectorXd& xs, const std::vector<Eigen::Matrix3d>& B, SparseMatrix& K,
                       const Eigen::MatrixXd& r, Eigen::MatrixXd& delta);

  /// The free obstacle's column of the tangent (free_axis()): c = ∂²Π/∂x∂s, reduced (−B_i d at
  /// each candidate node, the contact depending on x_i − t), and @p h = ∂²Π/∂s² = Σ dᵀ B_i d.
  VectorXd free_border(const std::vector<Eigen::Matrix3d>& B, double& h) const;
  /// Block elimination of the free obstacle's unknown s from [K c; cᵀ h] [δ; ds] = [r; rs], with
  /// the columns of @p sol z = K⁻¹r and y = K⁻¹c: ds = (rs − cᵀz) / (h − cᵀy), δ = z − y ds, the
  /// step scaled to move the obstacle at most 1 mm. False when the Schur complement h − cᵀy is not
  /// positive: nothing holds the obstacle along free_dir.
  static bool eliminate_free(const Eigen::MatrixXd& rhs, const Eigen::MatrixXd& sol, double h, double rs,
                             VectorXd& delta, double& ds);
  static constexpr double kMaxFreeStep = 1e-3;  ///< [m] eliminate_free's limit on the obstacle's step
  /// The obstacle's step @p ds was cut to kMaxFreeStep: no Newton step, and the nodes it would reach
  /// are not where predicted penalties would put them (a cube pushed with 60 N from a touch crawled
  /// 1 mm an iteration, its predicted nodes pulling at the wall, and lost its direction).
  static bool free_step_cut(double ds) { return std::abs(ds) >= (1 - 1e-9) * kMaxFreeStep; }

  /// Newton's direction at @p xs (newton_direction), on the last factorisation when a chord step
  /// is due (chord_next, @p in_tail: the residual within kRelagResidual × the tolerance).
  bool step_direction(const VectorXd& xs, const std::vector<Eigen::Matrix3d>& B, SparseMatrix& K, const VectorXd& r,
                      double rs, bool in_tail, VectorXd& delta, double& ds);
  /// The Newton step (@p delta, and @p ds along free_dir when the obstacle is free) from the
  /// tangent @p K and the residuals @p r, @p rs.
  bool newton_direction(const VectorXd& xs, const std::vector<Eigen::Matrix3d>& B, SparseMatrix& K, const VectorXd& r,
                        double rs, VectorXd& delta, double& ds);

  /// Free nodes (not in @p st's contact, not yet @p added) that the step @p d (with the obstacle's
  /// @p ds along free_dir when it is free) takes more than predict_contact_m through the wall, where
  /// the gap linearised at the node foresees it; their gap where they are in @p here.
  std::vector<char> nodes_through_wall(const VectorXd& xs, const std::vector<NodeContact>& st, const VectorXd& d,
                                       double ds, const std::vector<char>& added, std::vector<Gap>& here) const;
  /// One added penalty's column u of K' = K + U Uᵀ: its (up to three) reduced rows and values.
  struct PenaltyColumn {
    std::array<int, 3> row{-1, -1, -1};
    Vec3 value = Vec3::Zero();
  };
  /// The predicted contacts' step (@p d, and @p d_s when the obstacle is free) from their columns
  /// @p U through the factorisation: (K + U Uᵀ) d = @p r2, the free obstacle's border column from
  /// @p B_all (the blocks with every added penalty) and its balance @p rs2. False when not finite,
  /// nothing holds the obstacle, or its step is cut (free_step_cut).
  bool low_rank_step_with(const std::vector<PenaltyColumn>& U, const VectorXd& r2,
                          const std::vector<Eigen::Matrix3d>& B_all, double rs2, VectorXd& d, double& d_s);
  /// @p d = (K + U Uᵀ)⁻¹ @p r2 (one column per right-hand side) through llt's factorisation of K
  /// (Woodbury); false when not finite.
  bool solve_low_rank(const std::vector<PenaltyColumn>& U, const Eigen::MatrixXd& r2, Eigen::MatrixXd& d);
  /// The step @p delta solved again with the penalty of each free node it takes through the wall
  /// (ContactOptions::predict_contact_m) added, linearised where the node is; false when none is, or
  /// the step found is no descent direction of Π. Nonlinear body; the obstacle's position given, or
  /// free along free_dir (the standing push, a refit's one solve: the added penalties then join its
  /// border column and its balance too).
  bool predict_contacts(const VectorXd& xs, const std::vector<NodeContact>& st, const std::vector<Eigen::Matrix3d>& B,
                        SparseMatrix& K, const VectorXd& r, double rs, VectorXd& delta, double& ds);
  int predict_paused = 0;       // committed steps left without predicted contacts (after a failed solve)
  bool low_rank_step = false;   // this Newton step was solved through Woodbury (predict_contacts)
  bool llt_of_tangent = false;  // llt holds the factorisation of the exact tangent (solve_nonlinear)

  /// Newton on the equilibrium at translation t with the friction lag fixed (tissue::run_newton
  /// with its half, Newton, in contact_newton.cpp); updates xs (and t when the obstacle is free
  /// along free_dir). @p at_kink: accepted short of the tolerance at a kink of the wall.
  class Newton;
  std::string newton_message;  // how the last Newton solve ended (one line)
  bool newton(VectorXd& xs, Vec3& t, std::vector<NodeContact>& st, std::vector<Vec3>& th, int& iterations,
              double& rn, bool& at_kink);

  /// Predictor: @p xs (the last solution) becomes the extrapolation of the last converged increment
  /// along the obstacle's path to @p t (donning moves the socket in equal steps and the tissue
  /// follows smoothly) when that lowers the potential.
  void predict_start(const Vec3& t, VectorXd& xs);

  ContactStep solve(const Vec3& t_start, bool commit);

  /// Makes the last converged solve (x, state at last_t) the converged step: the friction
  /// history, the lag and the predictor's states move on to it.
  void commit_last();

  /// Starts the next solve at translation t from @p guess instead of the last solution when its
  /// potential there is lower (same friction lag as solve() starts with). @return whether it was.
  bool warm_start(const VectorXd& guess, const Vec3& t);

  /// push_with_force in one solve: the obstacle's position along @p d one more unknown, its
  /// equilibrium under @p force_n, Newton starting @p start_m along @p d; true (the step committed
  /// in @p out) when it converged, else the obstacle back where it was.
  bool push_free(const Vec3& d, double force_n, double rel_tol, ContactStep& out, double start_m = 0.0);

  /// push_with_force's bracket of the obstacle's position along its direction d from base: below
  /// the force at s_lo, above it at s_hi (the reactions r_lo, r_hi, the solutions x_lo, x_hi).
  struct PushBracket {
    double s_lo = 0, r_lo = 0, s_hi = 0, r_hi = 0;
    VectorXd x_lo, x_hi;
  };
  /// Brackets @p force_n: backs the obstacle off from @p base when it already carries more, else
  /// marches forwards, committing the steps that stay below it.
  PushBracket bracket_push(const Vec3& base, const Vec3& d, double force_n, double max_step_m, double first_step_m);
  /// Regula falsi on the reaction inside bracket @p b until it is @p force_n within @p rel_tol;
  /// the solve that reaches it is committed.
  ContactStep refine_push(const Vec3& base, const Vec3& d, double force_n, double rel_tol, PushBracket b);

  /// solve(t), and when it fails, path continuation: reach t through 2, 4, … 64 equal sub-steps
  /// from the last converged translation (a stick–slip switch or a new contact front can be too
  /// much for one Newton solve). Sub-steps are committed only when @p commit.
  ContactStep solve_path(const Vec3& t, bool commit);
};

}  // namespace socketsmith::contact
