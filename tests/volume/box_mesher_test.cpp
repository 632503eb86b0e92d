#include "socketsmith/volume/box_mesher.h"

#include <gtest/gtest.h>

#include "socketsmith/core/errors.h"

namespace socketsmith::volume {
namespace {

TEST(BoxMesher, builds_the_grid_with_the_documented_node_numbering_and_tags) {
  BoxMeshOptions o;
  o.origin = Vec3(1, 2, 3);
  o.size = Vec3(0.03, 0.02, 0.01);
  o.divisions = {3, 2, 1};
  const HexMesh m = mesh_box(o);
  EXPECT_EQ(m.num_nodes(), 4 * 3 * 2);
  EXPECT_EQ(m.num_hexahedra(), 6);
  EXPECT_TRUE(m.nodes[box_node_index(o.divisions, 3, 2, 1)].isApprox(Vec3(1.03, 2.02, 3.01)));
  EXPECT_EQ(m.count_tag(kNodeSurface), m.num_nodes());  // one layer: every node is on the surface
  BoxMeshOptions cube;
  cube.divisions = {4, 4, 4};
  const HexMesh c = mesh_box(cube);
  EXPECT_EQ(c.count_tag(kNodeSurface), 125 - 27);
  EXPECT_NO_THROW(validate(c));
}

TEST(BoxMesher, rejects_non_positive_sizes_and_divisions) {
  BoxMeshOptions o;
  o.size.x() = 0;
  EXPECT_THROW(mesh_box(o), InvalidInputError);
  o = {};
  o.divisions[1] = 0;
  EXPECT_THROW(mesh_box(o), InvalidInputError);
  EXPECT_EQ(cube_divisions_for_nodes(20000), 26);  // 27^3 = 19683 nodes
}

}  // namespace
}  // namespace socketsmith::volume
