#pragma once
/// @file mesh_repair.h
/// Surface repair for scanned limbs: orientation, small holes, degenerate triangles, and the
/// planar trim + cap of an open proximal end.

#include <string>
#include <vector>

#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::geometry {

/// What repair_surface changed.
struct RepairReport {
  int removed_degenerate_triangles = 0;
  int removed_duplicate_triangles = 0;
  int flipped_triangles = 0;       ///< re-oriented to agree with their neighbours
  bool flipped_inside_out = false;  ///< the whole surface was inside-out (negative volume)
  int filled_holes = 0;            ///< boundary loops closed (only loops up to max_hole_edges)
  int remaining_boundary_loops = 0;
  /// One human-readable line per change, empty when nothing changed.
  std::vector<std::string> changes() const;
};

struct RepairOptions {
  int max_hole_edges = 40;        ///< loops with more edges are left open (e.g. the proximal cut)
  double degenerate_area_m2 = 1e-14;
};

/// Removes degenerate and duplicate triangles, orients every edge-connected component
/// consistently, flips components whose enclosed volume is negative when they are closed (or
/// become closed after filling), fills boundary loops of at most max_hole_edges edges with planar
/// ear-clipped patches. Non-manifold edges are left alone (check_mesh reports them).
/// Vertices are neither added nor removed, so vertex indices stay valid.
/// @throws InvalidInputError for NaN/inf coordinates, indices out of range or negative options.
RepairReport repair_surface(TriMesh& mesh, const RepairOptions& options = {});

/// The open boundary loops of @p mesh (edges of exactly one triangle), each in the order a patch
/// closing it traverses it: against the triangles beside it, so a fan (centre, loop[i], loop[i+1])
/// faces the same way as they do. @throws InvalidInputError for NaN/inf or indices out of range.
std::vector<std::vector<int>> open_boundary_loops(const TriMesh& mesh);

/// Newell normal of the closed vertex loop @p loop (indices into @p vertices): twice its vector
/// area, right-handed with the loop's order, well defined for non-planar loops (not normalised).
Vec3 newell_normal(const std::vector<Vec3>& vertices, const std::vector<int>& loop);

/// Result of trim_and_cap.
struct TrimResult {
  /// Kept part + caps (vertices renumbered), closed when the kept part had no other hole.
  TriMesh mesh;
  int first_cap_triangle = 0;  ///< triangles [first_cap_triangle, end) are the caps
  /// Each cut loop (ordered polyline, closed implicitly), in the order its cap traverses it:
  /// counter-clockwise seen from the +normal side for an outward-oriented shell.
  std::vector<std::vector<Vec3>> loops;
};

/// Keeps the part of @p mesh where normal·(x − point) ≤ 0, splitting the triangles that cross the
/// plane, and closes every cut loop with a planar ear-clipped cap whose outward normal is
/// +normal. Vertices within 1e-9 m of the plane are treated as below it (no slivers).
/// The kept part must be consistently oriented with outward normals.
/// Every loop gets its own cap, also loops nested in one another (skin and bone shells cut by the
/// same plane); a loop that winds clockwise seen from +normal (a cavity) gets a cap facing −normal,
/// which overlaps the cap of the loop around it (a cross-section with holes is not merged into one
/// polygon).
/// @throws InvalidInputError for an empty mesh, NaN/inf coordinates, indices out of range, a zero
///         normal, or a plane that keeps nothing.
TrimResult trim_and_cap(const TriMesh& mesh, const Vec3& point, const Vec3& normal);

}  // namespace socketsmith::geometry
