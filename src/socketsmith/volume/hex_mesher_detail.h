#pragma once
/// The hexahedral limb mesher's pieces (inside `volume` only; `hex_mesher.h` is the interface):
/// - the topology on one grid size: the grid aligned with the limb frame, its core cells inside the
///   skin kept manifold, and the pillow layer extruded from the core to the skin
///   (`hex_mesher_topology.cpp`);
/// - the moves of the nodes afterwards: smoothing under the skin, rim and cut-plane constraints, and
///   conforming to the bones (`hex_mesher_nodes.cpp`).
/// Why apart: `mesh_limb` (`hex_mesher.cpp`) builds the topology on several grid sizes to meet the
/// node target before any node moves, and each of the two is a responsibility of its own.

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "socketsmith/geometry/surface_query.h"
#include "socketsmith/volume/hex_element.h"
#include "socketsmith/volume/hex_mesher.h"

namespace socketsmith::volume::hex_mesher_detail {

/// Each node's neighbours along the edges of @p quads, sorted; @p corners(q) gives quad q's four
/// node indices (≥ 0) in order round it. The list is as long as the largest index + 1.
template <class Quads, class Corners>
std::vector<std::vector<int>> quad_edge_neighbours(const Quads& quads, Corners corners) {
  std::vector<std::vector<int>> nb;
  for (const auto& q : quads) {
    const std::array<int, 4> c = corners(q);
    for (int m = 0; m < 4; ++m) {
      const int a = c[m], b = c[(m + 1) % 4];
      if (static_cast<int>(nb.size()) <= std::max(a, b)) nb.resize(std::max(a, b) + 1);
      nb[a].push_back(b);
      nb[b].push_back(a);
    }
  }
  for (auto& v : nb) {
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
  }
  return nb;
}

using geometry::SurfaceQuery;
using geometry::TriMesh;

/// Structured grid aligned with the limb frame. Local coordinates q = R^T (x − origin).
struct Grid {
  Vec3 origin = Vec3::Zero();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // columns: anterior, axis × anterior, axis
  Vec3 q0 = Vec3::Zero();                            // local coordinates of node (0,0,0)
  double h = 0.0;
  int nx = 0, ny = 0, nz = 0;  // nodes per direction (cells: n − 1)

  int cx() const { return nx - 1; }
  int cy() const { return ny - 1; }
  int cz() const { return nz - 1; }
  int node(int i, int j, int k) const { return (k * ny + j) * nx + i; }
  int cell(int i, int j, int k) const { return (k * cy() + j) * cx() + i; }
  int num_nodes() const { return nx * ny * nz; }
  int num_cells() const { return cx() * cy() * cz(); }
  Vec3 local(int i, int j, int k) const { return q0 + h * Vec3(i, j, k); }
  Vec3 world(int i, int j, int k) const { return origin + R * local(i, j, k); }
  Vec3 to_local(const Vec3& x) const { return R.transpose() * (x - origin); }
};

/// The side of the skin (cap triangles removed) and the rim loop segments (cap ∩ side edges).
struct SkinParts {
  TriMesh side;
  std::vector<std::array<Vec3, 2>> rim;
};

/// Everything built on one grid size (used for the node-count search and the final mesh).
struct Build {
  Grid grid;
  HexMesh mesh;
  std::vector<int> copy_of;        // mesh node -> core node it was extruded from (-1 for core)
  std::vector<std::uint8_t> kind;  // 0 interior core, 1 core on top plane, 2 skin copy, 3 rim copy
  int core_hexahedra = 0;
  int pillow_hexahedra = 0;
  int manifold_changes = 0;
  int cavities_filled = 0;
  int components_dropped = 0;
};

/// What a node of a Build is (Build::kind).
inline constexpr std::uint8_t kInterior = 0, kTopPlane = 1, kSkinNode = 2, kRimNode = 3;

SkinParts split_skin(const HexMesherInput& in);
/// The point of the segments nearest to @p p.
Vec3 closest_on_segments(const std::vector<std::array<Vec3, 2>>& segs, const Vec3& p);
/// The smallest corner scaled Jacobian of a hexahedron.
double min_scaled_jacobian(const std::vector<Vec3>& x, const Hex& hex);
/// The core cells of a grid of cell @p h inside the skin and the pillow layer extruded to it.
Build build_topology(const HexMesherInput& in, const SkinParts& parts, const SurfaceQuery& side_query,
                     double h, double core_offset, int presmooth_iterations);

/// Projection of a node of each kind onto its constraint.
struct Projector {
  const SurfaceQuery& side;
  const SkinParts& parts;
  const Grid& grid;
  double cut_h_local;  // local z of the cut plane

  Vec3 operator()(std::uint8_t kind, const Vec3& p) const {
    switch (kind) {
      case kSkinNode:
        return side.closest_point(p).point;
      case kRimNode:
        return closest_on_segments(parts.rim, p);
      case kTopPlane: {
        Vec3 q = grid.to_local(p);
        q.z() = cut_h_local;
        return grid.origin + grid.R * q;
      }
      default:
        return p;
    }
  }
};

/// Moves the nodes towards their neighbours' mean, each kept on its constraint (@p project), never
/// spoiling an element below @p goal.
void smooth(Build& b, const Projector& project, int iterations, double goal);

struct BoneReport {
  int removed = 0;   ///< elements wholly in bone, removed
  int snapped = 0;   ///< nodes moved onto a bone surface
  int held = 0;      ///< nodes that could not move without spoiling an element
};

/// Tags nodes inside bones, snaps the bone-interface nodes onto the bone surfaces where quality
/// allows, and removes elements whose 8 nodes are all in bone.
BoneReport apply_bones(HexMesh& mesh, const std::vector<geometry::TriMesh>& bones, std::vector<std::uint8_t>& kind,
                       const Projector& project, double h, double goal);
/// Drops unused nodes and renumbers (keeps the per-node arrays aligned).
void compact(HexMesh& mesh, std::vector<std::uint8_t>& kind);
/// Nodes a final mesh built on this topology will have (bone-interior nodes excluded).
int estimated_nodes(const Build& b, const std::vector<geometry::TriMesh>& bones,
                    const std::vector<SurfaceQuery>& bone_queries);

}  // namespace socketsmith::volume::hex_mesher_detail
