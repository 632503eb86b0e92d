#pragma once
/// @file simulated_sensor.h
/// A simulated Kinect v2: ray-casts a triangle mesh from posed sensors with real intrinsics
/// (one ray per pixel, undistorted, so the frames carry the lens distortion of the calibration)
/// and a seeded time-of-flight error model. Scene helpers for the thesis's targets (cylinders,
/// the 30×30×70 cm box, a chessboard board) and a ring rig.

#include <cstdint>
#include <string>
#include <vector>

#include "socketsmith/core/progress.h"
#include "socketsmith/geometry/surface_query.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/scan/recording.h"

namespace socketsmith::scan {

using Vec3 = Eigen::Vector3d;

/// Seeded depth error model of a time-of-flight sensor. Measured depth of a pixel that sees the
/// true depth d at normalised image radius ρ (0 at the principal point, 1 at the image corner):
///   d̃ = d + s·[b0 + o + b1 (d − 1 m) + w sin(2π d / λ) + r ρ²] + s·N(0, σ(d)²),
///   σ(d) = σ0 + σ2 d²,
/// then quantised to the raw unit. s = scale (0: noise free); o = this unit's own offset (real units
/// differ: simulate_recording draws o ~ N(0, sensor_offset_sd_m²) per sensor from the seed). Kinect v2 literature: 1–3 mm noise
/// growing with distance, a few mm of systematic "wiggling" error, flying pixels at edges.
struct SensorErrorModel {
  double scale = 1.0;                  ///< multiplies every error term and probability below, ≥ 0
  double bias_m = 1.5e-3;              ///< b0: depth bias at 1 m [m] (positive: measured too far)
  double bias_slope = 1.0e-3;          ///< b1: bias growth per metre of depth [m/m]
  double sensor_offset_m = 0.0;        ///< o: this unit's constant offset [m] (set per sensor)
  double sensor_offset_sd_m = 1.5e-3;  ///< spread of o between units, used by simulate_recording [m]
  double wiggle_amplitude_m = 1.5e-3;  ///< w: amplitude of the sinusoidal "wiggling" error [m]
  double wiggle_period_m = 0.5;        ///< λ: its period in depth [m], > 0
  double radial_bias_m = 3.0e-3;       ///< r: extra bias at the image corners (∝ ρ²) [m]
  double noise_sigma0_m = 0.8e-3;      ///< σ0 [m]
  double noise_sigma2_per_m = 1.0e-3;  ///< σ2 [1/m]: σ(0.75 m) ≈ 1.4 mm, σ(1.5 m) ≈ 3 mm
  /// Probability that a pixel at a depth edge (a 4-neighbour missing or > edge_jump_m away) is a
  /// flying pixel: depth mixed between its foreground and background, t ~ U(0.1, 0.9).
  double flying_pixel_probability = 0.5;
  double edge_jump_m = 0.03;               ///< depth step that makes an edge [m]
  double flying_background_m = 0.5;        ///< background depth behind a silhouette: d + this [m]
  double random_invalid_probability = 0.002;  ///< pixels randomly lost (0 in the frame)
  double grazing_limit_rad = 1.40;         ///< incidence angles above this (≈ 80°) return nothing
  double min_range_m = 0.5;                ///< Kinect v2 near limit [m]
  double max_range_m = 4.5;                ///< Kinect v2 far limit [m]
};

/// A posed simulated sensor.
struct SimulatedSensor {
  std::string name = "K1";
  CameraIntrinsics intrinsics = kinect_v2_typical_intrinsics();
  Eigen::Isometry3d world_from_sensor = Eigen::Isometry3d::Identity();  ///< OpenCV camera axes
};

/// Pose of a camera at @p eye looking at @p target with world @p up pointing up in the image
/// (OpenCV axes: z forward, x right, y down). @throws InvalidInputError when eye == target or the
/// view direction is parallel to @p up.
Eigen::Isometry3d look_at(const Vec3& eye, const Vec3& target, const Vec3& up = Vec3::UnitZ());

/// @p n sensors evenly on a horizontal circle of @p radius_m around @p target, @p height_m above
/// it, each looking at @p target (thesis: 4 sensors, 75 cm from the centre). Names K1…Kn.
/// @param intrinsics one per sensor, or one for all, or empty (typical Kinect v2).
std::vector<SimulatedSensor> default_rig(int n, double radius_m = 0.75, double height_m = 0.0,
                                         const Vec3& target = Vec3::Zero(),
                                         const std::vector<CameraIntrinsics>& intrinsics = {});

/// Renders one depth frame of @p scene (raw units of @p depth_scale_m, 0 = no return).
/// Rows are ray-cast in parallel (OpenMP); noise comes from @p seed only (deterministic).
DepthImage simulate_depth(const geometry::SurfaceQuery& scene, const SimulatedSensor& sensor,
                          const SensorErrorModel& model, std::uint64_t seed, double depth_scale_m = 1e-3);

/// Settings of simulate_recording.
struct SimulationOptions {
  SensorErrorModel error;
  std::uint64_t seed = 1;
  int frames = 1;               ///< frames per sensor (independent noise), 1 to 100
  double depth_scale_m = 1e-3;  ///< raw unit of the PNGs [m]
};

/// Renders every sensor (each with its own seed stream) into a recording.
/// @throws InvalidInputError for an empty scene, no sensors, or invalid model parameters.
Recording simulate_recording(const geometry::TriMesh& scene, const std::vector<SimulatedSensor>& sensors,
                             const SimulationOptions& options = {}, const ProgressCallback& progress = {});

/// Closed cylinder along z (axis through @p center), @p segments around, outward normals.
geometry::TriMesh make_cylinder(double diameter_m, double height_m, const Vec3& center = Vec3::Zero(),
                                int segments = 256, int rings = 16);

/// Closed axis-aligned box of the given sizes centred at @p center (thesis calibration box:
/// 0.30 × 0.30 × 0.70 m), each face split into a grid of ≈ 2 cm cells.
geometry::TriMesh make_box(const Vec3& size_m, const Vec3& center = Vec3::Zero());

/// A flat chessboard target: a thin closed slab of cols × rows squares of @p square_m, front face
/// facing −y (towards a sensor on the −y side), centred at @p center, @p thickness_m deep.
/// Depth-only: the squares share one plane (the pattern matters for the IR image, part 2).
geometry::TriMesh make_chessboard(int cols, int rows, double square_m, const Vec3& center = Vec3::Zero(),
                                  double thickness_m = 0.01);

}  // namespace socketsmith::scan
