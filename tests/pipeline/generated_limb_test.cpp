// The stump model against the generator's truth: frame, side, bones, landmarks, mesh.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include <Eigen/Geometry>

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

  const bool tt = t.type == LimbType::Transtibial;
  // A transfemoral axis follows the femur's shaft, which the generator (like the body) adducts
  // a few degrees against the thigh's axis; its origin is the skin's distal end on that axis.
  EXPECT_LT(angle_deg(m.frame.axis, g.frame.axis), tt ? 2.0 : 5.0);
  EXPECT_LT((m.frame.origin - g.frame.origin).norm(), tt ? 3e-3 : 15e-3);
  EXPECT_FALSE(m.bones_estimated);
  // Transtibial: the patella gives the front, the fibula the side; transfemoral: the hemipelvis.
  EXPECT_FALSE(m.frame.anterior_estimated);
  EXPECT_LT(angle_deg(m.frame.anterior, g.frame.anterior), tt ? 10.0 : 15.0);
  EXPECT_FALSE(m.frame.side_estimated);
  EXPECT_EQ(m.frame.side, g.frame.side);
  EXPECT_EQ(m.anterior_source, tt ? "patella" : "hemipelvis");
  EXPECT_EQ(m.axis_source, tt ? "skin" : "femur");
  // Landmarks: every code placed, on average within 12 mm of the truth, none beyond 35 mm.
  std::map<std::string, Eigen::Vector3d> truth;
  for (const auto& l : g.landmarks) truth[l.code] = l.position;
  ASSERT_EQ(m.landmarks.size(), truth.size());
  {
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

/// The embedded sample (transtibial, seed 1, as `design` generates it) meshes at the smallest
/// sizes a case file accepts. At 200, 210, 215, 265, 360 and 410 nodes the first grid kept a few
/// inverted elements (a bone's tip a cell from the skin) and mesh_limb threw; it now retries with
/// the cell nudged by a few per cent. At these sizes a 2 % step of the cell moves the count by up
/// to 20 % (200 → 161 nodes, 77 hexahedra).
TEST(GeneratedLimb, SampleMeshesAtTheSmallestAcceptedSizes) {
  const volume::GeneratedLimb g = volume::generate_limb(volume::default_params(LimbType::Transtibial, 1));
  volume::LimbInputOptions o;
  o.type = LimbType::Transtibial;
  const volume::LimbModel m = volume::prepare_limb(volume::merge_shells(g), {}, o);
  for (const int n : {200, 210, 215, 265, 360, 410}) {
    volume::HexMesherOptions mo;
    mo.target_nodes = n;
    volume::HexMesherResult r;
    ASSERT_NO_THROW(r = volume::mesh_limb(volume::mesher_input(m), mo)) << n << " nodes";
    EXPECT_EQ(r.quality.inverted, 0) << n << " nodes";
    EXPECT_GT(r.quality.min_scaled_jacobian, 0.1) << n << " nodes";
    EXPECT_NEAR(static_cast<double>(r.mesh.num_nodes()) / n, 1.0, 0.25) << n << " nodes";
  }
}

/// Transfemoral limbs of 10 seeds, both sides, each turned by an arbitrary rotation: the frame
/// from the femur and the hemipelvis is the truth turned the same way (the front within 15°).
TEST(GeneratedLimb, TransfemoralFrameFromFemurAndPelvisUnderRotation) {
  double worst = 0.0;
  for (int seed = 1; seed <= 10; ++seed)
    for (const auto side : {geometry::Side::Right, geometry::Side::Left}) {
      auto params = volume::default_params(LimbType::Transfemoral, seed);
      params.side = side;
      const volume::GeneratedLimb g = volume::generate_limb(params);
      const Eigen::Matrix3d R =
          Eigen::AngleAxisd(0.4 + 0.5 * seed, Eigen::Vector3d(std::sin(seed), std::cos(3.0 * seed), 0.7).normalized())
              .toRotationMatrix();
      geometry::TriMesh limb = volume::merge_shells(g);
      for (auto& v : limb.vertices) v = R * v;
      volume::LimbInputOptions o;
      o.type = LimbType::Transfemoral;
      const volume::LimbModel m = volume::prepare_limb(limb, {}, o);
      const double err = angle_deg(m.frame.anterior, R * g.frame.anterior);
      worst = std::max(worst, err);
      EXPECT_LT(err, 15.0) << "seed " << seed << " " << geometry::to_string(side);
      EXPECT_LT(angle_deg(m.frame.axis, R * g.frame.axis), 5.0) << "seed " << seed;
      EXPECT_EQ(m.frame.side, side) << "seed " << seed;
      EXPECT_EQ(m.anterior_source, "hemipelvis");
    }
  RecordProperty("worst_anterior_error_deg", std::to_string(worst));
}

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
