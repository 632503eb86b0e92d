#pragma once
/// @file intrinsics.h
/// Depth-camera intrinsics (pinhole + Brown–Conrady distortion, OpenCV's 5-coefficient model) and
/// their readers: the project's JSON, the OpenCV YAML calibrations of iai_kinect2
/// (`calib_ir.yaml` + `calib_depth.yaml`) and Open3D's `camera_*.json`. Per-pixel ray tables
/// (undistorted normalised image coordinates) for back-projection and ray casting.

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace socketsmith::scan {

/// Intrinsics of a depth camera. Pixel (u, v) has its centre at integer coordinates (OpenCV).
/// Distortion maps normalised coordinates (x, y) = (X/Z, Y/Z) to distorted ones:
/// r² = x² + y², x_d = x (1 + k1 r² + k2 r⁴ + k3 r⁶) + 2 p1 x y + p2 (r² + 2 x²),
/// y_d = y (1 + k1 r² + k2 r⁴ + k3 r⁶) + p1 (r² + 2 y²) + 2 p2 x y; then u = fx x_d + cx, v = fy y_d + cy.
struct CameraIntrinsics {
  int width = 512;    ///< [px], > 0 (Kinect v2 depth: 512)
  int height = 424;   ///< [px], > 0 (Kinect v2 depth: 424)
  double fx = 366.4;  ///< focal length along u [px], > 0
  double fy = 367.1;  ///< focal length along v [px], > 0
  double cx = 255.6;  ///< principal point [px]
  double cy = 204.0;  ///< principal point [px]
  double k1 = 0.0, k2 = 0.0, p1 = 0.0, p2 = 0.0, k3 = 0.0;  ///< distortion (OpenCV order), dimensionless
  /// Added to every valid depth reading to correct the sensor's offset [m] (iai_kinect2's
  /// `depthShift`, stored there in mm): d = raw·scale + depth_shift_m.
  double depth_shift_m = 0.0;

  bool has_distortion() const { return k1 != 0.0 || k2 != 0.0 || p1 != 0.0 || p2 != 0.0 || k3 != 0.0; }
};

/// Typical Kinect v2 depth intrinsics (512×424, fx ≈ fy ≈ 366 px) with a typical mild distortion;
/// used when no calibration is given.
CameraIntrinsics kinect_v2_typical_intrinsics();

/// @throws InvalidInputError naming @p what when a size or focal length is not positive, the
///         principal point lies outside the image, or a value is not finite.
void validate_intrinsics(const CameraIntrinsics& intrinsics, const std::string& what);

/// Pixel coordinates of the normalised image point (x, y) = (X/Z, Y/Z) (distortion applied).
Eigen::Vector2d project_normalised(const CameraIntrinsics& intrinsics, const Eigen::Vector2d& xy);

/// Undistorted normalised coordinates of pixel (u, v): the inverse of project_normalised
/// (OpenCV's cv::undistortPoints, refined by Newton steps to < 1e-6 px). NaN when the pixel has no
/// inverse: a calibrated polynomial can fold back beyond its maximal radius (image corners).
Eigen::Vector2d unproject_pixel(const CameraIntrinsics& intrinsics, const Eigen::Vector2d& uv);

/// Per-pixel rays of an image of width·upsample × height·upsample pixels: the undistorted
/// normalised coordinates (x, y) of each pixel centre, row-major, so that the camera-frame point
/// of depth d (along the optical axis) is (x d, y d, d) (thesis eq. 22 with undistortion).
/// Pixels without a valid inverse (see unproject_pixel) hold NaN and are never used.
struct RayTable {
  int width = 0;     ///< [px] of the (up-sampled) image
  int height = 0;    ///< [px]
  int upsample = 1;  ///< factor relative to the sensor's resolution
  std::vector<Eigen::Vector2d> xy;  ///< #width·height normalised coordinates
  const Eigen::Vector2d& at(int u, int v) const { return xy[static_cast<size_t>(v) * width + u]; }
};

/// Builds the ray table of @p intrinsics for an image up-sampled by @p upsample (≥ 1): pixel (U, V)
/// of the up-sampled image sits at sensor pixel ((U + 0.5)/N − 0.5, (V + 0.5)/N − 0.5).
/// @throws InvalidInputError for invalid intrinsics or upsample outside [1, 8].
RayTable make_ray_table(const CameraIntrinsics& intrinsics, int upsample = 1);

/// Reads the project's intrinsics JSON: {"width", "height", "fx", "fy", "cx", "cy", "k1", "k2",
/// "p1", "p2", "k3", "depth_shift_mm"} (distortion and shift optional, default 0). See docs/scan.md.
/// @throws IoError when the file cannot be opened; InvalidInputError for bad JSON, a missing or
///         unknown key, or invalid values.
CameraIntrinsics read_intrinsics_json(const std::filesystem::path& path);

/// Writes @p intrinsics as the project's JSON, atomically.
void write_intrinsics_json(const std::filesystem::path& path, const CameraIntrinsics& intrinsics);

/// Reads an iai_kinect2 calibration folder (`<serial>/calib_ir.yaml`: cameraMatrix,
/// distortionCoefficients; optional `calib_depth.yaml`: depthShift in mm). The size is the
/// Kinect v2 depth size 512×424. @p path may also be the `calib_ir.yaml` file itself.
/// @throws IoError when calib_ir.yaml is missing; InvalidInputError when it lacks a matrix.
CameraIntrinsics read_kinect2_calibration(const std::filesystem::path& path);

/// Reads Open3D's camera intrinsics JSON ({"width", "height", "intrinsic_matrix": 9 numbers,
/// column-major}); no distortion.
CameraIntrinsics read_open3d_intrinsics(const std::filesystem::path& path);

/// Reads intrinsics of any supported kind: a folder or a `.yaml` (iai_kinect2), a `.json` with
/// "intrinsic_matrix" (Open3D) or the project's `.json`.
CameraIntrinsics read_intrinsics(const std::filesystem::path& path);

}  // namespace socketsmith::scan
