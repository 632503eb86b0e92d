#pragma once
/// @file chessboard.h
/// Chessboard corners in a time-of-flight sensor's IR frame and their 3-D positions from the
/// pixel-aligned depth frame (thesis §4.2.2, eq. 23): OpenCV's corner detector with sub-pixel
/// refinement (optionally on a ×N bilinearly up-sampled image, as the thesis does), depth at the
/// sub-pixel corner by bilinear interpolation, back-projection along the undistorted ray.

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/scan/depth_image.h"
#include "socketsmith/scan/intrinsics.h"
#include "socketsmith/scan/recording.h"

namespace socketsmith::scan {

/// One inner corner of a detected board.
struct ChessboardCorner {
  int i = 0;                                   ///< column of the inner-corner grid, 0 … inner_cols − 1
  int j = 0;                                   ///< row, 0 … inner_rows − 1
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();  ///< sub-pixel position in the sensor image [px]
  /// Depth at uv by bilinear interpolation [m]; 0 when a neighbouring pixel is invalid or the four
  /// neighbours straddle a depth edge (then point is not meaningful).
  double depth_m = 0.0;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< sensor-frame point (x d, y d, d) [m]

  bool has_depth() const { return depth_m > 0.0; }
};

/// All inner corners of one board in one frame, row-major (index j·inner_cols + i). Grid
/// convention: i runs along the pattern's rows and j along its columns so that the grid is seen
/// unmirrored (i to the right and j downwards for a board facing the sensor upright), and corner
/// (0, 0) touches the black corner square — unique when inner_cols + inner_rows is odd (else the
/// grid is known up to a half turn).
struct ChessboardDetection {
  ChessboardPattern pattern;
  std::vector<ChessboardCorner> corners;

  const ChessboardCorner& at(int i, int j) const { return corners[static_cast<size_t>(j * pattern.inner_cols + i)]; }
  int count_with_depth() const;
};

/// How the depth at a sub-pixel corner is estimated.
enum class CornerDepth {
  /// The thesis's (§4.2.2): bilinear interpolation of the corner's four neighbouring pixels —
  /// carries the full per-pixel depth noise (×2.5 on the dark squares).
  Bilinear,
  /// Our stated better estimate: 1/d fitted as a plane in (u, v) (exact for a flat board seen by a
  /// pinhole camera) to every valid pixel within plane_radius_px of the corner, robustly (pixels
  /// beyond 3.5 robust σ — flying pixels, a board edge — dropped and the fit repeated), evaluated
  /// at the corner: the noise of ~100 pixels averaged instead of 4.
  LocalPlane,
};

/// Settings of detect_chessboard.
struct ChessboardOptions {
  int upsample = 2;                 ///< bilinear up-sampling of the IR frame before detection, 1 to 8
  double max_depth_jump_m = 0.01;   ///< the 4 pixels around a corner may differ by at most this in depth [m]
  CornerDepth corner_depth = CornerDepth::Bilinear;
  double plane_radius_px = 6.0;     ///< LocalPlane: window radius around the corner [sensor px], 2 to 30
};

/// Sub-pixel inner corners of @p pattern in @p ir (sensor pixel coordinates, the grid order of
/// ChessboardDetection), or nothing when the board is not found.
/// @throws InvalidInputError for an invalid pattern or upsample factor, or an empty image.
std::optional<std::vector<Eigen::Vector2d>> find_chessboard_corners(const IrImage& ir, const ChessboardPattern& pattern,
                                                                     int upsample = 2);

/// Up to @p max_boards boards of the same @p pattern in one IR frame (e.g. two faces of the
/// registration box): after each detection the board's squares are masked and the search repeats.
/// Each result is in the grid order of ChessboardDetection.
std::vector<std::vector<Eigen::Vector2d>> find_all_chessboard_corners(const IrImage& ir, const ChessboardPattern& pattern,
                                                                      int upsample = 2, int max_boards = 4);

/// Depth [m] at the sub-pixel position @p uv of @p depth by bilinear interpolation of its four
/// neighbouring pixels (depth shift applied), or 0 when one of them is invalid or they differ by
/// more than @p max_jump_m.
double bilinear_depth(const DepthImage& depth, double depth_shift_m, const Eigen::Vector2d& uv, double max_jump_m);

/// Depth [m] at @p uv from a robust local plane fit of 1/d over the valid pixels within
/// @p radius_px (CornerDepth::LocalPlane; depth shift applied), or 0 when fewer than half of the
/// window's pixels (and fewer than 12) are valid and consistent (within @p max_jump_m of their
/// median).
double local_plane_depth(const DepthImage& depth, double depth_shift_m, const Eigen::Vector2d& uv, double radius_px,
                         double max_jump_m);

/// Back-projects sub-pixel corners (grid order) with @p depth into a detection, the depth at each
/// corner estimated as @p options says.
ChessboardDetection corners_to_3d(const std::vector<Eigen::Vector2d>& uv, const DepthImage& depth,
                                  const CameraIntrinsics& intrinsics, const ChessboardPattern& pattern,
                                  const ChessboardOptions& options = {});

/// Detects the board in @p ir and back-projects its corners with the aligned @p depth frame.
/// @param what names the frame in messages, e.g. "K2/ir_0003.png".
/// @throws InvalidInputError "chessboard not found in <what> (...)" when the board is not found,
///         and when the IR and depth frames or intrinsics differ in size.
ChessboardDetection detect_chessboard(const IrImage& ir, const DepthImage& depth, const CameraIntrinsics& intrinsics,
                                      const ChessboardPattern& pattern, const ChessboardOptions& options = {},
                                      const std::string& what = "the IR frame");

}  // namespace socketsmith::scan
