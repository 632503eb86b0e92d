#pragma once
/// @file box_with_top.h
/// Test fixture of the calculix tests: a 20 mm box of 2 × 2 × 2 hexahedra and its top face as skin
/// quads / faces (the smallest stump with a skin).

#include <array>
#include <vector>

#include "socketsmith/calculix/calculix_deck.h"
#include "socketsmith/volume/box_mesher.h"

namespace socketsmith::calculix::testing {

struct BoxWithTop {
  volume::BoxMeshOptions options;
  volume::HexMesh mesh;
  std::vector<std::array<int, 4>> top_quads;  ///< the top face's 4 quads
  std::vector<HexFace> top;                   ///< the same as hexahedron faces
  std::vector<int> top_nodes;                 ///< the 9 nodes of the top face

  BoxWithTop() {
    options.size = Vec3(0.02, 0.02, 0.02);
    options.divisions = {2, 2, 2};
    mesh = volume::mesh_box(options);
    const auto id = [&](int i, int j) { return volume::box_node_index(options.divisions, i, j, 2); };
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) top_quads.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)});
    top = faces_of_quads(mesh, top_quads);
    for (int j = 0; j <= 2; ++j)
      for (int i = 0; i <= 2; ++i) top_nodes.push_back(id(i, j));
  }
};

}  // namespace socketsmith::calculix::testing
