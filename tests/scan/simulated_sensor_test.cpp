#include "socketsmith/scan/simulated_sensor.h"

#include <gtest/gtest.h>

#include <cmath>

#include "scan_fixtures.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/scan/point_cloud.h"

namespace socketsmith::scan {
namespace {

TEST(SimulatedSensor, scene_helpers_are_closed_outward_surfaces) {
  for (const geometry::TriMesh& m :
       {make_cylinder(0.16, 0.4), make_box(Vec3(0.3, 0.3, 0.7)), make_chessboard(9, 7, 0.08)}) {
    const auto rep = geometry::check_mesh(m);
    EXPECT_TRUE(rep.is_valid_closed_surface()) << (rep.problems().empty() ? "" : rep.problems().front());
    EXPECT_GT(rep.signed_volume_m3, 0.0);
  }
  EXPECT_NEAR(geometry::signed_volume(make_box(Vec3(0.3, 0.3, 0.7))), 0.063, 1e-9);
  EXPECT_NEAR(geometry::signed_volume(make_cylinder(0.16, 0.4)), M_PI * 0.08 * 0.08 * 0.4, 2e-4 * 0.008);  // 256-gon
}

TEST(SimulatedSensor, default_rig_looks_at_the_centre_from_the_ring) {
  const auto rig = default_rig(4, 0.75, 0.1);
  ASSERT_EQ(rig.size(), 4u);
  for (const auto& s : rig) {
    const Vec3 eye = s.world_from_sensor.translation();
    EXPECT_NEAR(std::hypot(eye.x(), eye.y()), 0.75, 1e-12);
    EXPECT_NEAR(eye.z(), 0.1, 1e-12);
    const Vec3 forward = s.world_from_sensor.linear().col(2);
    EXPECT_NEAR(forward.dot((-eye).normalized()), 1.0, 1e-12);
    EXPECT_LT(s.world_from_sensor.linear().col(1).z(), 0.0);  // image y points down
    EXPECT_NEAR(s.world_from_sensor.linear().determinant(), 1.0, 1e-12);
  }
  EXPECT_EQ(rig[0].name, "K1");
  EXPECT_THROW(default_rig(0), InvalidInputError);
}

TEST(SimulatedSensor, noise_free_depth_of_a_cylinder_back_projects_onto_it) {
  const double r = 0.08;
  const geometry::SurfaceQuery scene(make_cylinder(2 * r, 0.4, Vec3::Zero(), 512));
  CameraIntrinsics k = kinect_v2_typical_intrinsics();
  k.depth_shift_m = -0.02;
  SimulatedSensor s{"K1", k, look_at(Vec3(0, -0.75, 0.05), Vec3::Zero())};
  SensorErrorModel none;
  none.scale = 0.0;
  const DepthImage d = simulate_depth(scene, s, none, 7);
  EXPECT_GT(d.count_valid(), 5000);
  const PointCloud c = back_project(d, k, s.world_from_sensor);
  ASSERT_GT(c.size(), 5000);
  double worst = 0.0;
  for (const auto& p : c.points) worst = std::max(worst, std::abs(std::hypot(p.x(), p.y()) - r));
  EXPECT_LT(worst, 1.0e-3);  // 1 mm quantisation (plus tessellation)
}

TEST(SimulatedSensor, error_model_gives_the_documented_bias_and_noise_on_a_wall) {
  // A wall 1 m in front of the sensor, centre of the image only (ρ ≈ 0).
  const geometry::SurfaceQuery scene(make_box(Vec3(3.0, 0.02, 3.0), Vec3(0, 0.01, 0)));
  CameraIntrinsics k{};
  SimulatedSensor s{"K1", k, look_at(Vec3(0, -1.0, 0), Vec3::Zero())};
  SensorErrorModel m;
  m.flying_pixel_probability = 0.0;
  m.random_invalid_probability = 0.0;
  const DepthImage d = simulate_depth(scene, s, m, 11, 1e-4);
  double sum = 0, sum2 = 0;
  int n = 0;
  for (int v = k.height / 2 - 20; v < k.height / 2 + 20; ++v)
    for (int u = static_cast<int>(k.cx) - 20; u < static_cast<int>(k.cx) + 20; ++u) {
      const double e = d.at(u, v) * d.scale_m - 1.0;
      sum += e;
      sum2 += e * e;
      ++n;
    }
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  const double sigma = m.noise_sigma0_m + m.noise_sigma2_per_m;  // at 1 m
  const double bias = m.bias_m + m.wiggle_amplitude_m * std::sin(2 * M_PI / m.wiggle_period_m);  // ρ ≈ 0
  EXPECT_NEAR(sd, sigma, 0.1 * sigma);
  EXPECT_NEAR(mean, bias, 0.2e-3);
  // Same seed, same frame; another seed, another frame.
  EXPECT_EQ(simulate_depth(scene, s, m, 11, 1e-4).raw, d.raw);
  EXPECT_NE(simulate_depth(scene, s, m, 12, 1e-4).raw, d.raw);
}

TEST(SimulatedSensor, flying_pixels_appear_at_silhouettes_and_grazing_rays_return_nothing) {
  const geometry::SurfaceQuery scene(make_cylinder(0.16, 0.4));
  SimulatedSensor s{"K1", kinect_v2_typical_intrinsics(), look_at(Vec3(0, -0.75, 0), Vec3::Zero())};
  SensorErrorModel m;
  m.noise_sigma0_m = m.noise_sigma2_per_m = 0.0;
  m.flying_pixel_probability = 1.0;
  const DepthImage d = simulate_depth(scene, s, m, 5);
  SensorErrorModel none;
  none.scale = 0.0;
  const DepthImage truth = simulate_depth(scene, s, none, 5);
  int flying = 0;  // pixels of the silhouette moved > 2 cm towards the background
  for (size_t i = 0; i < d.raw.size(); ++i)
    flying += d.raw[i] != 0 && truth.raw[i] != 0 && std::abs(int(d.raw[i]) - int(truth.raw[i])) > 20;
  EXPECT_GT(flying, 100);
  EXPECT_LT(flying, 2000);  // only at edges
  m.flying_pixel_probability = 0.0;
  m.grazing_limit_rad = 60 * M_PI / 180;  // only the middle of the cylinder returns
  const DepthImage g = simulate_depth(scene, s, m, 5);
  const PointCloud cg = back_project(g, s.intrinsics, s.world_from_sensor);
  double max_abs_x = 0;
  for (const auto& p : cg.points) max_abs_x = std::max(max_abs_x, std::abs(p.x()));
  EXPECT_LT(max_abs_x, 0.08 * std::sin(62 * M_PI / 180));
}

TEST(SimulatedSensor, several_frames_of_one_cast_equal_single_frames_of_the_same_seeds) {
  const SimulatedSensor sensor = default_rig(1).front();
  const Scene scene = make_chessboard_scene(
      calibration_chessboard(sensor.world_from_sensor * Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.0, 0.8))));
  const geometry::SurfaceQuery query(scene.mesh);
  const SensorErrorModel model;
  const std::vector<std::uint64_t> seeds{17, 99};
  const std::vector<SimulatedFrame> frames = simulate_frames(query, scene, sensor, model, seeds);
  ASSERT_EQ(frames.size(), 2u);
  for (size_t q = 0; q < 2; ++q) {
    const SimulatedFrame one = simulate_frame(query, scene, sensor, model, seeds[q]);
    EXPECT_EQ(frames[q].depth.raw, one.depth.raw);
    EXPECT_EQ(frames[q].ir.value, one.ir.value);
  }
  EXPECT_NE(frames[0].depth.raw, frames[1].depth.raw);
  EXPECT_GT(frames[0].depth.count_valid(), 50000);  // the board fills a third of the view
}

}  // namespace
}  // namespace socketsmith::scan
