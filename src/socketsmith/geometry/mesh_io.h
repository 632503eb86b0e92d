#pragma once
/// @file mesh_io.h
/// Robust surface mesh IO: STL (binary and ASCII), OBJ, PLY (ASCII and binary little/big
/// endian), AAOP shape files (.aop, see aaop.h). Lengths are converted to metres at this boundary.

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "socketsmith/core/units.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::geometry {

/// Options of read_mesh.
struct MeshReadOptions {
  /// Length unit of the file. Empty: guess from the bounding box (a limb-sized object of
  /// 0.05-1 units is metres, 50-1000 is millimetres) and log which was chosen.
  std::optional<units::LengthUnit> unit;
  /// Warn when the declared unit makes the object implausibly large or small for a body part
  /// (bounding-box diagonal outside [kMinPlausibleSize_m, kMaxPlausibleSize_m]).
  bool warn_on_implausible_size = true;
  /// Vertices closer than this (in metres, after unit conversion) are merged. 0 disables.
  double weld_tol_m = 1e-9;
};

/// Plausible body-part sizes (bounding-box diagonal) used for unit checks [m].
inline constexpr double kMinPlausibleSize_m = 0.01;
inline constexpr double kMaxPlausibleSize_m = 3.0;

/// A named landmark a mesh file carries (AAOP files do): one or more points [m], in the mesh's frame.
struct MeshLandmark {
  std::string name;
  std::vector<Vec3> points;
};

/// Information about what was read, for reports.
struct MeshReadInfo {
  std::string format;            ///< "stl-binary", "stl-ascii", "obj", "ply-ascii", "ply-binary", "aaop"
  units::LengthUnit unit{};      ///< unit actually used for conversion
  bool unit_was_guessed = false;  ///< true when MeshReadOptions::unit was empty
  int welded_vertices = 0;       ///< vertices removed by welding
  int dropped_triangles = 0;     ///< degenerate (repeated index) triangles dropped
  std::string warning;           ///< non-empty when a unit or size warning was logged
  std::vector<MeshLandmark> landmarks;  ///< landmarks stored in the file (AAOP), else empty
  std::string side;  ///< "left" or "right" when the file states the limb's side (AAOP), else empty
};

/// Reads STL/OBJ/PLY/AOP by extension (case-insensitive), sniffing binary vs ASCII STL by content.
/// Polygons in OBJ/PLY are fan-triangulated. An AAOP file's spoke grid is triangulated in the
/// file's frame (aaop_surface: closed where a slice of zero radii closes it, else open); its unit
/// is millimetres unless options.unit says otherwise, and its landmarks go to info->landmarks.
/// @throws IoError if the file cannot be opened; InvalidInputError if it is not a mesh of that
///         format, is empty (0 triangles), has indices out of range, or NaN/inf coordinates.
TriMesh read_mesh(const std::filesystem::path& path, const MeshReadOptions& options = {},
                  MeshReadInfo* info = nullptr);

/// read_mesh of a file already in memory: @p data is its content, @p name its path (the
/// extension picks the format; the name is shown in messages). Same checks and throws.
TriMesh read_mesh_data(std::string_view data, const std::string& name, const MeshReadOptions& options = {},
                       MeshReadInfo* info = nullptr);

/// Output format of write_mesh (chosen from the extension when Auto).
enum class MeshFormat { Auto, StlBinary, StlAscii, Obj, PlyBinary, PlyAscii, Aaop };

/// Writes @p mesh (metres) in @p unit, atomically (temporary file + rename).
/// AAOP (.aop, millimetres only): the mesh, a closed limb or socket cavity or one open at its
/// proximal end, is resampled to 72 spokes × 100 slices about its own long axis
/// (sample_aaop in aaop.h takes the frame and the counts).
/// @throws IoError on write failure; InvalidInputError on an unknown extension, or for AAOP a unit
///         other than mm or a shape that is not a tube around its axis.
void write_mesh(const std::filesystem::path& path, const TriMesh& mesh,
                units::LengthUnit unit = units::LengthUnit::Millimetre,
                MeshFormat format = MeshFormat::Auto);

/// Unit a raw bounding-box diagonal suggests for a body part: Millimetre when > 5, else Metre.
units::LengthUnit guess_length_unit(double raw_diagonal);

}  // namespace socketsmith::geometry
