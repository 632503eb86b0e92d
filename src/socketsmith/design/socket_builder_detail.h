#pragma once
/// The socket builder's pieces (inside `design` only; `socket_builder.h` is the interface):
/// the inner wall cut below the brim and the shell assembled on it (`socket_builder.cpp`), the
/// distal platform — pad or attachment with its drilled holes — joined to the shell by exact
/// Booleans (`socket_platform.cpp`), and the faces of the finished solid labelled and its wall
/// measured (`socket_measurement.cpp`). Why apart: each is a step of its own in `build_socket`,
/// with its own geometry and its own tests of what it promises.

#include <array>
#include <numbers>
#include <vector>

#include "socketsmith/core/units.h"
#include "socketsmith/design/socket_builder.h"
#include "socketsmith/geometry/surface_query.h"

namespace socketsmith::design::socket_detail {

using geometry::TriMesh;
inline constexpr double kMm = units::mm;
inline constexpr double kDeg = units::deg;
inline constexpr double kPi = std::numbers::pi;

/// One key per undirected edge.
inline std::uint64_t edge_key(int a, int b) {
  const auto lo = static_cast<std::uint64_t>(std::min(a, b)), hi = static_cast<std::uint64_t>(std::max(a, b));
  return (lo << 32) | hi;
}

/// The inner wall below the brim with, per kept vertex, its normal.
struct CutSurface {
  TriMesh mesh;
  std::vector<Vec3> normal;
  std::vector<char> on_rim;  // vertex created on the brim curve
};

struct Attempt {
  TriMesh solid;
  std::vector<SocketFace> kind;
  int inner = 0, outer = 0, lip = 0;
};

/// Where the platform goes, in its own frame: x along `anterior`, y along `medial`, z along the
/// pylon `up`, origin on the pylon axis at the limb frame's distal level.
struct PlatformFrame {
  Vec3 origin = Vec3::Zero(), up = Vec3::UnitZ(), anterior = Vec3::UnitX(), medial = Vec3::UnitY();
  Vec3 at(double x, double y, double z) const { return origin + x * anterior + y * medial + z * up; }
  double z_of(const Vec3& p) const { return (p - origin).dot(up); }
  Eigen::Vector2d xy_of(const Vec3& p) const { return {(p - origin).dot(anterior), (p - origin).dot(medial)}; }
};

/// What the platform step decided, for the result and the face classification.
struct PlatformBuild {
  PlatformFrame frame;
  double radius = 0, z_face = 0, hole_radius = 0;
  std::vector<Eigen::Vector2d> holes;
  std::vector<double> hole_top;
  SocketPlatform report;
};

inline constexpr int kPlatformSectors = 72;  ///< around the platform's disc
inline constexpr int kHoleSides = 24;        ///< of each drill's polygon (circumscribed: never narrower than asked)
inline constexpr double kPlatformGap_m = 0.5e-3;  ///< flat face below the lowest outer-wall point of the disc

/// Joins the platform to the shell @p a (and drills the holes). The block's top follows the middle
/// of the wall (inner + half the offset), so it lies inside the wall's material: the union adds
/// material below the wall and never into the cavity. Its flat face lies kPlatformGap_m below the
/// lowest outer-wall point over the disc and, with holes, platform_thickness_m below the cavity
/// over every hole.
/// Asked thickness at every vertex of the cut wall.
std::vector<double> asked_per_vertex(const CutSurface& cut, const geometry::LimbFrame& frame, const BrimLine& brim,
                                     const SocketOptions& o);

/// Offsets along the normals that make the wall as thick as asked. Starting from the asked
/// thickness, every pass measures the distance to the inner wall at each outer vertex, edge
/// midpoint and centroid; where it falls short of 0.995 × asked (concave regions, where the
/// offset surface comes closer to the neighbouring faces, and facets across convex ones, whose
/// chords cut the corners) the vertices involved move further out, to 1.002 × asked: the deficit
/// divided by the rate at which moving along the normal opens the distance. At most three walls
/// out and four passes (a thinner spot left is reported by the measurement). Returns the passes
/// that raised.
int correct_offsets(const CutSurface& cut, const geometry::SurfaceQuery& inner, const std::vector<double>& asked,
                    std::vector<double>& s);

/// The shell: inner wall (reversed), outer wall at offsets @p s, lip along the rim.
Attempt assemble(const CutSurface& cut, const geometry::LimbFrame& frame, const SocketOptions& o,
                 const std::vector<double>& s);

/// Directed boundary edges (a → b as they appear in a triangle) of a surface.
std::vector<std::array<int, 2>> directed_boundary_edges(const TriMesh& m);

PlatformBuild add_platform(Attempt& a, const CutSurface& cut, const std::vector<double>& s,
                           const geometry::LimbFrame& frame, const SocketOptions& o, double phase);

/// Labels the faces of the solid after the Booleans: a face the Booleans left as it was (its three
/// vertices and the face are in @p shell) keeps its label from @p shell_kind; the others are
/// labelled by where they lie.
std::vector<SocketFace> classify_faces(const TriMesh& solid, const TriMesh& shell,
                                       const std::vector<SocketFace>& shell_kind, const geometry::SurfaceQuery& inner,
                                       const geometry::SurfaceQuery& lip, const PlatformBuild& pb);

/// Thickness of the whole outer surface: per vertex, and statistics over its vertices, edge
/// midpoints and centroids (points within the brim band left out).
void measure_thickness(SocketResult& r, const geometry::SurfaceQuery& inner, const geometry::SurfaceQuery* lip,
                       const geometry::LimbFrame& frame, const BrimLine& brim, const SocketOptions& o);

}  // namespace socketsmith::design::socket_detail
