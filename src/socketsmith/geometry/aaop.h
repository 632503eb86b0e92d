#pragma once
/// @file aaop.h
/// AAOP shape files (.aop): the American Academy of Orthotists and Prosthetists' cylindrical
/// shape-exchange format of O&P CAD programs. A shape is a grid of radii: `spokes` angles around
/// a long axis × `slices` heights along it, plus named landmarks, all in millimetres.
///
/// Layout (one value a line; CR, LF and CRLF line ends are all accepted):
///   version line ("AAOP1"), free comment lines up to "END COMMENTS",
///   coordinate system ("CYLINDRICAL", the only one supported), side (LEFT / RIGHT / NONE),
///   landmark count; per landmark: name, point count, then r [mm], theta [deg], z [mm] per point,
///   spoke count, spoke spacing [deg] (0: the spoke angles [deg] follow, one a line),
///   slice count, slice spacing [mm] (0: the slice heights [mm] follow, one a line),
///   slices × spokes radii [mm], slice by slice (a radius may be followed by a value on its line).
/// With a regular spacing d spoke j is at −90° + j·d (counter-clockwise seen from +z, the first
/// spoke along −y). Point (r, theta, z) is (r cos theta, r sin theta, z) in the file's frame.
/// This is the order in which ampscan's exported file of its scan matches that scan (the STL twin
/// in the shared data, mean radius difference 0.6 mm); ampscan's own reader takes the spokes in
/// the reverse order and so reads that file as the mirror image of the scan.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::geometry {

/// A named landmark of an AAOP file (one or more points).
struct AaopLandmark {
  std::string name;         ///< as in the file, surrounding blanks removed
  std::vector<Vec3> points_mm;  ///< (r, theta [deg], z) per point, as written [mm, deg, mm]
};

/// The contents of an AAOP file, in the file's units (mm, degrees).
struct AaopShape {
  std::string version = "AAOP1";
  std::vector<std::string> comments;  ///< lines between the version line and END COMMENTS
  std::string side = "NONE";          ///< LEFT, RIGHT or NONE
  std::vector<AaopLandmark> landmarks;
  double spoke_spacing_deg = 0.0;      ///< 0 when the angles are listed
  std::vector<double> spoke_angles_deg;  ///< one per spoke
  double slice_spacing_mm = 0.0;       ///< 0 when the heights are listed
  std::vector<double> slice_heights_mm;  ///< one per slice, distal first
  std::vector<double> radii_mm;        ///< slice-major: radii_mm[slice * spokes + spoke]

  int num_spokes() const { return static_cast<int>(spoke_angles_deg.size()); }
  int num_slices() const { return static_cast<int>(slice_heights_mm.size()); }
  double radius_mm(int slice, int spoke) const { return radii_mm[slice * num_spokes() + spoke]; }
};

/// Parses the text of an AAOP file. @p name names it in messages.
/// @throws InvalidInputError with one line naming the file, the line and what was expected for
///         a truncated file, a count that is not a positive integer, a value that is not a number
///         (or NaN/inf), a negative radius, spokes that do not make a full turn, slice heights
///         that do not increase, or a coordinate system other than CYLINDRICAL.
AaopShape parse_aaop(std::string_view text, const std::string& name);

/// Reads and parses an AAOP file. @throws IoError when it cannot be read; as parse_aaop.
AaopShape read_aaop(const std::filesystem::path& path);

/// The shape's text in the layout above (LF line ends), with enough digits to read back every
/// value exactly.
std::string format_aaop(const AaopShape& shape);

/// Writes @p shape atomically (temporary file + rename). @throws IoError on failure.
void write_aaop(const std::filesystem::path& path, const AaopShape& shape);

/// The surface of the spoke grid in metres, in the file's frame (z along the axis), with outward
/// normals. A slice whose radii are all 0 (the first or the last) collapses to one vertex on the
/// axis, closing that end; any other end stays open (a boundary loop).
/// @param distal_closed, proximal_closed set to whether the first / last slice closes the shape.
TriMesh aaop_surface(const AaopShape& shape, bool* distal_closed = nullptr,
                     bool* proximal_closed = nullptr);

/// A landmark point of @p shape in the surface's frame [m].
Vec3 aaop_point_m(const Vec3& r_theta_z);

/// Options of sample_aaop.
struct AaopSampleOptions {
  int spokes = 72;             ///< evenly spaced, 360/spokes degrees apart
  int slices = 100;            ///< including the closing slice when close_distal
  bool close_distal = true;    ///< first slice: radii 0 at the distal end (a closed end)
  double end_margin = 0.005;   ///< first and last ring slices this fraction of the length inside
  /// Heights of the ring slices above the distal end [mm], increasing; empty: `slices` (less the
  /// closing one) evenly spaced between the end margins. With close_distal they must be > 0.
  std::vector<double> heights_mm;
  std::string side = "NONE";
  std::vector<std::string> comments;
};

/// Resamples a limb or socket cavity @p mesh (metres) to an AAOP grid about @p frame: z along
/// frame.axis from frame.origin (h = 0 at the distal end), x along frame.anterior, y = axis ×
/// anterior. Each radius is the farthest crossing of the spoke's ray from the axis with the
/// surface's cross-section at that height.
/// @throws InvalidInputError when a spoke's ray misses the surface (the shape is not a tube
///         around the axis there) or the options are out of range.
AaopShape sample_aaop(const TriMesh& mesh, const LimbFrame& frame, const AaopSampleOptions& options = {});

/// sample_aaop about the mesh's own long axis (estimate_limb_axis).
AaopShape sample_aaop(const TriMesh& mesh, const AaopSampleOptions& options = {});

}  // namespace socketsmith::geometry
