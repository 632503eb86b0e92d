#pragma once
/// @file mesh_boolean.h
/// Boolean operations on closed triangle surfaces (union, difference, intersection), exact: CGAL's
/// corefinement (Polygon Mesh Processing) on an exact-constructions kernel, rounded back to double
/// coordinates at the end. CGAL stays inside the .cpp file.

#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::geometry {

enum class BooleanOperation {
  Union,         ///< a ∪ b
  Difference,    ///< a − b
  Intersection,  ///< a ∩ b
};

struct BooleanOptions {
  /// Check that both operands are free of self-intersections and bound a volume (exact tests over
  /// every face: about as long as the operation itself). Turn off only for operands the caller
  /// has checked or built valid by construction.
  bool check_operands = true;
};

/// The solid @p a (op) @p b. Both inputs must be closed, manifold, consistently outward-oriented
/// surfaces without self-intersections (several disjoint closed components are allowed, e.g. four
/// drill cylinders at once). The result is outward-oriented; it may be empty (e.g. a − b with
/// a inside b).
/// @throws InvalidInputError when an input is empty or has NaN coordinates; TopologyError when an
///         input is not a closed manifold surface, self-intersects or does not bound a volume
///         (when checked), or the operation fails.
TriMesh mesh_boolean(const TriMesh& a, const TriMesh& b, BooleanOperation op, const BooleanOptions& options = {});

}  // namespace socketsmith::geometry
