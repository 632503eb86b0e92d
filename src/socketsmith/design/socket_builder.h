#pragma once
/// @file socket_builder.h
/// The socket solid: the (deformed) stump surface below the brim line, given a wall thickness,
/// closed by a rounded lip along the brim — a closed, manifold, outward, self-intersection-free
/// triangle mesh ready to print (thesis ch. 5, docs/method.md §3 "Socket generation").
///
/// Algorithm (details and measurements in docs/socket_builder.md):
/// 1. check the inner surface (finite, manifold, oriented; it may be open only above the brim);
///    optional uniform midpoint subdivision;
/// 2. smoothed vertex normals on the whole inner surface (area-weighted, then Laplacian passes);
/// 3. exact cut along h = brim(θ): every edge crossing the curve gets a vertex on the curve
///    (bisection of the edge against the spline), triangles are clipped to the part below;
/// 4. outer wall = the kept inner wall moved along the smoothed normals (the normal of a rim
///    vertex is interpolated along its edge) by the asked thickness, then moved further where
///    the distance to the inner wall (at vertices, edge midpoints, centroids) falls short of it;
/// 5. lip: a half-round of `lip_segments` rings from the inner to the outer rim (a flat strip when
///    rounding is off); the distal end is closed because the inner surface is;
/// 6. optional distal platform (pad, or the attachment's platform with four through-holes),
///    normal to the pylon of the alignment: a block from a flat disc below the wall up into the
///    middle of the wall, joined to it and drilled by exact Booleans (CGAL corefinement) — built
///    outward, so the wall is never thinner;
/// 7. checks: closed, manifold, consistently oriented, no degenerate triangle, no
///    self-intersection (CGAL), positive volume. When the offset self-intersects (concave skin
///    with a radius of curvature below the thickness) the normals are smoothed more (4×, 16×
///    the passes) and the attempt is noted; a solid that still fails is never returned.

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/design/brim.h"
#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::design {

using Vec3 = Eigen::Vector3d;

/// Socket alignment on the pylon (bench alignment): the angles between the limb's axis and the
/// pylon's, which orient the distal platform (docs/socket_builder.md cites the clinical defaults).
/// The pylon's upward direction in the limb frame is u ∝ axis − tan(flexion)·anterior +
/// tan(adduction)·medial: with flexion the socket's top leans anteriorly (a flexed knee for a
/// transtibial socket, a flexed hip for a transfemoral one), with adduction its distal end lies
/// medially of its top. The platform is normal to u.
struct SocketAlignment {
  double flexion_rad = 5.0 * 0.017453292519943295;  ///< socket flexion [rad], in [−30°, 30°] (default 5°)
  double adduction_rad = 0.0;                        ///< socket adduction [rad], in [−30°, 30°] (default 0°)
};

/// The distal attachment of a pyramid adapter with the four-hole connection: four clearance holes
/// on a square centred on the pylon axis, through a flat platform normal to the pylon
/// (docs/socket_builder.md: dimensions, sources, which values are assumed).
struct SocketAttachment {
  bool enabled = false;                 ///< build the platform and the holes
  std::string bolt = "M6";              ///< nominal bolt (M4, M5, M6, M8); sets the default clearance hole
  double bolt_diameter_m = 0.006;       ///< nominal bolt diameter [m], > 0
  double hole_diameter_m = 0.0066;      ///< clearance hole [m], ≥ the bolt (ISO 273 medium: M6 → 6.6 mm)
  double hole_spacing_m = 0.030;        ///< centre distance of neighbouring holes (side of the square) [m], > hole
  double platform_diameter_m = 0.060;   ///< flat disc [m], holds the holes with a ligament ≥ min_feature_m
  double platform_thickness_m = 0.010;  ///< material along every hole, platform face to cavity, at least [m]
  double rotation_rad = 0.0;            ///< the square's rotation about the pylon, from the anterior–medial axes [rad]
  double offset_anterior_m = 0.0;       ///< pattern centre from the pylon axis, anterior [m], |·| ≤ 20 mm
  double offset_medial_m = 0.0;         ///< pattern centre from the pylon axis, medial [m], |·| ≤ 20 mm
};

