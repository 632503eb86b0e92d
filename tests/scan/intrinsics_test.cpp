#include "socketsmith/scan/intrinsics.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>

#include "scan_fixtures.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/scan/depth_image.h"
#include "socketsmith/scan/point_cloud.h"

namespace socketsmith::scan {
namespace {

/// max |project(unproject(u, v)) − (u, v)| over every pixel of the ray table that has a ray;
/// fails when more than 3 % of the pixels have none (a lens model folding back at the corners).
double max_round_trip_px(const CameraIntrinsics& k, int upsample) {
  const RayTable t = make_ray_table(k, upsample);
  double worst = 0.0;
  int missing = 0;
  for (int v = 0; v < t.height; ++v)
    for (int u = 0; u < t.width; ++u) {
      const Eigen::Vector2d uv((u + 0.5) / upsample - 0.5, (v + 0.5) / upsample - 0.5);
      if (!std::isfinite(t.at(u, v).x())) {
        ++missing;
        continue;
      }
      worst = std::max(worst, (project_normalised(k, t.at(u, v)) - uv).norm());
    }
  EXPECT_LT(missing, t.width * t.height * 3 / 100);
  return worst;
}

TEST(Intrinsics, ray_table_inverts_the_distortion_at_every_pixel) {
  CameraIntrinsics k = kinect_v2_typical_intrinsics();
  EXPECT_LT(max_round_trip_px(k, 1), 1e-4);
  EXPECT_LT(max_round_trip_px(k, 2), 1e-4);
  // A strongly distorted lens (the magnitude of real Kinect v2 calibrations).
  k.k1 = 0.13;
  k.k2 = -0.57;
  k.k3 = 0.75;
  k.p1 = -8e-4;
  k.p2 = 9e-4;
  EXPECT_LT(max_round_trip_px(k, 1), 1e-4);
  // Without distortion the rays are the pinhole ones.
  const CameraIntrinsics pin{};
  const RayTable t = make_ray_table(pin, 1);
  EXPECT_NEAR(t.at(0, 0).x(), (0 - pin.cx) / pin.fx, 1e-12);
  EXPECT_NEAR(t.at(511, 423).y(), (423 - pin.cy) / pin.fy, 1e-12);
}

TEST(Intrinsics, json_round_trip_and_bad_files) {
  const auto dir = test::temp_dir("intrinsics_json");
  CameraIntrinsics k = kinect_v2_typical_intrinsics();
  k.depth_shift_m = -0.0125;
  write_intrinsics_json(dir / "intrinsics.json", k);
  const CameraIntrinsics r = read_intrinsics(dir / "intrinsics.json");
  EXPECT_EQ(r.width, 512);
  EXPECT_EQ(r.height, 424);
  EXPECT_DOUBLE_EQ(r.fx, k.fx);
  EXPECT_DOUBLE_EQ(r.k2, k.k2);
  EXPECT_NEAR(r.depth_shift_m, -0.0125, 1e-12);

  EXPECT_THROW(read_intrinsics(dir / "missing.json"), IoError);
  std::ofstream(dir / "typo.json") << R"({"width": 512, "height": 424, "fx": 366, "fy": 366, "cx": 256, "cy": 212, "k4": 0})";
  try {
    read_intrinsics_json(dir / "typo.json");
    FAIL() << "unknown key accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown key 'k4'"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "no_fx.json") << R"({"width": 512, "height": 424, "fy": 366, "cx": 256, "cy": 212})";
  EXPECT_THROW(read_intrinsics_json(dir / "no_fx.json"), InvalidInputError);
  std::ofstream(dir / "neg.json") << R"({"width": 512, "height": 424, "fx": -1, "fy": 366, "cx": 256, "cy": 212})";
  EXPECT_THROW(read_intrinsics_json(dir / "neg.json"), InvalidInputError);
}

TEST(Intrinsics, reads_the_real_kinect2_calibrations) {
  const auto root = test::shared_data() / "kinect2_calibration";
  if (!std::filesystem::exists(root)) GTEST_SKIP() << "no " << root << " (shared data absent)";
  int read = 0;
  for (const auto& e : std::filesystem::directory_iterator(root)) {
    if (!std::filesystem::exists(e.path() / "calib_ir.yaml")) continue;
    const CameraIntrinsics k = read_kinect2_calibration(e.path());
    EXPECT_EQ(k.width, 512);
    EXPECT_EQ(k.height, 424);
    EXPECT_GT(k.fx, 300);
    EXPECT_LT(k.fx, 400);
    EXPECT_GT(k.cy, 180);
    EXPECT_LT(k.cy, 240);
    EXPECT_TRUE(k.has_distortion()) << e.path();
    EXPECT_LT(max_round_trip_px(k, 1), 1e-3) << e.path();
    ++read;
  }
  EXPECT_GE(read, 9);
  // One value checked against the file's text: 001530565347's depthShift is -23.75 mm.
  const CameraIntrinsics k = read_intrinsics(root / "001530565347");
  EXPECT_NEAR(k.depth_shift_m, -0.02375, 1e-5);
  EXPECT_NEAR(k.fx, 364.967, 1e-3);
  EXPECT_NEAR(k.k3, 0.74515, 1e-5);
}

TEST(Intrinsics, open3d_sample_frames_load_and_back_project) {
  const auto dir = test::shared_data() / "rgbd" / "open3d_sample";
  if (!std::filesystem::exists(dir / "camera_primesense.json")) GTEST_SKIP() << "no " << dir << " (shared data absent)";
  const CameraIntrinsics k = read_intrinsics(dir / "camera_primesense.json");
  EXPECT_EQ(k.width, 640);
  EXPECT_EQ(k.height, 480);
  EXPECT_DOUBLE_EQ(k.fx, 525.0);
  EXPECT_DOUBLE_EQ(k.cx, 319.5);
  EXPECT_FALSE(k.has_distortion());

  const DepthImage d = read_depth_png(dir / "RGBD" / "depth" / "00000.png");
  ASSERT_EQ(d.width, 640);
  ASSERT_EQ(d.height, 480);
  EXPECT_GT(d.count_valid(), 100000);
  const PointCloud c = back_project(d, k, Eigen::Isometry3d::Identity());
  EXPECT_GT(c.size(), 100000);
  for (int i = 0; i < c.size(); i += 997) {
    EXPECT_GT(c.points[static_cast<size_t>(i)].z(), 0.2);
    EXPECT_LT(c.points[static_cast<size_t>(i)].z(), 4.6);
    EXPECT_NEAR(c.normals[static_cast<size_t>(i)].norm(), 1.0, 1e-9);
    EXPECT_LT(c.normals[static_cast<size_t>(i)].dot(c.points[static_cast<size_t>(i)]), 0.0);  // faces the camera
  }
  // Up-sampled ×2: about four times the points.
  BackProjectionOptions up;
  up.upsample = 2;
  const PointCloud c2 = back_project(d, k, Eigen::Isometry3d::Identity(), up);
  EXPECT_GT(c2.size(), 3 * c.size());

  // The TUM frame uses 5000 units per metre; in metres its median depth is a room's, not 5x it.
  const DepthImage tum = read_depth_png(dir / "RGBD" / "other_formats" / "TUM_depth.png", 1.0 / 5000.0);
  const PointCloud ct = back_project(tum, k, Eigen::Isometry3d::Identity());
  ASSERT_GT(ct.size(), 10000);
  std::vector<double> z;
  for (const auto& p : ct.points) z.push_back(p.z());
  std::nth_element(z.begin(), z.begin() + static_cast<long>(z.size() / 2), z.end());
  EXPECT_GT(z[z.size() / 2], 0.5);
  EXPECT_LT(z[z.size() / 2], 4.0);
}

}  // namespace
}  // namespace socketsmith::scan
