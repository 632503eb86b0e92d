#include "socketsmith/volume/box_mesher.h"

#include <cmath>

#include "socketsmith/core/errors.h"

namespace socketsmith::volume {

HexMesh mesh_box(const BoxMeshOptions& o) {
  for (int d = 0; d < 3; ++d) {
    require(std::isfinite(o.size[d]) && o.size[d] > 0, "mesh_box: size[{}] = {} m (expected > 0)", d, o.size[d]);
    require(o.divisions[d] >= 1 && o.divisions[d] <= 2000, "mesh_box: divisions[{}] = {} (expected 1..2000)", d,
            o.divisions[d]);
  }
  const auto& n = o.divisions;
  HexMesh mesh;
  mesh.nodes.reserve(static_cast<size_t>(n[0] + 1) * (n[1] + 1) * (n[2] + 1));
  for (int k = 0; k <= n[2]; ++k)
    for (int j = 0; j <= n[1]; ++j)
      for (int i = 0; i <= n[0]; ++i)
        mesh.nodes.push_back(o.origin + Vec3(o.size.x() * i / n[0], o.size.y() * j / n[1], o.size.z() * k / n[2]));
  mesh.hexahedra.reserve(static_cast<size_t>(n[0]) * n[1] * n[2]);
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) {
        auto id = [&](int di, int dj, int dk) { return box_node_index(n, i + di, j + dj, k + dk); };
        mesh.hexahedra.push_back(
            {id(0, 0, 0), id(1, 0, 0), id(1, 1, 0), id(0, 1, 0), id(0, 0, 1), id(1, 0, 1), id(1, 1, 1), id(0, 1, 1)});
      }
  mesh.node_tags.assign(mesh.nodes.size(), kNodeNone);
  for (int k = 0; k <= n[2]; ++k)
    for (int j = 0; j <= n[1]; ++j)
      for (int i = 0; i <= n[0]; ++i)
        if (i == 0 || j == 0 || k == 0 || i == n[0] || j == n[1] || k == n[2])
          mesh.node_tags[box_node_index(n, i, j, k)] |= kNodeSurface;
  return mesh;
}

int cube_divisions_for_nodes(int target_nodes) {
  require(target_nodes >= 8, "cube_divisions_for_nodes: target {} (expected ≥ 8)", target_nodes);
  return std::max(1, static_cast<int>(std::lround(std::cbrt(static_cast<double>(target_nodes)) - 1.0)));
}

}  // namespace socketsmith::volume
