#pragma once
/// @file shape_compare.h
/// Two shapes of one limb compared as a prosthetist does (visit 1 against visit 2, a scan against
/// its socket's cavity): the second shape aligned rigidly onto the first (ICP seeded by the limb
/// frames or by landmarks), the signed distance between them at every point of the first (the
/// deviation map), and their circumferences, cross-sections and volumes slice by slice below a
/// crop height that leaves out the proximal rim, where scans are ragged.
///
/// A (the reference) is a limb surface, open at its proximal cut or closed; B is a limb surface,
/// or a socket solid, whose cavity (the inner wall, open at the brim) is then compared. Both are in
/// metres; a file holding several shells (a skin with its bones) is reduced to its largest shell.
/// Heights are A's limb frame's: h above A's distal end along A's axis.

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/rigid_alignment.h"
#include "socketsmith/geometry/slices.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::geometry {

/// What B is.
enum class ShapeKind {
  Auto,     ///< a socket when B is closed and the centre of its bounding box is outside it (a cavity), else a surface
  Surface,  ///< a limb surface (a scan)
  Socket,   ///< a socket solid: its cavity is compared
};
std::string to_string(ShapeKind kind);
/// "auto" | "surface" | "socket"; @throws InvalidInputError otherwise.
ShapeKind parse_shape_kind(const std::string& text);

/// How the alignment starts.
enum class AlignmentSeed {
  Auto,       ///< landmarks when both sets are given, else the best of the identity and the limb frames
  Frames,     ///< B's limb frame onto A's, turned about the axis in rotation_seeds steps; the best is kept
  Landmarks,  ///< the rigid transform that best maps B's landmarks onto A's (at least 3 common codes)
  Identity,   ///< the shapes are already in one coordinate system (a limb and its own designed socket)
  None,       ///< no alignment at all: the shapes are compared where they are
};
std::string to_string(AlignmentSeed seed);
/// "auto" | "frames" | "landmarks" | "identity" | "none"; @throws InvalidInputError otherwise.
AlignmentSeed parse_alignment_seed(const std::string& text);

/// A named point, for the landmark seed [m].
using NamedPoint = std::pair<std::string, Vec3>;

struct ShapeCompareOptions {
  ShapeKind b_kind = ShapeKind::Auto;
  AlignmentSeed seed = AlignmentSeed::Auto;
  std::vector<NamedPoint> landmarks_a, landmarks_b;  ///< for AlignmentSeed::Landmarks (codes matched by name)
  /// Compare below this height of A's frame [m]; 0 = automatic: 5 mm below the lower of A's and
  /// B's proximal openings (or A's top when both are closed). Must lie below both openings.
  double crop_height_m = 0.0;
  double slice_step_m = 0.01;  ///< slice levels every this much [m], > 0
  int rotation_seeds = 12;     ///< turns about the axis tried by the frame seed, [1, 72]
  IcpOptions icp;              ///< the final alignment (the seeds are scored with a coarser one)
};

/// Summary of a deviation field (over the points of A below the crop where B was found).
struct DeviationStats {
  int points = 0;             ///< A's vertices below the crop
  int covered = 0;            ///< of those, where B lies along the surface normal (not beyond B's rim)
  double mean_m = 0.0;        ///< area-weighted mean [m] (> 0: B outside A)
  double sd_m = 0.0;          ///< area-weighted standard deviation [m]
  double rms_m = 0.0;         ///< area-weighted root mean square [m]
  double min_m = 0.0, max_m = 0.0;
  double p05_m = 0.0, p95_m = 0.0;  ///< 5th and 95th percentiles [m]
};

/// One slab of the per-slice comparison: A and B at the same level of A's frame.
struct SliceComparison {
  double h_m = 0.0;                       ///< level [m]
  SliceLevel a, b;                         ///< the two shapes there
};

/// What compare_shapes found.
struct ShapeComparison {
  LimbFrame frame;                 ///< A's limb frame (estimated; anterior a placeholder unless given)
  ShapeKind b_kind = ShapeKind::Surface;  ///< what B was read as
  TriMesh a;                       ///< A's surface as compared (its largest shell) [m]
  TriMesh b;                       ///< B's surface (or cavity) aligned into A's coordinates [m]
  RigidTransform transform;        ///< B's coordinates → A's
  std::string seed;                ///< which seed won, e.g. "limb frames (turned 30° about the axis)"
  IcpResult icp;                   ///< the final alignment (rms over the pairs it kept)
  double crop_height_m = 0.0;      ///< the crop used [m]
  std::vector<double> deviation_m; ///< per vertex of a: signed distance to b [m], > 0 where b lies outside a; NaN above the crop or where b does not cover a
  DeviationStats stats;
  std::vector<SliceComparison> slices;  ///< every slice_step_m up to the crop
  double volume_a_m3 = 0.0;        ///< below the crop [m³]
  double volume_b_m3 = 0.0;
  std::vector<std::string> notes;  ///< shells dropped, crop lowered, seeds tried, one line each
};

/// Aligns B onto A and compares them (file comment).
/// @throws InvalidInputError with one line naming the problem and the fix: a shape that is empty
///         or not limb-like, B said to be a socket that is not one, fewer than 3 common landmarks,
///         a crop height outside the shapes, surfaces that do not overlap after the seed.
ShapeComparison compare_shapes(const TriMesh& a, const TriMesh& b, const ShapeCompareOptions& options = {});

/// Signed distance from each vertex of @p from to the surface @p to (> 0 where @p to lies outside
/// @p from, along @p from's outward side), or NaN where the nearest point of @p to is not along
/// its face normal (beyond its rim), is farther than @p max_distance_m, or @p use is 0.
/// @p use: per vertex of @p from, or empty (all).
std::vector<double> signed_deviation(const TriMesh& from, const TriMesh& to, double max_distance_m,
                                     const std::vector<char>& use = {});

/// Area-weighted statistics of @p values (NaN = not covered) on the vertices of @p mesh where @p use is 1.
DeviationStats deviation_stats(const TriMesh& mesh, const std::vector<double>& values, const std::vector<char>& use);

/// The largest shell (by area) of @p mesh, and how many were dropped.
TriMesh largest_shell(const TriMesh& mesh, int* dropped = nullptr);

/// Distance from @p frame's axis to @p surface along the ray at (θ, h): the first crossing [m];
/// nullopt when the ray misses.
std::optional<double> radius_at(const SurfaceQuery& surface, const LimbFrame& frame, double theta_rad, double h_m);

}  // namespace socketsmith::geometry
