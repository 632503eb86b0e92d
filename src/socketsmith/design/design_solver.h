#pragma once
/// @file design_solver.h
/// The design solve of the inverse socket design (thesis ch. 5, docs/method.md §3): pressures from
/// the spots, saturated at the pain thresholds and removed above the brim, become nodal forces
/// on the stump's skin; the static equilibrium of the tissue model's stump (bones and cut fixed)
/// under them is the socket's inner surface; the seven radar values say whether that pressure
/// field carries a standing patient.
///
/// Radar values, in the limb frame (x = anterior, y = medial, z = the limb axis, proximal):
///   F   = Σ_i p_i A_i (−n_i) + ẑ Σ_i μ p_i A_i cos θ_i     (eq. 42; the friction term only in z)
///   T   = Σ_i (P_i − C_I) × p_i A_i (−n_i)                   (eqs. 43–44, normal forces)
///   S   = Σ_i μ p_i A_i cos θ_i                               (eqs. 46–47, available friction)
/// with P_i, n_i, A_i the deformed position, outward normal and nodal area of skin node i,
/// cos θ_i = sqrt(1 − (n_i·ẑ)²) (θ_i: angle between the vertical and the surface tangent), and
/// C_I the stump's centre of inertia (mass-weighted mean of the deformed nodes).
/// Targets: F = (0, 0, M g / 2), T = 0, S ≥ m_prosthesis g. Tolerances: forces within
/// `force_tolerance` (1 %) of M g / 2, torques within `torque_tolerance` (1 %) of M g / 2 × the
/// stump length.
///
/// The pressure is a follower load: forces use the deformed normals and areas. The nonlinear
/// stump solves for it directly (tissue::FollowerPressure: Newton with the load's stiffness in the
/// tangent). The linearised stump fixes the forces at the current geometry, solves, recomputes the
/// geometry, and repeats until the nodal forces change by less than `follower_tolerance` (usually
/// 2–4 passes); when it oscillates or takes long, with Aitken relaxation. A state whose iteration
/// did not converge within its cap does not meet its constraints (ConstraintStatus::follower_converged).

#include <algorithm>
#include <cmath>
#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "socketsmith/design/spots.h"
#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/tissue/mass_spring_model.h"
#include "socketsmith/tissue/static_solver.h"
#include "socketsmith/volume/hex_mesher.h"

