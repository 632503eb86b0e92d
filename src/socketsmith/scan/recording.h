#pragma once
/// @file recording.h
/// A scan session on disk (docs/scan.md): a folder with `rig.json` (the sensors, their
/// intrinsics files, poses world←sensor in metres and depth scales) and one sub-folder per
/// sensor with `intrinsics.json` and `depth_XXXX.png` frames (16-bit, mm by default), optionally
/// the pixel-aligned IR frames `ir_XXXX.png` and the chessboard target's pattern.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "socketsmith/scan/depth_image.h"
#include "socketsmith/scan/error_compensation.h"
#include "socketsmith/scan/intrinsics.h"

namespace socketsmith::scan {

/// One sensor of a recording and its frames of a static scene.
struct SensorRecording {
  std::string name;                    ///< e.g. "K1"; also the sub-folder name
  CameraIntrinsics intrinsics;
  /// Pose of the sensor: maps sensor-frame points (OpenCV: x right, y down, z forward) to the
  /// world frame [m].
  Eigen::Isometry3d world_from_sensor = Eigen::Isometry3d::Identity();
  double depth_scale_m = 1e-3;         ///< metres per raw depth unit (1e-3: mm)
  std::vector<DepthImage> frames;      ///< at least one
  std::vector<std::string> frame_files;  ///< file names, same order (filled by read_recording)
  /// IR (amplitude) frames aligned with the depth frames: empty, or one per depth frame.
  std::vector<IrImage> ir_frames;
  /// Learned error compensation applied by the back-projection (rig.json "compensation": a model
  /// file written by scan calibrate, path relative to the recording), if any.
  std::optional<ErrorCompensation> compensation;
};

/// The printed pattern of a chessboard target: inner-corner grid and square size.
struct ChessboardPattern {
  int inner_cols = 9;      ///< inner corners along a row (squares per row − 1), ≥ 2
  int inner_rows = 6;      ///< inner corners along a column, ≥ 2
  double square_m = 0.06;  ///< side of a square [m], > 0
};

/// @throws InvalidInputError naming @p what when the pattern is not usable (fewer than 2×2 inner
///         corners, more than 100 either way, or a non-positive square).
void validate_pattern(const ChessboardPattern& pattern, const std::string& what);

/// A whole session.
struct Recording {
  std::vector<SensorRecording> sensors;
  std::string description;  ///< free text (e.g. what was simulated)
  /// The chessboard target of a calibration/registration session (rig.json "chessboard"), if any.
  std::optional<ChessboardPattern> chessboard;
  /// Consecutive frames of each sensor that show the same static board pose (rig.json
  /// "frames_per_pose", default 1): scan calibrate fuses each group into one observation.
  int frames_per_pose = 1;
};

/// Reads a recording folder: rig.json, every sensor's intrinsics (project JSON, iai_kinect2 YAML
/// folder or Open3D JSON, path relative to the recording) and its `depth_*.png` frames (sorted
/// by name) or the list "frames" of rig.json; the `ir_*.png` frames when present (or the list
/// "ir_frames"), which must then match the depth frames in number and size.
/// @throws IoError for a missing folder, rig.json, intrinsics or frame; InvalidInputError for a
///         malformed rig.json, a pose that is not a rigid transform, a frame of the wrong bit depth
///         or size, or a sensor without frames.
Recording read_recording(const std::filesystem::path& folder);

/// A one-sensor recording of loose depth frames of a static scene from one camera (e.g. the
/// open3d_sample frames): the sensor "frame" at the world origin (identity pose, OpenCV axes),
/// intrinsics from @p intrinsics (any kind read_intrinsics reads), @p depth_scale_m metres per raw
/// unit (0.001 for mm, 0.0002 for TUM's 5000 per metre).
/// @throws IoError for a missing file; InvalidInputError for no frames, a frame of the wrong bit
///         depth or size, or an invalid scale.
Recording recording_from_frames(const std::vector<std::filesystem::path>& frames,
                                const std::filesystem::path& intrinsics, double depth_scale_m = 1e-3);

/// Writes @p recording to @p folder (created if needed): rig.json, <name>/intrinsics.json and
/// <name>/depth_0000.png… and <name>/ir_0000.png… when the sensor has IR frames (every file atomically).
void write_recording(const std::filesystem::path& folder, const Recording& recording);

/// Parses a row-major 4×4 rigid transform (array of 4 arrays of 4 numbers, last row 0 0 0 1).
/// @throws InvalidInputError when it is not a rotation (|RᵀR − I| > 1e-4 or det < 0) + translation.
Eigen::Isometry3d pose_from_rows(const std::vector<std::vector<double>>& rows, const std::string& what);

}  // namespace socketsmith::scan
