#include "socketsmith/volume/bone_template.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <Eigen/Geometry>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/volume/limb_generator.h"
#include "brute_force.h"

namespace socketsmith::volume {
namespace {

using geometry::LimbFrame;
using geometry::LimbType;
using geometry::Side;
using geometry::TriMesh;
using geometry::Vec3;
using namespace test;

constexpr double kPi = 3.14159265358979323846;

/// Closed cylinder of @p radius from z = 0 to z = @p height, outward, @p n vertices per ring.
TriMesh make_cylinder(double radius, double height, int n = 64, int rings = 40) {
  TriMesh m;
  m.vertices.push_back(Vec3::Zero());
  for (int r = 0; r <= rings; ++r)
    for (int j = 0; j < n; ++j) {
      const double a = 2 * kPi * j / n;
      m.vertices.emplace_back(radius * std::cos(a), radius * std::sin(a), height * r / rings);
    }
  m.vertices.emplace_back(0, 0, height);
  const int top = m.num_vertices() - 1;
  auto id = [&](int r, int j) { return 1 + r * n + (j % n); };
  for (int j = 0; j < n; ++j) m.triangles.push_back({0, id(0, j + 1), id(0, j)});
  for (int r = 0; r < rings; ++r)
    for (int j = 0; j < n; ++j) {
      m.triangles.push_back({id(r, j), id(r, j + 1), id(r + 1, j + 1)});
      m.triangles.push_back({id(r, j), id(r + 1, j + 1), id(r + 1, j)});
    }
  for (int j = 0; j < n; ++j) m.triangles.push_back({id(rings, j), id(rings, j + 1), top});
  return m;
}

GeneratedLimb make(LimbType type, std::uint64_t seed, bool open = false, Side side = Side::Right) {
  LimbShapeParams p = default_params(type, seed);
  p.open_proximal = open;
  p.side = side;
  return generate_limb(p);
}

const NamedMesh& find(const std::vector<NamedMesh>& bones, const std::string& name) {
  for (const auto& b : bones)
    if (b.name == name) return b;
  throw std::runtime_error("no bone " + name);
}

// --- Tests --------------------------------------------------------------------------------------

TEST(BoneTemplate, measures_the_radius_of_a_cylinder) {
  const double radius = 0.05;
  const TriMesh cyl = make_cylinder(radius, 0.2);
  LimbFrame frame;  // axis +z through the cylinder's axis, origin at its bottom
  const SkinRadii r = measure_skin_radii(cyl, frame, 20, 36);
  EXPECT_NEAR(r.bottom_m, 0.0, 1e-12);
  EXPECT_NEAR(r.top_m, 0.2, 1e-12);
  const double chord = radius * std::cos(kPi / 64);  // the polygon's smallest radius
  for (double h = 0.01; h < 0.2; h += 0.02)
    for (double th = -kPi; th < kPi; th += 0.37) {
      EXPECT_GE(r.radius(th, h), chord - 1e-9);
      EXPECT_LE(r.radius(th, h), radius + 1e-9);
    }
  EXPECT_NEAR(r.width_ml(0.1), 2 * radius, 2 * (radius - chord) + 1e-9);
}

TEST(BoneTemplate, skin_open_in_its_distal_half_is_rejected) {
  GeneratedLimb limb = make(LimbType::Transtibial, 1, /*open=*/false);
  // Remove the fan around the distal pole: a hole at the distal end.
  auto& tris = limb.skin.triangles;
  tris.erase(std::remove_if(tris.begin(), tris.end(), [](const auto& t) { return t[0] == 0 || t[1] == 0 || t[2] == 0; }),
             tris.end());
  try {
    estimate_bones(limb.skin, limb.frame, LimbType::Transtibial);
    ADD_FAILURE() << "no error for a skin open distally";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("open"), std::string::npos) << e.what();
  }
  EXPECT_THROW(estimate_bones(TriMesh{}, limb.frame, LimbType::Transtibial), InvalidInputError);
}

TEST(BoneTemplate, estimated_tibia_is_near_the_true_tibia) {
  for (const auto& [seed, open] : std::vector<std::pair<std::uint64_t, bool>>{{1, false}, {2, false}, {3, true}, {4, false}}) {
    const GeneratedLimb limb = make(LimbType::Transtibial, seed, open);
    const auto est = estimate_bones(limb.skin, limb.frame, LimbType::Transtibial);
    std::vector<std::string> names;
    for (const auto& b : est) names.push_back(b.name);
    EXPECT_EQ(names, (std::vector<std::string>{"tibia (estimated)", "fibula (estimated)", "patella (estimated)",
                                               "femur (estimated)"}))
        << "seed " << seed;
    const Vec3 truth = volume_centroid(find(limb.bones, "tibia").mesh);
    const Vec3 guess = volume_centroid(find(est, "tibia (estimated)").mesh);
    EXPECT_LT((truth - guess).norm(), 0.015) << "seed " << seed;
    const Vec3 fib_truth = volume_centroid(find(limb.bones, "fibula").mesh);
    const Vec3 fib_guess = volume_centroid(find(est, "fibula (estimated)").mesh);
    EXPECT_LT((fib_truth - fib_guess).norm(), 0.025) << "seed " << seed;
    for (const auto& b : est) EXPECT_TRUE(geometry::check_mesh(b.mesh).is_valid_closed_surface()) << b.name;
  }
}

TEST(BoneTemplate, estimated_femur_is_near_the_true_femur_transfemoral) {
  for (const std::uint64_t seed : {1u, 5u}) {
    const GeneratedLimb limb = make(LimbType::Transfemoral, seed);
    const auto est = estimate_bones(limb.skin, limb.frame, LimbType::Transfemoral);
    ASSERT_EQ(est.size(), 1u);
    EXPECT_EQ(est[0].name, "femur (estimated)");
    EXPECT_LT((volume_centroid(est[0].mesh) - volume_centroid(limb.bones[0].mesh)).norm(), 0.02) << "seed " << seed;
  }
}

TEST(BoneTemplate, estimated_bones_lie_inside_the_skin_with_3mm_of_tissue) {
  for (const auto& [type, seed] :
       std::vector<std::pair<LimbType, std::uint64_t>>{{LimbType::Transtibial, 6}, {LimbType::Transfemoral, 2}}) {
    const GeneratedLimb limb = make(type, seed, /*open=*/false, Side::Left);
    const auto est = estimate_bones(limb.skin, limb.frame, type);
    for (const auto& b : est) {
      EXPECT_GE(min_vertex_distance(b.mesh, limb.skin), kMinBoneClearance_m) << b.name;
      EXPECT_GE(min_vertex_distance(limb.skin, b.mesh), kMinBoneClearance_m) << b.name;
      EXPECT_TRUE(inside_by_parity(b.mesh.vertices[0], limb.skin, Vec3(0.6, 0.8, 0.0))) << b.name;
      EXPECT_GT(geometry::signed_volume(b.mesh), 0.0) << b.name;
    }
  }
}

TEST(BoneTemplate, estimate_follows_a_rigid_motion_of_skin_and_frame) {
  const GeneratedLimb limb = make(LimbType::Transtibial, 2);
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()) * Eigen::AngleAxisd(-0.4, Vec3::UnitX())).toRotationMatrix();
  const Vec3 t(0.3, -1.2, 0.5);
  TriMesh moved = limb.skin;
  for (Vec3& v : moved.vertices) v = R * v + t;
  LimbFrame frame = limb.frame;
  frame.origin = R * frame.origin + t;
  frame.axis = R * frame.axis;
  frame.anterior = R * frame.anterior;
  const auto a = estimate_bones(limb.skin, limb.frame, LimbType::Transtibial);
  const auto b = estimate_bones(moved, frame, LimbType::Transtibial);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    EXPECT_LT((R * volume_centroid(a[i].mesh) + t - volume_centroid(b[i].mesh)).norm(), 1e-6) << a[i].name;
}

