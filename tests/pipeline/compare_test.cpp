// `socketsmith compare` end to end (files in, compare.json and the page out, through
// pipeline::run_compare, which the command calls): a generated limb against itself moved by a
// known rigid motion, and against a copy offset outward by 2 mm (issue 23's bars: the motion to
// 0.1 mm and 0.1°, zero deviation; 2 mm everywhere ± 0.05 mm and the volume the offset adds).
// The same on every limb of ../shared/data in the slow build (SOCKETSMITH_REAL_LIMBS).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/geometry/rigid_alignment.h"
#include "socketsmith/pipeline/shape_comparison.h"
#include "socketsmith/volume/limb_generator.h"

namespace socketsmith::pipeline {
namespace {

namespace fs = std::filesystem;
using geometry::RigidTransform;
using geometry::TriMesh;
using geometry::Vec3;

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("socketsmith_compare_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

/// A generated transtibial limb's skin (open at its proximal cut, like a scan), in metres. With
/// @p smooth, without the tibial crest's corner (anterior_flattening 0): moving vertices along
/// their normals is an exact offset only where the skin has no crease. Measured on this limb: with
/// the crest the 2 mm copy lies 1.937–2.001 mm from it, smoothed 1.997–2.001 mm.
[[maybe_unused]] TriMesh limb_skin(bool smooth = false) {
  auto p = volume::default_params(geometry::LimbType::Transtibial, 7);
  if (smooth) p.anterior_flattening = 0;
  return volume::generate_limb(p).skin;
}

RigidTransform transform_from_json(const nlohmann::json& t) {
  RigidTransform r;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) r.rotation(i, k) = t["rotation"][i][k].get<double>();
  for (int i = 0; i < 3; ++i) r.translation[i] = t["translation_mm"][i].get<double>() * 1e-3;
  return r;
}

double max_displacement(const RigidTransform& t, const TriMesh& m) {
  double d = 0;
  for (const auto& p : m.vertices) d = std::max(d, (t.apply(p) - p).norm());
  return d;
}

/// Area of the triangles of @p m whose centroid lies below @p h_m along @p axis above @p origin.
double area_below(const TriMesh& m, const Vec3& origin, const Vec3& axis, double h_m) {
  double a = 0;
  for (const auto& t : m.triangles) {
    const Vec3 &p = m.vertices[t[0]], &q = m.vertices[t[1]], &r = m.vertices[t[2]];
    if (((p + q + r) / 3 - origin).dot(axis) < h_m) a += 0.5 * (q - p).cross(r - p).norm();
  }
  return a;
}

/// A against itself moved by a known rigid motion, through files and run_compare.
void expect_motion_recovered(const TriMesh& a, const std::string& name) {
  const fs::path dir = fresh_dir("motion_" + name);
  RigidTransform motion = geometry::rotation_about(Vec3(0.01, -0.02, 0.05), Vec3(0.3, 1.0, 0.2), 15 * M_PI / 180);
  motion.translation += Vec3(0.008, -0.005, 0.012);
  geometry::write_mesh(dir / "a.stl", a);
  geometry::write_mesh(dir / "b.stl", geometry::transformed(a, motion));

  const nlohmann::json j = run_compare(dir / "a.stl", dir / "b.stl", dir / "out");
  // B → A after A → B is the identity when the motion is recovered.
  const RigidTransform residual = transform_from_json(j["transform_b_to_a"]).after(motion);
  EXPECT_LT(max_displacement(residual, a), 1e-4) << "the motion is recovered to 0.1 mm on every point of the limb";
  EXPECT_LT(residual.angle_rad() * 180 / M_PI, 0.1);
  const auto& d = j["deviation"];
  EXPECT_GT(d["covered"].get<int>(), 0.999 * d["points"].get<int>());  // a raw scan may leave a vertex uncovered
  EXPECT_GT(d["points"].get<int>(), 1000);
  EXPECT_LT(std::abs(d["min_mm"].get<double>()), 0.01);
  EXPECT_LT(std::abs(d["max_mm"].get<double>()), 0.01);
  EXPECT_LT(std::abs(j["icp"]["uniform_offset_mm"].get<double>()), 0.01);
  EXPECT_LT(std::abs(j["volume"]["change_percent"].get<double>()), 0.01);
  for (const auto& f : j["outputs"]) EXPECT_TRUE(fs::exists(dir / "out" / f.get<std::string>())) << f;
  std::printf("[ measured ] %s moved by 15 deg and 15.4 mm: residual motion %.2g mm, %.2g deg; deviation %.3g..%.3g mm "
              "over %d points; volume change %.3g %%; %.1f s\n",
              name.c_str(), max_displacement(residual, a) * 1e3, residual.angle_rad() * 180 / M_PI,
              d["min_mm"].get<double>(), d["max_mm"].get<double>(), d["covered"].get<int>(),
              j["volume"]["change_percent"].get<double>(), j["seconds"].get<double>());
  std::ifstream in(dir / "out" / "compare.json");
  EXPECT_EQ(nlohmann::json::parse(in)["seed"], j["seed"]);
}

/// A against a copy offset outward by 2 mm along its vertex normals: 2 mm ± @p tolerance_mm at
/// every point (@p everywhere), else between the 5th and 95th percentiles — a raw scan's creases
/// and folds make the copy itself no exact offset at some vertices (measured minima: ampscan
/// 1.47 mm, the transfemoral limb −2.0 mm, while 5th–95th stay within 0.03 mm of 2 mm).
void expect_offset_measured(const TriMesh& a, const std::string& name, double tolerance_mm, bool everywhere) {
  const fs::path dir = fresh_dir("offset_" + name);
  const double d_m = 0.002;
  geometry::write_mesh(dir / "a.stl", a);
  geometry::write_mesh(dir / "b.stl", geometry::offset_along_normals(a, d_m));

  const nlohmann::json j = run_compare(dir / "a.stl", dir / "b.stl", dir / "out");
  const auto& d = j["deviation"];
  EXPECT_GT(d["covered"].get<int>(), 0.99 * d["points"].get<int>());
  const char* lo = everywhere ? "min_mm" : "p05_mm";
  const char* hi = everywhere ? "max_mm" : "p95_mm";
  EXPECT_NEAR(d[lo].get<double>(), 2.0, tolerance_mm) << lo;
  EXPECT_NEAR(d[hi].get<double>(), 2.0, tolerance_mm) << hi;
  EXPECT_NEAR(d["mean_mm"].get<double>(), 2.0, 0.01);
  EXPECT_NEAR(j["icp"]["uniform_offset_mm"].get<double>(), 2.0, 0.05);
  // The copy is not slid along the axis to close the gap: it stays where it was.
  EXPECT_LT(max_displacement(transform_from_json(j["transform_b_to_a"]), a), 1e-4);
  // The volume an offset d adds below the crop is d × the area there, plus the curvature's d²
  // term (Steiner): ≥ 0 on a convex limb and, at r ≈ 45 mm, a few % of the first.
  Vec3 origin, axis;
  for (int i = 0; i < 3; ++i) {
    origin[i] = j["frame"]["origin_mm"][i].get<double>() * 1e-3;
    axis[i] = j["frame"]["axis"][i].get<double>();
  }
  const double first_order_cm3 = area_below(a, origin, axis, j["crop_height_mm"].get<double>() * 1e-3) * d_m * 1e6;
  const double change_cm3 = j["volume"]["change_cm3"].get<double>();
  EXPECT_GT(change_cm3, first_order_cm3);
  EXPECT_LT(change_cm3, 1.08 * first_order_cm3);
  std::printf("[ measured ] %s offset 2 mm: deviation %.4f..%.4f mm (mean %.4f, 5th-95th %.4f..%.4f) over %d of %d "
              "points; ICP offset %.4f mm, B moved %.2g mm; volume +%.2f cm3 = %.4f x area x 2 mm; %.1f s\n",
              name.c_str(), d["min_mm"].get<double>(), d["max_mm"].get<double>(), d["mean_mm"].get<double>(),
              d["p05_mm"].get<double>(), d["p95_mm"].get<double>(), d["covered"].get<int>(), d["points"].get<int>(),
              j["icp"]["uniform_offset_mm"].get<double>(),
              max_displacement(transform_from_json(j["transform_b_to_a"]), a) * 1e3, change_cm3,
              change_cm3 / first_order_cm3, j["seconds"].get<double>());
}

#ifndef SOCKETSMITH_REAL_LIMBS

TEST(Compare, a_limb_against_itself_moved_by_a_known_rigid_motion_recovers_the_motion_and_shows_no_deviation) {
  expect_motion_recovered(limb_skin(), "generated_tt_7");
}

TEST(Compare, a_copy_offset_outward_by_2_mm_shows_2_mm_everywhere_and_the_volume_it_adds) {
  expect_offset_measured(limb_skin(true), "generated_tt_7_smooth", 0.05, true);
}

TEST(Compare, bad_options_are_one_line_naming_the_fix) {
  const fs::path dir = fresh_dir("bad");
  geometry::write_mesh(dir / "a.stl", limb_skin());
  CompareRunOptions o;
  o.scale = -1;
  try {
    run_compare(dir / "a.stl", dir / "a.stl", dir / "out", o);
    FAIL() << "a negative scale was accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("scale -1 must be positive"), std::string::npos) << e.what();
  }
  o = {};
  o.landmarks_a = dir / "a.json";
  EXPECT_THROW(run_compare(dir / "a.stl", dir / "a.stl", dir / "out", o), InvalidInputError);
}

#else

/// The limbs of ../shared/data, each as compare reads it (its largest shell is the skin).
struct RealLimb {
  const char* name;
  const char* file;
  double metres_per_unit;
};

class RealLimbCompare : public ::testing::TestWithParam<RealLimb> {};

TEST_P(RealLimbCompare, recovers_a_known_motion_and_measures_a_2_mm_offset) {
  const RealLimb l = GetParam();
  const fs::path file = fs::path(SOCKETSMITH_SHARED_DATA_DIR) / "limbs" / l.file;
  if (!fs::exists(file)) GTEST_SKIP() << "shared data absent: " << file;
  geometry::MeshReadOptions ro;
  ro.unit = units::LengthUnit::Metre;
  ro.warn_on_implausible_size = false;
  TriMesh limb = geometry::read_mesh(file, ro);
  geometry::scale(limb, l.metres_per_unit);
  limb = geometry::largest_shell(limb);
  expect_motion_recovered(limb, l.name);
  expect_offset_measured(limb, l.name, 0.05, false);
}

INSTANTIATE_TEST_SUITE_P(
    SharedData, RealLimbCompare,
    ::testing::Values(RealLimb{"openlimb_tt", "transtibial/openlimb_tt_mean_limb_with_bones_mm.stl", 1e-3},
                      RealLimb{"openlimb_tt_skin", "transtibial/openlimb_tt_mean_skin_mm.stl", 1e-3},
                      RealLimb{"ampscan_tt", "transtibial/ampscan_limb_scan_mm.stl", 1e-3},
                      // normalised to the femur's length (../shared/data/README.md)
                      RealLimb{"openlimb_tf", "transfemoral/openlimb_tf_mean_limb_normalised.stl", 0.45}),
    [](const auto& param_info) { return std::string(param_info.param.name); });

#endif

}  // namespace
}  // namespace socketsmith::pipeline
