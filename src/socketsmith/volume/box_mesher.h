#pragma once
/// @file box_mesher.h
/// Structured hexahedral mesh of an axis-aligned box.

#include <array>

#include "socketsmith/volume/hex_mesh.h"

namespace socketsmith::volume {

struct BoxMeshOptions {
  Vec3 origin = Vec3::Zero();                        ///< minimum corner [m]
  Vec3 size = Vec3::Constant(0.05);                  ///< edge lengths [m], each > 0
  std::array<int, 3> divisions = {8, 8, 8};          ///< elements along x, y, z, each ≥ 1
};

/// Regular grid of (nx+1)(ny+1)(nz+1) nodes; node (i,j,k) has index i + (nx+1)(j + (ny+1)k).
/// Boundary nodes are tagged kNodeSurface.
/// @throws InvalidInputError for a non-positive size or division count.
HexMesh mesh_box(const BoxMeshOptions& options);

/// Index of grid node (i, j, k) in a mesh made by mesh_box with @p divisions.
inline int box_node_index(const std::array<int, 3>& divisions, int i, int j, int k) {
  return i + (divisions[0] + 1) * (j + (divisions[1] + 1) * k);
}

/// Divisions of a cube lattice with about @p target_nodes nodes (n+1)^3.
int cube_divisions_for_nodes(int target_nodes);

}  // namespace socketsmith::volume
