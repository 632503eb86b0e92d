#pragma once
/// @file closed_loop.h
/// Closed-loop socket design: the socket that would be printed is donned and stood on (the
/// contact simulation with friction and half the body weight), and its wall is corrected until
/// the pressures it delivers are the pressures the design asked for.
///
/// The open-loop design (thesis ch. 5) takes the stump deformed by the designed pressures as the
/// socket's inner wall. Donning drags the skin along the wall (friction's history), standing
/// pushes the socket further up, and the socket's rim and smoothing differ from the skin: the
/// delivered pressures then differ from the design (on the demo, below the brim: R 0.77, MAE
/// 1.8 kPa, the distal end at half its designed pressure). The loop measures that difference and
/// removes it:
///
///   δ ← δ − ω u_n(S (p_delivered − p_target))
///
/// δ_i is the wall's offset along the designed skin normal at skin node i (outward positive),
/// u_n(e) the normal displacement of the skin under the pressure field e on the stump linearised
/// at rest (DesignSolver::normal_displacement, one back-substitution of the factorised K₀), ω the
/// relaxation and S a smoothing of the excess over the skin (ClosedLoopOptions::smoothing_passes).
/// For a frictionless, linear stump whose skin follows the wall this is the exact
/// correction (the stump under p_target differs from the stump under p_delivered by u(p_target −
/// p_delivered)); friction, standing and the body's nonlinearity are what the next donning
/// measures. Donning drags the skin along the wall by about a node spacing (5–7 mm on the demo),
/// so node i presses the wall where it ended up, not at its own vertex: each correction is moved
/// onto the wall vertices near the node's donned position before it is applied. Each iteration
/// builds the socket from the corrected wall and dons it from scratch, so the socket written is
/// the one whose delivered pressures are reported.

#include <filesystem>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "socketsmith/contact/donning.h"
#include "socketsmith/core/progress.h"
#include "socketsmith/design/socket_builder.h"
#include "socketsmith/report/delivery_bar.h"
#include "socketsmith/report/design_report.h"
#include "socketsmith/report/field_comparison.h"

namespace socketsmith::design {
class DesignSolver;
}  // namespace socketsmith::design

