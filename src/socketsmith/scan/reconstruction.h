#pragma once
/// @file reconstruction.h
/// From oriented points (or a whole recording) to a watertight limb surface: statistical outlier
/// removal, voxel-grid simplification, CGAL Poisson reconstruction (thesis Fig. 42), the largest
/// component, a planar cut at the proximal end (left open or capped) and optional Taubin smoothing.

#include <limits>
#include <string>
#include <vector>

#include "socketsmith/core/progress.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/scan/point_cloud.h"
#include "socketsmith/scan/recording.h"

namespace socketsmith::scan {

/// Settings of reconstruct_surface / reconstruct_recording.
struct ReconstructionOptions {
  BackProjectionOptions back_projection;  ///< used by reconstruct_recording
  bool use_outlier_removal = true;
  OutlierOptions outliers;
  double grid_cell_m = 2.5e-3;  ///< voxel-grid simplification before Poisson [m]; 0 disables
  /// Largest facet of the Poisson surface mesher: bound on the radius of its surface Delaunay
  /// balls [m] (CGAL's sm_radius × spacing); smaller is finer and slower.
  double max_facet_m = 8e-3;
  /// Bound on the distance between facet and implicit surface, relative to the average point
  /// spacing (CGAL's sm_distance); smaller is more accurate and slower.
  double poisson_distance = 0.375;
  double poisson_angle_deg = 20.0;  ///< minimum facet angle of the mesher [deg]
  /// The mesher finds the surface along its segments by bisection down to this fraction of the
  /// distance bound (CGAL's poisson_surface_reconstruction_delaunay: 1/1000, far below the sensor
  /// noise; each step evaluates the implicit function).
  double poisson_bisection_fraction = 2e-2;
  /// Relative residual at which the Poisson equation's conjugate gradient stops (CGAL's default
  /// solver runs to machine precision).
  double poisson_solver_tolerance = 1e-6;
  /// Cut the Poisson closure above the data at the proximal end: a plane normal to @p up,
  /// proximal_trim_m below the highest point.
  bool cut_proximal = true;
  bool open_proximal = false;          ///< true: leave the cut open (one boundary loop); false: cap it
  Vec3 up = Vec3::UnitZ();             ///< proximal direction (the rig's vertical) — unit length
  double proximal_trim_m = 5e-3;       ///< [m], ≥ 0
  int smoothing_iterations = 0;        ///< Taubin λ|μ pairs (λ 0.5, μ −0.53), interior vertices
  /// Every sensor must share at least this fraction of its points with another sensor (within
  /// overlap_radius_m), else the rig is broken (a wrong pose, a sensor aimed elsewhere).
  double min_overlap_fraction = 0.01;
  double overlap_radius_m = 5e-3;      ///< [m]
};

/// What the reconstruction did.
struct ReconstructionResult {
  geometry::TriMesh mesh;               ///< [m]; closed unless open_proximal
  geometry::MeshCheckReport check;      ///< check_mesh of the result
  int input_points = 0;                 ///< back-projected points (all sensors)
  int outliers_removed = 0;
  int poisson_points = 0;               ///< after grid simplification
  double average_spacing_m = 0.0;
  std::vector<int> points_per_sensor;
  std::vector<double> overlap_per_sensor;  ///< fraction of each sensor's points seen by another
  /// Height of the proximal cut plane along options.up [m] (NaN without a cut).
  double cut_height_m = std::numeric_limits<double>::quiet_NaN();
  int first_cap_triangle = -1;          ///< mesh triangles from here on are the planar cap; −1: none
  /// Wall times of the stages [s]: back-projection (incl. ray tables and the temporal median),
  /// the sensor-overlap check, outlier removal, voxel-grid simplification, the point spacing,
  /// Poisson (Delaunay refinement, solve, surface meshing), largest component + proximal cut,
  /// smoothing, the final mesh check; total.
  double back_projection_s = 0.0, overlap_s = 0.0, outliers_s = 0.0, simplify_s = 0.0, spacing_s = 0.0,
         poisson_s = 0.0, poisson_implicit_s = 0.0, poisson_mesher_s = 0.0, cut_s = 0.0, smoothing_s = 0.0, check_s = 0.0, total_s = 0.0;
  bool converged = true;                ///< false when cancelled
  std::string message;
};

/// Reconstructs a surface from oriented points (normals pointing out of the object).
/// @throws InvalidInputError for fewer than 100 points, invalid options, or a Poisson failure
///         ("the points do not enclose a volume"); TopologyError when the result is not a valid
///         surface.
ReconstructionResult reconstruct_surface(const PointCloud& cloud, const ReconstructionOptions& options = {},
                                         const ProgressCallback& progress = {});

/// Back-projects every sensor of @p recording (its frames fused per pixel, options.back_projection.fusion; with the
/// sensor's learned error compensation when it has one), checks that
/// each frame has valid pixels and that the sensors overlap, then reconstruct_surface.
/// @throws InvalidInputError for an all-invalid frame ("sensor K2: no valid depth pixel") or a
///         sensor that overlaps no other one (names the sensor and the fix).
ReconstructionResult reconstruct_recording(const Recording& recording, const ReconstructionOptions& options = {},
                                           const ProgressCallback& progress = {});

/// Merged world-frame point cloud of a recording (no filtering), and the per-sensor checks above.
PointCloud recording_point_cloud(const Recording& recording, const BackProjectionOptions& options = {});

/// Taubin smoothing (λ = 0.5, μ = −0.53, uniform weights) of the vertices not on a boundary.
void taubin_smooth(geometry::TriMesh& mesh, int iterations);

}  // namespace socketsmith::scan
