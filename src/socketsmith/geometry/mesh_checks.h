#pragma once
/// @file mesh_checks.h
/// Checks of a surface mesh: closed, manifold, orientation, degenerate triangles, NaN.

#include <string>
#include <vector>

#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::geometry {

/// What check_mesh found.
struct MeshCheckReport {
  int num_vertices = 0;
  int num_triangles = 0;
  int non_finite_vertices = 0;      ///< vertices with NaN or inf coordinates
  int out_of_range_indices = 0;     ///< triangle indices outside [0, num_vertices)
  int degenerate_triangles = 0;     ///< area below (abs_tol_m)^2 or repeated index
  int boundary_edges = 0;           ///< edges used by exactly one triangle (0 for a closed mesh)
  int non_manifold_edges = 0;       ///< edges used by more than two triangles
  int inconsistently_oriented_edges = 0;  ///< interior edges traversed twice the same way
  int boundary_loops = 0;           ///< number of closed loops of boundary edges
  int connected_components = 0;     ///< by shared edges
  double signed_volume_m3 = 0.0;    ///< meaningful when closed
  /// Pairs of triangles that intersect other than along the vertices or the edge they share
  /// (find_self_intersections); -1: not looked for (MeshCheckOptions::find_self_intersections).
  int self_intersecting_pairs = -1;
  Vec3 first_self_intersection = Vec3::Zero();  ///< centroid of a triangle of the first such pair [m]

  bool is_closed() const { return boundary_edges == 0; }
  bool is_manifold() const { return non_manifold_edges == 0; }
  bool is_oriented() const { return inconsistently_oriented_edges == 0; }
  bool is_valid_closed_surface() const {
    return non_finite_vertices == 0 && out_of_range_indices == 0 && is_closed() &&
           is_manifold() && is_oriented() && degenerate_triangles == 0 && num_triangles > 0 &&
           self_intersecting_pairs <= 0;
  }
  /// One line per problem found, empty when none.
  std::vector<std::string> problems() const;
};

/// Options of check_mesh.
struct MeshCheckOptions {
  double degenerate_area_tol_m2 = 1e-14;  ///< triangles with area below this are degenerate [m^2]
  /// Also look for triangles that cross each other (find_self_intersections: 0.06 s on the
  /// 30k-triangle OpenLimb transfemoral file); off where a caller checks topology only.
  bool find_self_intersections = false;
};

/// What find_self_intersections found.
struct SelfIntersections {
  int pairs = 0;                     ///< pairs of intersecting triangles
  int first_a = -1, first_b = -1;    ///< the first pair found (triangle indices), -1 when none
};

/// Pairs of triangles of @p mesh that intersect anywhere but along the vertices or the edge they
/// share: candidate pairs from overlapping bounding boxes (CGAL's box_intersection_d), each tested
/// with exact predicates — triangle–triangle when they share no vertex, each one's opposite edge
/// against the other when they share one, coplanar folding over when they share an edge, and a
/// repeated triangle counts. Works on any triangle soup (open, non-manifold, several shells:
/// nested shells that do not touch do not count). Triangles with a NaN vertex, an index out of
/// range or three collinear vertices are skipped (check_mesh reports them).
SelfIntersections find_self_intersections(const TriMesh& mesh);


/// Inspects @p mesh without modifying it. Never throws on bad geometry: reports it.
MeshCheckReport check_mesh(const TriMesh& mesh, const MeshCheckOptions& options = {});

/// Whether two triangles of @p mesh that do not share an edge or a vertex intersect, or two that
/// do overlap beyond it (CGAL Polygon Mesh Processing's does_self_intersect, exact predicates).
/// @throws TopologyError when @p mesh is not a manifold surface (CGAL cannot read it);
///         InvalidInputError for NaN coordinates or indices out of range.
bool has_self_intersections(const TriMesh& mesh);

/// Throws TopologyError (or InvalidInputError for NaN) with one line naming the first problem
/// and the fix when @p mesh is not a valid closed, manifold, consistently oriented surface.
/// @param what names the mesh in the message, e.g. "limb 'scan.stl'".
void require_closed_surface(const TriMesh& mesh, const std::string& what);

/// Splits a mesh into its edge-connected components (e.g. skin + bones in one STL).
std::vector<TriMesh> split_components(const TriMesh& mesh);

}  // namespace socketsmith::geometry