namespace socketsmith::design {

using Vec3 = Eigen::Vector3d;

/// Patient data that enter the constraints.
struct PatientLoad {
  double body_mass_kg = 70.0;        ///< M [kg], > 0
  double prosthesis_mass_kg = 2.0;   ///< [kg], ≥ 0 (thesis: ≈ 2 kg)
  double friction = 0.5;             ///< static friction coefficient μ skin–socket [-], ≥ 0
  double force_tolerance = 0.01;     ///< forces within this fraction of M g / 2
  double torque_tolerance = 0.01;    ///< torques within this fraction of M g / 2 × stump length
};

/// The seven radar values (frame components: x anterior, y medial, z axis).
struct RadarValues {
  Vec3 force_n = Vec3::Zero();
  Vec3 torque_nm = Vec3::Zero();
  double stability_n = 0.0;
};

/// Targets and tolerances of the radar values.
struct RadarTargets {
  double fz_n = 0.0;            ///< M g / 2
  double stability_min_n = 0.0; ///< m_prosthesis g
  double force_tol_n = 0.0;
  double torque_tol_nm = 0.0;
};

/// Which constraints hold.
struct ConstraintStatus {
  bool force_ok[3] = {false, false, false};
  bool torque_ok[3] = {false, false, false};
  bool stability_ok = false;
  bool comfort_ok = false;          ///< no node's requested pressure above its threshold
  /// The follower iteration converged: the shape is the equilibrium under its own forces. A
  /// state whose iteration stopped at its cap never counts as meeting its constraints.
  bool follower_converged = true;
  bool all_ok() const;
  std::string failing() const;      ///< "F_x, comfort, follower iteration" or "" when all hold
};

RadarTargets radar_targets(const PatientLoad& patient, double stump_length_m);

/// The friction a skin node offers along the limb's @p axis (unit) in the design's model: sliding
/// friction μ p A on the skin's tangent plane, its axial part μ p A |n × axis| [N] (@p normal the
/// outward unit normal). The radar's stability S is the sum over the nodes.
inline double axial_friction_n(double pressure_pa, double area_m2, const Vec3& normal, const Vec3& axis,
                               double friction) {
  const double nz = normal.dot(axis);
  return friction * pressure_pa * area_m2 * std::sqrt(std::max(0.0, 1.0 - nz * nz));
}

/// A skin node's part of the radar's F_z: its normal force along the axis plus axial_friction_n [N].
inline double axial_load_n(double pressure_pa, double area_m2, const Vec3& normal, const Vec3& axis, double friction) {
  return -pressure_pa * area_m2 * normal.dot(axis) + axial_friction_n(pressure_pa, area_m2, normal, axis, friction);
}

/// Radar values of pressures @p p [Pa] on skin nodes at deformed @p pos with outward unit
/// @p normal and nodal @p area, about @p centre. Pure function (the same formula a reader applies
/// to surface_nodes.csv).
RadarValues compute_radar(const std::vector<Vec3>& pos, const std::vector<Vec3>& normal,
                          const std::vector<double>& area, const std::vector<double>& p,
                          const geometry::LimbFrame& frame, const Vec3& centre, double friction);

ConstraintStatus check_constraints(const RadarValues& r, const RadarTargets& t, double max_requested_ratio);

/// The design state after a solve.
struct DesignState {
  tissue::VectorXd positions;              ///< deformed node positions (3N) [m]
  std::vector<double> requested_pa;        ///< the spots' field at each skin node, 0 above the brim [Pa]
  std::vector<double> pressure_pa;         ///< applied: requested saturated at the threshold [Pa]
  std::vector<Vec3> skin_positions;        ///< deformed skin node positions [m]
  std::vector<Vec3> skin_normals;          ///< deformed outward unit normals
  std::vector<double> skin_areas;          ///< deformed nodal areas [m²]
  std::vector<double> displacement_m;      ///< |u| per skin node [m]
  Vec3 centre_of_inertia = Vec3::Zero();   ///< [m], world frame
  RadarValues radar;
  ConstraintStatus status;
  double max_requested_ratio = 0.0;        ///< max requested / threshold (> 1: saturated)
  double max_applied_ratio = 0.0;          ///< max applied / threshold (≤ 1)
  int max_ratio_node = -1;                 ///< skin node of max_requested_ratio
  int saturated_nodes = 0;
  double max_displacement_m = 0.0;
  bool converged = false;
  bool linearised = false;                 ///< the shape comes from the linearised model
  std::string nonlinear_failure;           ///< why the nonlinear solve failed (Auto mode)
  int follower_passes = 0;                 ///< linear solves of the linearised stump (1 for a nonlinear solve)
  bool follower_capped = false;            ///< stopped at its pass cap before the tolerance (not met)
  double follower_change = 0.0;            ///< the last pass's relative force change
  int follower_relaxed_from = 0;           ///< relaxation started after this pass (0: plain iteration)
  int newton_iterations = 0;
  /// DesignSolver::preview: the last equilibrium moved by the tangent there, not an equilibrium
  /// of its own (the GUI shows it while a slider moves; the full solve follows on release).
  bool is_preview = false;
  double seconds = 0.0;
  std::string message;
};

/// How the stump's equilibrium is found.
enum class DesignSolveMode {
  Nonlinear,  ///< the tissue model's static equilibrium under the follower pressure (Newton, warm-started)
  Linear,     ///< its linearisation at rest: K₀ u = f with K₀ factorised once (updates in ms)
  Auto,       ///< nonlinear; once the lattice loses stability (no equilibrium), the linearised
              ///< model from then on, reported in DesignState::linearised and its message
};
std::string to_string(DesignSolveMode mode);
DesignSolveMode parse_design_solve_mode(const std::string& text);

struct DesignSolverOptions {
  /// Linear by default: on automatically meshed stumps the nonlinear MSS-CS lattice (any variant)
  /// loses stability at 10–30 kPa where thin tissue covers the tibia (docs/design.md), below the
  /// pressures a standing patient needs; its linearisation is stable, and factorised once it
  /// makes a design update a few back-substitutions.
  DesignSolveMode mode = DesignSolveMode::Linear;
  tissue::StaticSolverOptions solver;
  double follower_tolerance = 1e-3;  ///< linearised stump: max |Δf_i| / max |f_i| between passes
  int max_follower_passes = 8;       ///< linearised stump: plain passes (x = y), [1, 1000]
  int max_relaxed_passes = 32;       ///< linearised stump: then passes with Aitken relaxation, [0, 1000]; 0 = none
  /// preview(): the relative residual of the tangent step against the whole tangent (the
  /// follower load makes it non-symmetric; its symmetric part is what is factorised). 0.05: one
  /// back-substitution as a rule, the step's error first order in the change (≈ 2 % of it, measured
  /// on the demo); 1e-10: refined to the exact tangent step, error second order (≈ 0.2 % at +10 %),
  /// two to four more back-substitutions.
  double preview_tolerance = 0.05;
};

/// The stump under design: model, solver and skin geometry built once; each solve() warm-starts
/// from the previous equilibrium and reuses the factorisation.
class DesignSolver {
 public:
  /// @param thresholds_pa pain threshold per skin node (extract_skin_surface(mesh) order) [Pa].
  DesignSolver(const volume::HexMesh& mesh, const tissue::TissueMaterial& material,
               const tissue::MassSpringOptions& model_options, const geometry::LimbFrame& frame,
               std::vector<double> thresholds_pa, const PatientLoad& patient, double stump_length_m,
               const DesignSolverOptions& options = {});
  ~DesignSolver();
  DesignSolver(const DesignSolver&) = delete;
  DesignSolver& operator=(const DesignSolver&) = delete;

