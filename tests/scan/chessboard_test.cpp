#include "socketsmith/scan/chessboard.h"

#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "scan_fixtures.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/scan/simulated_sensor.h"

namespace socketsmith::scan {
namespace {

using test::temp_dir;

/// A sensor at the origin (OpenCV axes) and the calibration board @p distance_m in front of it,
/// turned by @p yaw_rad about its vertical axis.
struct BoardView {
  SimulatedSensor sensor;
  ChessboardPatch board;
  Scene scene;
};

BoardView board_view(double distance_m, double yaw_rad, double pitch_rad = 0.0) {
  BoardView v;
  v.sensor.intrinsics = kinect_v2_typical_intrinsics();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = (Eigen::AngleAxisd(yaw_rad, Vec3::UnitY()) * Eigen::AngleAxisd(pitch_rad, Vec3::UnitX())).matrix();
  pose.translation() = Vec3(0.02, -0.01, distance_m);
  v.board = calibration_chessboard(pose);
  v.scene = make_chessboard_scene(v.board);
  return v;
}

SensorErrorModel noise_free() {
  SensorErrorModel m;
  m.scale = 0.0;
  return m;
}

TEST(Chessboard, noiseless_board_corners_are_found_with_sub_pixel_accuracy_and_1_mm_in_3d) {
  for (const double yaw : {0.0, 0.45}) {
    const BoardView v = board_view(0.8, yaw, -0.2);
    const geometry::SurfaceQuery query(v.scene.mesh);
    const SimulatedFrame f = simulate_frame(query, v.scene, v.sensor, noise_free(), 3);
    const ChessboardDetection det = detect_chessboard(f.ir, f.depth, v.sensor.intrinsics, v.board.pattern);
    ASSERT_EQ(det.corners.size(), 54u);
    EXPECT_EQ(det.count_with_depth(), 54);
    double worst_px = 0.0, worst_mm = 0.0;
    Eigen::Vector2d bias = Eigen::Vector2d::Zero();
    for (const ChessboardCorner& c : det.corners) {
      const Vec3 truth = v.board.corner(c.i, c.j);  // sensor frame = world frame here
      const Eigen::Vector2d uv = project_normalised(v.sensor.intrinsics, truth.head<2>() / truth.z());
      worst_px = std::max(worst_px, (uv - c.uv).norm());
      worst_mm = std::max(worst_mm, (c.point - truth).norm() * 1e3);
      bias += (c.uv - uv) / 54.0;
    }
    EXPECT_LT(worst_px, 0.2) << "yaw " << yaw;  // grid order and sub-pixel position
    EXPECT_LT(bias.norm(), 0.05) << "yaw " << yaw;
    EXPECT_LT(worst_mm, 1.0) << "yaw " << yaw;   // 1 mm depth quantisation, interpolated
  }
}

TEST(Chessboard, noisy_board_is_still_found) {
  const BoardView v = board_view(0.95, -0.3);
  const geometry::SurfaceQuery query(v.scene.mesh);
  const SimulatedFrame f = simulate_frame(query, v.scene, v.sensor, SensorErrorModel{}, 11);
  const ChessboardDetection det = detect_chessboard(f.ir, f.depth, v.sensor.intrinsics, v.board.pattern);
  EXPECT_GT(det.count_with_depth(), 40);
  double worst_px = 0.0;
  for (const ChessboardCorner& c : det.corners) {
    const Vec3 truth = v.board.corner(c.i, c.j);
    worst_px = std::max(worst_px, (project_normalised(v.sensor.intrinsics, truth.head<2>() / truth.z()) - c.uv).norm());
  }
  EXPECT_LT(worst_px, 0.5);
}

TEST(Chessboard, both_visible_faces_of_the_registration_box_are_found) {
  Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
  turn.linear() = Eigen::AngleAxisd(M_PI / 4, Vec3::UnitZ()).matrix();
  const Scene box = make_box_scene(Vec3(0.3, 0.3, 0.7), turn);
  ASSERT_EQ(box.chessboards.size(), 4u);
  const auto rig = default_rig(1, 0.75);
  const geometry::SurfaceQuery query(box.mesh);
  const SimulatedFrame f = simulate_frame(query, box, rig[0], noise_free(), 5);
  const auto boards = find_all_chessboard_corners(f.ir, box.chessboards[0].pattern, 2, 4);
  ASSERT_EQ(boards.size(), 2u);
  // Each detection matches one of the two faces turned towards K1, corner for corner.
  const CameraIntrinsics& k = rig[0].intrinsics;
  const Eigen::Isometry3d sensor_from_world = rig[0].world_from_sensor.inverse();
  for (const auto& uv : boards) {
    double best = 1e9;
    for (const ChessboardPatch& b : box.chessboards) {
      double worst = 0.0;
      for (int j = 0; j < b.pattern.inner_rows; ++j)
        for (int i = 0; i < b.pattern.inner_cols; ++i) {
          const Vec3 p = sensor_from_world * b.corner(i, j);
          worst = std::max(worst, (project_normalised(k, p.head<2>() / p.z()) -
                                   uv[static_cast<size_t>(j * b.pattern.inner_cols + i)]).norm());
        }
      best = std::min(best, worst);
    }
    EXPECT_LT(best, 0.3);
  }
}

TEST(Chessboard, local_plane_corner_depth_is_closer_to_the_truth_than_the_four_pixel_interpolation) {
  // The box's boards are seen at ~45°: random noise only (no systematic terms), so what is left is
  // how well each estimate averages the noise of the corner's (partly dark) pixels.
  const BoardView v = board_view(0.75, 0.75, 0.1);
  const geometry::SurfaceQuery query(v.scene.mesh);
  const SimulatedFrame f =
      simulate_frame(query, v.scene, v.sensor, scale_systematic_errors(SensorErrorModel{}, 0.0), 21);
  const auto uv = find_chessboard_corners(f.ir, v.board.pattern);
  ASSERT_TRUE(uv.has_value());
  ChessboardOptions plane;
  plane.corner_depth = CornerDepth::LocalPlane;
  const ChessboardDetection a = corners_to_3d(*uv, f.depth, v.sensor.intrinsics, v.board.pattern);
  const ChessboardDetection b = corners_to_3d(*uv, f.depth, v.sensor.intrinsics, v.board.pattern, plane);
  double sum_a = 0.0, sum_b = 0.0;
  int n = 0;
  for (size_t c = 0; c < a.corners.size(); ++c) {
    if (!a.corners[c].has_depth() || !b.corners[c].has_depth()) continue;
    const double truth = v.board.corner(a.corners[c].i, a.corners[c].j).z();
    sum_a += std::pow(a.corners[c].depth_m - truth, 2);
    sum_b += std::pow(b.corners[c].depth_m - truth, 2);
    ++n;
  }
  ASSERT_GT(n, 45);
  EXPECT_EQ(b.count_with_depth(), 54);
  const double rms_a = std::sqrt(sum_a / n) * 1e3, rms_b = std::sqrt(sum_b / n) * 1e3;
  EXPECT_LT(rms_b, 0.4 * rms_a) << "bilinear " << rms_a << " mm, local plane " << rms_b << " mm";
  EXPECT_LT(rms_b, 0.5);
}

TEST(Chessboard, local_plane_depth_ignores_a_depth_edge_and_needs_enough_valid_pixels) {
  DepthImage d;
  d.width = 40;
  d.height = 30;
  d.scale_m = 1e-3;
  d.raw.assign(static_cast<size_t>(d.width) * d.height, 800);
  for (int v = 0; v < d.height; ++v)
    for (int u = 24; u < d.width; ++u) d.raw[static_cast<size_t>(v) * d.width + u] = 1400;  // background
  EXPECT_NEAR(local_plane_depth(d, 0.0, Eigen::Vector2d(20.3, 15.0), 6.0, 0.01), 0.8, 1e-9);
  for (int v = 0; v < d.height; ++v)
    for (int u = 0; u < 24; ++u)
      if ((u + v) % 4 != 0) d.raw[static_cast<size_t>(v) * d.width + u] = 0;
  EXPECT_EQ(local_plane_depth(d, 0.0, Eigen::Vector2d(12.0, 15.0), 6.0, 0.01), 0.0);
}

TEST(Chessboard, a_frame_without_a_board_gives_a_one_line_error_naming_it) {
  const geometry::TriMesh cyl = make_cylinder(0.16, 0.4);
  const auto rig = default_rig(1, 0.75);
  Scene scene;
  scene.mesh = cyl;
  const SimulatedFrame f = simulate_frame(geometry::SurfaceQuery(cyl), scene, rig[0], SensorErrorModel{}, 1);
  try {
    detect_chessboard(f.ir, f.depth, rig[0].intrinsics, ChessboardPattern{}, {}, "K2/ir_0003.png");
    FAIL() << "expected an error";
  } catch (const InvalidInputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("chessboard not found in K2/ir_0003.png ("), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos);
  }
  EXPECT_THROW(find_chessboard_corners(f.ir, ChessboardPattern{1, 6, 0.06}), InvalidInputError);
}

TEST(Chessboard, bilinear_depth_skips_invalid_and_edge_neighbourhoods) {
  DepthImage d;
  d.width = d.height = 4;
  d.raw.assign(16, 1000);
  d.raw[1 * 4 + 2] = 1010;  // (2, 1)
  EXPECT_NEAR(bilinear_depth(d, 0.0, Eigen::Vector2d(1.5, 0.5), 0.02), 1.0025, 1e-9);
  EXPECT_NEAR(bilinear_depth(d, 0.005, Eigen::Vector2d(0.0, 0.0), 0.02), 1.005, 1e-9);
  d.raw[1 * 4 + 2] = 0;
  EXPECT_EQ(bilinear_depth(d, 0.0, Eigen::Vector2d(1.5, 0.5), 0.02), 0.0);
  d.raw[1 * 4 + 2] = 1500;
  EXPECT_EQ(bilinear_depth(d, 0.0, Eigen::Vector2d(1.5, 0.5), 0.02), 0.0);
  EXPECT_EQ(bilinear_depth(d, 0.0, Eigen::Vector2d(3.2, 0.5), 0.02), 0.0);  // outside
}

TEST(Chessboard, recordings_keep_ir_frames_and_the_pattern) {
  const BoardView v = board_view(0.7, 0.1);
  SimulationOptions o;
  o.frames = 2;
  const Recording rec = simulate_recording(v.scene, {v.sensor}, o);
  ASSERT_EQ(rec.sensors[0].ir_frames.size(), 2u);
  const auto dir = temp_dir("chessboard_recording");
  write_recording(dir, rec);
  ASSERT_TRUE(std::filesystem::exists(dir / "K1" / "ir_0001.png"));
  const Recording back = read_recording(dir);
  ASSERT_TRUE(back.chessboard.has_value());
  EXPECT_EQ(back.chessboard->inner_cols, 9);
  EXPECT_NEAR(back.chessboard->square_m, 0.06, 1e-12);
  ASSERT_EQ(back.sensors[0].ir_frames.size(), 2u);
  EXPECT_EQ(back.sensors[0].ir_frames[1].value, rec.sensors[0].ir_frames[1].value);
  // An 8-bit IR PNG is accepted (×257); a missing IR frame for a depth frame is an error.
  cv::Mat eight(v.sensor.intrinsics.height, v.sensor.intrinsics.width, CV_8UC1, cv::Scalar(200));
  cv::imwrite((dir / "K1" / "ir_0001.png").string(), eight);
  EXPECT_EQ(read_recording(dir).sensors[0].ir_frames[1].at(5, 5), 200 * 257);
  std::filesystem::remove(dir / "K1" / "ir_0001.png");
  EXPECT_THROW(read_recording(dir), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::scan