TEST(BoneTemplate, explicit_knee_height_places_the_joint_line) {
  const GeneratedLimb limb = make(LimbType::Transtibial, 0);
  BoneEstimateOptions options;
  options.knee_height_m = 0.14;
  const auto est = estimate_bones(limb.skin, limb.frame, LimbType::Transtibial, options);
  const auto tibia = geometry::bounding_box(find(est, "tibia (estimated)").mesh);
  EXPECT_LE(tibia.max.z(), 0.14 + 1e-9);
  EXPECT_GT(tibia.max.z(), 0.14 - 0.02);
  EXPECT_GT(geometry::bounding_box(find(est, "femur (estimated)").mesh).min.z(), 0.14);
  // The automatic estimate of the joint line is the proximal 32 % of a 220 mm skin: 70 mm.
  const SkinRadii radii = measure_skin_radii(limb.skin, limb.frame);
  EXPECT_NEAR(estimate_knee_height(radii), limb.params.residual_length_m, 0.005);
  options.knee_height_m = 0.5;  // above the skin
  EXPECT_THROW(estimate_bones(limb.skin, limb.frame, LimbType::Transtibial, options), InvalidInputError);
}

TEST(BoneTemplate, template_on_a_left_frame_is_outward_and_mirrors_the_right_one) {
  const GeneratedLimb right = make(LimbType::Transtibial, 3, false, Side::Right);
  const GeneratedLimb left = make(LimbType::Transtibial, 3, false, Side::Left);
  BonePlacement placement;
  placement.knee_height_m = right.params.residual_length_m;
  const auto br = build_bone_template(measure_skin_radii(right.skin, right.frame), right.frame, right.params.bones, placement);
  const auto bl = build_bone_template(measure_skin_radii(left.skin, left.frame), left.frame, left.params.bones, placement);
  ASSERT_EQ(br.size(), bl.size());
  for (std::size_t i = 0; i < br.size(); ++i) {
    EXPECT_TRUE(geometry::check_mesh(bl[i].mesh).is_valid_closed_surface()) << bl[i].name;
    EXPECT_NEAR(geometry::signed_volume(bl[i].mesh), geometry::signed_volume(br[i].mesh), 1e-12);
    const Vec3 cr = volume_centroid(br[i].mesh);
    EXPECT_LT((volume_centroid(bl[i].mesh) - Vec3(-cr.x(), cr.y(), cr.z())).norm(), 1e-9) << br[i].name;
  }
}

