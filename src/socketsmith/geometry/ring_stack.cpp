#include "socketsmith/geometry/ring_stack.h"

#include <array>

#include "socketsmith/core/errors.h"

namespace socketsmith::geometry {

TriMesh mesh_ring_stack(const RingStack& stack, bool flip, std::vector<int>* band_first_triangle) {
  TriMesh mesh;
  std::vector<int> first;  // first vertex index of each ring
  if (stack.has_bottom_pole) mesh.vertices.push_back(stack.bottom_pole);
  for (const auto& ring : stack.rings) {
    require(ring.size() >= 3, "mesh_ring_stack: a ring of {} vertices (expected at least 3)", ring.size());
    first.push_back(mesh.num_vertices());
    mesh.vertices.insert(mesh.vertices.end(), ring.begin(), ring.end());
  }
  const int top = mesh.num_vertices();
  if (stack.has_top_pole) mesh.vertices.push_back(stack.top_pole);
  auto tri = [&](int a, int b, int c) { mesh.triangles.push_back(flip ? std::array<int, 3>{a, c, b} : std::array<int, 3>{a, b, c}); };
  if (band_first_triangle) band_first_triangle->clear();
  if (stack.has_bottom_pole && !stack.rings.empty()) {
    const int n = static_cast<int>(stack.rings.front().size());
    for (int j = 0; j < n; ++j) tri(0, first[0] + (j + 1) % n, first[0] + j);
  }
  for (std::size_t k = 0; k + 1 < stack.rings.size(); ++k) {
    if (band_first_triangle) band_first_triangle->push_back(mesh.num_triangles());
    const int na = static_cast<int>(stack.rings[k].size()), nb = static_cast<int>(stack.rings[k + 1].size());
    const int a0 = first[k], b0 = first[k + 1];
    int i = 0, j = 0;
    while (i < na || j < nb) {
      // Advance on A when its next vertex comes first in angle (ties: A first).
      const bool advance_a = j == nb || (i < na && static_cast<double>(i + 1) / na <= static_cast<double>(j + 1) / nb);
      if (advance_a) {
        tri(a0 + i, a0 + (i + 1) % na, b0 + j % nb);
        ++i;
      } else {
        tri(a0 + i % na, b0 + (j + 1) % nb, b0 + j);
        ++j;
      }
    }
  }
  if (band_first_triangle) band_first_triangle->push_back(mesh.num_triangles());
  if (stack.has_top_pole && !stack.rings.empty()) {
    const int n = static_cast<int>(stack.rings.back().size());
    const int b0 = first.back();
    for (int j = 0; j < n; ++j) tri(b0 + j, b0 + (j + 1) % n, top);
  }
  return mesh;
}

}  // namespace socketsmith::geometry
