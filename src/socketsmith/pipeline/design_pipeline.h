#pragma once
/// @file design_pipeline.h
/// The inverse socket design of a case file as a library: limb → stump model → pressure spots
/// (optimised) → socket STL and report. The CLI (`design`, `run`, `demo`), the GUI and the
/// CalculiX validation call it, so a design made in one replays in the others.
///
/// Three stages, usable alone or through run_design:
///  1. prepare_design: reads/generates the limb, builds its model (frame, bones, landmarks),
///     checks the case against it, meshes the stump and builds the DesignSolver (the expensive,
///     once-per-case part);
///  2. solve_design: the optimiser (or one solve of the case's spots) and the socket;
///  3. write_design_outputs: every file of docs/design.md and the summary JSON.

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "socketsmith/core/progress.h"
#include "socketsmith/design/brim.h"
#include "socketsmith/design/case_file.h"
#include "socketsmith/design/design_solver.h"
#include "socketsmith/design/ischial_check.h"
#include "socketsmith/design/load_regions.h"
#include "socketsmith/design/optimizer.h"
#include "socketsmith/design/pain_map.h"
#include "socketsmith/design/socket_builder.h"
#include "socketsmith/design/template_regions.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/pipeline/closed_loop.h"
#include "socketsmith/pipeline/sock_ply.h"
#include "socketsmith/report/design_report.h"
#include "socketsmith/volume/hex_mesher.h"
#include "socketsmith/volume/limb_model.h"

namespace socketsmith::pipeline {

/// Everything a case needs before the first design solve. Not copyable or movable (the solver
/// refers to the mesh): prepare_design returns it behind a unique_ptr.
struct DesignSetup {
  design::CaseFile case_file;
  std::string limb_label;              ///< file name, or "generated right transtibial limb (seed 1)"
  geometry::TriMesh limb;              ///< the limb surface as read [m]
  volume::LimbModel model;             ///< frame, bones, landmarks, length
  design::ThresholdTable table;        ///< pain thresholds per landmark [Pa]
  design::BrimLine brim;
  std::vector<std::string> brim_notes; ///< template key points clamped into the stump (a scan ending too low)
  std::vector<design::Spot> spots;     ///< the case's spots, or the default layout
  std::vector<design::LoadRegion> regions;  ///< where the axial load is counted (design/load_regions.h)
  volume::HexMesherResult mesh;
  tissue::MassSpringOptions model_options;
  tissue::TissueMaterial material;
  std::vector<double> thresholds;      ///< pain threshold per skin node [Pa]
  std::unique_ptr<design::DesignSolver> solver;

