// Hexahedral mesher on analytic limb-like shapes: volume, skin fidelity, quality, node count.
#include <gtest/gtest.h>

#include <cmath>

#include "limb_shapes.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_repair.h"
#include "socketsmith/geometry/surface_query.h"
#include "socketsmith/volume/hex_element.h"
#include "socketsmith/volume/hex_mesher.h"

namespace socketsmith::volume {
namespace {

constexpr double kR = 0.05, kH = 0.2, kCut = 0.18;

/// A capsule trimmed and capped at kCut, with an optional capsule-shaped bone on the axis.
HexMesherInput capsule_input(bool with_bone) {
  HexMesherInput in;
  const auto open = test::capsule(kR, kH, true);
  auto trimmed = geometry::trim_and_cap(open, Vec3(0, 0, kCut), Vec3::UnitZ());
  in.skin = trimmed.mesh;
  in.first_cap_triangle = trimmed.first_cap_triangle;
  in.frame = test::capsule_frame();
  in.cut_height_m = kCut;
  if (with_bone) {
    // Bone: radius 12 mm capsule from z = 0.06 up through the cut (trimmed at the cut too).
    auto bone = test::capsule(0.012, 0.2, true, 60, 48);
    for (auto& v : bone.vertices) v.z() += 0.06;
    in.bones.push_back(geometry::trim_and_cap(bone, Vec3(0, 0, kCut), Vec3::UnitZ()).mesh);
  }
  return in;
}

HexMesherOptions nodes(int n) {
  HexMesherOptions o;
  o.target_nodes = n;
  return o;
}

HexMesherOptions cell(double h) {
  HexMesherOptions o;
  o.cell_size_m = h;
  return o;
}

double capsule_volume(double R, double H) { return 2.0 / 3.0 * M_PI * R * R * R + M_PI * R * R * (H - R); }

TEST(HexMesher, CapsuleVolumeSkinDistanceQualityAndNodeCount) {
  const auto in = capsule_input(false);
  ASSERT_TRUE(geometry::check_mesh(in.skin).is_valid_closed_surface());
  HexMesherOptions opt;
  opt.target_nodes = 3000;
  const auto r = mesh_limb(in, opt);
  EXPECT_NEAR(r.skin_volume_m3, capsule_volume(kR, kCut), 0.01 * capsule_volume(kR, kCut));
  EXPECT_NEAR(r.mesh_volume_m3 / r.skin_volume_m3, 1.0, 0.02);
  EXPECT_LT(r.max_skin_distance_m, 0.5e-3);
  EXPECT_GT(r.quality.min_scaled_jacobian, 0.2);
  EXPECT_EQ(r.quality.inverted, 0);
  EXPECT_NEAR(static_cast<double>(r.mesh.num_nodes()) / opt.target_nodes, 1.0, 0.15);
  EXPECT_NO_THROW(validate(r.mesh));
  // Every skin node is on the skin; proximal nodes on the cut plane and fixed.
  int proximal = 0;
  for (int n = 0; n < r.mesh.num_nodes(); ++n)
    if (r.mesh.has_tag(n, kNodeProximal)) {
      ++proximal;
      EXPECT_NEAR(r.mesh.nodes[n].z(), kCut, 1e-9);
      EXPECT_TRUE(r.mesh.has_tag(n, kNodeFixed));
    }
  EXPECT_GT(proximal, 50);
}

TEST(HexMesher, SkinSurfaceAreasAndNormalsMatchTheCapsule) {
  const auto r = mesh_limb(capsule_input(false), nodes(3000));
  const auto s = extract_skin_surface(r.mesh);
  double area = 0.0;
  Vec3 sum_an = Vec3::Zero();
  for (size_t i = 0; i < s.nodes.size(); ++i) {
    area += s.area_m2[i];
    sum_an += s.area_m2[i] * s.normal[i];
    const Vec3 p = r.mesh.nodes[s.nodes[i]];
    // Outward: the normal points away from the axis (side) or downwards (distal cap).
    const Vec3 radial = p.z() >= kR ? Vec3(p.x(), p.y(), 0.0) : Vec3(p - Vec3(0, 0, kR));
    EXPECT_GT(s.normal[i].dot(radial.normalized()), 0.8) << "node " << s.nodes[i];
  }
  const double exact = 2 * M_PI * kR * kR + 2 * M_PI * kR * (kCut - kR);  // without the cut disc
  EXPECT_NEAR(area / exact, 1.0, 0.02);
  // A closed surface has Σ A n = 0; the open cut disc makes it −π R² e_z.
  EXPECT_NEAR(sum_an.z() / (M_PI * kR * kR), -1.0, 0.03);
  EXPECT_NEAR(sum_an.head<2>().norm() / (M_PI * kR * kR), 0.0, 0.02);
  EXPECT_EQ(s.triangles().num_triangles(), 2 * static_cast<int>(s.quads.size()));
}

TEST(HexMesher, BoneNodesAreFixedAndTheBoneIsCarvedOut) {
  const auto in = capsule_input(true);
  const auto r = mesh_limb(in, nodes(4000));
  const double bone = geometry::signed_volume(in.bones[0]);
  EXPECT_NEAR(r.bone_volume_m3, bone, 1e-12);
  EXPECT_GT(r.removed_bone_hexahedra, 0);
  EXPECT_NEAR(r.tissue_volume_m3 / (r.skin_volume_m3 - r.bone_volume_m3), 1.0, 0.02);
  const geometry::SurfaceQuery q(in.bones[0]);
  // Bone nodes are inside or on the bone; a few are held just outside (within 0.75 cell) where
  // an element wrapping the bone was given to it.
  int bone_nodes = 0, held_outside = 0;
  for (int n = 0; n < r.mesh.num_nodes(); ++n) {
    if (!r.mesh.has_tag(n, kNodeBone)) continue;
    ++bone_nodes;
    EXPECT_TRUE(r.mesh.has_tag(n, kNodeFixed));
    const double d = q.signed_distance(r.mesh.nodes[n]);
    EXPECT_LT(d, 0.75 * r.cell_size_m);
    held_outside += d > 1e-6 ? 1 : 0;
  }
  EXPECT_GT(bone_nodes, 20);
  EXPECT_LT(held_outside, bone_nodes / 10);
  EXPECT_GT(r.quality.min_scaled_jacobian, 0.2);
}

TEST(HexMesher, ExplicitCellSizeAndBadOptions) {
  const auto in = capsule_input(false);
  const auto r = mesh_limb(in, cell(0.012));
  EXPECT_DOUBLE_EQ(r.cell_size_m, 0.012);
  EXPECT_THROW(mesh_limb(in, nodes(10)), InvalidInputError);
  HexMesherInput no_cap = in;
  no_cap.first_cap_triangle = -1;
  EXPECT_THROW(mesh_limb(no_cap, {}), InvalidInputError);
  // A cell far larger than the limb: nothing fits.
  EXPECT_THROW(mesh_limb(in, cell(0.2)), TopologyError);
}

// Bones that fill the skin leave no tissue: the grid size from the target node count came out
// negative and `mesh` ended in "internal error: cannot create std::vector larger than max_size()"
// (issue 26, a fuzzed limb whose second copy 0.5 mm off was taken for the tibia).
TEST(HexMesher, BonesThatFillTheSkinAreRefusedByName) {
  HexMesherInput in = capsule_input(false);
  in.bones.push_back(in.skin);
  for (auto& v : in.bones[0].vertices) v = Vec3(1.01 * v.x(), 1.01 * v.y(), v.z());
  try {
    mesh_limb(in, nodes(300));
    ADD_FAILURE() << "bones filling the skin meshed";
  } catch (const InvalidInputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("the bones (102 % of the skin's volume) leave no tissue to mesh"), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
}

}  // namespace
}  // namespace socketsmith::volume
