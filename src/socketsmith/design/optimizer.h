#pragma once
/// @file optimizer.h
/// Automatic inverse design (the thesis's "future work"): from a default spot layout, find spot
/// amplitudes — and, where it helps, positions — that meet every constraint of the radar with the
/// most even pressure.
///
/// For a fixed skin geometry and fixed spot positions, every radar value and every node's
/// pressure is linear in the amplitudes a: F = G a, T = H a, S = s·a, p_i = Σ_k a_k φ_k(i). The
/// amplitude problem is then
///     minimise  J(a) = (Σ_i A_i r_i^q / Σ_i A_i)^(1/q),  r_i = p_i / T_i   (q = 8: a soft peak
///               ratio that also rewards even pressure)
///     subject to F = (0, 0, M g / 2), T = 0 (equalities), S ≥ m_p g, r_i ≤ 1 at every node, a ≥ 0,
/// solved with SLSQP (NLopt) with exact gradients. Around it:
///  - positions (θ0, h0 of the spots marked optimise_position) are searched derivative-free
///    (NLopt Sbplx, within ±25° and ±15 mm of the layout) when the amplitudes alone cannot meet the
///    constraints, minimising J plus a penalty on the violated constraints;
///  - the skin geometry is the deformed one: fit, solve the stump, recompute normals and areas at
///    the equilibrium, refit — until the radar of the solved stump meets the constraints (2–3
///    rounds), because the socket's pressures act on the deformed surface.
/// When the constraints cannot all be met, the result says which one fails and by how much.
/// With fewer than six free amplitudes the six equalities are fitted in the least-squares sense
/// (½ Σ (residual / tolerance)²) under the same inequalities; the message then asks for more spots
/// when the balance fails.

#include <string>
#include <vector>

#include "socketsmith/core/progress.h"
#include "socketsmith/design/design_solver.h"
#include "socketsmith/volume/landmarks.h"

