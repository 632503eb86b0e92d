#pragma once
/// @file slices.h
/// Measurements of a limb (or a socket's cavity) in slices normal to the limb axis — what a
/// prosthetist tapes and what ampscan's report tabulates: the circumference and the cross-section
/// area at a level, and the volume enclosed below it.
///
/// The volume below a plane is exact for a triangle surface: with h = (x − o)·a the height along
/// the unit axis a, div(h a) = 1, so by the divergence theorem the volume of the region below the
/// plane h = H is
///
///   V(H) = Σ_{t below H} ∫_t h (n·a) dA  +  H · A(H)
///
/// over the parts of the triangles below the plane (clipped exactly; h is linear on a triangle, so
/// ∫_t h (n·a) dA = (n·a) |t| h̄_t) plus the flux through the cross-section A(H) at the plane.
/// It needs the surface to be closed below H only: a scan open at its proximal cut, or a socket's
/// inner wall open above the brim, measure correctly below their openings. Slab volumes are
/// differences of V, so they add up to the volume below the top level exactly.

#include <vector>

#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::geometry {

/// Volume [m³] enclosed by @p mesh below the plane h = @p h_m of @p frame (h along frame.axis from
/// frame.origin). The surface must be outward oriented and closed below the plane (it may be open
/// above it); a plane above the whole surface gives the volume of a closed surface. 0 below it.
/// @throws InvalidInputError for an empty mesh, indices out of range or non-finite coordinates.
double volume_below(const TriMesh& mesh, const LimbFrame& frame, double h_m);

/// One level of a slice table.
struct SliceLevel {
  double h_m = 0.0;                ///< height of the level above the frame's origin [m]
  double circumference_m = 0.0;    ///< length of the cross-section's curves (0 when the plane misses) [m]
  double area_m2 = 0.0;            ///< enclosed cross-section area [m²]
  double volume_below_m3 = 0.0;    ///< V(h): volume enclosed below the level [m³]
  double slab_volume_m3 = 0.0;     ///< V(h) − V(previous level) (the first: V(h)) [m³]
};

/// Levels every @p step_m from @p step_m up to @p top_m, then @p top_m itself when it is not a
/// multiple of the step (so the slabs cover [0, top_m]): 10, 20, …, 150, 157 mm.
/// @throws InvalidInputError when step_m is not > 0 or top_m is not > 0, or more than 10⁵ levels.
std::vector<double> slice_heights(double step_m, double top_m);

/// The circumference, cross-section area and volume of @p mesh at each of @p heights (ascending)
/// along @p frame's axis. The surface must be outward oriented and closed below the highest level.
/// @throws InvalidInputError as volume_below, or when the heights are not ascending and finite.
std::vector<SliceLevel> measure_slices(const TriMesh& mesh, const LimbFrame& frame, const std::vector<double>& heights);

}  // namespace socketsmith::geometry
