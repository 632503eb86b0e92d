#pragma once
/// @file experiments.h
/// The thesis's scan accuracy experiments repeated on simulated recordings (docs/VALIDATION.md,
/// "Scan"): chessboard dimension errors without/with the learned compensation on held-out frames
/// (Table 3 style) and cylinders of 10, 16 and 21 cm scanned by four sensors (RMSE and maximum
/// error against the analytic cylinder, point cloud and reconstructed mesh). Seeded, deterministic.

#include <cstdint>
#include <string>
#include <vector>

#include "socketsmith/core/progress.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/scan/sensor_calibration.h"
#include "socketsmith/scan/simulated_sensor.h"

namespace socketsmith::scan {

/// Settings shared by the experiments.
struct ExperimentOptions {
  std::uint64_t seed = 1;          ///< units' errors, training and test frames all derive from it
  int sensors = 4;                 ///< K1…Kn (the thesis: 4)
  int training_frames = 50;        ///< board frames per sensor for learning (thesis ≈ 50, 50–100 cm)
  int test_frames_per_distance = 5;  ///< held-out frames at each of 60, 75, 90 cm (thesis: one each)
  int scan_frames = 1;             ///< cylinder experiment: frames per sensor, fused per pixel by scan_fusion
  FrameFusion scan_fusion = FrameFusion::Median;  ///< how the cylinder scans' frames are fused
  /// Frames of each training board pose, fused (SensorCalibrationOptions::frames_per_pose); the
  /// held-out frames stay single frames, measured the thesis's way.
  int board_frames_per_pose = 1;
  double noise_scale = 1.0;        ///< SensorErrorModel::scale (every term)
  double systematic_scale = 1.0;   ///< and the systematic terms once more (scale_systematic_errors)
  std::vector<CameraIntrinsics> intrinsics;  ///< of the rig: none (typical), one, or one per sensor
  TruthEstimate truth = TruthEstimate::Pnp;
  /// Depth at the corners of the training frames (the held-out frames are measured the thesis's
  /// way, CornerDepth::Bilinear).
  CornerDepth training_corner_depth = CornerDepth::Bilinear;
  CompensationForm form = CompensationForm::LinearUvd;  ///< the model learned
  int depth_degree = 3;  ///< of a RayPolynomial model
  bool refine_distortion = false;  ///< SensorCalibrationOptions::refine_distortion
};

/// Table 3 row: one sensor, one test distance (or all).
struct ChessboardRow {
  std::string sensor;
  double distance_m = 0.0;  ///< 0: all test frames
  DimensionStats raw, compensated;
};

struct ChessboardExperiment {
  std::vector<ChessboardRow> rows;       ///< per sensor: all, then 0.60, 0.75, 0.90 m
  std::vector<SensorCalibrationResult> calibrations;  ///< per sensor (models learned on the training frames)
  std::vector<SimulatedSensor> rig;
  SensorErrorModel base_error;
  int test_frames_missed = 0;  ///< held-out frames where the board was not found (left out)
  double wall_s = 0.0;
};

/// Learns each sensor's model on its training session and measures dimension errors on held-out
/// frames of the same units (other poses and noise) at 60, 75 and 90 cm.
ChessboardExperiment run_chessboard_experiment(const ExperimentOptions& options, const ProgressCallback& progress = {});

/// Error of a scanned cylinder against the analytic one (axis z through the origin).
struct SurfaceError {
  double rmse_mm = 0.0, max_mm = 0.0, mean_mm = 0.0;  ///< of the radial distance, signed mean
  int count = 0;
};

struct CylinderRow {
  double diameter_m = 0.0;
  SurfaceError cloud_raw, cloud_compensated;  ///< filtered point cloud (outliers removed)
  SurfaceError mesh_raw, mesh_compensated;    ///< reconstructed watertight mesh (vertices and facet centroids)
  bool mesh_done = false;
};

struct CylinderExperiment {
  std::vector<CylinderRow> rows;
  double wall_s = 0.0;
};

/// Scans cylinders of @p diameters_m (400 mm tall, 4-sensor ring at 75 cm) with the units of
/// @p chessboard's rig and measures them without/with the models it learned; errors within the
/// middle @p band_m of the height.
CylinderExperiment run_cylinder_experiment(const ChessboardExperiment& chessboard, const ExperimentOptions& options,
                                           const std::vector<double>& diameters_m = {0.10, 0.16, 0.21},
                                           bool reconstruct_meshes = true, double band_m = 0.3,
                                           const ProgressCallback& progress = {});

/// Radial error of @p points against the z-axis cylinder of @p radius_m within |z| ≤ half_band_m.
SurfaceError cylinder_error(const std::vector<Eigen::Vector3d>& points, double radius_m, double half_band_m);
/// The same for a surface, sampled at its vertices and its triangles' centroids (so that coarse
/// facets count too).
SurfaceError cylinder_error(const geometry::TriMesh& mesh, double radius_m, double half_band_m);

}  // namespace socketsmith::scan
