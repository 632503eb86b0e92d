#pragma once
/// @file load_regions.h
/// Where the socket carries the patient: the axial load (F_z of the radar: the normal forces'
/// axial component plus the available friction, thesis eq. 42) split by anatomical region of
/// the skin — the share of the ischial/gluteal region, the lateral wall, the distal end… that a
/// transfemoral template is meant to load, reported in design.json and the report, and a floor
/// the optimiser can be asked to keep (OptimizerOptions::region_floors).

#include <string>
#include <vector>

#include "socketsmith/design/brim.h"
#include "socketsmith/design/design_solver.h"
#include "socketsmith/volume/landmarks.h"

namespace socketsmith::design {

/// A region of the skin: a sector of θ (from theta_from_rad towards increasing θ to theta_to_rad,
/// possibly across ±180°) between two heights.
struct LoadRegion {
  std::string key;              ///< "ischial_gluteal", "lateral_wall", …
  std::string name;             ///< as shown: "ischial / gluteal"
  double theta_from_rad = 0.0;  ///< sector start [rad]
  double theta_to_rad = 0.0;    ///< sector end [rad]; equal to the start: every angle
  double h_min_m = 0.0;         ///< [m]
  double h_max_m = 1e9;         ///< [m]
  /// True when (θ, h) lies in the region.
  bool contains(double theta, double h) const;
};

/// The regions of a limb type, placed from its landmarks; a skin node belongs to the first region
/// that contains it. Transfemoral: distal end (h < 0.2 L), ischial/gluteal (the posterior arc from
/// 20° in front of IS round to −135°, from 50 mm below IS up), lateral wall (−135° to −45°),
/// anterior (Scarpa's triangle: −45° to 10° before AL), medial (adductors and ramus: from there to
/// 20° before IS), posterior thigh (the posterior arc below the gluteal region). Transtibial: distal
/// end, patellar tendon (PT ± 30°, ± 25 mm), anterior, medial, posterior, lateral (90° sectors).
/// @throws InvalidInputError when a landmark they need (IS, AL; PT) is missing.
std::vector<LoadRegion> load_regions(geometry::LimbType type, const std::vector<volume::Landmark>& landmarks,
                                     double stump_length_m);

/// Index of the region of each point (−1: none), first match in order.
std::vector<int> region_of(const std::vector<LoadRegion>& regions, const std::vector<geometry::Cylindrical>& points);

/// What one region carries.
struct RegionLoad {
  std::string key, name;
  double area_m2 = 0.0;            ///< loaded skin area (pressure > 0, below the brim) [m²]
  double normal_axial_n = 0.0;     ///< Σ p A (−n)·axis [N]
  double friction_axial_n = 0.0;   ///< Σ μ p A sqrt(1 − (n·axis)²) [N]
  double axial_n = 0.0;            ///< the two together: the region's part of F_z [N]
  double share = 0.0;              ///< axial_n / F_z of the whole socket
  double mean_pressure_pa = 0.0;   ///< area-weighted over its loaded area [Pa]
  double peak_pressure_pa = 0.0;   ///< [Pa]
};

/// The axial load of @p state split by region (the skin nodes' rest coordinates @p rest choose the
/// region; @p above marks the nodes above the brim, which carry nothing). The shares of all the
/// regions plus that of the nodes in none add up to 1.
std::vector<RegionLoad> region_loads(const std::vector<LoadRegion>& regions,
                                     const std::vector<geometry::Cylindrical>& rest, const std::vector<char>& above,
                                     const DesignState& state, const geometry::LimbFrame& frame, double friction);

/// The least share of the axial load the optimiser keeps on the ischial/gluteal region for a
/// transfemoral brim template (0: none): quadrilateral 0.30 (an ischial-gluteal seat: the tuberosity
/// sits on it), ischial containment 0.15 (the containment shares the load with the soft tissue
/// held in total contact). Assumed values — the literature gives none as a number;
/// design.ischial_share_min overrides them.
double default_ischial_share(BrimTemplate kind);

}  // namespace socketsmith::design