TEST(BoneTemplate, fit_reports_a_skin_too_thin_for_the_bones) {
  const TriMesh thin = make_cylinder(0.012, 0.22);
  LimbFrame frame;
  try {
    estimate_bones(thin, frame, LimbType::Transtibial);
    ADD_FAILURE() << "no error for a 24 mm wide limb";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("does not fit"), std::string::npos) << e.what();
  }
}

TEST(BoneTemplate, validate_rejects_out_of_range_params) {
  BoneTemplateParams p;
  EXPECT_NO_THROW(validate(p));
  p.tibia_plateau_width_m = 0.2;
  EXPECT_THROW(validate(p), InvalidInputError);
  p = BoneTemplateParams{};
  p.fibula_angle_rad = 0.0;  // anterior: not where a fibula is
  EXPECT_THROW(validate(p), InvalidInputError);
  const BoneTemplateParams s = scaled_bone_sizes(BoneTemplateParams{}, 0.5);
  EXPECT_NO_THROW(validate(s));  // clamped into range
  EXPECT_DOUBLE_EQ(s.tibia_end_height_m, BoneTemplateParams{}.tibia_end_height_m);
  EXPECT_DOUBLE_EQ(scaled_bone_sizes(BoneTemplateParams{}, 1.1).tibia_shaft_radius_m, 1.1 * BoneTemplateParams{}.tibia_shaft_radius_m);
}

}  // namespace
}  // namespace socketsmith::volume
