#pragma once
/// @file simulated_sensor.h
/// A simulated Kinect v2: ray-casts a triangle mesh from posed sensors with real intrinsics
/// (one ray per pixel, undistorted, so the frames carry the lens distortion of the calibration)
/// and a seeded time-of-flight error model, producing the depth frame and the pixel-aligned IR
/// (amplitude) frame. Scenes may carry printed chessboards (seen in the IR image). Scene helpers
/// for the thesis's targets (cylinders, the 30×30×70 cm box with a chessboard on each side, a
/// chessboard board), a ring rig and a simulated calibration session.

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
  /// σ multiplier on black (IR albedo 0.05) relative to bright (≥ 0.7) surfaces, linear in between
  /// (thesis §4.2.1: ≈ 1 mm on white, ≈ 3 mm on black), ≥ 1.
  double dark_noise_factor = 2.5;
  /// This unit's lateral scale errors: the true rays are the calibration's divided by (1 + s·e) per
  /// axis, so a back-projected point lies a factor (1 + s·e_x, 1 + s·e_y) too far from the optical
  /// axis (an imperfect factory/OpenCV intrinsic calibration; thesis §4.2.1: recalibration did
  /// not remove the dimension errors). simulate_recording draws them per unit with ray_scale_sd.
  double ray_scale_x = 0.0, ray_scale_y = 0.0;
  double ray_scale_sd = 0.012;  ///< spread of ray_scale_x/y between units (relative)
  double ir_counts_at_1m = 12000;      ///< IR amplitude of albedo 1 at 1 m, normal incidence [counts]
  double ir_noise_relative = 0.03;     ///< IR noise σ relative to the amplitude (× scale)
  double ir_noise_floor = 150;         ///< IR noise σ floor [counts] (× scale)
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

/// @p model with its systematic terms — depth bias b0 and slope b1, the spread of the units'
/// offsets, wiggling, radial bias, the spread of the units' lateral scale errors — multiplied by
/// @p factor (≥ 0), the random ones (noise σ, IR noise, flying pixels, losses) kept: a unit whose
/// learnable errors are larger (factor > 1) or absent (0: only what no compensation can remove).
/// @throws InvalidInputError for a negative or non-finite factor.
SensorErrorModel scale_systematic_errors(SensorErrorModel model, double factor);

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

/// A chessboard printed on a planar face of a scene. Board frame: origin at the centre of the
/// squares, x along a row of the pattern (inner-corner index i), y along a column (index j), z into
/// the board: the pattern is seen from the −z side (a camera whose axes equal the board's sees it
/// head-on and unmirrored). Square (a, b) (a along x from 0 to inner_cols, b along y) is black when
/// a + b is even, so inner corner (0, 0) touches the black corner square.
struct ChessboardPatch {
  ChessboardPattern pattern;
  double margin_m = 0.06;  ///< white border around the squares [m], ≥ 0
  Eigen::Isometry3d world_from_board = Eigen::Isometry3d::Identity();

  /// Inner corner (i, j) in the board frame (z = 0) [m].
  Vec3 corner_in_board(int i, int j) const;
  /// Inner corner (i, j) in the world [m].
  Vec3 corner(int i, int j) const { return world_from_board * corner_in_board(i, j); }
  /// IR albedo at board coordinates (x, y) [m]: 0.05 on black squares, 0.9 on white squares and the
  /// margin, −1 outside the board.
  double albedo_at(double x, double y) const;
  /// Half extents of the board (squares + margin) along x and y [m].
  Eigen::Vector2d half_size() const;
};

/// A scene to scan: a closed mesh, chessboards printed on some of its planar faces, and the IR
/// albedo of the rest of its surface.
struct Scene {
  geometry::TriMesh mesh;
  std::vector<ChessboardPatch> chessboards;
  double albedo = 0.7;  ///< IR albedo outside the boards, in (0, 1]
};

/// One simulated frame: depth and the pixel-aligned IR amplitude.
struct SimulatedFrame {
  DepthImage depth;
  IrImage ir;
};

/// Renders one frame of @p scene as @p sensor sees it: depth in raw units of @p depth_scale_m
/// (0 = no return) with the error model, and the IR amplitude (albedo × cos(incidence) / range²,
/// chessboard squares antialiased by 8×8 sub-pixel rays, with noise). Rows are ray-cast in
/// parallel (OpenMP); noise comes from @p seed only (deterministic). @p query must be built on
/// scene.mesh.
SimulatedFrame simulate_frame(const geometry::SurfaceQuery& query, const Scene& scene, const SimulatedSensor& sensor,
                              const SensorErrorModel& model, std::uint64_t seed, double depth_scale_m = 1e-3);

/// Several frames of the static @p scene, one per seed: the ray casting and the albedo are done
/// once, the errors drawn per frame (frame q equals simulate_frame with seeds[q]).
std::vector<SimulatedFrame> simulate_frames(const geometry::SurfaceQuery& query, const Scene& scene,
                                            const SimulatedSensor& sensor, const SensorErrorModel& model,
                                            const std::vector<std::uint64_t>& seeds, double depth_scale_m = 1e-3);

/// The depth frame of simulate_frame for a scene without chessboards.
DepthImage simulate_depth(const geometry::SurfaceQuery& scene, const SimulatedSensor& sensor,
                          const SensorErrorModel& model, std::uint64_t seed, double depth_scale_m = 1e-3);

