#include "socketsmith/volume/hex_mesh.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/volume/box_mesher.h"

namespace socketsmith::volume {
namespace {

TEST(HexMesh, boundary_of_a_box_is_a_closed_outward_surface_with_the_box_volume) {
  BoxMeshOptions o;
  o.size = Vec3(0.02, 0.03, 0.04);
  o.divisions = {2, 3, 4};
  const HexMesh m = mesh_box(o);
  EXPECT_EQ(boundary_quads(m).size(), static_cast<size_t>(2 * (2 * 3 + 3 * 4 + 2 * 4)));
  const auto surf = boundary_surface(m);
  const auto rep = geometry::check_mesh(surf);
  EXPECT_EQ(rep.boundary_edges, 0);
  EXPECT_EQ(rep.non_manifold_edges, 0);
  EXPECT_NEAR(geometry::signed_volume(surf), 0.02 * 0.03 * 0.04, 1e-15);  // positive: outward
  EXPECT_NEAR(total_volume(m), 0.02 * 0.03 * 0.04, 1e-15);
}

TEST(HexMesh, quality_of_a_regular_grid_and_of_a_distorted_element) {
  BoxMeshOptions o;
  o.size = Vec3(0.01, 0.01, 0.02);
  o.divisions = {1, 1, 1};
  HexMesh m = mesh_box(o);
  auto q = hex_quality(m);
  EXPECT_NEAR(q.min_scaled_jacobian, 1.0, 1e-12);
  EXPECT_NEAR(q.max_aspect_ratio, 2.0, 1e-12);
  EXPECT_EQ(q.inverted, 0);
  m.nodes[6] = m.nodes[0] + Vec3(0.001, 0.001, 0.001);  // push the far corner through the element
  q = hex_quality(m);
  EXPECT_LT(q.min_scaled_jacobian, 0.0);
  EXPECT_EQ(q.inverted, 1);
  EXPECT_THROW(validate(m), TopologyError);
}

TEST(HexMesh, validate_rejects_bad_indices_nan_and_missing_tags) {
  HexMesh m = mesh_box({});
  EXPECT_NO_THROW(validate(m));
  HexMesh bad = m;
  bad.hexahedra[0][3] = 99999;
  EXPECT_THROW(validate(bad), InvalidInputError);
  bad = m;
  bad.nodes[0].x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(validate(bad), InvalidInputError);
  bad = m;
  bad.node_tags.pop_back();
  EXPECT_THROW(validate(bad), InvalidInputError);
  EXPECT_THROW(validate(HexMesh{}), InvalidInputError);
}

TEST(HexMesh, colours_group_runs_of_elements_that_share_no_node) {
  BoxMeshOptions o;
  o.size = Vec3(0.04, 0.05, 0.06);
  o.divisions = {4, 5, 6};
  HexMesh m = mesh_box(o);
  const auto check = [](const HexMesh& mesh, const std::vector<std::vector<ElementRun>>& groups, int length) {
    std::vector<int> seen(mesh.hexahedra.size(), 0);
    for (const auto& g : groups) {
      std::vector<int> owner(static_cast<size_t>(mesh.num_nodes()), -1);
      for (size_t r = 0; r < g.size(); ++r) {
        EXPECT_EQ(g[r].begin % length, 0);
        EXPECT_TRUE(g[r].end - g[r].begin == length || g[r].end == mesh.num_hexahedra());
        for (int e = g[r].begin; e < g[r].end; ++e) {
          ++seen[static_cast<size_t>(e)];
          for (int n : mesh.hexahedra[static_cast<size_t>(e)]) {
            const int prev = owner[static_cast<size_t>(n)];
            EXPECT_TRUE(prev == -1 || prev == static_cast<int>(r)) << "runs " << prev << " and " << r << " share node " << n;
            owner[static_cast<size_t>(n)] = static_cast<int>(r);
          }
        }
      }
    }
    for (int s : seen) EXPECT_EQ(s, 1);
  };
  const auto singles = colour_element_runs(m.num_nodes(), m.hexahedra, 1);
  EXPECT_EQ(singles.size(), 8u);  // a structured grid: the 2×2×2 parity classes
  check(m, singles, 1);
  // Runs of 7 elements (not a row's length: runs straddle rows and layers).
  const auto runs = colour_element_runs(m.num_nodes(), m.hexahedra, 7);
  EXPECT_GE(runs.size(), 2u);
  check(m, runs, 7);
  // Elements listed in a scrambled order (as a mesher's may be) still colour correctly.
  std::reverse(m.hexahedra.begin(), m.hexahedra.end());
  std::swap(m.hexahedra[3], m.hexahedra[70]);
  check(m, colour_element_runs(m.num_nodes(), m.hexahedra, 1), 1);
  check(m, colour_element_runs(m.num_nodes(), m.hexahedra, 5), 5);
  EXPECT_THROW(colour_element_runs(3, m.hexahedra, 4), InvalidInputError);
  EXPECT_THROW(colour_element_runs(m.num_nodes(), m.hexahedra, 0), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::volume
