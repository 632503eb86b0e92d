#pragma once
/// @file ring_stack.h
/// A closed or open surface from closed loops of vertices ("rings") stacked along a direction,
/// as made by sweeping a cross-section: limb skins, bones, tubes. Consecutive rings may have
/// different vertex counts; they are joined by a zipper that follows the rings' angles.

#include <vector>

#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::geometry {

/// Rings stacked from the first (bottom) to the last (top). Each ring is ordered by increasing
/// angle about the stacking direction (counter-clockwise seen from the top, e.g. from anterior
/// towards medial in a right-handed limb frame) and starts at angle 0.
struct RingStack {
  std::vector<std::vector<Vec3>> rings;
  bool has_bottom_pole = false;  ///< close the first ring with a fan to bottom_pole
  Vec3 bottom_pole = Vec3::Zero();
  bool has_top_pole = false;     ///< close the last ring with a fan to top_pole
  Vec3 top_pole = Vec3::Zero();
};

/// Triangulates a RingStack: fans at the poles and, between consecutive rings, a zipper that
/// advances on the ring whose next vertex has the smaller angle (n_k + n_(k+1) triangles).
/// Vertices: bottom pole (if any), rings in order, top pole (if any). Triangles are outward for
/// rings counter-clockwise seen from the top; pass @p flip = true for clockwise rings (a limb
/// frame that is left-handed, LimbFrame::is_left_handed).
/// @param band_first_triangle if not null, receives for each ring k the index of the first
///        triangle of the band between ring k and ring k + 1 (the last entry: the top fan).
/// @throws InvalidInputError for a ring of fewer than 3 vertices.
TriMesh mesh_ring_stack(const RingStack& stack, bool flip, std::vector<int>* band_first_triangle = nullptr);

}  // namespace socketsmith::geometry