/// Settings of simulate_recording.
struct SimulationOptions {
  SensorErrorModel error;
  std::uint64_t seed = 1;
  int frames = 1;               ///< frames per sensor (independent noise), 1 to 100
  double depth_scale_m = 1e-3;  ///< raw unit of the PNGs [m]
};

/// The error model of unit @p index of a session seeded with @p seed: @p base with this unit's
/// constant offset and lateral scale errors drawn from their spreads (what simulate_recording uses).
SensorErrorModel unit_error_model(const SensorErrorModel& base, std::uint64_t seed, size_t index);

/// Renders every sensor (each with its own seed stream and unit errors, unit_error_model) into a
/// recording with depth and IR frames; the recording's chessboard pattern is that of the scene's
/// first board, if any.
/// @throws InvalidInputError for an empty scene, no sensors, or invalid model parameters.
Recording simulate_recording(const Scene& scene, const std::vector<SimulatedSensor>& sensors,
                             const SimulationOptions& options = {}, const ProgressCallback& progress = {});
/// The same for a scene without chessboards (albedo 0.7).
Recording simulate_recording(const geometry::TriMesh& scene, const std::vector<SimulatedSensor>& sensors,
                             const SimulationOptions& options = {}, const ProgressCallback& progress = {});

/// Settings of simulate_calibration_session.
struct CalibrationSessionOptions {
  SimulationOptions simulation;   ///< seed, frames per sensor (thesis ≈ 50), error model
  double min_distance_m = 0.55;   ///< board distance range along the optical axis [m] (thesis 50–100 cm)
  double max_distance_m = 1.0;
  double max_tilt_rad = 0.5;      ///< board yaw and pitch drawn in ±this [rad] (≈ 29°); roll in ±a third of it
  ChessboardPatch board = ChessboardPatch{ChessboardPattern{9, 6, 0.06}, 0.06, Eigen::Isometry3d::Identity()};
  /// Seed of the board poses and frame noise; 0: simulation.seed. The units' errors always come
  /// from simulation.seed, so held-out frames of the same units take another frame_seed.
  std::uint64_t frame_seed = 0;
  /// Frames recorded of each board pose (independent noise), 1 to 30: simulation.frames poses ×
  /// this many frames, stored pose by pose (a real session holds the board still for a moment at
  /// 30 fps); the recording's frames_per_pose tells scan calibrate to fuse them.
  int frames_per_pose = 1;
};

/// A simulated calibration session: every sensor (its unit errors as in simulate_recording with
/// the same seed, so a model learned here applies to that unit) records frames of the board in a
/// random pose per frame (or per options.frames_per_pose frames) — distance, tilt and offset drawn so that all inner corners are in view
/// (≥ 12 px from the border). The recording's chessboard is the board's pattern.
/// @throws InvalidInputError for an invalid range, no sensors, or a board that cannot fit the view.
Recording simulate_calibration_session(const std::vector<SimulatedSensor>& sensors,
                                       const CalibrationSessionOptions& options = {},
                                       const ProgressCallback& progress = {});

/// Closed cylinder along z (axis through @p center), @p segments around, outward normals.
geometry::TriMesh make_cylinder(double diameter_m, double height_m, const Vec3& center = Vec3::Zero(),
                                int segments = 256, int rings = 16);

/// Closed axis-aligned box of the given sizes centred at @p center (thesis calibration box:
/// 0.30 × 0.30 × 0.70 m), each face split into a grid of ≈ 2 cm cells.
geometry::TriMesh make_box(const Vec3& size_m, const Vec3& center = Vec3::Zero());

/// A flat chessboard target: a thin closed slab of cols × rows squares of @p square_m, front face
/// facing −y (towards a sensor on the −y side), centred at @p center, @p thickness_m deep.
/// The mesh only; chessboard_facing_minus_y gives the same board with its printed pattern.
geometry::TriMesh make_chessboard(int cols, int rows, double square_m, const Vec3& center = Vec3::Zero(),
                                  double thickness_m = 0.01);

/// The calibration target (thesis: an A0 chessboard at 50–100 cm): 10 × 7 squares of 60 mm (9 × 6
/// inner corners) with a 60 mm white margin, 720 × 540 mm — a full A0 pattern would not fit the
/// Kinect v2's 70 × 58 cm field of view at 50 cm. Posed by @p world_from_board (see ChessboardPatch).
ChessboardPatch calibration_chessboard(const Eigen::Isometry3d& world_from_board = Eigen::Isometry3d::Identity());

/// @p board as a scene: a closed slab spanning the board (squares + margin), its front face the
/// printed plane, @p thickness_m deep behind it.
/// @throws InvalidInputError for an invalid pattern, margin or thickness.
Scene make_chessboard_scene(const ChessboardPatch& board, double thickness_m = 0.01);

/// The registration box (thesis: 30 × 30 × 70 cm) with a chessboard centred on each of its four
/// vertical faces (rows horizontal, columns down the face, seen from outside), posed by
/// @p world_from_box (box centred at its origin, z up). Boards in the order +x, +y, −x, −y faces.
/// Default pattern: 5 × 12 squares of 50 mm (4 × 11 inner corners), 25 mm margin, filling the
/// 300 mm width. @throws InvalidInputError when the board does not fit a face.
Scene make_box_scene(const Vec3& size_m = Vec3(0.30, 0.30, 0.70),
                     const Eigen::Isometry3d& world_from_box = Eigen::Isometry3d::Identity(),
                     const ChessboardPattern& pattern = ChessboardPattern{4, 11, 0.05}, double margin_m = 0.025);

}  // namespace socketsmith::scan
