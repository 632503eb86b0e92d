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

  bool is_closed() const { return boundary_edges == 0; }
  bool is_manifold() const { return non_manifold_edges == 0; }
  bool is_oriented() const { return inconsistently_oriented_edges == 0; }
  bool is_valid_closed_surface() const {
    return non_finite_vertices == 0 && out_of_range_indices == 0 && is_closed() &&
           is_manifold() && is_oriented() && degenerate_triangles == 0 && num_triangles > 0;
  }
  /// One line per problem found, empty when none.
  std::vector<std::string> problems() const;
};

/// Options of check_mesh.
struct MeshCheckOptions {
  double degenerate_area_tol_m2 = 1e-14;  ///< triangles with area below this are degenerate [m^2]
};

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
