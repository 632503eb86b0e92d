#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Dense>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "scan_fixtures.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/scan/depth_image.h"
#include "socketsmith/scan/point_cloud.h"
#include "socketsmith/scan/simulated_sensor.h"

namespace socketsmith::scan {
namespace {

/// Depth image (0.1 mm units) of the plane n·P = c seen through @p k (exact rays, distortion
/// included): d = c / (n·(x, y, 1)).
DepthImage plane_image(const CameraIntrinsics& k, const Vec3& n, double c) {
  const RayTable t = make_ray_table(k, 1);
  DepthImage d;
  d.width = k.width;
  d.height = k.height;
  d.scale_m = 1e-4;
  d.raw.resize(static_cast<size_t>(k.width) * k.height);
  for (int v = 0; v < k.height; ++v)
    for (int u = 0; u < k.width; ++u) {
      const Eigen::Vector2d& xy = t.at(u, v);
      const double depth = c / n.dot(Vec3(xy.x(), xy.y(), 1.0)) - k.depth_shift_m;
      d.raw[static_cast<size_t>(v) * k.width + u] = static_cast<std::uint16_t>(std::lround(depth / d.scale_m));
    }
  return d;
}

/// Least-squares plane of points: unit normal and offset, and the RMS distance to it.
struct PlaneFit {
  Vec3 normal;
  double offset = 0, rms = 0;
};
PlaneFit fit_plane(const std::vector<Vec3>& pts) {
  Vec3 c = Vec3::Zero();
  for (const auto& p : pts) c += p;
  c /= static_cast<double>(pts.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : pts) cov += (p - c) * (p - c).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  PlaneFit f;
  f.normal = es.eigenvectors().col(0);
  f.offset = f.normal.dot(c);
  double s = 0;
  for (const auto& p : pts) s += std::pow(f.normal.dot(p) - f.offset, 2);
  f.rms = std::sqrt(s / static_cast<double>(pts.size()));
  return f;
}

TEST(BackProjection, a_synthetic_plane_comes_back_as_the_plane_in_the_world) {
  CameraIntrinsics k = kinect_v2_typical_intrinsics();
  k.k1 = 0.13;  // strong distortion: undistortion must be right for the plane to come out flat
  k.k2 = -0.57;
  k.k3 = 0.75;
  k.depth_shift_m = -0.02;
  const Vec3 n_cam = Vec3(0.2, -0.1, -1.0).normalized();  // tilted plane facing the camera
  const double c = n_cam.dot(Vec3(0, 0, 1.0));            // through (0, 0, 1 m)
  const DepthImage img = plane_image(k, n_cam, c);
  Eigen::Isometry3d pose = look_at(Vec3(0.3, -0.8, 0.2), Vec3(0, 0, 0.1));
  const PointCloud cloud = back_project(img, k, pose);
  ASSERT_GT(cloud.size(), 150000);
  const PlaneFit f = fit_plane(cloud.points);
  const Vec3 n_world = pose.linear() * n_cam;
  EXPECT_GT(std::abs(f.normal.dot(n_world)), std::cos(0.05 * M_PI / 180));  // within 0.05°
  EXPECT_LT(f.rms, 0.1e-3);                                                  // 0.1 mm units → < 0.1 mm
  const double c_world = n_world.dot(pose * Vec3(0, 0, 1.0));
  EXPECT_NEAR(std::abs(f.offset), std::abs(c_world), 0.1e-3);
  // Normals from the depth grid are the plane's, facing the sensor.
  double worst = 1.0;
  for (const auto& nn : cloud.normals) worst = std::min(worst, nn.dot(n_world));
  EXPECT_GT(worst, std::cos(3.0 * M_PI / 180));
}

TEST(BackProjection, skips_invalid_pixels_applies_the_depth_shift_and_upsamples) {
  const CameraIntrinsics k{};  // pinhole
  const Vec3 n(0, 0, -1);
  DepthImage img = plane_image(k, n, -1.0);  // z = 1 m
  for (size_t i = 0; i < img.raw.size(); i += 3) img.raw[i] = 0;
  const PointCloud a = back_project(img, k, Eigen::Isometry3d::Identity());
  EXPECT_GT(a.size(), img.count_valid() * 9 / 10);
  EXPECT_LE(a.size(), img.count_valid());
  for (const auto& p : a.points) ASSERT_NEAR(p.z(), 1.0, 1e-4);
  CameraIntrinsics shifted = k;
  shifted.depth_shift_m = 0.010;
  const PointCloud b = back_project(img, shifted, Eigen::Isometry3d::Identity());
  for (const auto& p : b.points) ASSERT_NEAR(p.z(), 1.010, 1e-4);
  BackProjectionOptions up;
  up.upsample = 3;
  const DepthImage full = plane_image(k, n, -1.0);
  const PointCloud c1 = back_project(full, k, Eigen::Isometry3d::Identity());
  const PointCloud c3 = back_project(full, k, Eigen::Isometry3d::Identity(), up);
  EXPECT_GT(c3.size(), 8 * c1.size());
  for (size_t i = 0; i < c3.points.size(); i += 101) ASSERT_NEAR(c3.points[i].z(), 1.0, 1e-4);
  // A frame that does not match the intrinsics is refused.
  CameraIntrinsics small = k;
  small.width = 256;
  small.cx = 128;
  EXPECT_THROW(back_project(full, small, Eigen::Isometry3d::Identity()), InvalidInputError);
}

TEST(DepthPng, round_trip_and_an_8_bit_png_is_refused) {
  const auto dir = test::temp_dir("depth_png");
  DepthImage d;
  d.width = 7;
  d.height = 5;
  for (int i = 0; i < 35; ++i) d.raw.push_back(static_cast<std::uint16_t>(i * 1800));
  write_depth_png(dir / "d.png", d);
  const DepthImage r = read_depth_png(dir / "d.png");
  EXPECT_EQ(r.raw, d.raw);
  cv::Mat eight(5, 7, CV_8UC1, cv::Scalar(100));
  cv::imwrite((dir / "eight.png").string(), eight);
  try {
    read_depth_png(dir / "eight.png");
    FAIL() << "8-bit PNG accepted as depth";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("is 8-bit (expected 16-bit depth"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_depth_png(dir / "none.png"), IoError);
}

TEST(DepthImage, median_fusion_removes_a_lone_outlier_and_keeps_majority_validity) {
  DepthImage a;
  a.width = 2;
  a.height = 1;
  a.raw = {1000, 0};
  DepthImage b = a, c = a;
  b.raw = {1002, 0};
  c.raw = {5000, 1500};
  const DepthImage m = fuse_frames({a, b, c});
  EXPECT_EQ(m.raw[0], 1002);
  EXPECT_EQ(m.raw[1], 0);  // valid in 1 of 3 frames
  EXPECT_EQ(m.scale_m, 1e-3);
}

TEST(DepthImage, trimmed_mean_fusion_drops_the_outer_quarters_and_keeps_a_finer_unit) {
  // One pixel over 8 frames: 1000 1000 1001 1001 1002 1003 5000 (a flying pixel) and one lost
  // reading: 7 valid, a quarter (1) dropped each side, the mean of the middle 5 = 1001.4 mm.
  std::vector<DepthImage> frames;
  const std::uint16_t values[8] = {1001, 5000, 1000, 0, 1003, 1001, 1000, 1002};
  for (std::uint16_t v : values) {
    DepthImage d;
    d.width = d.height = 1;
    d.raw = {v};
    frames.push_back(d);
  }
  const DepthImage m = fuse_frames(frames, FrameFusion::TrimmedMean);
  EXPECT_DOUBLE_EQ(m.scale_m, 1e-4);
  EXPECT_EQ(m.raw[0], 10014);
  EXPECT_EQ(fuse_frames(frames, FrameFusion::Median).raw[0], 1001);
  // Readings too large for a tenth of the unit in 16 bits keep a coarser one (25,000 × 2 fits, × 5 not).
  for (DepthImage& d : frames) d.raw[0] = d.raw[0] == 0 ? 0 : static_cast<std::uint16_t>(d.raw[0] + 20000);
  EXPECT_DOUBLE_EQ(fuse_frames(frames, FrameFusion::TrimmedMean).scale_m, 1e-3 / 2);
  EXPECT_EQ(parse_frame_fusion("trimmed-mean", "t"), FrameFusion::TrimmedMean);
  EXPECT_THROW(parse_frame_fusion("mean", "t"), InvalidInputError);
}

TEST(DepthImage, trimmed_mean_of_noisy_frames_is_closer_to_the_truth_than_their_median) {
  // 20,000 pixels at 1000.3 mm, 10 frames of Gaussian noise σ 3 mm quantised to 1 mm; one reading in
  // 200 a flying pixel 40-200 mm off (the trimming drops up to two per pixel). The median's error is
  // ≈ √(π/2) times the mean's, and it stays on the 1 mm grid.
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, 3.0);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const int n = 20000;
  std::vector<DepthImage> frames(10);
  for (DepthImage& d : frames) {
    d.width = n;
    d.height = 1;
    d.raw.resize(n);
    for (auto& r : d.raw) {
      const double fly = uni(rng) < 0.005 ? 40.0 + 160.0 * uni(rng) : 0.0;
      r = static_cast<std::uint16_t>(std::lround(1000.3 + noise(rng) + fly));
    }
  }
  auto rms_mm = [&](const DepthImage& d) {
    double s = 0.0;
    for (auto r : d.raw) s += std::pow(r * d.scale_m * 1e3 - 1000.3, 2);
    return std::sqrt(s / n);
  };
  const double median = rms_mm(fuse_frames(frames, FrameFusion::Median));
  const double trimmed = rms_mm(fuse_frames(frames, FrameFusion::TrimmedMean));
  EXPECT_LT(trimmed, 0.9 * median) << "median " << median << " trimmed mean " << trimmed;
  EXPECT_LT(trimmed, 1.15);  // σ/√10 ≈ 0.95 mm plus what the trimming costs
}

TEST(DepthImage, mean_of_ir_frames_averages_each_pixel) {
  const IrImage m = mean_of_ir_frames({IrImage{2, 1, {100, 4000}}, IrImage{2, 1, {103, 4100}}, IrImage{2, 1, {110, 4300}}});
  EXPECT_EQ(m.value[0], 104);
  EXPECT_EQ(m.value[1], 4133);
  EXPECT_THROW(mean_of_ir_frames({IrImage{2, 1, {1, 2}}, IrImage{1, 1, {1}}}), InvalidInputError);
}

TEST(OutlierRemoval, removes_scattered_points_and_keeps_the_surface) {
  PointCloud cloud;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  for (int i = 0; i < 100; ++i)
    for (int j = 0; j < 100; ++j) {
      cloud.points.emplace_back(i * 2e-3, j * 2e-3, 0.0);
      cloud.normals.emplace_back(0, 0, 1);
      cloud.sensor.push_back(0);
    }
  for (int i = 0; i < 60; ++i) {
    cloud.points.emplace_back(0.1 + u(rng), 0.1 + u(rng), 0.05 + std::abs(u(rng)));
    cloud.normals.emplace_back(0, 0, 1);
    cloud.sensor.push_back(0);
  }
  const int removed = remove_statistical_outliers(cloud);
  int flying_left = 0;
  for (const auto& p : cloud.points) flying_left += p.z() > 0.01;
  EXPECT_LE(flying_left, 3);
  EXPECT_LE(removed, 60 + 200);  // at most 2 % of the surface
  EXPECT_GE(cloud.size(), 10000 - 200);
}

}  // namespace
}  // namespace socketsmith::scan