/// The clearance hole of a bolt by ISO 273 (medium series): M4 4.5, M5 5.5, M6 6.6, M8 9.0 mm.
/// @throws InvalidInputError for another bolt name (the message lists the known ones).
double clearance_hole_diameter_m(const std::string& bolt);
/// The nominal diameter of a metric bolt name (M4 … M8) [m]. @throws as clearance_hole_diameter_m.
double bolt_diameter_m(const std::string& bolt);

/// Settings of build_socket.
struct SocketOptions {
  double thickness_m = 0.005;          ///< wall thickness [m], in (0, 0.05] (thesis: 5 mm ch. 5, 8 mm ch. 3)
  /// Variable wall: the thickness at the distal end and at the brim [m]; 0 = thickness_m. In
  /// between it varies linearly with h / brim(θ) (0 at the distal end, 1 on the brim line).
  double distal_thickness_m = 0.0;
  double brim_thickness_m = 0.0;
  bool round_brim = true;              ///< half-round lip along the brim (false: a flat strip)
  int lip_segments = 6;                ///< rings of the half-round lip, [2, 32] (used when round_brim)
  /// Flat distal pad for an adapter: a disc of distal_pad_diameter_m normal to the pylon
  /// (alignment), built outward of the wall, so the wall is never thinner there.
  bool distal_pad = false;
  double distal_pad_diameter_m = 0.04; ///< diameter of the flat disc [m], in (0, 0.15]
  SocketAlignment alignment;           ///< orients the pad or the attachment's platform
  SocketAttachment attachment;         ///< four-hole pyramid-adapter attachment (its platform replaces the pad)
  double min_feature_m = 0.001;        ///< smallest printable feature (walls, holes, ligaments) [m], > 0
  double brim_band_m = 0.002;          ///< the thickness measurement leaves out outer points this close to the lip [m]
  int subdivisions = 0;                ///< uniform midpoint subdivisions of the inner surface, [0, 3]
                                       ///< (each quadruples the triangles; smooths the rim's polygon)
  int normal_smoothing_iterations = 2; ///< Laplacian passes over the vertex normals, [0, 200]
  double level_step_m = 0.01;          ///< circumference levels every this much of h [m], > 0
  /// Undeformed limb skin (closed or open at the top, same frame), for the % reduction of the
  /// circumferences; nullptr = not reported. Not copied; must outlive the call.
  const geometry::TriMesh* undeformed_skin = nullptr;
};

/// The thickness asked at a point of the inner wall at height @p h_m where the brim is at
/// @p brim_h_m (the variable wall of SocketOptions, or thickness_m) [m].
double asked_thickness_m(const SocketOptions& options, double h_m, double brim_h_m);

/// Circumference of the socket's inner wall at one level (full rings only: below the brim).
struct SocketLevel {
  double h_m = 0.0;                    ///< height above the distal end [m]
  double inner_circumference_m = 0.0;  ///< inner wall (socket cavity) [m]
  double limb_circumference_m = 0.0;   ///< undeformed limb at the same h [m]; NaN when not given
  double reduction_percent = 0.0;      ///< 100 (1 − inner / limb); NaN when not given
};

/// What a triangle of the socket solid belongs to.
enum class SocketFace : unsigned char {
  Inner,     ///< the inner wall (on the stump surface)
  Outer,     ///< the outer wall, and the sides of the platform
  Lip,       ///< the rounded (or flat) brim edge
  Platform,  ///< the flat distal face of the pad or attachment platform
  Hole,      ///< the bore of an attachment hole
};

