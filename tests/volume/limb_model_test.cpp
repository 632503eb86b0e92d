// prepare_limb on real limbs (shared data) and on bad input; mesh_limb on real limbs.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "limb_shapes.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/geometry/surface_query.h"
#include "socketsmith/volume/hex_mesher.h"
#include "socketsmith/volume/limb_model.h"

namespace socketsmith::volume {
namespace {

namespace fs = std::filesystem;
const fs::path kData = SOCKETSMITH_SHARED_DATA_DIR "/limbs";

geometry::TriMesh read_mm(const fs::path& p) {
  geometry::MeshReadOptions ro;
  ro.unit = units::LengthUnit::Millimetre;
  return geometry::read_mesh(p, ro);
}

const Landmark& find(const std::vector<Landmark>& ls, const std::string& code) {
  for (const auto& l : ls)
    if (l.code == code) return l;
  throw std::runtime_error("no landmark " + code);
}

void expect_on_skin(const LimbModel& m) {
  const geometry::SurfaceQuery q(m.skin);
  for (const auto& l : m.landmarks) EXPECT_LT(q.closest_point(l.position).distance, 0.5e-3) << l.code;
}

TEST(LimbModel, OpenLimbTranstibialWithItsFourBones) {
  const fs::path file = kData / "transtibial/openlimb_tt_mean_limb_with_bones_mm.stl";
  if (!fs::exists(file)) GTEST_SKIP() << "shared data absent: " << file;
  const LimbModel m = prepare_limb(read_mm(file), {}, {});
  EXPECT_TRUE(geometry::check_mesh(m.skin).is_valid_closed_surface());
  EXPECT_FALSE(m.bones_estimated);
  std::vector<std::string> names;
  for (const auto& b : m.bones) {
    names.push_back(b.name);
    EXPECT_TRUE(geometry::check_mesh(b.mesh).is_valid_closed_surface()) << b.name;
    EXPECT_GT(geometry::signed_volume(b.mesh), 0.0) << b.name;
  }
  for (const char* want : {"tibia", "fibula", "patella", "femur"})
    EXPECT_NE(std::find(names.begin(), names.end(), want), names.end()) << want;
  EXPECT_FALSE(m.frame.anterior_estimated);
  EXPECT_FALSE(m.frame.side_estimated);
  EXPECT_GT(m.cut_height_m, 0.2);
  ASSERT_EQ(m.landmarks.size(), 8u);
  expect_on_skin(m);
  const double deg = units::deg;
  EXPECT_LT(std::abs(find(m.landmarks, "PT").cylindrical.theta), 30 * deg);
  EXPECT_GT(std::abs(find(m.landmarks, "POP").cylindrical.theta), 150 * deg);
  EXPECT_GT(find(m.landmarks, "MF").cylindrical.theta, 0.0);
  EXPECT_LT(find(m.landmarks, "FH").cylindrical.theta, 0.0);
  EXPECT_LT(find(m.landmarks, "DT").cylindrical.h, find(m.landmarks, "AD").cylindrical.h);
}

TEST(LimbModel, AmpscanScanWithoutBonesGetsEstimatedBones) {
  const fs::path file = kData / "transtibial/ampscan_limb_scan_mm.stl";
  if (!fs::exists(file)) GTEST_SKIP() << "shared data absent: " << file;
  const LimbModel m = prepare_limb(read_mm(file), {}, {});
  EXPECT_TRUE(geometry::check_mesh(m.skin).is_valid_closed_surface());
  EXPECT_TRUE(m.bones_estimated);
  EXPECT_TRUE(m.frame.anterior_estimated);
  EXPECT_TRUE(m.frame.side_estimated);
  EXPECT_GE(m.bones.size(), 1u);
  const geometry::SurfaceQuery skin(m.skin);
  for (const auto& b : m.bones) {
    EXPECT_NE(b.name.find("estimated"), std::string::npos) << b.name;
    for (const auto& v : b.mesh.vertices) EXPECT_LT(skin.signed_distance(v), 0.0);
  }
  expect_on_skin(m);
}

TEST(LimbModel, TransfemoralNormalisedLimbScaledByAFemurLength) {
  const fs::path file = kData / "transfemoral/openlimb_tf_mean_limb_normalised.stl";
  if (!fs::exists(file)) GTEST_SKIP() << "shared data absent: " << file;
  geometry::MeshReadOptions ro;
  ro.unit = units::LengthUnit::Metre;
  ro.warn_on_implausible_size = false;
  geometry::TriMesh limb = geometry::read_mesh(file, ro);
  geometry::scale(limb, 0.45);
  LimbInputOptions o;
  o.type = geometry::LimbType::Transfemoral;
  const LimbModel m = prepare_limb(limb, {}, o);
  EXPECT_TRUE(geometry::check_mesh(m.skin).is_valid_closed_surface());
  ASSERT_FALSE(m.bones.empty());
  EXPECT_EQ(m.bones.front().name, "femur");
  EXPECT_FALSE(m.bones_estimated);
  ASSERT_EQ(m.landmarks.size(), 4u);
  expect_on_skin(m);
}

TEST(LimbModel, BadInputGetsOneClearError) {
  const auto limb = test::capsule(0.05, 0.25, true);
  // Wrong units: a 250 m limb.
  geometry::TriMesh huge = limb;
  geometry::scale(huge, 1000.0);
  EXPECT_THROW(prepare_limb(huge, {}, {}), InvalidInputError);
  // Empty, sphere, box.
  EXPECT_THROW(prepare_limb(geometry::TriMesh{}, {}, {}), InvalidInputError);
  EXPECT_THROW(prepare_limb(test::capsule(0.1, 0.2, false, 40, 32), {}, {}), InvalidInputError);
  // A bone that pokes out of the skin.
  geometry::TriMesh bone = test::capsule(0.02, 0.3, false, 40, 24);
  for (auto& v : bone.vertices) v += Vec3(0.045, 0, 0.05);
  try {
    prepare_limb(limb, bone, {});
    ADD_FAILURE() << "bones outside the skin accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("outside the skin"), std::string::npos) << e.what();
  }
  // A cut above the rim.
  LimbInputOptions o;
  o.cut_height_m = 0.4;
  EXPECT_THROW(prepare_limb(limb, {}, o), InvalidInputError);
}

TEST(LimbModel, InsideOutSkinIsFlippedAndSaid) {
  geometry::TriMesh limb = test::capsule(0.05, 0.25, true);
  geometry::flip_orientation(limb);
  LimbInputOptions o;
  o.estimate_bones = false;
  const LimbModel m = prepare_limb(limb, {}, o);
  EXPECT_GT(geometry::signed_volume(m.skin), 0.0);
  bool said = false;
  for (const auto& n : m.notes) said = said || n.find("inside-out") != std::string::npos;
  EXPECT_TRUE(said);
}

}  // namespace
}  // namespace socketsmith::volume
