#pragma once
/// @file socket_cavity.h
/// The cavity of a socket solid: which of its triangles form the inner wall (the surface the
/// stump touches), a limb frame for a socket given alone, and the cavity as a surface oriented
/// like a limb's skin (normals out of the cavity), to measure and compare it as one.

#include <vector>

#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::geometry {

/// Whether horizontal rays from @p frame's axis, at 30, 50 and 70 % of the solid's height, meet a
/// wall facing them (normal towards the axis) in at least 7 of 8 directions: the solid surrounds
/// the axis like a socket around a stump. @p facing_out, when given, receives the fewest such
/// directions over the three heights.
bool surrounds_axis(const TriMesh& solid, const LimbFrame& frame, int* facing_out = nullptr);

/// Triangles of the closed, outward @p solid seen from @p frame's axis — the cavity's wall (the
/// cavity is star-shaped about its axis) — from origins on the axis at each triangle's height or
/// lifted towards the opening, no higher than the solid (else the lip's top is "seen"), and in the
/// cavity: an origin in the distal wall would "see" faces of the outside (the ledge where a distal
/// platform joins the outer wall) from within the material; an origin is in the cavity when the
/// ray up the axis leaves through the open brim.
std::vector<int> cavity_triangles(const TriMesh& solid, const LimbFrame& frame);

/// The triangles @p ids of @p mesh with only the vertices they use (renumbered in order).
TriMesh submesh(const TriMesh& mesh, const std::vector<int>& ids);

/// A frame for a socket solid given alone: the axis along the principal direction of its
/// vertices, pointing to the opening (a ray from the centre of its bounding box leaves the solid
/// through the opening without meeting a wall, and meets the floor the other way), the origin on
/// the axis at the solid's lowest point; anterior is a placeholder (anterior_estimated).
/// @throws InvalidInputError when the solid does not open at one end of its long axis or does not
///         surround that axis (not a socket).
LimbFrame estimate_socket_frame(const TriMesh& solid);

/// The cavity's wall of @p solid (cavity_triangles) as a surface oriented like a limb's skin:
/// normals pointing out of the cavity, open at the brim.
/// @throws InvalidInputError when the solid does not surround @p frame's axis.
TriMesh cavity_surface(const TriMesh& solid, const LimbFrame& frame);

}  // namespace socketsmith::geometry