/// The distal platform as built.
struct SocketPlatform {
  bool is_built = false;
  Vec3 centre = Vec3::Zero();        ///< on the flat face, on the pylon axis (+ offset) [m]
  Vec3 normal = Vec3::Zero();        ///< outward normal of the flat face (= −pylon up)
  Vec3 anterior = Vec3::Zero();      ///< in-plane axes of the hole pattern (anterior, medial)
  Vec3 medial = Vec3::Zero();
  double diameter_m = 0.0;
  double min_hole_depth_m = 0.0;     ///< shortest hole, flat face to cavity [m] (0 without holes)
  double max_height_m = 0.0;         ///< tallest platform column, flat face to the wall [m]
  std::vector<Vec3> hole_centres;    ///< on the flat face [m]
  double hole_diameter_m = 0.0;
  double smallest_feature_m = 0.0;   ///< min of hole diameter, ligaments between holes and to the edge [m]
};

/// The socket and what was measured on it.
struct SocketResult {
  geometry::TriMesh solid;        ///< closed, manifold, outward, no self-intersections [m]
  std::vector<SocketFace> face_kind;  ///< per triangle of solid
  int inner_triangles = 0;        ///< triangles of the inner wall (the cut stump surface)
  int outer_triangles = 0;        ///< triangles of the outer wall (before the platform)
  int lip_triangles = 0;          ///< triangles of the lip along the brim
  double shell_volume_m3 = 0.0;   ///< material volume (signed volume of the solid) [m^3]
  double cavity_volume_m3 = 0.0;  ///< volume inside the inner wall, closed by a fan to the rim centroid [m^3]
  double rim_min_h_m = 0.0;       ///< lowest and highest h of the inner rim [m]
  double rim_max_h_m = 0.0;
  double max_rim_error_m = 0.0;   ///< max |h − brim(θ)| over the inner rim vertices [m]
  /// Wall thickness: the distance from points of the whole outer surface (outer wall, platform;
  /// vertices, edge midpoints and centroids) to the inner wall, leaving out points within
  /// brim_band_m of the lip [m].
  double min_thickness_m = 0.0;
  double median_thickness_m = 0.0;
  double max_thickness_m = 0.0;
  double mean_thickness_m = 0.0;
  double min_thickness_ratio = 0.0;  ///< min over the same points of thickness / asked thickness
  /// Per vertex of solid: distance to the inner wall [m]; NaN on the inner wall.
  std::vector<double> vertex_thickness_m;
  int thickness_passes = 0;       ///< passes of the offset correction that raised thin spots
  SocketPlatform platform;
  int normal_smoothing_used = 0;  ///< Laplacian passes of the attempt that passed the checks
  std::vector<SocketLevel> levels;
  std::vector<std::string> notes; ///< automatic decisions (fallbacks, dropped islands), one line each
};

/// Builds the socket from the inner surface @p inner (the deformed stump skin in metres, outward
/// orientation; closed, or open only above the brim — e.g. SkinSurface::triangles() whose top is
/// the proximal cut), the limb @p frame and the @p brim.
/// @throws InvalidInputError with one line naming the problem and the fix: thickness ≤ 0 or NaN
///         (or other options out of range), NaN coordinates, a brim above the top of the surface,
///         a brim below the distal end (nothing left), an inside-out surface, an attachment whose
///         holes or ligaments are below min_feature_m, a platform wider than the socket's distal
///         end, a hole that does not reach the cavity;
///         TopologyError: non-manifold or inconsistently oriented input, a surface open below the
///         brim, or a solid that fails the final checks.
SocketResult build_socket(const geometry::TriMesh& inner, const geometry::LimbFrame& frame, const BrimLine& brim,
                          const SocketOptions& options = {});

/// Writes the solid as a binary STL in millimetres (the unit of printers and CAD), atomically.
/// @throws InvalidInputError for an empty solid; IoError when the file cannot be written.
void write_socket_stl(const std::filesystem::path& path, const SocketResult& result);

}  // namespace socketsmith::design
