#pragma once
/// @file socket_builder.h
/// The socket solid: the (deformed) stump surface below the brim line, given a wall thickness,
/// closed by a rounded lip along the brim — a closed, manifold, outward, self-intersection-free
/// triangle mesh ready to print (thesis ch. 5, METHOD.md §3 "socket generation").
///
/// Algorithm (details and measurements in docs/socket_builder.md):
/// 1. check the inner surface (finite, manifold, oriented; it may be open only above the brim);
///    optional uniform midpoint subdivision;
/// 2. smoothed vertex normals on the whole inner surface (area-weighted, then Laplacian passes);
/// 3. exact cut along h = brim(θ): every edge crossing the curve gets a vertex on the curve
///    (bisection of the edge against the spline), triangles are clipped to the part below;
/// 4. outer wall = the kept inner wall moved by the thickness along the smoothed normals (the
///    normal of a rim vertex is interpolated along its edge);
/// 5. lip: a half-round of `lip_segments` rings from the inner to the outer rim (a flat strip when
///    rounding is off); the distal end is closed because the inner surface is;
/// 6. optional distal pad: outer-wall vertices below a plane normal to the axis are moved onto
///    it, the plane chosen so the flat disc has the requested diameter;
/// 7. checks: closed, manifold, consistently oriented, no degenerate triangle, no
///    self-intersection (CGAL), positive volume. When the offset self-intersects (concave skin
///    with a radius of curvature below the thickness) the normals are smoothed more (4×, 16×
///    the passes) and the attempt is noted; a solid that still fails is never returned.

#include <filesystem>
#include <string>
#include <vector>

#include "socketsmith/design/brim.h"
#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::design {

/// Settings of build_socket.
struct SocketOptions {
  double thickness_m = 0.005;          ///< wall thickness [m], in (0, 0.05] (thesis: 5 mm ch. 5, 8 mm ch. 3)
  bool round_brim = true;              ///< half-round lip along the brim (false: a flat strip)
  int lip_segments = 6;                ///< rings of the half-round lip, [2, 32] (used when round_brim)
  bool distal_pad = false;             ///< flatten the outer distal end for an adapter
  double distal_pad_diameter_m = 0.04; ///< diameter of the flat disc [m], in (0, 0.15]
  int subdivisions = 0;                ///< uniform midpoint subdivisions of the inner surface, [0, 3]
                                       ///< (each quadruples the triangles; smooths the rim's polygon)
  int normal_smoothing_iterations = 2; ///< Laplacian passes over the vertex normals, [0, 200]
  double level_step_m = 0.01;          ///< circumference levels every this much of h [m], > 0
  /// Undeformed limb skin (closed or open at the top, same frame), for the % reduction of the
  /// circumferences; nullptr = not reported. Not copied; must outlive the call.
  const geometry::TriMesh* undeformed_skin = nullptr;
};

/// Circumference of the socket's inner wall at one level (full rings only: below the brim).
struct SocketLevel {
  double h_m = 0.0;                    ///< height above the distal end [m]
  double inner_circumference_m = 0.0;  ///< inner wall (socket cavity) [m]
  double limb_circumference_m = 0.0;   ///< undeformed limb at the same h [m]; NaN when not given
  double reduction_percent = 0.0;      ///< 100 (1 − inner / limb); NaN when not given
};

/// The socket and what was measured on it.
struct SocketResult {
  geometry::TriMesh solid;        ///< closed, manifold, outward, no self-intersections [m]
  int inner_triangles = 0;        ///< triangles of the inner wall (the cut stump surface)
  int outer_triangles = 0;        ///< triangles of the outer wall
  int lip_triangles = 0;          ///< triangles of the lip along the brim
  double shell_volume_m3 = 0.0;   ///< material volume (signed volume of the solid) [m^3]
  double cavity_volume_m3 = 0.0;  ///< volume inside the inner wall, closed by a fan to the rim centroid [m^3]
  double rim_min_h_m = 0.0;       ///< lowest and highest h of the inner rim [m]
  double rim_max_h_m = 0.0;
  double max_rim_error_m = 0.0;   ///< max |h − brim(θ)| over the inner rim vertices [m]
  double min_thickness_m = 0.0;   ///< over the outer-wall vertices (pad excluded): distance to the inner wall [m]
  double max_thickness_m = 0.0;
  double mean_thickness_m = 0.0;
  double pad_plane_h_m = 0.0;     ///< h of the distal pad plane [m] (0 without a pad)
  int pad_vertices = 0;           ///< outer vertices moved onto the pad plane
  int normal_smoothing_used = 0;  ///< Laplacian passes of the attempt that passed the checks
  std::vector<SocketLevel> levels;
  std::vector<std::string> notes; ///< automatic decisions (fallbacks, dropped islands), one line each
};

/// Builds the socket from the inner surface @p inner (the deformed stump skin in metres, outward
/// orientation; closed, or open only above the brim — e.g. SkinSurface::triangles() whose top is
/// the proximal cut), the limb @p frame and the @p brim.
/// @throws InvalidInputError with one line naming the problem and the fix: thickness ≤ 0 or NaN
///         (or other options out of range), NaN coordinates, a brim above the top of the surface,
///         a brim below the distal end (nothing left), an inside-out surface;
///         TopologyError: non-manifold or inconsistently oriented input, a surface open below the
///         brim, or a solid that fails the final checks.
SocketResult build_socket(const geometry::TriMesh& inner, const geometry::LimbFrame& frame, const BrimLine& brim,
                          const SocketOptions& options = {});

/// Writes the solid as a binary STL in millimetres (the unit of printers and CAD), atomically.
/// @throws InvalidInputError for an empty solid; IoError when the file cannot be written.
void write_socket_stl(const std::filesystem::path& path, const SocketResult& result);

}  // namespace socketsmith::design
