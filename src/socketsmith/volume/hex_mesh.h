#pragma once
/// @file hex_mesh.h
/// Hexahedral volume mesh: nodes, 8-node hexahedra, node tags.

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::volume {

using Vec3 = Eigen::Vector3d;

/// Node tags (bit flags).
enum NodeTag : std::uint8_t {
  kNodeNone = 0,
  kNodeFixed = 1 << 0,    ///< Dirichlet node (e.g. inside a bone)
  kNodeSurface = 1 << 1,  ///< on the outer boundary surface
  kNodeBone = 1 << 2,     ///< on or inside a bone
  kNodeProximal = 1 << 3, ///< on the proximal cut plane of a limb
};

/// An 8-node hexahedron. Node order as VTK_HEXAHEDRON and Abaqus/CalculiX C3D8: the bottom face
/// 0-1-2-3 counter-clockwise seen from the top, then the top face 4-5-6-7 above 0-1-2-3.
/// Reference coordinates: node k sits at (xi, eta, zeta) = kHexCorners[k].
using Hex = std::array<int, 8>;

/// Reference-cube corners (±1) of the 8 nodes, in the order of Hex.
inline constexpr int kHexCorners[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                          {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};

/// The 12 edges, 12 face diagonals and 4 body diagonals of a hexahedron (local node pairs).
inline constexpr int kHexEdges[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                                         {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
inline constexpr int kHexFaceDiagonals[12][2] = {{0, 2}, {1, 3}, {4, 6}, {5, 7}, {0, 5}, {1, 4},
                                                 {1, 6}, {2, 5}, {2, 7}, {3, 6}, {3, 4}, {0, 7}};
inline constexpr int kHexBodyDiagonals[4][2] = {{0, 6}, {1, 7}, {2, 4}, {3, 5}};

/// The 6 faces, local node indices ordered counter-clockwise seen from outside the element.
inline constexpr int kHexFaces[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                        {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};

/// Hexahedral mesh in metres.
struct HexMesh {
  std::vector<Vec3> nodes;              ///< positions [m]
  std::vector<Hex> hexahedra;           ///< element connectivity (0-based)
  std::vector<std::uint8_t> node_tags;  ///< NodeTag flags per node (same size as nodes)

  int num_nodes() const { return static_cast<int>(nodes.size()); }
  int num_hexahedra() const { return static_cast<int>(hexahedra.size()); }
  bool has_tag(int node, NodeTag tag) const { return (node_tags[node] & tag) != 0; }
  int count_tag(NodeTag tag) const;
};

/// A boundary face: a quad used by exactly one hexahedron, oriented outward.
struct BoundaryQuad {
  std::array<int, 4> nodes;  ///< counter-clockwise seen from outside
  int hexahedron;            ///< owning element
  int local_face;            ///< index into kHexFaces
};

/// The faces used by exactly one element (the outer surface and the bone interfaces).
std::vector<BoundaryQuad> boundary_quads(const HexMesh& mesh);

/// Sets kNodeSurface on every node of a boundary quad (clears it elsewhere).
void tag_boundary_nodes(HexMesh& mesh);

/// Boundary quads split into triangles (outward), vertices = all mesh nodes (unused ones kept).
geometry::TriMesh boundary_surface(const HexMesh& mesh);

/// Total volume of the elements [m^3].
double total_volume(const HexMesh& mesh);

/// Quality summary.
struct HexQuality {
  double min_scaled_jacobian = 0.0;   ///< in [-1, 1]; ≤ 0 means an inverted or degenerate corner
  double mean_scaled_jacobian = 0.0;
  double max_aspect_ratio = 0.0;      ///< longest / shortest edge per element, max over elements
  int inverted = 0;                   ///< elements with a non-positive corner Jacobian
};
HexQuality hex_quality(const HexMesh& mesh);

/// Elements [begin, end) of a mesh, in element order.
struct ElementRun {
  int begin = 0, end = 0;
};
/// The elements cut into runs of @p run_length consecutive elements, the runs grouped ("colours")
/// so that no two runs of a group share a node: a parallel loop over one group's runs, each run in
/// element order, may scatter into per-node storage without locks or atomics and keeps the cache
/// locality of the element order; adding the groups in turn gives the same sum whatever the number
/// of threads. Greedy, first fit in run order. run_length 1 colours single elements (8 groups on a
/// structured grid). @throws InvalidInputError for a node index outside [0, num_nodes) or
/// run_length < 1.
std::vector<std::vector<ElementRun>> colour_element_runs(int num_nodes, const std::vector<Hex>& hexahedra,
                                                         int run_length);

/// Validates indices, tag array size, finite coordinates and positive corner Jacobians.
/// @throws InvalidInputError (NaN, bad index) or TopologyError (inverted element) naming the
///         first offending node/element and the fix.
void validate(const HexMesh& mesh);

}  // namespace socketsmith::volume
