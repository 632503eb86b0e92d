#pragma once
/// @file distal_dome.h
/// Closing the distal opening of a limb surface that is open at both ends (a tube): an AAOP shape
/// whose first slice is a ring, or a scan that missed the tip. O&P CAD programs close such a shape
/// with a distal end; here a dome that continues the surface's own taper at the rim and ends flat
/// on the axis.

#include <optional>
#include <string>

#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::geometry {

/// What close_distal_opening added.
struct DistalDome {
  int rim_edges = 0;         ///< edges of the closed opening
  double rim_width_m = 0.0;  ///< its equivalent diameter (a circle of the same area) [m]
  double depth_m = 0.0;      ///< from the rim's mean plane to the dome's apex [m]
  int added_vertices = 0;
  int added_triangles = 0;
  /// One line for a report: what was closed and that the tip's shape is assumed.
  std::string describe() const;
};

/// When @p mesh is open at exactly two boundary loops and one of them encloses less than half the
/// area of the other (a limb tapers to its distal end), closes that smaller loop with a dome and
/// returns what it added; otherwise leaves @p mesh alone and returns nullopt.
///
/// Each rim vertex starts a quadratic Bézier spoke: tangent at the rim to the surface there (its
/// slope from the mean distance to the axis and height of its neighbours off the rim) and
/// perpendicular to the axis at the apex. The
/// apex lies on the rim's normal through its centroid, at half the median depth at which the rims'
/// tangents reach the axis (where a paraboloid tangent to them would end), between 0.15 and 1 times
/// the rim's equivalent radius. Rings of the spokes, about one rim edge apart, are joined by
/// triangles facing like the surface beside the rim.
/// @throws InvalidInputError for NaN/inf coordinates or indices out of range.
std::optional<DistalDome> close_distal_opening(TriMesh& mesh);

}  // namespace socketsmith::geometry
