// Ring stacks: rings of different vertex counts zipped into a closed, outward surface, the band
// indices, and the flip for clockwise rings.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/ring_stack.h"

namespace socketsmith::geometry {
namespace {

constexpr double kPi = std::numbers::pi;

TEST(RingStack, uneven_rings_make_a_closed_oriented_surface) {
  RingStack stack;
  stack.has_bottom_pole = stack.has_top_pole = true;
  stack.bottom_pole = Vec3(0, 0, -0.01);
  stack.top_pole = Vec3(0, 0, 0.05);
  const int counts[] = {8, 13, 21, 21, 5};
  for (int k = 0; k < 5; ++k) {
    std::vector<Vec3> ring;
    for (int j = 0; j < counts[k]; ++j) {
      // Angles from anterior (+y) towards medial of a right limb (-x).
      const double a = 2 * kPi * j / counts[k];
      ring.emplace_back(-0.02 * std::sin(a), 0.02 * std::cos(a), 0.01 * k);
    }
    stack.rings.push_back(ring);
  }
  std::vector<int> bands;
  const TriMesh m = mesh_ring_stack(stack, false, &bands);
  const auto rep = check_mesh(m);
  EXPECT_TRUE(rep.is_valid_closed_surface());
  EXPECT_GT(rep.signed_volume_m3, 0.0);
  EXPECT_EQ(m.num_triangles(), 8 + (8 + 13) + (13 + 21) + (21 + 21) + (21 + 5) + 5);
  ASSERT_EQ(bands.size(), 5u);
  EXPECT_EQ(bands.front(), 8);
  EXPECT_EQ(bands.back(), m.num_triangles() - 5);
  EXPECT_LT(signed_volume(mesh_ring_stack(stack, true)), 0.0);
}

TEST(RingStack, ring_of_two_vertices_is_rejected) {
  RingStack stack;
  stack.rings = {{Vec3(0, 0, 0), Vec3(1, 0, 0)}};
  EXPECT_THROW(mesh_ring_stack(stack, false), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::geometry
