// The stump model against the generator's truth: frame, side, bones, landmarks, mesh.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "socketsmith/core/units.h"
#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/volume/hex_mesher.h"
#include "socketsmith/volume/limb_generator.h"
#include "socketsmith/volume/limb_model.h"

namespace socketsmith {
namespace {

using geometry::LimbType;

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) / units::deg;
}

struct Truth {
  LimbType type;
  geometry::Side side;
  std::uint64_t seed;
};

class GeneratedLimb : public ::testing::TestWithParam<Truth> {};

TEST_P(GeneratedLimb, FrameSideLandmarksAndMeshMatchTheTruth) {
  const Truth t = GetParam();
  volume::LimbShapeParams p = volume::default_params(t.type, t.seed);
  p.side = t.side;
  const volume::GeneratedLimb g = volume::generate_limb(p);
  volume::LimbInputOptions o;
  o.type = t.type;
  const volume::LimbModel m = volume::prepare_limb(volume::merge_shells(g), {}, o);

  EXPECT_LT(angle_deg(m.frame.axis, g.frame.axis), 2.0);
  EXPECT_LT((m.frame.origin - g.frame.origin).norm(), 3e-3);
  EXPECT_FALSE(m.bones_estimated);
  if (t.type == LimbType::Transtibial) {
    // The patella gives the front, the fibula the side.
    EXPECT_FALSE(m.frame.anterior_estimated);
    EXPECT_LT(angle_deg(m.frame.anterior, g.frame.anterior), 10.0);
    EXPECT_FALSE(m.frame.side_estimated);
    EXPECT_EQ(m.frame.side, g.frame.side);
  }
  // Landmarks: every code placed, on average within 12 mm of the truth, none beyond 35 mm.
  std::map<std::string, Eigen::Vector3d> truth;
  for (const auto& l : g.landmarks) truth[l.code] = l.position;
  ASSERT_EQ(m.landmarks.size(), truth.size());
  if (t.type == LimbType::Transtibial) {
    double sum = 0.0;
    for (const auto& l : m.landmarks) {
      ASSERT_TRUE(truth.count(l.code)) << l.code;
      const double d = (l.position - truth[l.code]).norm();
      sum += d;
      EXPECT_LT(d, 0.035) << l.code;
    }
    EXPECT_LT(sum / m.landmarks.size(), 0.012);
  }
  volume::HexMesherOptions mo;
  mo.target_nodes = 3000;
  const auto r = volume::mesh_limb(volume::mesher_input(m), mo);
  EXPECT_GT(r.quality.min_scaled_jacobian, 0.2);
  EXPECT_NEAR(static_cast<double>(r.mesh.num_nodes()) / mo.target_nodes, 1.0, 0.15);
  double bones = 0.0;
  for (const auto& b : m.bones) bones += geometry::signed_volume(b.mesh);
  EXPECT_NEAR(r.tissue_volume_m3 / (r.skin_volume_m3 - bones), 1.0, 0.03);
}

INSTANTIATE_TEST_SUITE_P(Seeds, GeneratedLimb,
                         ::testing::Values(Truth{LimbType::Transtibial, geometry::Side::Right, 1},
                                           Truth{LimbType::Transtibial, geometry::Side::Left, 2},
                                           Truth{LimbType::Transtibial, geometry::Side::Right, 3},
                                           Truth{LimbType::Transfemoral, geometry::Side::Right, 1},
                                           Truth{LimbType::Transfemoral, geometry::Side::Left, 4}));

/// The skin-only anterior estimate (outline skewness) against the truth, left and right limbs.
TEST(GeneratedLimb, SkinOnlyAnteriorEstimateOnTranstibialLimbs) {
  int within_30 = 0;
  const int n = 6;
  for (int seed = 1; seed <= n; ++seed) {
    auto params = volume::default_params(LimbType::Transtibial, seed);
    if (seed % 2 == 0) params.side = geometry::Side::Left;
    const volume::GeneratedLimb g = volume::generate_limb(params);
    geometry::LimbFrame f = geometry::estimate_limb_axis(g.skin);
    f.side = params.side;
    const Eigen::Vector3d a = geometry::estimate_anterior_from_skin(g.skin, f);
    const double err = angle_deg(a - a.dot(f.axis) * f.axis, g.frame.anterior);
    RecordProperty("seed_" + std::to_string(seed) + "_anterior_error_deg", std::to_string(err));
    within_30 += err < 30.0 ? 1 : 0;
  }
  EXPECT_EQ(within_30, n);
}

}  // namespace
}  // namespace socketsmith