  const volume::SkinSurface& skin() const;
  /// Rest cylindrical coordinates of the skin nodes (where the spots are evaluated).
  const std::vector<geometry::Cylindrical>& skin_cylindrical() const;
  const std::vector<double>& thresholds() const;
  const geometry::LimbFrame& frame() const;
  const PatientLoad& patient() const;
  const RadarTargets& targets() const;
  const tissue::MassSpringModel& model() const;
  const DesignSolverOptions& options() const;
  double stump_length_m() const;

  /// Marks skin nodes above the brim (above_brim_of): no pressure there; below it, within the
  /// flare (set_brim_flare, before), the spots' field eases in (brim_weight).
  void set_brim(const std::function<double(double theta)>& brim_height_m);
  /// A flared brim [m], ≥ 0: the spots' field is applied in full from this far below the brim and
  /// eases to nothing at the brim (smoothstep), as a flared trim line presses nothing at its edge.
  /// 0 (the default): the field up to the brim. Takes effect at the next set_brim.
  void set_brim_flare(double flare_m);
  /// A band below the brim that presses nothing, its depth per angle [m] (≥ 0; empty: none): the
  /// flare eases in from the band's lower edge instead of from the brim. The closed loop's drag
  /// band (pipeline::solve_design): skin the donning drags out of the socket can carry no pressure.
  /// Takes effect at the next set_brim.
  void set_brim_band(std::function<double(double theta)> depth_m);
  /// Per skin node: the share of the spots' field applied — 0 above the brim, 1 from the flare's
  /// depth below it (everywhere below it without a flare).
  const std::vector<double>& brim_weight() const;
  /// Which skin nodes lie above @p brim_height_m (h > brim(θ), rest coordinates), without setting
  /// it: the test set_brim applies, for a caller on another thread than the solves (the GUI).
  std::vector<char> above_brim_of(const std::function<double(double theta)>& brim_height_m) const;
  const std::vector<char>& above_brim() const;

  /// The spots' field at the skin nodes (rest coordinates), 0 above the brim, not saturated [Pa].
  std::vector<double> requested_pressure(const std::vector<Spot>& spots) const;

  /// Static equilibrium under the spots (warm start from the last equilibrium).
  /// @throws SolverError when the equilibrium cannot be found (the stump's message says why).
  DesignState solve(const std::vector<Spot>& spots);

  /// A quick answer while the spots are being dragged: the last equilibrium x* (pressures p*)
  /// moved by the stump's tangent there, x = x* + K_T(x*)⁻¹ (f(p) − f(p*)), the forces taken on
  /// the skin of x* and K_T the internal forces' and the follower load's tangent (symmetrised),
  /// factorised once per equilibrium (prepare_preview, or the first preview after a solve). One
  /// back-substitution: tens of ms at 20k nodes where a nonlinear solve takes seconds. The
  /// state is flagged is_preview; the warm start stays at x*. In Linear mode (or after the Auto
  /// fallback), and before any nonlinear solve, it is solve() itself.
  /// @throws SolverError as solve() does.
  DesignState preview(const std::vector<Spot>& spots);
  /// Factorises the tangent at the last equilibrium for preview() (the GUI's worker calls it when
  /// idle, so the first frame of a drag does not pay for it). Nothing to do in Linear mode.
  void prepare_preview();
  /// Skin geometry (positions, outward normals, nodal areas) at node positions @p x (3N).
  void skin_geometry(const tissue::VectorXd& x, std::vector<Vec3>& pos, std::vector<Vec3>& normal,
                     std::vector<double>& area) const;

  /// Normal displacement of every skin node (along the outward normal, [m]) when pressures
  /// @p pressure_pa [Pa, one per skin node] push on the skin with the nodal areas and normals of
  /// @p state, on the stump linearised at rest (K₀, factorised once and shared with the linear
  /// design solve). A pressure pushes inwards, so a positive pressure gives negative values. This
  /// is the stump's compliance seen from its skin: the closed-loop design moves a socket wall by
  /// it to take away a pressure the wall delivers in excess.
  /// @throws InvalidInputError for a field of the wrong size or with non-finite values.
  std::vector<double> normal_displacement(const std::vector<double>& pressure_pa, const DesignState& state);

  /// Forgets the warm start (next solve starts from rest).
  void reset();

  /// After a failed solve: the rest position of the centre of the element that collapsed or was
  /// closest to inversion (the stall diagnosis's worst element) [m]; NaN when none is known.
  Vec3 last_failure_point() const;

 private:
  /// The spots' field at the skin, saturated at the thresholds, with its ratios, into @p st.
  void applied_pressure(const std::vector<Spot>& spots, DesignState& st) const;
  /// Skin geometry, displacements, centre of inertia, radar, constraints and timing of @p st at @p x.
  void finish_state(DesignState& st, const tissue::VectorXd& x, std::chrono::steady_clock::time_point t0) const;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace socketsmith::design
