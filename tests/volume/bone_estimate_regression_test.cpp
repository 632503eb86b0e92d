// Pins the bones estimate_bones produces today, so that a refactoring of the bone template
// (its data, its clearance queries, its spline and ring helpers) is shown not to move a vertex:
// per bone the vertex and triangle counts, the volume, the volume centroid and a weighted sum of
// the vertex positions (which changes when any vertex moves or two vertices swap), to 1e-9 m.
// The expected values were recorded from the template before it was split (issue 24); a change
// of the template's shapes is expected to update them, a refactoring is not.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/volume/bone_template.h"
#include "socketsmith/volume/limb_generator.h"
#include "socketsmith/volume/limb_model.h"
#include "brute_force.h"

namespace socketsmith::volume {
namespace {

using geometry::TriMesh;
using geometry::Vec3;

struct BonePrint {
  std::string name;
  int vertices;
  int triangles;
  double volume_m3;
  Vec3 centroid_m;
  Vec3 weighted_sum_m;  ///< sum of w_i v_i, w_i = 1 + (7919 i mod 13) / 13
};

BonePrint print_of(const NamedMesh& b) {
  Vec3 sum = Vec3::Zero();
  for (std::size_t i = 0; i < b.mesh.vertices.size(); ++i)
    sum += (1.0 + static_cast<double>((7919 * i) % 13) / 13.0) * b.mesh.vertices[i];
  return {b.name, b.mesh.num_vertices(), b.mesh.num_triangles(), geometry::signed_volume(b.mesh),
          test::volume_centroid(b.mesh), sum};
}

void expect_bones(const std::vector<NamedMesh>& bones, const std::vector<BonePrint>& expected) {
  EXPECT_EQ(bones.size(), expected.size());
  for (std::size_t i = 0; i < std::min(bones.size(), expected.size()); ++i) {
    const BonePrint got = print_of(bones[i]);
    const BonePrint& want = expected[i];
    EXPECT_EQ(got.name, want.name);
    EXPECT_EQ(got.vertices, want.vertices) << want.name;
    EXPECT_EQ(got.triangles, want.triangles) << want.name;
    EXPECT_NEAR(got.volume_m3, want.volume_m3, 1e-12) << want.name;  // ~1e-9 m over a bone's ~1e-3 m^2 surface
    EXPECT_LT((got.centroid_m - want.centroid_m).norm(), 1e-9) << want.name;
    // Each vertex within 1e-9 m moves the sum by at most 2e-9 m per vertex.
    EXPECT_LT((got.weighted_sum_m - want.weighted_sum_m).norm(), 2e-9 * want.vertices) << want.name;
  }
  // On a mismatch, the values as table rows (to update the table after an intended change of shape).
  if (!::testing::Test::HasFailure()) return;
  for (const NamedMesh& b : bones) {
    const BonePrint got = print_of(b);
    std::printf("{\"%s\", %d, %d, %.17g, Vec3(%.17g, %.17g, %.17g), Vec3(%.17g, %.17g, %.17g)},\n", got.name.c_str(),
                got.vertices, got.triangles, got.volume_m3, got.centroid_m.x(), got.centroid_m.y(), got.centroid_m.z(),
                got.weighted_sum_m.x(), got.weighted_sum_m.y(), got.weighted_sum_m.z());
  }
}

TEST(BoneEstimateRegression, generated_transtibial_limb_gets_the_same_bones) {
  const GeneratedLimb limb = generate_limb(default_params(geometry::LimbType::Transtibial, 1));
  expect_bones(estimate_bones(limb.skin, limb.frame, geometry::LimbType::Transtibial), {
      {"tibia (estimated)", 1855, 3706, 0.00019871928037330962, Vec3(-0.0031151157901634697, 0.008288451572330215, 0.09961311416473638), Vec3(-8.8686262942735663, 25.982758020273472, 234.49362628878427)},
      {"fibula (estimated)", 1240, 2476, 1.3474230751867192e-05, Vec3(0.024255739007970612, -0.021118412808713353, 0.097259367470378777), Vec3(42.441541100515259, -35.298354238068086, 162.77471957598564)},
      {"patella (estimated)", 1062, 2120, 1.984520327191603e-05, Vec3(0.00021898616057534453, 0.045150397633891337, 0.17596608874267919), Vec3(0.34685021998217325, 70.054560515139784, 272.89217080671665)},
      {"femur (estimated)", 1126, 2248, 0.00015692388550551481, Vec3(-0.0017821410038238068, 0.0015601978726862969, 0.17291425300115898), Vec3(-2.9215360209945831, 2.3156698745798217, 286.54325941811669)},
  });
}

TEST(BoneEstimateRegression, generated_transfemoral_limb_with_ischium_gets_the_same_bones) {
  const GeneratedLimb limb = generate_limb(default_params(geometry::LimbType::Transfemoral, 1));
  BoneEstimateOptions o;
  ASSERT_TRUE(limb.transfemoral.has_value());
  o.ischial_height_m = limb.frame.axis.dot(limb.transfemoral->ischial_tuberosity - limb.frame.origin);
  expect_bones(estimate_bones(limb.skin, limb.frame, geometry::LimbType::Transfemoral, o), {
      {"femur (estimated)", 2317, 4630, 0.00023979306384956328, Vec3(0.021042660860394611, 0.0076049982442296044, 0.24011138991187878), Vec3(63.528226640644093, 26.836657552727502, 736.58411750439564)},
      {"hemipelvis (estimated)", 2821, 5638, 0.00010467041941597143, Vec3(-0.033542840001309748, 0.025346298074012358, 0.35381993023022124), Vec3(-164.57837528247552, 87.127726102532094, 1408.7769250475305)},
  });
}

TEST(BoneEstimateRegression, real_skin_only_transtibial_limb_gets_the_same_bones) {
  const std::filesystem::path file = SOCKETSMITH_SHARED_DATA_DIR "/limbs/transtibial/openlimb_tt_mean_skin_mm.stl";
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "shared data absent: " << file;
  geometry::MeshReadOptions ro;
  ro.unit = units::LengthUnit::Millimetre;
  const LimbModel m = prepare_limb(geometry::read_mesh(file, ro), {}, {});
  ASSERT_TRUE(m.bones_estimated);
  expect_bones(m.bones, {
      {"tibia (estimated)", 1893, 3782, 0.00020772238828346281, Vec3(0.0046797686866740709, -0.0055077472146015192, -0.038079623687165089), Vec3(13.479843941467351, -12.962546166160708, -152.07969589719218)},
      {"fibula (estimated)", 1256, 2508, 1.7957387687547719e-05, Vec3(-0.023029809623083288, 0.024161982264664483, -0.033122442354058493), Vec3(-39.191243861409504, 42.395882545414565, -87.223860302982231)},
      {"patella (estimated)", 1062, 2120, 1.5153138455370663e-05, Vec3(0.0048174284363598895, -0.050459594596547627, 0.038672527338859251), Vec3(7.46693089830727, -78.277011564944843, 59.887546577382608)},
      {"femur (estimated)", 1204, 2404, 0.00016635367651276914, Vec3(0.0068288664758306824, -0.0096934503939399771, 0.043921119250465837), Vec3(12.075205994127455, -17.526778617585883, 83.015389722668218)},
  });
}

}  // namespace
}  // namespace socketsmith::volume
