#pragma once
/// @file registration.h
/// Rigid registration of the sensors of a rig from shared reference points (thesis §4.3.2,
/// Table 2): the chessboard corners on the 30×30×70 cm box, each board seen by two neighbouring
/// sensors. Multi-set: sensor K1 fixed; repeat, for each other sensor, the SVD (Kabsch) fit of all
/// its reference points shared with any other sensor to their counterparts at once, until the
/// poses stop moving. The sequential baseline chains pairwise fits K1 ← K2 ← K3 ← K4.

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "socketsmith/core/progress.h"
#include "socketsmith/scan/chessboard.h"
#include "socketsmith/scan/recording.h"
#include "socketsmith/scan/simulated_sensor.h"

namespace socketsmith::scan {

/// One sensor's measurement of one physical reference point, in the sensor's frame [m].
struct ReferenceObservation {
  int sensor = 0;
  int point = 0;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
};

/// Reference points of a session: which sensor saw which point where.
struct ReferenceSet {
  std::vector<std::string> sensor_names;
  std::vector<std::string> point_names;  ///< e.g. "board2:i3j7"
  std::vector<ReferenceObservation> observations;
  int num_sensors() const { return static_cast<int>(sensor_names.size()); }
  /// Number of points sensors @p a and @p b both saw.
  int shared(int a, int b) const;
};

/// The rigid transform T minimising Σ |T src_i − dst_i|² (Kabsch / Horn by SVD, no reflection).
/// @throws InvalidInputError for fewer than 3 pairs, sizes that differ, or collinear points.
Eigen::Isometry3d kabsch(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst);

/// Distances between the world positions two sensors give one reference point (thesis Table 4's
/// "registration error on reference-point pairs"), over every pair of sensors that share a point.
struct PairErrors {
  double mean_m = 0.0, rms_m = 0.0, min_m = 0.0, max_m = 0.0;
  int pairs = 0;
};
PairErrors pair_errors(const ReferenceSet& refs, const std::vector<Eigen::Isometry3d>& world_from_sensor);
/// {"mean_mm", "rms_mm", "min_mm", "max_mm", "pairs"}: the reports' form of @p e.
nlohmann::json pair_errors_json(const PairErrors& e);

/// Settings of the registrations.
struct RegistrationOptions {
  int fixed_sensor = 0;          ///< its pose is kept (K1: the world frame)
  int max_iterations = 500;      ///< multi-set sweeps, ≥ 1
  double tolerance_m = 1e-9;     ///< stop when no pose moves a reference point by more than this [m]
  int min_shared_points = 6;     ///< a sensor needs at least this many points shared with others
};

/// What a registration did.
struct RegistrationResult {
  std::vector<Eigen::Isometry3d> world_from_sensor;
  PairErrors initial;   ///< pair errors at the starting poses
  PairErrors final;     ///< at the registered poses
  int iterations = 0;
  bool converged = false;
  std::string method;   ///< "multi-set" or "sequential"
};
/// {"method", "iterations", "converged", "initial", "final"} (pair_errors_json): the reports' and
/// the rig files' form of @p r.
nlohmann::json registration_json(const RegistrationResult& r);

/// Multi-set registration (thesis Table 2), starting from @p initial (one pose per sensor).
/// @throws InvalidInputError naming the sensor when one shares fewer than min_shared_points
///         points with the others ("sensors do not overlap"), or for a size mismatch.
RegistrationResult register_multiset(const ReferenceSet& refs, const std::vector<Eigen::Isometry3d>& initial,
                                     const RegistrationOptions& options = {});

/// Sequential registration: sensor k+1 fitted to sensor k alone (with k's new pose), k = fixed, …
/// in index order (K1 ← K2 ← K3 ← K4).
/// @throws InvalidInputError when a sensor shares too few points with its predecessor.
RegistrationResult register_sequential(const ReferenceSet& refs, const std::vector<Eigen::Isometry3d>& initial,
                                       const RegistrationOptions& options = {});

/// Settings of box_reference_points.
struct BoxDetectionOptions {
  /// Corner depth by a local plane fit (our estimate; the thesis's 4-pixel bilinear depth leaves
  /// the corners' full depth noise in the reference points: docs/VALIDATION.md, "Registration").
  ChessboardOptions chessboard{2, 0.01, CornerDepth::LocalPlane, 6.0};
  int max_boards_per_sensor = 2;  ///< boards looked for in each IR frame
  /// Detections of two sensors are the same board when their centroids, mapped to the world by the
  /// approximate poses, are closer than this [m] (boards on neighbouring faces are ≥ 20 cm apart).
  double same_board_distance_m = 0.10;
};

/// Finds the boards of a registration-box recording (IR + depth frames, rig.json "chessboard"):
/// every board in the mean of each sensor's IR frames (depth: median of its frames), corners with depth
/// back-projected; detections of different sensors matched into physical boards by their world
/// centroids under @p approx_world_from_sensor (e.g. the rig's hand-measured poses).
/// @throws InvalidInputError when the recording has no chessboard pattern or IR frames, or a sensor
///         sees no board ("chessboard not found in K3/ir_0000.png …").
ReferenceSet box_reference_points(const Recording& recording,
                                  const std::vector<Eigen::Isometry3d>& approx_world_from_sensor,
                                  const BoxDetectionOptions& options = {});

/// Pose error of @p estimate relative to @p truth: translation [m] and rotation angle [rad].
struct PoseError {
  double translation_m = 0.0, rotation_rad = 0.0;
};
PoseError pose_error(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth);

/// Writes a rig file: {"format": "socketsmith-scan-rig", "version": 1, "sensors": [{"name",
/// "pose_world_from_sensor"}], "registration": @p info_json} atomically. @p info_json is a JSON text
/// ("{}" for none).
void write_rig_file(const std::filesystem::path& path, const std::vector<std::string>& names,
                    const std::vector<Eigen::Isometry3d>& world_from_sensor, const std::string& info_json = "{}");

/// Replaces the pose of every sensor of @p recording by the pose of the same name in the rig file
/// @p path (a rig file of write_rig_file, or any rig.json).
/// @throws IoError for a missing file; InvalidInputError when a sensor of the recording is not in it.
void apply_rig_file(Recording& recording, const std::filesystem::path& path);

/// How far one sensor's reference points lie from the true corners of a simulated scene, in the
/// sensor frame: the error along the sensor's ray to the point (depth) and across it (lateral).
struct ReferenceAccuracy {
  std::string sensor;
  int points = 0;
  double along_mean_m = 0.0;  ///< signed mean along the ray (> 0: measured too far)
  double along_rms_m = 0.0;   ///< RMS along the ray (bias included)
  double across_rms_m = 0.0;  ///< RMS across the ray
  double rms_m = 0.0;         ///< RMS 3-D distance
};

/// Per sensor of @p refs: every observation mapped to the world by @p truth (the rendering poses)
/// is matched to the nearest inner corner of @p scene's boards (within 3 cm) and its error split
/// along / across the ray.
std::vector<ReferenceAccuracy> reference_accuracy(const ReferenceSet& refs, const Scene& scene,
                                                  const std::vector<Eigen::Isometry3d>& truth);

/// Settings of run_registration_experiment.
struct RegistrationExperimentOptions {
  int sensors = 4;
  double radius_m = 0.75;
  std::vector<CameraIntrinsics> intrinsics;  ///< 0, 1 or one per sensor (see default_rig)
  SimulationOptions simulation;
  /// The box turned about the vertical so that each board faces two neighbouring sensors at 45°
  /// (0: each sensor sees one board head-on and none is shared) [deg].
  double box_yaw_deg = 45.0;
  double pose_error_deg = 3.0;    ///< rotation of every hand-measured pose but K1's [deg]
  double pose_error_m = 0.02;     ///< and its displacement [m]
  std::uint64_t pose_seed = 7;    ///< directions of those errors
  RegistrationOptions registration;
  BoxDetectionOptions detection;
  /// Learned error compensation of each unit (scan calibrate / scan experiment chessboard with the
  /// same seed and intrinsics): empty, or one per sensor; adds the "multi-set + compensation" row.
  std::vector<ErrorCompensation> compensation;
};

/// The thesis's Table 4 on a simulated session: the box recorded by a ring rig, the rig's poses
/// perturbed ("hand-measured"), reference points found, sequential and multi-set registration.
struct RegistrationExperimentResult {
  std::vector<SimulatedSensor> rig;
  std::vector<Eigen::Isometry3d> truth;     ///< the poses the frames were rendered with
  std::vector<Eigen::Isometry3d> measured;  ///< the perturbed starting poses
  Recording recording;
  ReferenceSet refs;
  RegistrationResult sequential, multiset;
  std::vector<PoseError> measured_pose_errors, sequential_pose_errors, multiset_pose_errors;
  PairErrors truth_errors;  ///< pair errors at the true poses: what depth errors alone leave
  std::vector<ReferenceAccuracy> accuracy, accuracy_compensated;  ///< reference points against the true corners
  /// With options.compensation: the corners corrected by each unit's model, multi-set again.
  ReferenceSet refs_compensated;
  RegistrationResult multiset_compensated;
  std::vector<PoseError> multiset_compensated_pose_errors;
  PairErrors truth_errors_compensated;
};
RegistrationExperimentResult run_registration_experiment(const RegistrationExperimentOptions& options = {},
                                                         const ProgressCallback& progress = {});

}  // namespace socketsmith::scan
