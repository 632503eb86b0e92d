#pragma once
/// @file surface_query.h
/// Fast geometric queries against a triangle surface: closest point, ray hits, inside test,
/// signed distance. Backed by a CGAL AABB tree (CGAL stays inside the .cpp file).

#include <memory>
#include <optional>

#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::geometry {

/// A point on the surface.
struct SurfaceHit {
  Vec3 point = Vec3::Zero();  ///< position on the surface [m]
  int triangle = -1;          ///< index of the triangle that holds it
  double distance = 0.0;      ///< |query − point| for closest_point, |origin − point| = t·|direction| for ray hits
};

/// Spatial index of a triangle mesh (copied at construction; later edits of the source mesh are
/// not seen). Queries are const and thread-safe.
class SurfaceQuery {
 public:
  /// Degenerate (zero-area) triangles are left out of the index; they are never returned.
  /// @throws InvalidInputError when @p mesh has no triangles, only degenerate ones, vertex indices
  ///         out of range, or NaN/inf coordinates.
  explicit SurfaceQuery(const TriMesh& mesh);
  ~SurfaceQuery();
  SurfaceQuery(SurfaceQuery&&) noexcept;
  SurfaceQuery& operator=(SurfaceQuery&&) noexcept;
  SurfaceQuery(const SurfaceQuery&) = delete;
  SurfaceQuery& operator=(const SurfaceQuery&) = delete;

  const TriMesh& mesh() const;

  /// Closest point of the surface to @p p.
  SurfaceHit closest_point(const Vec3& p) const;

  /// The same, starting the search from @p hint — a point on triangle hint.triangle of the mesh
  /// near the answer (an earlier hit, or the surface point a query was offset from) instead of
  /// the nearest vertex's; faster when many queries come from known nearby surface points. A hint
  /// with a triangle that is out of range or left out of the index is ignored.
  SurfaceHit closest_point(const Vec3& p, const SurfaceHit& hint) const;

  /// First intersection of the ray origin + t·direction, t > 0 (direction need not be unit;
  /// distance = t·|direction|). Triangles through the origin are ignored, so a ray cast from a
  /// surface point finds the next surface. nullopt when the ray misses.
  /// @throws InvalidInputError for a zero or non-finite direction.
  std::optional<SurfaceHit> first_hit(const Vec3& origin, const Vec3& direction) const;

  /// min(@p limit_m, distance from @p p to the surface) [m]: the search skips every part of the
  /// tree farther than limit_m, so clearance checks against a threshold cost little away from the
  /// surface. @throws InvalidInputError for a non-finite point or a negative or non-finite limit.
  double distance_up_to(const Vec3& p, double limit_m) const;

  /// Inside test for a closed surface: parity of ray crossings, majority vote over three
  /// non-axis-aligned rays (robust to rays that graze an edge or a vertex).
  bool is_inside(const Vec3& p) const;

  /// The same vote over three rays perpendicular to @p axis (any length), for a surface that is
  /// closed or open only where @p axis leaves it — a limb's skin open at its proximal cut: no ray
  /// escapes through such an opening.
  /// @throws InvalidInputError for a non-finite point or a zero or non-finite axis.
  bool is_inside_across(const Vec3& p, const Vec3& axis) const;

  /// Distance to the surface, negative inside (closed surfaces only).
  double signed_distance(const Vec3& p) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace socketsmith::geometry
