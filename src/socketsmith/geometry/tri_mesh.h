#pragma once
/// @file tri_mesh.h
/// Triangle surface mesh in SI units (metres).

#include <array>
#include <limits>
#include <optional>
#include <vector>

#include <limits>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace socketsmith::geometry {

using Vec3 = Eigen::Vector3d;

/// Axis-aligned box. Empty when min > max.
struct Aabb {
  Vec3 min = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 max = Vec3::Constant(-std::numeric_limits<double>::infinity());
  bool is_empty() const { return (min.array() > max.array()).any(); }
  Vec3 extent() const { return is_empty() ? Vec3::Zero() : Vec3(max - min); }
  Vec3 center() const { return 0.5 * (min + max); }
  void extend(const Vec3& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
};

/// A triangle soup with shared vertices. Triangles are counter-clockwise seen from outside
/// (outward normals) for closed surfaces.
struct TriMesh {
  std::vector<Vec3> vertices;                ///< positions [m]
  std::vector<std::array<int, 3>> triangles;  ///< vertex indices, 0-based

  int num_vertices() const { return static_cast<int>(vertices.size()); }
  int num_triangles() const { return static_cast<int>(triangles.size()); }
  bool empty() const { return triangles.empty(); }
};

/// Bounding box of the vertices.
Aabb bounding_box(const TriMesh& mesh);

/// Unit normal of triangle @p t (zero vector for a degenerate triangle).
Vec3 triangle_normal(const TriMesh& mesh, int t);

/// Area of triangle @p t [m^2].
double triangle_area(const TriMesh& mesh, int t);

/// Total area [m^2].
double surface_area(const TriMesh& mesh);

/// Centroid of the surface: the area-weighted mean of the triangles' centroids [m]; std::nullopt
/// when the surface has no area.
std::optional<Vec3> area_centroid(const TriMesh& mesh);

/// Signed enclosed volume by the divergence theorem [m^3]: positive for a closed surface with
/// outward normals, negative when the orientation is inside-out. Meaningless for open surfaces.
double signed_volume(const TriMesh& mesh);

/// Applies p -> scale * p to every vertex.
void scale(TriMesh& mesh, double factor);

/// Reverses the orientation of every triangle.
void flip_orientation(TriMesh& mesh);

/// Merges vertices closer than @p abs_tol_m (STL files repeat every vertex per triangle).
/// Drops triangles that become degenerate (two equal indices). Returns the merged mesh.
TriMesh weld_vertices(const TriMesh& mesh, double abs_tol_m);

}  // namespace socketsmith::geometry
