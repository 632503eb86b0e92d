#include "socketsmith/volume/hex_mesh.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace socketsmith::volume
