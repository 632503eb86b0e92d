#pragma once
/// @file sensor_calibration.h
/// Learning a sensor's error compensation ε = LR(u, v, d) from frames of a chessboard of known
/// square size (thesis §4.2.4, eqs. 29–35), and the chessboard dimension errors of Table 3
/// (eqs. 24–25). See docs/scan.md, "Error compensation". This calibrates a depth sensor's
/// errors (applied by error_compensation.h); its intrinsics and their readers are intrinsics.h.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/core/progress.h"
#include "socketsmith/scan/chessboard.h"
#include "socketsmith/scan/error_compensation.h"
#include "socketsmith/scan/recording.h"

namespace socketsmith::scan {

/// How the true corner positions of a calibration frame are estimated.
enum class TruthEstimate {
  /// The board's pose from its sub-pixel corners in the IR image (cv::calibrateCamera over the
  /// session refines f_x, f_y — principal point and distortion kept — then the pose of each frame):
  /// depth-independent, so depth biases are learned too (the default).
  Pnp,
  /// The thesis's estimate (eqs. 31–35): the ideal grid fitted rigidly (SVD) to the measured 3-D
  /// corners about the board point on the optical axis (the "focal centre", kept at its measured
  /// depth): lateral errors are learned, a depth offset is not seen.
  Kabsch,
};

/// Settings of calibrate_sensor.
struct SensorCalibrationOptions {
  ChessboardOptions chessboard;
  TruthEstimate truth = TruthEstimate::Pnp;
  CompensationForm form = CompensationForm::LinearUvd;  ///< the model fitted
  int depth_degree = 3;  ///< RayPolynomial: highest power of d in the depth correction
  /// TruthEstimate::Pnp: also refine the radial distortion k1, k2, k3 over the session (not only
  /// f_x, f_y). A unit whose rays are scaled by 1 + e relative to its calibration sees the lens
  /// distortion at a radius scaled by 1 + e too, which refined focal lengths alone cannot express
  /// (the k_n r^2n term changes by ≈ 2n e k_n r^2n: ≈ 0.6 % of x at the image corner of a real
  /// Kinect v2 calibration for e = 3.5 %).
  bool refine_distortion = false;
  int min_frames = 5;  ///< fewer usable board frames (poses) is an error (the thesis used ≈ 50)
  /// Consecutive frames of one static board pose fused into one observation (a recording's
  /// frames_per_pose): depth by #fusion, IR by the per-pixel mean — less noise on the corners and
  /// their depth, and boards found in IR frames too noisy one by one. The sensor's frame count
  /// must be a multiple of it.
  int frames_per_pose = 1;
  FrameFusion fusion = FrameFusion::TrimmedMean;  ///< depth fusion of a pose's frames
};

/// One frame's detected corners and their estimated truth (sensor frame).
struct BoardObservation {
  int frame = 0;  ///< index into the sensor's frames (the first of its pose's frames)
  ChessboardDetection detection;
  std::vector<Eigen::Vector3d> truth;  ///< per corner, same order as detection.corners [m]
};

/// What calibrate_sensor learned and how well it fits its own data.
struct SensorCalibrationResult {
  ErrorCompensation model;
  std::vector<BoardObservation> observations;
  std::vector<std::string> skipped;  ///< frames without a usable board, with the reason
  double fx = 0.0, fy = 0.0;         ///< focal lengths used for the truth (refined for Pnp) [px]
  double rms_before_mm = 0.0;        ///< RMS 3-D distance of the measured corners to the truth
  double rms_after_mm = 0.0;         ///< … after compensation (training data)
};

/// Detects the board in every frame of @p sensor (IR + depth; or in every pose's fused frames,
/// options.frames_per_pose), estimates the true corners and
/// fits ε = LR(u, v, d) by least squares on P − P_true = ε P (eq. 29 multiplied out by P, so points
/// near the optical axis do not divide by ≈ 0), then once more without residuals beyond 5 MADs.
/// @throws InvalidInputError when the sensor has no IR frames, fewer than options.min_frames
///         frames show the board, or too few corners have depth.
SensorCalibrationResult calibrate_sensor(const SensorRecording& sensor, const ChessboardPattern& pattern,
                                         const SensorCalibrationOptions& options = {}, const ProgressCallback& progress = {});

/// Summary of dimension errors: mean and standard deviation over all adjacent-corner distances,
/// and the mean over the grid's border (Table 3's "edge points").
struct DimensionStats {
  double mean_mm = 0.0, sd_mm = 0.0;
  double border_mean_mm = 0.0;
  int count = 0;  ///< distances
};

/// Chessboard dimension errors (thesis eq. 24): accumulates |distance between adjacent corners −
/// square| over pairs of horizontally (along i) and vertically (along j) adjacent corners that
/// have depth, over several frames.
struct EdgeErrors {
  std::vector<double> all, border;  ///< [mm]
  void add(const ChessboardDetection& detection, const std::vector<Eigen::Vector3d>& points);
  DimensionStats stats() const;
};

/// Corners of @p detection corrected by @p model ((I − ε) P), or unchanged when null.
std::vector<Eigen::Vector3d> compensated_corners(const ChessboardDetection& detection, const ErrorCompensation* model);

/// A calibration's dimension errors on its own training poses, without and with the model it
/// learned (`scan calibrate`'s "dimension_error_mm"; the held-out frames are the chessboard
/// experiment's, experiments.h).
struct TrainingDimensionErrors {
  DimensionStats before, after;
};
TrainingDimensionErrors training_dimension_errors(const SensorCalibrationResult& result);

}  // namespace socketsmith::scan