namespace socketsmith::pipeline {

struct DesignSetup;
struct DesignResult;

/// Settings of the closed loop.
struct ClosedLoopOptions {
  /// Donnings from scratch at most, the open-loop socket's included, in [1, 20]. 1 measures the
  /// open-loop socket only (no correction).
  int max_donnings = 3;
  /// Corrections between two donnings from scratch, each tried by a refit (the worn socket's wall
  /// replaced, contact and standing solved again from the worn state, friction history kept:
  /// contact::DonningSimulation::refit), in [0, 20]. A refit within the tolerances, or the last of
  /// a round, is checked by a donning from scratch. (Correcting a refit's pressures by how the last
  /// full donning differed from the refit of the same socket made the demo overshoot: the
  /// difference is not stable from one socket to the next.) 0: every correction is donned from
  /// scratch. Six: a refit costs a sixth of a donning (its wall and standing in one solve), so the
  /// demo's loop refits until a refit meets the tolerances and checks it with one donning (8k:
  /// 2 donnings + 5 refits, where three refits a round needed 3 donnings + 6 refits).
  int refits_per_donning = 6;
  double relaxation = 1.0;        ///< ω, the share of the computed correction applied, in (0, 1.5]
  /// Past iterates that Anderson acceleration combines (since the last donning from scratch), in
  /// [0, 10]; 0: the plain iteration δ ← δ + correction.
  int anderson_depth = 3;
  /// Stop once a socket donned from scratch delivers its design below the brim with an MAE of at
  /// most this [Pa], > 0, and a 99th percentile of at most p99_tolerance_pa. Issue 20's bar for a
  /// donned and stood socket is MAE ≤ 1.5 kPa and p99 ≤ 4 kPa; the MAE is asked three times
  /// tighter. (0.3 / 1.5 kPa before: the node-scale 99th percentile never came under 2.8 kPa, so the
  /// loop always ran all its donnings — at 8k nodes the fourth donning and its refits gained
  /// nothing on the third.)
  double mae_tolerance_pa = 500.0;
  double p99_tolerance_pa = 4000.0;  ///< [Pa], > 0
  /// ... and every landmark's deviation from its design (ClosedLoopIteration::landmark_deviation)
  /// at most this, > 0 (∞: the landmarks do not stop the loop). Issue 20's bar (report::DeliveryBar).
  /// A stopping rule, not a term of the loop's score (see landmark_deviation): with the MAE and
  /// p99 alone, seed 3 of the generated limbs stopped at donning 2 with the anterior distal tibia
  /// 0.013 of its threshold under its design (bar 0.01); asked for the landmarks too it went on and
  /// its third donning met them (docs/design.md, "Closed loop"). The socket kept is one that meets
  /// every tolerance if any does, else one that meets the delivery bar (ClosedLoopIteration::bar_met),
  /// else the one closest to the MAE and p99 tolerances.
  double landmark_tolerance = 0.10;
  /// ... and every thesis path below the brim within the delivery bar's MAE and p99
  /// (ClosedLoopIteration::path_score ≤ 1); false: the paths do not stop the loop.
  bool paths_within_bar = true;
  /// Passes of area-weighted averaging over each skin node's neighbours applied to the excess
  /// pressure before it becomes a correction, in [0, 50]. 0 by default: the corrections are moved
  /// to where each node touches the wall (see close_design_loop), and that alone keeps
  /// neighbouring corrections consistent; smoothing also removed the node-scale peaks the loop
  /// should correct (demo, 3k nodes: 2 passes stalled at MAE 0.96 kPa, none reached 0.62).
  int smoothing_passes = 0;
  /// Largest wall correction |δ| [m], > 0: a correction that would move the wall further is
  /// clamped (the loop corrects a design, it does not redesign it).
  double max_offset_m = 0.005;
  /// Largest node-scale part of the wall correction [m] (δ minus the mean of its neighbours',
  /// pipeline::node_scale_part), ≥ 0: after each correction a node further from its neighbours'
  /// mean is moved to this distance from it. 0 (no cap) by default: on the AAOP example at 3k, whose
  /// wall grows rough, 0.2 mm gives CalculiX MAE 1.28 / p99 5.40 kPa and the uncapped socket 1.35 /
  /// 5.65 with CalculiX's increments halved (1.92 / 13.16 with 5 %: its increment path), while
  /// socketsmith's own goes from 0.80 / 4.00 to 0.91 / 6.02; on the 8k demo it gained nothing in
  /// CalculiX (p99 2.79 → 3.00; docs/design.md, "Limits").
  double max_roughness_m = 0.0;
  /// How far the socket's brim may rise above the design's [m], ≥ 0 (0: never). Where donning and
  /// standing drag skin nodes designed below the brim above the socket's brim, only its lip still
  /// presses them (from nothing to most of their designed pressure), and no wall correction reaches
  /// them; the next socket's brim rises there by how far they ended above it plus half a node spacing
  /// (design::raise_brim: over ±10° around each, easing to nothing over another 10°), at most by
  /// this and never closer than a node spacing to the skin's top. The design, its compared nodes and
  /// their targets stay the design's: the band added holds the skin that donning brings up into it.
  /// 0 by default: on 12 limbs (docs/design.md, "Nodes dragged out of the socket") 10 mm took every
  /// 99th percentile under 2.8 kPa and R over 0.99 but left the anterior distal tibia 0.013–0.024 of
  /// its threshold short on five (the bar: 0.01), and the band presses up to 12 kPa where the
  /// design presses nothing.
  double max_brim_raise_m = 0.0;
  /// A corrected socket differs from the open-loop one by millimetres, and its donning needs about
  /// as many Newton iterations (8k transtibial: 56 then 54; OpenLimbTF 3k: 233 then 431, 8k: 211
  /// then 172). A donning (or refit) of a corrected socket may spend check_newton_ratio × the
  /// open-loop donning's, at least check_newton_min (and never more than donning's own limit): one
  /// that grinds (OpenLimbTF 3k before ContactOptions::residual_floor_ratio: 5,200 iterations, 6 of
  /// the run's 8 minutes) then ends as a stalled donning and the loop keeps its best socket so far.
  double check_newton_ratio = 4.0;  ///< > 0
  int check_newton_min = 300;       ///< ≥ 0
  /// The donning: start, steps, penalty, smooth wall. Its friction and standing force are set
  /// from the case's patient (μ, M g / 2) unless `keep_donning_loads` is true.
  contact::DonningOptions donning;
  bool keep_donning_loads = false;
  /// The donned stump is the design's: linearised at rest for a linear design solve, the nonlinear
  /// tissue model for a nonlinear one (so that a frictionless donning gives back the designed
  /// state). false: `donning.contact.linear_body` as given.
  bool body_follows_design = true;
  ProgressCallback progress;
};

/// One donning of the loop.
struct ClosedLoopIteration {
  bool refit = false;              ///< a refit of the worn socket, else a donning from scratch
  report::ErrorStats below_brim;   ///< delivered (a) vs target (b), skin nodes below the brim [Pa]
  /// Skin nodes below the brim that donning and standing left above the socket's brim (friction drags the skin
  /// proximally: 3–9 mm on generated limbs at μ 0.5): only the brim's lip, which the corrections do
  /// not shape, still presses them (from nothing to most of their designed pressure).
  int dragged_out = 0;
  double dragged_out_max_target_pa = 0.0;  ///< the largest designed pressure among them [Pa]
  double dragged_out_height_m = 0.0;       ///< how far above the brim the highest of them ended [m]
  /// The shortest arc of the limb frame holding them, from `from` to `to` through increasing θ, in
  /// degrees [0, 360) from anterior towards medial (to < from when it passes anterior) [deg]: where
  /// a higher brim would keep them in.
  double dragged_out_from_deg = 0.0, dragged_out_to_deg = 0.0;
  report::ErrorStats in_socket;    ///< as below_brim, over the nodes below the brim still in the socket [Pa]
  /// How far the donned socket's brim lies above the design's, at most over the angles [m] (0: the
  /// design's brim; ClosedLoopOptions::max_brim_raise_m). The dragged-out nodes are those above it.
  double brim_raise_m = 0.0;
  /// The landmark furthest from its design: |delivered − designed| pressure / threshold of its zone
  /// over max(designed, 0.1) (issue 20's bar: ≤ 0.1), and its code ("" without zones). A stopping
  /// rule of the loop (ClosedLoopOptions::landmark_tolerance), not a term of its score: at 3k nodes
  /// a landmark's zone holds 2–7 nodes, and a donning from
  /// scratch moves it by what refits cannot see (generated transfemoral limb, seed 2: refits took the
  /// distal femur from 39 % to 9 %, the next donning put it back at 49 %; transtibial seed 3 with the
  /// deviation in the loop's score, 2026-12-01: refits 3 %, the next donning 12 %, its refit 16 %,
  /// and the loop stopped with the socket it keeps without it). report::judge_delivery judges it;
  /// of the sockets that miss the delivery bar, it counts in which one is kept (bar_score).
  double landmark_deviation = 0.0;
  std::string landmark_furthest;
  /// The thesis path below the brim furthest from the delivery bar's MAE and p99
  /// (report::DeliveryBar): max(MAE / 1.5 kPa, p99 / 4 kPa) over the paths (≤ 1: every path
  /// within), its label and its MAE and p99 [Pa]. A stopping rule of the loop, like the landmarks:
  /// a socket is not "converged" while a path misses the bar it is judged by (the back line of
  /// seed 5, 4.62 kPa at p99, had been).
  double path_score = 0.0;
  std::string path_furthest;
  double path_mae_pa = 0.0, path_p99_pa = 0.0;
  /// The whole delivery bar (report::judge_delivery: below the brim, each path, each landmark) met.
  /// Looser than the loop's tolerances on the MAE (1.5 against 0.5 kPa): of the sockets donned from
  /// scratch that miss the tolerances, the loop keeps one that meets the bar before a closer one
  /// that does not.
  bool bar_met = false;
  /// The delivery bar's MAE, p99 and R below the brim met (bar_met false: a landmark or a path missed it).
  bool bar_below_brim_met = false;
  double max_offset_m = 0.0;       ///< max |δ| of the socket donned [m]
  /// The wall's node-scale roughness below the brim: RMS and 99th percentile of δ minus the mean of
  /// its neighbours' (pipeline::wall_roughness) [m]. Refits that fit the wall to socketsmith's own
  /// sliding make it grow; CalculiX then parts from socketsmith (docs/design.md, "Limits").
  double wall_roughness_rms_m = 0.0, wall_roughness_p99_m = 0.0;
  /// The RMS over the standard deviation of δ below the brim: the node-scale part's share of the
  /// correction's spread (WallRoughness::share; 0 for the open-loop socket).
  double wall_roughness_share = 0.0;
  double mean_offset_m = 0.0;      ///< mean δ below the brim [m] (> 0: the wall moved outwards)
  double stood_offset_m = 0.0;     ///< where the socket stood, relative to its designed pose along the axis [m]
  double axial_friction_n = 0.0;   ///< the share of the standing load friction carried [N] (the design assumed μ Σ p A cos θ)
  /// axial_friction_n over μ Σ p A |n × axis| of the delivered pressures: the share of the friction
  /// the design counts on that donning and standing mobilise [-]
  double friction_utilisation = 1.0;
  int factorizations = 0;
  double donning_seconds = 0.0;    ///< the donning or the refit
  double socket_seconds = 0.0;     ///< building the socket solid
};

/// What the loop delivered.
struct ClosedLoopResult {
  bool converged = false;          ///< the tolerances were met
  std::string message;             ///< how it ended, one line
  std::vector<ClosedLoopIteration> iterations;  ///< donnings and refits in order; [0] is the open-loop socket
  /// The iteration whose socket is kept: of those donned from scratch, the one closest to the
  /// tolerances, the smallest max(MAE / mae_tolerance, p99 / p99_tolerance) below the brim.
  int best = 0;
  int kept_donning = 0;            ///< which donning from scratch that is (1: the open-loop socket's)
  /// Donnings from scratch that failed and were donned again on a path of half the steps (a stall
  /// where the brim passes a bulge moves with the path; each counts once in `iterations`).
  int retried_donnings = 0;
  std::vector<double> target_pa;   ///< designed pressure per skin node (0 above the brim) [Pa]
  bool linear_body = true;         ///< the donned stump was linearised at rest (else the nonlinear tissue model)
  std::vector<double> open_loop_pa;    ///< delivered by the open-loop socket [Pa]
  std::vector<double> closed_loop_pa;  ///< delivered by the kept socket [Pa]
  std::vector<double> wall_offset_m;   ///< δ of the kept socket per skin node [m]
  std::vector<char> dragged_out;       ///< per skin node: below the brim, dragged above it by the kept donning
  std::vector<char> ever_dragged_out;  ///< per skin node: below the brim, dragged above it by any donning or refit
  std::vector<char> below_brim;        ///< skin nodes compared (1: below the brim)
  std::vector<std::vector<double>> delivered_by_iteration;  ///< per donning, per skin node [Pa]
  std::vector<std::vector<double>> offset_by_iteration;     ///< per donning, δ per skin node [m]
  design::SocketResult socket;         ///< the kept socket
  design::BrimLine socket_brim;        ///< its brim: the design's, raised where donning dragged skin above it
  contact::DonningResult donning;      ///< its donning and standing
  double seconds = 0.0;
};

/// The drag band (case design.closed_loop_drag_band): where a closed loop saw donning drag skin
/// below the brim out of the socket, the depth below the brim at which the design, solved again,
/// starts asking pressure (DesignSolver::set_brim_band; pipeline::solve_design keeps the design
/// whose socket delivers it better).
struct DragBand {
  std::vector<design::BrimLift> lifts;  ///< per node dragged out: its angle, the band's depth there [m]
  std::vector<int> node_ids;            ///< those nodes (skin order), designed above kDragBandMinPa
  double max_depth_m = 0.0;             ///< the band's depth at most [m]
  double max_designed_pa = 0.0;         ///< their largest designed pressure [Pa]
  double first_score = 0.0;             ///< the design without the band (its socket missed the bar): its bar_score
  bool kept = false;                    ///< the design with the band is the one written
  std::string why_not;                  ///< why not, when not kept
};
/// A node dragged out counts in the band when designed above this [Pa] (a quarter of the delivery
/// bar's 99th percentile: what it loses, dragged out, counts little against the bar).
inline constexpr double kDragBandMinPa = 1000.0;
/// Each node's depth holds over this angle either side, then eases to nothing over as much (design::eased_lift).
inline constexpr double kDragBandPlateau = 10.0 * std::numbers::pi / 180.0;
/// The band of @p loop's nodes ever dragged out and designed above kDragBandMinPa: each node's depth
/// below @p brim at rest (@p solver's cylindrical coordinates) plus half the skin's mean spacing.
DragBand drag_band(const design::DesignSolver& solver, const design::BrimLine& brim, const ClosedLoopResult& loop);

/// Delivered against designed pressures in one region of the skin (below the brim, a path).
struct RegionDelivery {
  std::string key;    ///< "below_brim", "front_line", "back_line", "mid_circumference"
  std::string name;   ///< as shown
  report::ErrorStats open_loop, closed_loop;  ///< a = delivered, b = designed [Pa]
};

/// Mean pressures over a landmark's zone (skin nodes below the brim within its radius, at most
/// 15 mm), area-weighted, and the zone's mean pain threshold.
struct LandmarkDelivery {
  std::string code;
  int nodes = 0;
  double threshold_pa = 0, target_pa = 0, open_loop_pa = 0, closed_loop_pa = 0;
};

/// A landmark's zone on the skin: the nodes @p use marks (below the brim) within its radius, at
/// most 15 mm, with their area; the zone's mean of a field is area-weighted.
struct LandmarkZone {
  std::string code;
  std::vector<int> nodes;
  double area_m2 = 0;
  /// The area-weighted mean of @p field (per skin node) over the zone.
  double mean(const std::vector<double>& field, const std::vector<double>& area_m2_per_node) const;
};

/// The zones of the setup's landmarks among the skin nodes where @p use is 1; a landmark with no
/// node there (above the brim, off the stump) has none.
std::vector<LandmarkZone> landmark_zones(const DesignSetup& setup, const std::vector<char>& use);

struct DeliverySummary {
  std::vector<RegionDelivery> regions;
  std::vector<LandmarkDelivery> landmarks;
};

/// The closed loop's agreement with the design by region and at the landmarks.
DeliverySummary summarise_delivery(const DesignSetup& setup, const ClosedLoopResult& loop);

/// The open-loop and the kept socket of @p sum judged against report::DeliveryBar below the brim
/// and on each thesis path (design.json's `open_loop_bar` and `bar`; the GUI's delivery line).
std::pair<report::DeliveryVerdict, report::DeliveryVerdict> delivery_verdicts(const DeliverySummary& sum);

/// Writes `delivered.csv` (per skin node: designed position, designed, open-loop and closed-loop
/// pressures, wall correction), `delivered_iterations.csv` (every donning's pressures and wall
/// corrections), `delivered_map.png` and `delivered_error_map.png` into @p out, fills @p delivery for the
/// report and returns the loop's summary for design.json.
/// @pre result.closed_loop holds a loop.
nlohmann::json write_closed_loop_outputs(const DesignSetup& setup, const DesignResult& result,
                                         const std::filesystem::path& out, report::ReportDelivery& delivery);

/// Whether a socket donned from scratch replaces the one the loop keeps: one within every tolerance
/// (@p within: MAE, p99, landmarks, paths) before one that meets only the delivery bar (@p bar_met:
/// its MAE is 1.5 kPa, the loop's 0.5), before one that meets neither; within a tier, the smaller
/// @p score — max(MAE / tol, p99 / tol) in the first two tiers, bar_score in the third.
/// @p kept_rank: the kept socket's tier (2, 1, 0; −1 when none is kept yet), @p kept_score its score.
bool replaces_kept(bool within, bool bar_met, double score, int kept_rank, double kept_score);
/// How far a donned socket is from the delivery bar (report::DeliveryBar): the largest of its MAE
/// and p99 below the brim over the bar's, its landmark deviation over the bar's and its path score
/// (≤ 1 on each where the bar is met; R aside). Of two sockets that miss the bar, the loop keeps the
/// one that misses it least: by the MAE and p99 alone it kept the transfemoral seed 4 at 8k's third
/// donning (MAE 0.23 kPa, the greater trochanter 116 % over its design) before its second (0.28 kPa,
/// 39 %), 2026-12-06.
double bar_score(const ClosedLoopIteration& it);
/// The tier replaces_kept ranks a socket by: 2 within the tolerances, 1 the delivery bar, 0 neither.
int kept_rank(bool within, bool bar_met);

/// ", landmarks within N % (CODE)": @p it's landmark furthest from its design, for the loop's lines
/// ("" when no landmark lies below the brim).
std::string landmark_note(const ClosedLoopIteration& it);

/// A thesis path's skin nodes below the brim (design_paths, sampled on the rest skin).
struct PathNodes {
  std::string key, name;
  std::vector<int> nodes;
};
/// The thesis paths with at least 3 skin nodes flagged in @p below_brim: what the closed loop's
/// stopping rule and its delivery summary compare.
std::vector<PathNodes> path_nodes_below_brim(const DesignSetup& setup, const std::vector<char>& below_brim);

/// ", <path label>: MAE …, 99th percentile … kPa": @p it's thesis path furthest from the delivery
/// bar when one misses it ("" otherwise).
std::string path_note(const ClosedLoopIteration& it);

/// What the below-brim figures of @p it owe to the nodes donning dragged above the brim, for the
/// loop's log line ("" when none were; no in-socket figures when fewer than 3 nodes stayed in).
std::string dragged_out_note(const ClosedLoopIteration& it);
/// A wall correction whose node-scale part is more than this share of its spread
/// (ClosedLoopIteration::wall_roughness_share) is reported with advice to check the socket in
/// CalculiX: the demo and OpenLimb's limb and skin at 8k, which CalculiX confirms, have 0.12–0.14;
/// the 12 limbs of docs/sweeps/closed_loop_limbs.json at 3k, which meet the delivery bar, 0.18–0.27;
/// the clinical AAOP example at 3k, where the two codes part by MAE 1.1, p99 6 kPa after the loop,
/// 0.50. (The RMS itself grows as the mesh coarsens: 0.064–0.068 mm at 8k, 0.091–0.122 mm on the 3k
/// limbs, 0.167 mm on the AAOP example; docs/design.md, "Limits".)
inline constexpr double kRoughWallShare = 0.35;

/// The report's line on the kept socket's node-scale roughness (@p cap_m: the case's cap, 0 none),
/// with the advice when its share exceeds kRoughWallShare.
std::string roughness_advice(const ClosedLoopIteration& kept, double cap_m);

/// The report's sentence on those nodes of the kept socket @p kept, with the prosthetist's options
/// ("" when none were; no in-socket figures when fewer than 3 nodes stayed in).
std::string dragged_out_advice(const ClosedLoopIteration& kept);

/// The report's sentence on the drag band @p b: where it came from, and whether its design is the one kept.
std::string drag_band_note(const DragBand& b);

/// Runs the loop on a design whose constraints are met (result.socket is the open-loop socket).
/// The setup's DesignSolver provides the compliance (its K₀ is factorised on first use).
/// @throws InvalidInputError for options out of range or a design without a socket;
///         SolverError when the open-loop socket cannot be donned (the message says where it stalled).
ClosedLoopResult close_design_loop(DesignSetup& setup, const DesignResult& result, const ClosedLoopOptions& options = {});

}  // namespace socketsmith::pipeline