namespace socketsmith::design {

/// The default spot layout of a limb type, placed from its landmarks: where prosthetists tighten a
/// socket (transtibial: patellar tendon, popliteal, medial and lateral flares, the medial and
/// lateral tibial sides, the posterior calf, a distal GRAD; transfemoral: the ischial seat (IS) and
/// the gluteal band behind it, the ischial ramus (IR), the lateral wall over the trochanter (GT) and
/// along the femur, Scarpa's triangle (ST), the anterior, posterior and medial walls, a distal
/// GRAD), plus a total-contact background (8 around × 3 heights, up to 0.8 × the length; with
/// @p total_surface, a fourth row up to the brim: a TSB socket bears on the whole skin). Amplitudes
/// start at 10 kPa. @throws InvalidInputError when a needed landmark is missing.
std::vector<Spot> default_spots(geometry::LimbType type, const std::vector<volume::Landmark>& landmarks,
                                double stump_length_m, bool total_surface = false);

struct OptimizerOptions {
  int max_rounds = 5;                ///< fit → solve → refit rounds on the deformed geometry
  bool optimise_positions = true;    ///< allow the position search when amplitudes alone fail
  int max_position_evaluations = 300;
  double max_position_seconds = 20.0;  ///< wall-time cap of the position search [s]
  double max_position_shift_rad = 25.0 * 3.14159265358979 / 180.0;
  double max_position_shift_m = 0.015;
  double softmax_power = 8.0;        ///< q of J
  /// What J evens out: Pressure (J of p_i / 10 kPa: the most even pressure, the smallest
  /// deformation — the default), Ratio (J of p_i / T_i: loads the tolerant zones more, the PTB
  /// idea; larger peaks where thresholds are high, e.g. 190 kPa at the patellar tendon) or Uniform
  /// (J = the squared coefficient of variation of the pressure over the whole skin below the
  /// brim, unloaded nodes included: total surface bearing, what a TSB brim means).
  enum class Objective { Pressure, Ratio, Uniform } objective = Objective::Pressure;
  double max_amplitude_ratio = 1.5;  ///< amplitude ≤ this × the largest threshold
  /// When the stump model finds no equilibrium under a fitted field (the lattice collapses where
  /// thin tissue is crushed, docs/tissue.md), the pressure around the collapsing element is capped
  /// at this fraction of its peak there and the amplitudes are refitted, at most max_model_caps times.
  double model_cap_factor = 0.6;
  /// Largest pressure the optimiser may ask of the stump, as a fraction of the tissue's Young's
  /// modulus (0: no limit). The MSS-CS lattice collapses where thin tissue over bone is pressed by
  /// more than ≈ 0.25–0.3 E (measured, docs/design.md); real tissue stiffens instead.
  double model_pressure_limit = 0.25;
  int max_model_caps = 6;
  /// What the brim template means, as linear constraints on the amplitudes beside the seven of the
  /// radar (every one is linear in the amplitudes for a fixed skin geometry). They are the
  /// template's intent, not the patient's safety: a fit that cannot keep them together with the
  /// seven constraints drops them for that fit and says so in the log.
  ///
  /// A region's share of F_z (its skin nodes' normal forces' axial part plus the available
  /// friction on them): at least `min_share` (the ischial seat of an ischial containment) and at
  /// most `max_share` (the distal end of a PTB socket, design/template_regions.h).
  struct RegionShare {
    std::string name;           ///< for the log: "ischial / gluteal"
    std::vector<char> nodes;    ///< per skin node (DesignSolver::skin order): 1 = in the region
    double min_share = 0.0;     ///< of F_z, [0, 1)
    double max_share = 1.0;     ///< of F_z, (0, 1]; 1: no ceiling
  };
  std::vector<RegionShare> region_shares;
  /// The area-weighted mean pressure of the `bearing` nodes at least `min_ratio` × that of the
  /// `relieved` ones (PTB: the patellar tendon, flares and popliteal area bear, the fibular head,
  /// tibial crest and distal tibia are relieved). Means over every node of the region below the
  /// brim, loaded or not — as design::check_template reads them.
  struct PressureRatio {
    std::string name;                 ///< for the log: "tolerant / sensitive"
    std::vector<char> bearing, relieved;  ///< per skin node: 1 = in the region
    double min_ratio = 1.0;           ///< > 0
  };
  std::vector<PressureRatio> pressure_ratios;
  /// Wall-time bound of the whole optimisation [s], 0 = none. When it stops the search, the last
  /// fitted layout is solved and returned with is_time_limited and a message that says so.
  double time_limit_s = 0.0;
  /// Called at every objective evaluation (the bar moves while a large fit runs); the stage ends
  /// with a detail in parentheses ("design: optimising, round 1 (amplitude fit, 37 evaluations, 12 s)").
  /// Returning false cancels: message "cancelled".
  ProgressCallback progress;
};

struct OptimizerResult {
  std::vector<Spot> spots;           ///< the optimised layout
  DesignState state;                 ///< the stump solved under it
  bool constraints_met = false;
  int rounds = 0;                    ///< fit/solve rounds
  int evaluations = 0;               ///< amplitude fits (SLSQP runs)
  int slsqp_iterations = 0;          ///< total SLSQP objective evaluations
  double objective = 0.0;            ///< J of the last fit
  int model_caps = 0;                ///< zones where the stump model's stability limited the pressure
  double seconds = 0.0;
  bool is_time_limited = false;      ///< stopped by OptimizerOptions::time_limit_s
  std::string message;               ///< "all constraints met …" or which constraint fails and why
  bool region_constraints_met = true;  ///< every region share and pressure ratio held in the last fit
  std::vector<std::string> log;      ///< one line per round
};

/// Optimises @p spots (the initial layout) on @p solver's stump. @p solver's brim must be set.
/// Never throws for an infeasible case: constraints_met = false and the message names the failing
/// constraint. @throws SolverError when the stump cannot be solved at all.
OptimizerResult optimise_design(DesignSolver& solver, std::vector<Spot> spots, const OptimizerOptions& options = {});

}  // namespace socketsmith::design