  DesignSetup() = default;
  DesignSetup(const DesignSetup&) = delete;
  DesignSetup& operator=(const DesignSetup&) = delete;
};

/// Stage 1. When the case's limb is generated and @p generated_limb_stl is not empty, the
/// generated limb is written there. Progress goes from 0 to 1 over reading, meshing, building.
/// @throws InvalidInputError (one line: the problem and the fix) for a case that does not fit
///         its limb: thresholds for unknown landmarks, a brim outside the limb, a spot off the stump…
std::unique_ptr<DesignSetup> prepare_design(const design::CaseFile& c,
                                            const std::filesystem::path& generated_limb_stl = {},
                                            const ProgressCallback& progress = {});

/// The least share of the axial load a transfemoral design keeps on the ischial/gluteal region:
/// the case's design.ischial_share_min, else the brim template's (design::default_ischial_share);
/// 0 for a transtibial limb.
double ischial_share_floor(const DesignSetup& setup);
/// That floor as an optimiser region share (nullopt when 0), asked with a 5 % margin (floor × 1.05):
/// the optimiser's last fit is on the geometry of the round before, the floor is read on the final state.
std::optional<design::OptimizerOptions::RegionShare> ischial_floor(const DesignSetup& setup);
/// The optimiser's settings for case @p c on @p setup's stump (the CLI's design and the GUI's
/// Optimise both take them from here): the case's objective, model pressure limit and time limit;
/// a transfemoral limb's ischial floor; and, when the case follows its template
/// (design.follow_template), what the brim template means (design/template_regions.h) — PTB family:
/// the tolerant / sensitive mean pressure ≥ 1.5 × and the distal fifth ≤ 10 % of the axial load,
/// each with a 5 % margin (the last fit is on the geometry of the round before it, the check reads
/// the final one); TSB: the Uniform objective in place of the default Pressure one.
design::OptimizerOptions optimizer_options(const DesignSetup& setup, const design::CaseFile& c);

/// The MSS model options and material a case asks for.
tissue::MassSpringOptions model_options(const design::CaseFile& c);
tissue::TissueMaterial material(const design::CaseFile& c);

/// What solve_design found.
struct DesignResult {
  std::vector<design::Spot> spots;     ///< the final layout (optimised or as given)
  design::DesignState state;           ///< the stump solved under it
  design::OptimizerResult optimiser;   ///< empty when not optimised
  bool optimised = false;
  bool constraints_met = false;
  geometry::TriMesh rest_skin;         ///< skin triangles at rest (local ids = skin order) [m]
  geometry::TriMesh deformed_skin;     ///< same triangles at the designed shape = the socket's inner wall
  std::optional<design::SocketResult> socket;  ///< only when every constraint is met (the closed loop's when it ran)
  double limb_volume_below_brim_m3 = 0.0;      ///< the cavity measure on the undeformed skin
  std::vector<design::RegionLoad> region_loads; ///< the axial load by region (setup.regions) of `state`
  /// Transfemoral limbs with a socket: the bony ischial tuberosity against the socket's cavity in 3D
  /// (design/ischial_check.h: inside it for ICS, on the seat for quadrilateral).
  std::optional<design::IschialCheck> ischial_check;
  /// The closed loop (case `design.closed_loop`): the open-loop socket donned and stood on, its
  /// wall corrected; `socket` is then the corrected socket.
  std::optional<ClosedLoopResult> closed_loop;
  /// Why the closed loop the case did not ask for by name (design::closes_loop's default) stopped
  /// with an error; `socket` is then the open-loop one. Empty when it ran, or was off. A loop the
  /// case asks for by name throws instead.
  std::string closed_loop_failed;
  /// The design solved again with the drag band (case design.closed_loop_drag_band), when the
  /// closed loop's socket missed the delivery bar with skin dragged out over the brim: kept or not.
  std::optional<DragBand> drag_band;
  /// The sock-ply study (`simulate sockply`, run_sock_ply_study): the socket donned on the limb
  /// shrunk and grown; written with the design's outputs and in its report when present.
  std::optional<SockPlyResult> sock_ply;
};

/// The closed loop's settings for case @p c as `design` runs it (without progress).
ClosedLoopOptions closed_loop_options(const design::CaseFile& c);
/// The contact's augmented Lagrangian tolerance the case asks of every donning of its socket (the
/// closed loop's, `simulate donning --case`, `validate design`'s own): contact::kRigidWallAugmentedTol
/// with design.closed_loop_rigid_wall, else 0 (the penalty alone).
double case_augmented_tol(const design::CaseFile& c);
/// Whether the stump the design solved is the one linearised at rest: a linear design solve, or a
/// nonlinear one that fell back to it (DesignState::linearised). Every donning of the case's socket
/// dons that body (the closed loop's, the sock-ply study's, `simulate donning --case`'s and
/// `validate design`'s own); design.json's `linearised` says it.
bool design_body_linearised(const design::DesignState& state, const design::CaseFile& c);

/// Stage 2. Optimises (or solves the setup's spots) and builds the socket when every constraint
/// holds, then closes the loop when the case asks for it. Never builds a socket that violates the
/// constraints.
/// @throws SolverError when the stump cannot be solved at all.
DesignResult solve_design(DesignSetup& setup, bool optimise, const ProgressCallback& progress = {});

/// The socket solve_design builds on a designed skin before any closed loop: @p options (the
/// case's `socket`) with @p rest_skin as the undeformed skin its circumference reductions are
/// measured against. Needs no DesignSetup: the GUI builds it from copies on a thread of its own.
/// @throws as design::build_socket.
design::SocketResult build_design_socket(const geometry::TriMesh& designed_skin, const geometry::TriMesh& rest_skin,
                                         const geometry::LimbFrame& frame, const design::BrimLine& brim,
                                         design::SocketOptions options);

/// True when @p result's final state keeps the ischial floor (its ischial/gluteal share ≥ the
/// floor; always true without a floor) — design.json's ischial_share_floor_met.
bool ischial_floor_holds(const DesignSetup& setup, const DesignResult& result);

/// Stage 3. Writes surface_nodes.csv, stump.vtu, the maps, radar, profiles, socket.stl (when
/// built), design_case.json (the replay), report.html and design.json into @p out (created).
/// Returns the summary (the content of design.json). @p seconds: time spent so far, reported.
nlohmann::json write_design_outputs(const DesignSetup& setup, const DesignResult& result,
                                    const std::filesystem::path& out, double seconds);

/// The skin point at cylindrical (θ [rad], h [m]) of the limb frame: on the ray from the axis,
/// at the radius of the nearest skin node (rest shape) [m].
Eigen::Vector3d skin_point(const DesignSetup& setup, double theta, double h);

/// The brim line drawn on the skin: @p samples points, each where the ray from the axis at
/// (θ, brim(θ)) meets the skin (radius of the nearest skin node) [m]. For pictures and the GUI.
std::vector<Eigen::Vector3d> brim_on_skin(const DesignSetup& setup, int samples);

/// @p state read against the brim template (design::check_template): the tolerant and sensitive
/// regions' mean and peak pressure and axial share, the distal fifth's, the CV below the brim, and
/// whether the template's first criteria hold. The report, design.json and the GUI show it.
design::TemplateCheck template_check(const DesignSetup& setup, const design::DesignState& state);

/// The seven radar axes of @p state (report::seven_radar_axes with the case's patient and the
/// state's verdict per axis in is_ok).
std::vector<report::RadarAxis> radar_axes(const DesignSetup& setup, const design::DesignState& state);

/// A path of the design report on the skin.
struct DesignPath {
  std::string key;       ///< "front_line", "back_line", "mid_circumference"
  std::string name;      ///< as shown: "front line (through the patellar tendon)", ...
  report::PathSpec spec; ///< banded to one row of skin nodes (from the mean node spacing)
};

/// The front line through the patellar tendon (PT; θ = 0 without it), the back line opposite it
/// and the circumference at mid-stump.
std::vector<DesignPath> design_paths(const DesignSetup& setup);

/// Applied pressure against the pain threshold along design_paths(), sampled on the rest skin.
std::vector<report::PathProfile> pressure_profiles(const DesignSetup& setup, const design::DesignState& state);

/// The setup and the result of a run, for callers that go on with them (validation, GUI).
struct DesignArtifacts {
  std::unique_ptr<DesignSetup> setup;
  DesignResult result;
};

/// The three stages into @p out. Returns the summary (also written as design.json); when
/// @p artifacts is given, the setup and result are moved into it.
nlohmann::json run_design(const design::CaseFile& c, const std::filesystem::path& out, bool optimise,
                          const ProgressCallback& progress = {}, DesignArtifacts* artifacts = nullptr);

/// The embedded sample: the generated transtibial limb, 70 kg, E = 100 kPa, PTB brim, distal pad.
design::CaseFile demo_case(int target_nodes = 8000);

}  // namespace socketsmith::pipeline
