#pragma once
/// @file depth_image.h
/// A raw 16-bit depth frame (0 = invalid) and its PNG IO, the temporal fusion of several frames,
/// and conversion to metres with optional bilinear up-sampling.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace socketsmith::scan {

/// A depth frame as the sensor delivers it: depth along the optical axis (Z, not the ray length).
struct DepthImage {
  int width = 0;                   ///< [px]
  int height = 0;                  ///< [px]
  std::vector<std::uint16_t> raw;  ///< #width·height row-major readings, 0 = no measurement
  double scale_m = 1e-3;           ///< metres per raw unit (1e-3: mm; TUM: 1/5000)

  std::uint16_t at(int u, int v) const { return raw[static_cast<size_t>(v) * width + u]; }
  int count_valid() const;
};

/// Reads a single-channel 16-bit PNG (or PGM) depth frame.
/// @param scale_m metres per raw unit.
/// @throws IoError when the file is missing or unreadable; InvalidInputError when it is not a
///         single-channel 16-bit image (e.g. an 8-bit PNG: "expected 16-bit depth in mm").
DepthImage read_depth_png(const std::filesystem::path& path, double scale_m = 1e-3);

/// Writes @p image as a 16-bit single-channel PNG, atomically.
void write_depth_png(const std::filesystem::path& path, const DepthImage& image);

/// An infrared (amplitude) frame of a time-of-flight sensor, pixel-aligned with its depth frame
/// (the Kinect v2 measures both with the same sensor): what chessboard corners are found on.
struct IrImage {
  int width = 0;                     ///< [px]
  int height = 0;                    ///< [px]
  std::vector<std::uint16_t> value;  ///< #width·height row-major intensities (16-bit; 8-bit files are ×257)

  std::uint16_t at(int u, int v) const { return value[static_cast<size_t>(v) * width + u]; }
};

/// Reads a single-channel 8- or 16-bit PNG IR frame (8-bit values are scaled by 257 to 16 bits).
/// @throws IoError when missing or unreadable; InvalidInputError for a colour or float image.
IrImage read_ir_png(const std::filesystem::path& path);

/// Writes @p image as a 16-bit single-channel PNG, atomically.
void write_ir_png(const std::filesystem::path& path, const IrImage& image);

/// How several depth frames of one static scene are fused per pixel (a pixel valid in fewer than
/// half of the frames becomes invalid).
enum class FrameFusion {
  /// The median of the valid readings (robust to a flying pixel or a lost reading; stays on the
  /// raw unit grid).
  Median,
  /// The mean of the valid readings after dropping the lowest and highest quarter (rounded down;
  /// none of 2–3 readings): nearly the mean's efficiency on Gaussian noise (the median's variance
  /// is ≈ π/2 times the mean's) while a lone flying pixel is still left out. The result is kept at
  /// a tenth of the raw unit (or the finest of 1/5, 1/2 that the frames' largest reading fits in 16
  /// bits), so the average is not rounded back to the sensor's 1 mm.
  TrimmedMean,
};

/// Parses "median" | "trimmed-mean"; @p what names the caller in the message.
/// @throws InvalidInputError for another name.
FrameFusion parse_frame_fusion(const std::string& name, const std::string& what);
/// "median" | "trimmed-mean".
const char* frame_fusion_name(FrameFusion fusion);

/// Fuses several frames of one static scene pixel by pixel (a temporal denoiser), see FrameFusion.
/// One frame is returned unchanged.
/// @throws InvalidInputError for no frames or frames of different sizes or scales.
DepthImage fuse_frames(const std::vector<DepthImage>& frames, FrameFusion fusion = FrameFusion::Median);

/// Per-pixel mean of several IR frames of one static scene (the amplitude noise is Gaussian; a
/// sharper image for corner detection).
/// @throws InvalidInputError for no frames or frames of different sizes.
IrImage mean_of_ir_frames(const std::vector<IrImage>& frames);

/// Depth in metres (0 = invalid) on a grid up-sampled by @p upsample, depth shift applied to valid
/// readings. Bilinear interpolation between the four surrounding sensor pixels when they are all
/// valid and within @p max_jump_m of each other (no mixing across depth edges), else the nearest
/// sensor pixel.
struct DepthMap {
  int width = 0, height = 0;
  std::vector<float> depth_m;  ///< row-major [m], 0 = invalid
  float at(int u, int v) const { return depth_m[static_cast<size_t>(v) * width + u]; }
};
DepthMap to_depth_map(const DepthImage& image, double depth_shift_m, int upsample = 1, double max_jump_m = 0.02);

}  // namespace socketsmith::scan
