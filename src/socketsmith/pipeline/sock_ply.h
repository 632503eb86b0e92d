#pragma once
/// @file sock_ply.h
/// Sock-ply sensitivity (issue 23, item 5): what happens when the limb shrinks or swells in the
/// socket designed for it. The residual limb's fluid volume changes by a median −2.3 %/h within a
/// session (Sanders et al. 2012); patients answer with sock plies. Here the designed socket is
/// donned (contact::DonningSimulation, the same donning as `simulate donning` and the closed loop)
/// on the stump shrunk and grown by a few per cent of its volume, and stood on with half the body
/// weight: how far the limb sinks or rises in the socket, the peak pressure / pain threshold, the
/// pressure on the distal end, and whether the design's conditions still hold.
///
/// The changed limb: every skin node moves by one uniform offset d along its outward normal, the
/// bones (and the proximal cut's rim) stay where they are, and the nodes between follow the
/// harmonic extension of the skin's displacement over the hexahedral mesh (graph Laplacian, the
/// maximum principle keeps every node's move below |d|). The same mesh, so the frame, the brim,
/// the pain thresholds and the node ids are the design's. d is found so that the stump's exact
/// (trilinear) volume changes by the asked fraction (a cubic in d: secant iterations).

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "socketsmith/contact/donning.h"
#include "socketsmith/core/progress.h"
#include "socketsmith/design/design_solver.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/report/design_report.h"
#include "socketsmith/volume/hex_mesh.h"
#include "socketsmith/volume/hex_mesher.h"

namespace socketsmith::pipeline {

struct DesignSetup;
struct DesignResult;

/// The skin's displacement per unit normal offset, extended into the stump: for each node the
/// displacement [m per m of offset] when every free skin node moves by 1 along its outward normal
/// and the nodes tagged kNodeFixed (bones, the proximal rim) stay. Nodes between: the harmonic
/// extension (graph Laplacian of the hexahedra's edges, Dirichlet on the skin and the fixed nodes).
/// @param skin the mesh's skin (nodes and outward normals at rest)
/// @returns #nodes displacement directions
/// @throws InvalidInputError when the skin's nodes or normals do not match the mesh.
std::vector<Eigen::Vector3d> skin_offset_field(const volume::HexMesh& mesh, const volume::SkinSurface& skin);

/// The exact volume of @p mesh with its nodes at rest + @p offset_m × @p field [m³].
double offset_volume(const volume::HexMesh& mesh, const std::vector<Eigen::Vector3d>& field, double offset_m);

/// The uniform normal offset [m] that changes the stump's volume by @p volume_change (a fraction,
/// −0.04 = shrunk by 4 %), within 1e-6 of the fraction.
/// @throws InvalidInputError when |volume_change| > 0.2 or no offset reaches it (elements inverting).
double offset_for_volume_change(const volume::HexMesh& mesh, const std::vector<Eigen::Vector3d>& field,
                                double volume_change);

/// Settings of the study.
struct SockPlyOptions {
  /// Volume changes to try, fractions of the stump's volume, each in [−0.2, 0.2]; the designed
  /// volume (0) is added when missing (the reference of the sink).
  std::vector<double> volume_changes = {-0.04, -0.02, 0.02, 0.04};
  /// The donning: start, steps, penalty, smooth wall. Its friction and standing force are the case's
  /// (μ, M g / 2) unless keep_donning_loads.
  contact::DonningOptions donning;
  bool keep_donning_loads = false;
  /// The distal end: skin nodes below the brim within this fraction of the stump's length from
  /// its distal end (the template check's distal fifth), in (0, 1].
  double distal_fraction = 0.2;
  ProgressCallback progress;
};

/// One volume: the designed socket donned and stood on.
struct SockPlyLevel {
  double volume_change = 0.0;        ///< asked, fraction of the stump's volume
  double achieved_volume_change = 0.0;  ///< of the offset stump (within 1e-6 of the asked)
  double skin_offset_m = 0.0;        ///< the uniform normal offset of the skin [m] (< 0: shrunk)
  bool completed = false;            ///< the donning reached the designed pose
  bool stood = false;                ///< and the socket took the standing load
  std::string message;               ///< why not, when not
  double stood_offset_m = 0.0;       ///< where the socket stood along the axis from its designed pose [m]
  /// How much deeper the limb sits in the socket than at the designed volume [m]: the socket stood
  /// this much further up the limb (< 0: the limb rises out of it).
  double sink_m = 0.0;
  double peak_pressure_pa = 0.0;     ///< below the brim
  double peak_ratio = 0.0;           ///< max contact pressure / pain threshold below the brim
  std::string peak_zone;             ///< the landmark nearest the peak ratio
  double distal_mean_pa = 0.0;       ///< area-weighted mean over the distal end
  double distal_peak_pa = 0.0;
  int contact_nodes = 0;
  double axial_force_n = 0.0;        ///< the standing reaction along the axis [N]
  design::RadarValues radar;         ///< the seven values of the delivered pressures (compute_radar)
  design::ConstraintStatus status;   ///< the design's conditions on them (comfort: peak_ratio ≤ 1)
  std::vector<double> pressure_pa;   ///< contact pressure per skin node [Pa]
  geometry::TriMesh donned_skin;     ///< skin triangles at the donned shape (for the maps)
  double seconds = 0.0;              ///< the donning
  int factorizations = 0;
};

/// The study.
struct SockPlyResult {
  std::vector<SockPlyLevel> levels;  ///< ascending volume change; the designed volume included
  int reference = -1;                ///< index of the designed volume (0)
  double stump_volume_m3 = 0.0;      ///< the stump's volume at rest (the meshed limb below the cut)
  double skin_area_m2 = 0.0;         ///< the skin's area (free skin nodes)
  double standing_force_n = 0.0;
  double friction = 0.0;
  std::string summary;               ///< one line
  double seconds = 0.0;
};

/// Runs the study on a design whose constraints are met (its socket, the closed loop's when it ran).
/// Progress 0..1 over the donnings. A level whose donning stalls or cannot stand is reported as such
/// (the others go on); the designed volume's must stand.
/// @throws InvalidInputError for options out of range or a design without a socket; SolverError
///         when the socket cannot be donned and stood on at the designed volume.
SockPlyResult run_sock_ply_study(DesignSetup& setup, const DesignResult& result, const SockPlyOptions& options = {});

/// Writes sockply.csv (one row per level), sockply_nodes.csv (contact pressure per skin node and
/// level), sockply.svg / sockply.png (sink, peak ratio and distal pressure against the volume
/// change) and the contact pressure maps of the extreme levels and the designed one on one scale
/// (sockply_map_-4pct.png, sockply_map_designed.png, sockply_map_+4pct.png) into @p out; fills the
/// report's section (its maps refer to the result's donned skins, which must outlive the report's
/// writing); returns the JSON of design.json's "sock_ply".
/// @throws InvalidInputError when the result has no study.
nlohmann::json write_sock_ply_outputs(const DesignSetup& setup, const DesignResult& result,
                                      const std::filesystem::path& out, report::ReportSockPly& section);

}  // namespace socketsmith::pipeline
