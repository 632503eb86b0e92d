#pragma once
/// @file closed_loop_correction.h
/// The closed loop's wall correction (pipeline/closed_loop.h, step 2 and 3 of docs/design.md,
/// "Closed loop"): the excess of the delivered over the designed pressures becomes the skin's normal
/// displacement under it, moved onto the wall where each node touches it once donned.

#include <limits>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/contact/donning.h"
#include "socketsmith/design/design_solver.h"
#include "socketsmith/pipeline/closed_loop.h"

namespace socketsmith::pipeline {

/// The mean of √area over the skin nodes where @p use is 1: their spacing [m] (0 when none).
double mean_spacing(const std::vector<double>& area_m2, const std::vector<char>& use);

/// Each skin node's position donned and stood, in the socket's frame (the socket's standing offset
/// along @p axis taken off).
std::vector<Eigen::Vector3d> donned_in_socket(const volume::SkinSurface& skin, const contact::DonningResult& d,
                                              const Eigen::Vector3d& axis);

/// The wall's correction at each skin node's vertex: the skin's normal displacement under the excess
/// of @p delivered over @p target (smoothed, ClosedLoopOptions::smoothing_passes), ω-relaxed, moved
/// to where each node touches the wall (@p donned, in the socket's frame; the wall is the designed
/// skin moved by @p offset along its normals). Only the nodes @p in_socket (compared, and donned
/// below the brim) correct the wall: a node that donning dragged above the brim touches at most the
/// brim's lip, which no correction shapes, and its deficit, moved onto the vertices above the brim,
/// only pulled the rim in from one correction to the next (seed 7, 3k: to the 5 mm clamp, raising
/// the 99th percentile of the ring below from 5.8 to 10 kPa). @p spacing: the skin nodes' mean
/// spacing [m] (the Gaussian's σ is half of it).
std::vector<double> wall_corrections(design::DesignSolver& solver, const design::DesignState& state,
                                     const std::vector<int>& in_socket, const std::vector<double>& delivered,
                                     const std::vector<double>& target, const std::vector<Eigen::Vector3d>& donned,
                                     const std::vector<double>& offset, double spacing,
                                     const ClosedLoopOptions& options);

/// The node-scale part of a field @p v on the skin: at each node where @p use is 1, v minus the
/// area-weighted (@p area_m2) mean of its @p neighbours (volume::SkinSurface::neighbours) where @p use
/// is 1; NaN at the others and at a node with fewer than 2 such neighbours. A field linear over the
/// skin's one-rings has none (up to the rings' asymmetry); a field alternating node by node is all
/// node-scale.
std::vector<double> node_scale_part(const std::vector<std::vector<int>>& neighbours, const std::vector<double>& area_m2,
                                    const std::vector<char>& use, const std::vector<double>& v);

/// Moves each node of @p v whose node_scale_part exceeds @p cap (> 0) in magnitude to @p cap from
/// its neighbours' mean (the means taken before any node moves; ClosedLoopOptions::max_roughness_m).
/// Returns how many nodes moved.
int cap_node_scale_part(const std::vector<std::vector<int>>& neighbours, const std::vector<double>& area_m2,
                        const std::vector<char>& use, double cap, std::vector<double>& v);

/// How rough the wall's correction is at the scale of a node: the RMS and 99th percentile (nearest
/// rank) of |node_scale_part(offset)| over the nodes where it is defined [m], and how many; and the
/// standard deviation of @p offset over the nodes @p use marks [m], against which the RMS is read
/// (share(): the node-scale part's share of the correction's spread, which a coarser mesh does not
/// raise as it raises the RMS).
/// The loop's refits fit the wall to socketsmith's own sliding, node by node: on the AAOP example
/// (3k) the roughness grew refit by refit from 0.10 to 0.17 mm RMS while the refits' MAE fell (CalculiX
/// and socketsmith part there by MAE 1.1, p99 6 kPa, as on the open-loop socket, once CalculiX's
/// increments are short enough); on the three 8k limbs whose closed loop CalculiX confirms it is
/// 0.064–0.068 mm (docs/design.md, "Limits").
struct WallRoughness {
  double rms_m = 0, p99_m = 0;
  int nodes = 0;
  double spread_m = 0;  ///< standard deviation of the offset over the used nodes [m]
  double share() const { return spread_m > 0 ? rms_m / spread_m : 0.0; }
};
WallRoughness wall_roughness(const std::vector<std::vector<int>>& neighbours, const std::vector<double>& area_m2,
                             const std::vector<char>& use, const std::vector<double>& offset);

/// Each landmark zone's wall step by the secant of its own response. wall_corrections turns the
/// excess into a wall movement through the design's stiffness, over the whole skin: at a zone of a
/// few nodes the movement it asks is mostly its neighbours' (generated transfemoral limb, seed 1,
/// 3k: the greater trochanter 7.1 kPa short asked the wall 0.96 mm outwards, with the region around
/// it pressing too much), and where the donned stump answers more softly than the design's stiffness
/// (friction holding the skin, a thin pad near the brim) one correction removes a share of a zone's
/// excess: that landmark crept towards its design over many refits, −150, −100, −84, −64, −43 %,
/// and ended 42 % short after three donnings while the MAE had settled at 0.3 kPa. After each refit
/// the zone's mean excess and mean wall offset against the last call's give its slope [Pa/m], kept
/// when the wall moved more than kZoneMoved and the slope is a stiffness of at least kMinZoneSlope
/// (moving out relieves); the slope used is the stiffer of the last two kept (a soft outlier would
/// overshoot). From then on the zone's mean correction is the secant step −excess / slope (at most
/// kMaxZoneStep), its nodes keeping their correction's shape. (Dropping the slope when a secant step
/// did not shrink the zone's excess met the delivery bar on 3 of the 11 transfemoral limbs of
/// docs/sweeps/closed_loop_tf_limbs.json, against 7 without it.)
/// A zone facing along the axis (its mean normal within 45° of it: the transfemoral distal femur;
/// the transtibial distal tibia's zone on the demo faces more across than along) that carries load
/// is left to the loop's correction: what it carries is set by where the socket stands under
/// the load, by the whole wall (generated transfemoral limb, seed 2: the distal femur stepped by its
/// own slope stayed 0.14 of its threshold over its design, where the loop's correction brought it
/// within 0.011). A relieved one (designed under kReliefRatio of its threshold: practically
/// nothing) keeps its secant steps: what it carries is its own gap to the wall (generated
/// transtibial limb, seed 4, 3k, pressures per deformed area: the distal tibia, designed 0.002 of
/// its threshold, stayed 0.011 over it after three donnings on the loop's correction, and ended
/// within 0.004 on its own slope). The transfemoral distal femur designed at 0.012–0.088 of its
/// threshold is not: stepped by its own slope when "relieved" meant under 0.1, it ended 0.066 and
/// 0.160 over on seed 6 and OpenLimbTF (the delivery bar on 2 of 11 transfemoral limbs, against 4).
class ZoneSteps {
 public:
  ZoneSteps() = default;
  /// @p zones: the landmarks' zones; @p relieved: per zone, 1 where its design is a relief (under
  /// kReliefRatio of its threshold); @p area_m2, @p normals: the skin
  /// nodes' areas (the zones' means weigh by them, LandmarkZone::mean) and outward normals; @p axis:
  /// the limb's axis (unit).
  ZoneSteps(const std::vector<LandmarkZone>& zones, const std::vector<char>& relieved, std::vector<double> area_m2,
            const std::vector<Eigen::Vector3d>& normals, const Eigen::Vector3d& axis);
  /// Sets @p correction's mean (per skin node's wall vertex [m]) at each zone with a measured slope to
  /// its secant step. When @p response, @p excess (delivered − target per skin node [Pa]) is what the
  /// wall @p offset (per node [m]) made of the last call's correction delivered, and each zone's slope
  /// is measured first; otherwise (a donning from scratch: the path changed too) the slopes stay.
  void apply(const std::vector<double>& excess, const std::vector<double>& offset, bool response,
             std::vector<double>& correction);
  /// Zone @p zone's slope [Pa/m] (0: not measured, or an end of the stump: the loop's correction).
  double slope(size_t zone) const { return zones_[zone].slope; }
  /// Whether zone @p zone faces along the axis and carries load (left to the loop's correction).
  bool end(size_t zone) const { return zones_[zone].end; }

 private:
  struct Zone {
    LandmarkZone zone;
    bool end = false;  // facing along the axis, loaded
    double excess = std::numeric_limits<double>::quiet_NaN(), offset = 0;  // at the last call
    double slope = 0, last_seen = 0;  // [Pa/m]: the one used, the last measured
  };
  std::vector<Zone> zones_;
  std::vector<double> area_m2_;  // per skin node
};

inline constexpr double kZoneMoved = 2e-5;     ///< [m] ZoneSteps: a smaller move measures noise, not a slope
inline constexpr double kMinZoneSlope = 5e5;   ///< [Pa/m] ZoneSteps: the softest slope believed
inline constexpr double kMaxZoneStep = 1e-3;   ///< [m] ZoneSteps: the largest secant step
inline constexpr double kReliefRatio = 0.01;   ///< ZoneSteps: a zone designed under this share of its threshold is relieved

}  // namespace socketsmith::pipeline
