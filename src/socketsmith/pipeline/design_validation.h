#pragma once
/// @file design_validation.h
/// A whole CalculiX validation of a case (`socketsmith validate design` / `validate donning`,
/// docs/validation_fe.md) as one library call, so the CLI and the Python package run the same
/// code: the case is designed (run_design into OUT/design), socketsmith's own donning
/// runs when it is compared or stood on, the designed stump goes to CalculiX (check_design), and
/// the comparison is written — comparison.csv, path profiles, scatter, colour maps, stump_fe.vtu,
/// summary.json.

#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "socketsmith/contact/donning.h"
#include "socketsmith/core/progress.h"
#include "socketsmith/design/case_file.h"
#include "socketsmith/calculix/design_check.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/report/field_comparison.h"

namespace socketsmith::pipeline {

/// What to check and how (the flags of `validate design`; every default is the CLI's).
struct DesignValidationOptions {
  calculix::DesignCheckMode mode = calculix::DesignCheckMode::Contact;
  /// Donning mode: compare CalculiX's donning with socketsmith's own donning (contact solver, same
  /// travel and μ) instead of with the designed pressures (thesis ch. 3; `validate donning`).
  bool against_donning = false;
  /// Donning mode: then push the socket with half the body weight in CalculiX (thesis step 2),
  /// and compare socketsmith's own donned-and-stood pressures too.
  bool stand = false;
  /// against_donning: socketsmith's donning with the nonlinear tissue model instead of its
  /// linearisation at rest. Otherwise socketsmith's own donning has the design's body (the closed
  /// loop's rule: nonlinear unless the design was solved linearly or fell back to the linearised
  /// stump).
  bool nonlinear_body = false;
  bool optimise = true;                 ///< false: the case's spots as given; true: as the case says
  double poisson_ratio = -1.0;          ///< CalculiX's ν, [0, 0.5); < 0: fe_material's (the case's model, else 0.45)
  bool neo_hookean = false;             ///< neo-Hookean in CalculiX (automatic for a neo-hookean case)
  bool small_strain = false;            ///< CalculiX without NLGEOM (not with a neo-Hookean tissue)
  bool printed_wall = false;            ///< Donning: CalculiX dons the printed socket's wall (DesignCheckOptions)
  /// Donning: the shell's quads split n × n (DesignCheckOptions), 1–4; empty: calculix_shell's default.
  std::optional<int> shell_subdivision;
  bool shell_on_wall = false;           ///< Donning: the shell laid on socketsmith's smoothed wall (DesignCheckOptions)
  /// Donning: the shell across the brim onto the lip (DesignCheckOptions); empty: calculix_shell's default.
  std::optional<bool> shell_lip;
  /// CalculiX's element; empty: the tissue's twin (C3D8, or C3D8I for tissue.element fbar).
  std::optional<calculix::ElementType> element;
  /// CalculiX's contact penalty [Pa/m]; 0: socketsmith's donning's on this stump (20 E / h). Empty:
  /// socketsmith's with DesignCheckMode::Donning (the same contact law on both sides; a case whose
  /// closed loop dons on a rigid wall: CALCULIX.md's 1e9), 1e9 with Contact (the design has no penalty).
  std::optional<double> penalty_pa_per_m;
  double stick_slope_pa_per_m = 5e7;    ///< CalculiX's friction stick slope [Pa/m], > 0
  double friction = -1.0;               ///< μ, [0, 2]; < 0: the case's
  double clearance_m = 1e-3;            ///< Contact: the fit starts this far outside the skin [m], > 0
  double travel_m = 0.06;               ///< Donning: start this far distally [m], > 0
  double initial_increment = 0.05;      ///< first ccx increment, a fraction of the step, (0, 1]
  int alternation_rerun_nodes = 5;      ///< calculix::DesignCheckOptions::alternation_rerun_nodes
  calculix::FePressure fe_pressure = calculix::FePressure::NodalForce;
  calculix::CcxOptions ccx;             ///< executable, threads, time limit, ccx's progress
  ProgressCallback progress;            ///< the design and socketsmith's donning
  std::string case_label = "case";      ///< summary.json's "case" (the case file's path, "demo")
  bool write_case = false;              ///< also write the case as OUT/case.json (one made in memory, to replay it)
};

/// CalculiX's socket as summary.json's "fe_socket" names it: which shell or wall was donned (or
/// fitted), so a run's figures say what they checked.
std::string fe_socket_description(const calculix::DesignCheckOptions& o);

/// How a check's compared field is reported: contact pressure in kPa, or (Load) displacement in mm.
struct ComparedQuantity {
  double scale = 1e-3;             ///< SI → the reported unit
  std::string unit = "kPa";        ///< "kPa" | "mm"
  std::string suffix = "_kpa";     ///< of summary.json's keys: "_kpa" | "_mm"
  std::string what = "contact pressure";  ///< "contact pressure" | "displacement"
};
ComparedQuantity compared_quantity(calculix::DesignCheckMode mode);

/// A validation run: the design, socketsmith's donning when one ran, CalculiX's comparison.
struct DesignValidation {
  DesignArtifacts artifacts;            ///< the design run (OUT/design)
  nlohmann::json design_summary;        ///< its design.json
  calculix::DesignedStump stump;        ///< what went to CalculiX (refers to artifacts' setup)
  std::vector<double> designed_pa;      ///< the design's pressure per skin node [Pa] (stump's may be a donning's)
  calculix::DesignCheckOptions check_options; ///< the check as run
  calculix::DesignCheckResult check;    ///< the comparison, per skin node and summarised
  std::optional<contact::DonningResult> donning;  ///< socketsmith's own (against_donning or stand)
  bool donning_from_closed_loop = false;  ///< the closed loop's kept donning, not one run here
  /// socketsmith's donning body: linearised at rest, else the nonlinear tissue model (the design's
  /// own, as the closed loop dons it; validate donning: --nonlinear-body).
  bool own_body_linear = true;
  double stand_force_n = 0.0;           ///< CalculiX's step 2 force [N] (0 without stand)
  double socketsmith_stand_offset_m = 0.0;  ///< socketsmith's stood pose past the designed pose [m]
  double socketsmith_wall_s = 0.0;      ///< the whole design run [s]
  /// Designed, CalculiX and socketsmith (stood) pressures per ring below the brim (empty without a
  /// standing step): summary.json rings_below_brim, rings.svg.
  std::vector<report::BandMeans> rings;
  nlohmann::json summary;               ///< summary.json
};

/// Where socketsmith's donning @p ours stood the socket: its standing pose past the donned (designed)
/// one along the axis [m]. @throws InvalidInputError when @p ours did not stand.
double stand_offset_m(const contact::DonningResult& ours);

/// The push CalculiX's standing step is given past the donned pose [m] (calculix::DesignCheckOptions::
/// stand_travel_m): three times stand_offset_m(@p ours), at least 0.5 mm (CalculiX stands the sockets
/// measured within 15 % of socketsmith's offset, the 3k demo's printed wall barely at all; the
/// interpolation needs the load bracketed; a push that falls short is run again from CalculiX's own
/// reactions). @throws as stand_offset_m.
double calculix_stand_travel_m(const contact::DonningResult& ours);

/// socketsmith's own donning contact penalty on the stump of @p art (20 E / h,
/// contact::contact_penalty_pa_per_m with the default donning options) [Pa/m].
double socketsmith_penalty_pa_per_m(const DesignArtifacts& art);

/// The contact penalty CalculiX is given for case @p c checked as @p o asks
/// (DesignValidationOptions::penalty_pa_per_m), with socketsmith's own @p ours [Pa/m]. Measured with
/// socketsmith's on the demo 1.8k / 3k, OpenLimb 3k and the demo 5.9k: MAE to the design 1.01 /
/// 0.89 / 0.74 / 0.74 kPa against 1.19 / 0.98 / 0.94 / 0.80 with 1e9; ccx 88 vs 107 Newton iterations at 5.9k
/// (docs/VALIDATION.md).
double calculix_penalty_pa_per_m(const design::CaseFile& c, const DesignValidationOptions& o, double ours);

/// CalculiX's socket for a donning check as @p o asks, into @p co (printed_wall, shell_on_wall,
/// shell_lip, shell_subdivision). By default a donned socket is the shell on the skin quads, split
/// 2 × 2, with the lip of the socket socketsmith writes (@p has_socket) across the brim — the printed
/// socket's rounded rim, not the shell's sharp edge. Measured at 3k (2026-12-02, docs/VALIDATION.md):
/// the demo's 99th percentile below the brim 4.31 → 3.54 kPa, OpenLimb's limb 4.59 → 3.66, every
/// landmark within the bar on both; the lip alone, unsplit, 4.13 / 4.71 (its kink at the first ring
/// still cuts in); ccx 20–60 % longer. Without a written socket (a design that does not meet its
/// constraints), or for the printed wall, no lip and no split.
void calculix_shell(const DesignValidationOptions& o, bool has_socket, calculix::DesignCheckOptions& co);

/// Designs @p c into @p out/design, checks it in CalculiX and writes the comparison into @p out.
/// A CalculiX run that stops after some increments is compared on its last converged increment
/// (result.check.converged false, summary "converged": false); the caller decides whether that is
/// an error (the CLI exits 3).
/// @throws InvalidInputError for inconsistent options (named as `validate design`'s flags), a
///         missing ccx (before the design runs), a design without a socket to don; SolverError when socketsmith's donning
///         does not complete or ccx gives no usable increment; IoError when @p out cannot be written.
DesignValidation validate_design(const design::CaseFile& c, const DesignValidationOptions& options,
                                 const std::filesystem::path& out);

}  // namespace socketsmith::pipeline
