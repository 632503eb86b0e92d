#pragma once
/// @file donning.h
/// The donning simulation (thesis ch. 3.5 and 5.4, docs/method.md §2): the designed socket starts
/// below the stump along the limb axis and slides up onto it in displacement steps, with Coulomb
/// friction between skin and socket and the bones held; optionally the patient then stands (the
/// socket is pushed until its axial reaction equals half the body weight). The contact pressure at
/// the end is compared with the pressure the design asked for: if the design is right, the socket
/// reproduces it.

#include <memory>
#include <string>
#include <vector>

#include "socketsmith/contact/contact_solver.h"
#include "socketsmith/core/progress.h"
#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/volume/hex_mesh.h"
#include "socketsmith/volume/hex_mesher.h"

namespace socketsmith::contact {

struct DonningOptions {
  /// The socket starts this far distal of its designed pose [m]; 0 = automatic: its top 5 mm
  /// below the stump's distal end (nothing touches at the start).
  double start_offset_m = 0.0;
  /// How the user sets start_offset_m, named in the messages that ask for another one
  /// (simulate donning: "--offset-mm"; validate donning: "--travel-mm"); empty where the user has
  /// no such setting (the closed-loop design): the messages then name no flag.
  std::string start_offset_name = "--offset-mm";
  /// > 0: this many equal displacement steps to the designed pose. 0 (default): adaptive steps of
  /// at most step_m, halved (down to min_step_m) when a node that was sliding, or not touching,
  /// sticks at the end of a trial step — the path is then refined where friction's history needs
  /// it (the distal end, where the socket's bottom drags the skin along) and long elsewhere.
  int steps = 0;
  /// The longest step [m], > 0. 6 mm, refined near the end: the nodal pressures of the 7.5k demo,
  /// the 1.8k demo and the OpenLimb limb are within 40 Pa on average and 1–2 % of the peak at most
  /// of a 1 mm path's (docs/contact.md, "Speed").
  double step_m = 0.006;
  double min_step_m = 0.002;  ///< the shortest adaptive step [m], > 0 (at most step_m: a longer one is step_m)
  double friction = 0.5;         ///< Coulomb μ skin–socket
  /// > 0: after donning, push the socket along the axis until its axial reaction is this force [N]
  /// (half the body weight for a standing patient); 0: stop at the designed pose.
  double stand_force_n = 0.0;
  double socket_density_kg_m3 = 1250.0;
  /// The standing push's first step predicted from the reaction's slope over the last donning step
  /// (false: one full step, which overshoots the load).
  bool predict_stand_step = true;
  /// A path that stalls at its shortest step (the brim meeting a bulge such as a prominent tibial
  /// tuberosity head-on) is guided around it: the socket sidesteps across the axis, in the direction
  /// the skin pushes it, by 2 mm (else 4 mm) from where it is, up to this much in all [m], and goes on from
  /// there on a straight line back to the axis at the designed pose (a prosthetist guides the socket
  /// on the same way). 0: the socket moves along the axis only and such a path stalls.
  double max_sidestep_m = 0.006;
  /// The Newton iterations a run() or a refit() may spend in all (every solve: the rejected trial
  /// steps, the refinements and the standing push included); 0: no limit. A path that grinds —
  /// the contact set flipping among a few nodes while Newton runs to its limit step after step —
  /// then ends as a stalled one (completed = false, a message naming where), not after minutes.
  /// Measured: the 8k transtibial closed loop's donnings spend 54–56; transfemoral ones at 3k
  /// 170–430, and 2,416 on the generated limb of seed 10 (a long path, refined at every other step:
  /// 178 s) — where a limit of 2,000 failed its design; a grinding donning (before
  /// ContactOptions::residual_floor_ratio) 5,200. The closed loop limits a corrected socket's
  /// donning further (ClosedLoopOptions::check_newton_ratio).
  int max_newton_iterations = 6000;
  /// Contact against the smoothed inner wall (RigidSocket::set_smooth_wall), fitted to the facets
  /// at the skin nodes' footprints (RigidSocket::fit_smooth_wall_to), instead of the facets: nodes
  /// sliding along the wall do not cross its kinks and meet it where they would meet the facets
  /// (docs/contact.md).
  bool smooth_wall = true;
  /// Penalty, tolerances (its friction is set from `friction`). The penalty factor is 20 here
  /// (15 kPa penetrates ~45 µm at E = 100 kPa, h = 6 mm): against a faceted socket wall, a stiffer
  /// penalty made Newton 2–3× slower for the same pressures (docs/contact.md). Every Newton
  /// iteration factorises (max_reuse_cg = 0): CG on the last factorisation saved factorisations
  /// but cost more in triangular solves (7.5k nodes: 4,034 CG iterations saved 142 of 390
  /// factorisations for 10 % more CPU).
  ///
  /// The stick is 5× softer than the normal penalty (stick_stiffness_ratio 0.2: ≈ 75 µm of elastic
  /// slip at 10 kPa, the order of Abaqus's default 0.5 % of the element length): with the penalty's
  /// stiffness Newton crawled where the brim drags the skin and nodes switch from slip to stick
  /// (7.5k nodes, 2 mm steps: 144 instead of 177 factorisations, pressures within 8 Pa on average
  /// of the stiff stick's). Softer still (0.1, 0.05) was cheaper again but did not give the same
  /// state along two Newton paths (test Donning.the_fast_newton_path_…): a few sticking nodes at the
  /// distal end differed by 7.5 kPa.
  ///
  /// Tolerances: ‖r‖ ≤ 1e-4 of the contact forces' sum (≈ 0.06 N at 8k nodes), the friction lag
  /// refreshed until the normal forces move by less than 3 % of the largest. Against 1e-5 and 1 %
  /// the 8k closed loop took 151 instead of 207 factorisations (182 Newton steps, 31 of them chord
  /// steps: ContactOptions::chord_ratio), the open-loop donning's pressures within 5 Pa on average
  /// and 0.27 kPa at most; against a 1 mm path the 7.5k donning differs by 48 / 869 Pa (mean /
  /// largest) where it differed by 47 / 839 Pa (docs/contact.md, "Speed").
  ContactOptions contact = [] {
    ContactOptions c;
    c.penalty_factor = 20.0;
    c.max_reuse_cg = 0;
    c.stick_stiffness_ratio = 0.2;
    c.rel_tol = 1e-4;
    c.friction_lag_tol = 0.03;
    return c;
  }();
  /// The skin (the skin_nodes' surface, same order) whose deformed nodal areas turn each node's
  /// normal force into its contact pressure in the results: force per deformed area, the Cauchy
  /// pressure the design prescribes as a follower load (tissue::FollowerPressure) and CalculiX's
  /// nodal-force pressure measures. Without it (nullptr) the pressure is per rest area, which reads
  /// 5 % low where the donned skin is compressed under the brim and 2 % high where it is stretched
  /// at the distal end (docs/contact.md, "Pressure per deformed area"; the pipeline's donnings and
  /// the closed loop do not set it yet: with it the loop's own bar regressed, measured there).
  /// Must outlive the donning.
  const volume::SkinSurface* skin = nullptr;
  ProgressCallback progress;
};

/// ContactOptions::augmented_tol for a wall the skin does not penetrate (case key
/// design.closed_loop_rigid_wall, `simulate donning --rigid-wall`): passes until the penalty part
/// of every normal force is ≤ 2 % of the largest.
inline constexpr double kRigidWallAugmentedTol = 0.02;

/// One point of the donning path.
struct DonningSample {
  double offset_m = 0.0;          ///< socket position along the axis relative to the designed pose (< 0: below)
  double axial_force_n = 0.0;     ///< force of the stump on the socket along −axis (what holds the socket)
  double lateral_force_n = 0.0;   ///< its component across the axis
  /// The part of axial_force_n that friction carries (Σ of the friction forces on the nodes along
  /// the axis) [N]; the rest is the normal pressures'. The design assumes μ Σ p A cos θ (eq. 42).
  double axial_friction_n = 0.0;
  int contact_nodes = 0;
  int sliding_nodes = 0;
  double max_pressure_pa = 0.0;
  double mean_pressure_pa = 0.0;  ///< over the nodes in contact
  double max_penetration_m = 0.0;
  int newton_iterations = 0;
  int friction_passes = 0;        ///< Newton solves with an updated friction lag in this step
  long factorizations = 0;        ///< tangent factorisations since the start of the path
  double seconds = 0.0;
};

struct DonningResult {
  bool completed = false;              ///< every step converged (the socket reached its designed pose)
  bool stood = false;                  ///< the standing load was reached (when asked)
  std::string message;                 ///< why it stopped early / why standing failed; "" when all went well
  std::vector<DonningSample> series;   ///< one per converged step (and one for the standing load)
  std::vector<int> nodes;              ///< the candidate (skin) nodes
  std::vector<NodeContact> contacts;   ///< their contact state at the end
  tissue::VectorXd positions;          ///< node positions at the end (3N) [m]
  double start_offset_m = 0.0;         ///< where the path started (below the designed pose) [m]
  int steps = 0;                       ///< displacement steps taken (committed)
  double final_offset_m = 0.0;
  Vec3 force_on_socket_n = Vec3::Zero();
  double socket_mass_kg = 0.0;
  int newton_iterations = 0;
  /// Every Newton iteration of this run or refit, those of rejected steps and failed solves too
  /// (what DonningOptions::max_newton_iterations limits).
  long newton_spent = 0;
  double seconds = 0.0;
  int rejected_steps = 0;  ///< adaptive trial steps refined because a node started sticking in them
  /// The largest sidestep of the socket across the axis on the way (DonningOptions::max_sidestep_m)
  /// [m]; 0: the path stayed on the axis.
  double max_sidestep_m = 0.0;
};

/// The socket @p solid (closed, [m], at its designed pose) as the donning dons it: a RigidSocket of
/// options.socket_density_kg_m3 whose contact wall, with options.smooth_wall, is the smoothed wall
/// fitted to the skin @p skin_at_rest (the skin nodes' rest positions). The CalculiX check lays its
/// shell on this same wall (pipeline/validation_inputs.cpp).
RigidSocket donning_socket(const geometry::TriMesh& solid, const geometry::LimbFrame& frame,
                           std::vector<Vec3> skin_at_rest, const DonningOptions& options = {});

/// Simulates donning @p socket_solid (closed, [m], at its designed pose) onto the stump @p mesh
/// (nodes tagged kNodeFixed are held) whose candidate nodes are the skin nodes @p skin_nodes with
/// rest nodal areas @p skin_areas. The body is the linearised MSS model of @p model (K₀).
/// A step that does not converge ends the path: the result then holds the converged part,
/// completed = false and a message naming the offset where it stalled and the fix (more steps).
/// A standing load that cannot be reached leaves the donned state with stood = false.
/// @throws InvalidInputError for bad options, a socket that does not surround the axis or one
///         that grips the stump already at the start.
DonningResult simulate_donning(const tissue::MassSpringModel& model, const std::vector<int>& skin_nodes,
                               const std::vector<double>& skin_areas, const geometry::TriMesh& socket_solid,
                               const geometry::LimbFrame& frame, const DonningOptions& options = {});

/// A donning that can go on after its run: run() dons and stands (simulate_donning is a
/// DonningSimulation's run()); refit() then replaces the socket while it is worn and finds the new
/// equilibrium from the worn state, the skin's friction history kept, and the standing load again
/// — what a small correction of the socket's wall does, at a fraction of a donning's cost (the
/// closed-loop design's inner iterations; its answer is checked by a full donning).
/// The model must outlive the simulation.
class DonningSimulation {
 public:
  /// @throws as simulate_donning.
  DonningSimulation(const tissue::MassSpringModel& model, const std::vector<int>& skin_nodes,
                    const std::vector<double>& skin_areas, const geometry::TriMesh& socket_solid,
                    const geometry::LimbFrame& frame, const DonningOptions& options = {});
  ~DonningSimulation();
  DonningSimulation(const DonningSimulation&) = delete;
  DonningSimulation& operator=(const DonningSimulation&) = delete;

  /// The donning path and the standing load, once. @throws InvalidInputError when called twice.
  DonningResult run();
  /// Replaces the worn socket by @p socket_solid (same frame) and finds its equilibrium from the
  /// worn state: when the run stood, the new wall and the standing load in one solve (the socket
  /// free along the axis, ContactOptions::free_push), else — or when that fails — where the socket
  /// stood, then pushed to the standing load again. The result's series holds the refit's steps
  /// only; completed = false (with a message) when no equilibrium was found, and the simulation
  /// cannot be refitted again.
  /// @throws InvalidInputError when run() did not complete; as RigidSocket for a bad solid.
  DonningResult refit(const geometry::TriMesh& socket_solid);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace socketsmith::contact
