#include "socketsmith/scan/sensor_calibration.h"

#include <gtest/gtest.h>

#include <fstream>

#include "scan_fixtures.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/scan/point_cloud.h"
#include "socketsmith/scan/simulated_sensor.h"

namespace socketsmith::scan {
namespace {

using test::temp_dir;

/// One unit with a clear systematic error (lateral scale +2.5 % / −1.5 %, the default depth
/// biases) and the default noise: a reduced calibration session (8 frames, shared by the tests)
/// and 2 held-out frames of the same unit.
struct Session {
  std::vector<SimulatedSensor> rig = default_rig(1);
  CalibrationSessionOptions train, test;
  Recording training, held;
  Session() {
    train.simulation.seed = 5;
    train.simulation.frames = 8;
    train.simulation.error.ray_scale_x = 0.025;
    train.simulation.error.ray_scale_y = -0.015;
    train.simulation.error.ray_scale_sd = 0.0;
    test = train;
    test.simulation.frames = 2;
    test.frame_seed = 977;
    training = simulate_calibration_session(rig, train);
    held = simulate_calibration_session(rig, test);
  }
};

const Session& session() {
  static const Session s;
  return s;
}

DimensionStats held_out_errors(const Recording& held, const ErrorCompensation* model) {
  EdgeErrors e;
  const SensorRecording& s = held.sensors[0];
  for (size_t f = 0; f < s.frames.size(); ++f) {
    const ChessboardDetection det = detect_chessboard(s.ir_frames[f], s.frames[f], s.intrinsics, *held.chessboard);
    e.add(det, compensated_corners(det, model));
  }
  return e.stats();
}

TEST(SensorCalibration, learned_compensation_reduces_held_out_chessboard_errors) {
  const Session& x = session();
  ASSERT_TRUE(x.training.chessboard.has_value());
  for (const TruthEstimate truth : {TruthEstimate::Pnp, TruthEstimate::Kabsch}) {
    SensorCalibrationOptions o;
    o.truth = truth;
    const SensorCalibrationResult r = calibrate_sensor(x.training.sensors[0], *x.training.chessboard, o);
    EXPECT_EQ(r.observations.size(), 8u);
    EXPECT_LT(r.rms_after_mm, 0.8 * r.rms_before_mm);
    // The lateral scale errors appear in e_x and e_y at the image centre (≈ +2.5 %, −1.5 %; with
    // the thesis's truth they also carry the depth offset, ≈ δ/d).
    const Eigen::Vector3d centre = r.model.rates(256, 212, 0.75);
    EXPECT_NEAR(centre.x(), 0.025, 0.008);
    EXPECT_NEAR(centre.y(), -0.015, 0.008);
    const DimensionStats raw = held_out_errors(x.held, nullptr), comp = held_out_errors(x.held, &r.model);
    EXPECT_GT(raw.mean_mm, 0.8);
    EXPECT_LT(comp.mean_mm, 0.75 * raw.mean_mm) << "raw " << raw.mean_mm << " compensated " << comp.mean_mm;
  }
}

TEST(SensorCalibration, the_training_dimension_errors_are_those_of_its_own_boards_without_and_with_the_model) {
  const Session& x = session();
  const SensorCalibrationResult r = calibrate_sensor(x.training.sensors[0], *x.training.chessboard);
  const TrainingDimensionErrors e = training_dimension_errors(r);
  EdgeErrors raw;
  for (const auto& ob : r.observations) raw.add(ob.detection, compensated_corners(ob.detection, nullptr));
  EXPECT_EQ(e.before.mean_mm, raw.stats().mean_mm);
  EXPECT_EQ(e.before.count, raw.stats().count);
  EXPECT_EQ(e.after.count, e.before.count) << "the same corners, corrected";
  EXPECT_GT(e.before.count, 0);
  EXPECT_LT(e.after.mean_mm, e.before.mean_mm) << "the model fits its own boards";
  SensorCalibrationResult none = r;
  none.observations.clear();
  EXPECT_EQ(training_dimension_errors(none).before.count, 0);
}

TEST(SensorCalibration, ray_polynomial_model_follows_the_radial_and_wiggling_depth_errors_better_than_linear_rates) {
  // The session's unit has the default radial bias (3 mm × ρ²) and wiggling (1.5 mm, period 0.5 m):
  // neither is linear in (u, v, d).
  // Corner depths by the local plane fit, so that the noise does not hide the model's misfit.
  const Session& x = session();
  SensorCalibrationOptions linear, ray;
  linear.chessboard.corner_depth = ray.chessboard.corner_depth = CornerDepth::LocalPlane;
  ray.form = CompensationForm::RayPolynomial;
  const SensorCalibrationResult a = calibrate_sensor(x.training.sensors[0], *x.training.chessboard, linear);
  const SensorCalibrationResult b = calibrate_sensor(x.training.sensors[0], *x.training.chessboard, ray);
  EXPECT_EQ(b.model.form, CompensationForm::RayPolynomial);
  EXPECT_LT(b.rms_after_mm, 0.8 * a.rms_after_mm) << "linear " << a.rms_after_mm << " ray-poly " << b.rms_after_mm;
  // Its lateral rates at the image centre are the unit's lateral scale errors (+2.5 %, −1.5 %).
  EXPECT_NEAR(b.model.lateral(0, 0) + 0.75 * b.model.lateral(0, 3), 0.025, 0.006);
  EXPECT_NEAR(b.model.lateral(1, 0) + 0.75 * b.model.lateral(1, 3), -0.015, 0.006);
  const auto dir = temp_dir("calibration_ray_poly");
  write_compensation_json(dir / "model.json", {b.model});
  const auto back = read_compensation_json(dir / "model.json");
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].form, CompensationForm::RayPolynomial);
  const Vec3 p(0.12, -0.05, 0.8);
  EXPECT_LT((back[0].apply(p, 300, 180) - b.model.apply(p, 300, 180)).norm(), 1e-12);
}

/// A unit without systematic errors and little noise (0.3 mm σ, also on black squares).
SensorErrorModel quiet_unit() {
  SensorErrorModel e = scale_systematic_errors(SensorErrorModel{}, 0.0);
  e.noise_sigma0_m = 0.3e-3;
  e.noise_sigma2_per_m = 0.0;
  e.dark_noise_factor = 1.0;
  return e;
}

/// 12 board frames at 0.55-1.0 m of one unit with error model @p e.
Recording one_unit_session(const SensorErrorModel& e, std::uint64_t seed) {
  CalibrationSessionOptions o;
  o.simulation.seed = seed;
  o.simulation.frames = 12;
  o.simulation.error = e;
  return simulate_calibration_session(default_rig(1), o);
}

SensorCalibrationOptions ray_poly_plane() {
  SensorCalibrationOptions o;
  o.form = CompensationForm::RayPolynomial;
  o.chessboard.corner_depth = CornerDepth::LocalPlane;
  return o;
}

TEST(SensorCalibration, a_higher_depth_degree_follows_a_wiggling_error_over_the_board_distances) {
  // A unit whose depth error is the periodic "wiggling" (4.5 mm, period 0.5 m: three times the
  // default, as at --noise-scale 3) with little noise; boards at 0.55-1.0 m. A cubic in d leaves a
  // part of the sine (0.45 mm of 3-D corner residual); degree 7 follows it (4 more coefficients
  // cannot halve the residual of ~600 corners by fitting noise).
  SensorErrorModel e = quiet_unit();
  e.wiggle_amplitude_m = 4.5e-3;
  const Recording rec = one_unit_session(e, 4);
  SensorCalibrationOptions cubic = ray_poly_plane(), seventh = ray_poly_plane();
  seventh.depth_degree = 7;
  const SensorCalibrationResult a = calibrate_sensor(rec.sensors[0], *rec.chessboard, cubic);
  const SensorCalibrationResult b = calibrate_sensor(rec.sensors[0], *rec.chessboard, seventh);
  EXPECT_EQ(b.model.depth_degree, 7);
  ASSERT_EQ(b.model.depth_polynomial.size(), 13);
  EXPECT_GT(a.rms_after_mm, 0.3) << "the cubic followed the sine: no test (degree 7: " << b.rms_after_mm << " mm)";
  EXPECT_LT(b.rms_after_mm, 0.5 * a.rms_after_mm) << "cubic " << a.rms_after_mm << " degree 7 " << b.rms_after_mm;
  // The file keeps the degree; a file without one is a cubic.
  const auto dir = temp_dir("calibration_depth_degree");
  write_compensation_json(dir / "model.json", {b.model});
  const auto back = read_compensation_json(dir / "model.json");
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].depth_degree, 7);
  const Vec3 p(0.12, -0.05, 0.8);
  EXPECT_LT((back[0].apply(p, 300, 180) - b.model.apply(p, 300, 180)).norm(), 1e-12);
  std::ofstream(dir / "old.json") << R"({"format": "socketsmith-scan-compensation", "sensors": [{"name": "K1", "width": 512,
    "height": 424, "model": "ray-poly", "depth_poly": [0.001, 0, 0, 0, 0, 0, 0, 0, 0], "lateral_x": [0, 0, 0, 0],
    "lateral_y": [0, 0, 0, 0]}]})";
  const auto old = read_compensation_json(dir / "old.json");
  EXPECT_EQ(old[0].depth_degree, 3);
  EXPECT_NEAR(old[0].apply(p, 0, 0).z(), 0.799, 1e-12);
}

TEST(SensorCalibration, refining_the_distortion_gives_a_truth_consistent_with_a_unit_whose_rays_are_scaled) {
  // A unit whose rays are 3.5 % wider than its calibration says (as a unit of --noise-scale 3 may
  // be), no other systematic error, little noise. Refined focal lengths alone cannot express the
  // distortion seen at a 3.5 % larger radius; with k1..k3 refined too the board poses, and so the
  // learned model's residual on its own corners, are consistent.
  SensorErrorModel e = quiet_unit();
  e.ray_scale_x = e.ray_scale_y = 0.035;
  const Recording rec = one_unit_session(e, 6);
  SensorCalibrationOptions focal = ray_poly_plane(), full = ray_poly_plane();
  full.refine_distortion = true;
  const SensorCalibrationResult a = calibrate_sensor(rec.sensors[0], *rec.chessboard, focal);
  const SensorCalibrationResult b = calibrate_sensor(rec.sensors[0], *rec.chessboard, full);
  const double f = rec.sensors[0].intrinsics.fx;
  EXPECT_NEAR(b.fx / f, 1.035, 0.004);
  EXPECT_LT(b.rms_after_mm, 0.7 * a.rms_after_mm) << "focal lengths only " << a.rms_after_mm << " mm (f "
                                                  << a.fx / f << " f0), with the distortion " << b.rms_after_mm;
}

TEST(SensorCalibration, ray_polynomial_correction_moves_the_depth_along_the_ray_and_scales_the_ray) {
  ErrorCompensation m;
  m.form = CompensationForm::RayPolynomial;
  m.depth_polynomial(0) = 0.002;  // 2 mm too far everywhere
  m.lateral(0, 0) = 0.01;         // rays 1 % too wide in x
  const Vec3 p(0.2, 0.1, 0.8);
  const double d = 0.798;
  EXPECT_LT((m.apply(p, 0, 0) - Vec3(0.25 * 0.99 * d, 0.125 * d, d)).norm(), 1e-12);
}

TEST(SensorCalibration, back_project_applies_the_model) {
  // ε = (1 %, −2 %, 0.3 %) everywhere: every point becomes (0.99 X, 1.02 Y, 0.997 Z).
  ErrorCompensation m;
  m.sensor = "K1";
  m.width = 512;
  m.height = 424;
  m.coefficients.col(0) = Eigen::Vector3d(0.01, -0.02, 0.003);
  DepthImage d;
  d.width = 512;
  d.height = 424;
  d.raw.assign(512 * 424, 800);
  const CameraIntrinsics k = kinect_v2_typical_intrinsics();
  const PointCloud raw = back_project(d, k, Eigen::Isometry3d::Identity());
  const PointCloud comp = back_project(d, k, Eigen::Isometry3d::Identity(), {}, 0, nullptr, &m);
  ASSERT_EQ(raw.size(), comp.size());
  ASSERT_GT(raw.size(), 1000);
  for (int i = 0; i < raw.size(); i += 997) {
    const Vec3& p = raw.points[static_cast<size_t>(i)];
    EXPECT_LT((comp.points[static_cast<size_t>(i)] - Vec3(0.99 * p.x(), 1.02 * p.y(), 0.997 * p.z())).norm(), 1e-9);
  }
}

TEST(SensorCalibration, model_files_round_trip_and_bad_inputs_get_one_line_errors) {
  Recording training = session().training;
  const SensorCalibrationResult r = calibrate_sensor(training.sensors[0], *training.chessboard);
  const auto dir = temp_dir("calibration_models");
  write_compensation_json(dir / "model.json", {r.model});
  const auto back = read_compensation_json(dir / "model.json");
  ASSERT_EQ(back.size(), 1u);
  EXPECT_LT((back[0].coefficients - r.model.coefficients).norm(), 1e-12);
  EXPECT_EQ(back[0].truth, "pnp");
  // A model for another sensor or resolution.
  EXPECT_THROW(compensation_for(back, "K2", 512, 424, "model.json"), InvalidInputError);
  try {
    compensation_for(back, "K1", 640, 480, "model.json");
    FAIL();
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("learned on 512x424 frames but sensor 'K1' has 640x480"), std::string::npos);
  }
  // Recording + rig.json "compensation" round trip.
  training.sensors[0].compensation = r.model;
  write_recording(dir / "rec", training);
  const Recording again = read_recording(dir / "rec");
  ASSERT_TRUE(again.sensors[0].compensation.has_value());
  EXPECT_LT((again.sensors[0].compensation->coefficients - r.model.coefficients).norm(), 1e-12);
  // Too few frames; no IR frames; a wrong pattern (board never found).
  SensorRecording three = training.sensors[0];
  three.frames.resize(3);
  three.ir_frames.resize(3);
  three.frame_files.resize(3);
  EXPECT_THROW(calibrate_sensor(three, *training.chessboard), InvalidInputError);
  SensorRecording no_ir = three;
  no_ir.ir_frames.clear();
  EXPECT_THROW(calibrate_sensor(no_ir, *training.chessboard), InvalidInputError);
  try {
    calibrate_sensor(three, ChessboardPattern{11, 8, 0.06});
    FAIL();
  } catch (const InvalidInputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("the board was found in"), std::string::npos) << m;
    EXPECT_NE(m.find("chessboard not found in K1/ir_0000.png"), std::string::npos) << m;
  }
  EXPECT_THROW(read_compensation_json(dir / "missing.json"), IoError);
}

TEST(SensorCalibration, fusing_the_frames_of_each_board_pose_gives_closer_corners_and_more_boards) {
  // A unit without systematic errors and three times the default noise (the configuration whose
  // single-frame chessboard errors reach the thesis's): every corner error is noise. 8 poses × 4
  // frames; the first frame of each pose is the frame of a one-frame-per-pose session.
  CalibrationSessionOptions o;
  o.simulation.seed = 3;
  o.simulation.frames = 8;
  o.simulation.error = scale_systematic_errors(SensorErrorModel{}, 0.0);
  o.simulation.error.scale = 3.0;
  o.frames_per_pose = 4;
  const std::vector<SimulatedSensor> rig = default_rig(1);
  const Recording fused = simulate_calibration_session(rig, o);
  EXPECT_EQ(fused.frames_per_pose, 4);
  ASSERT_EQ(fused.sensors[0].frames.size(), 32u);
  CalibrationSessionOptions one = o;
  one.frames_per_pose = 1;
  const Recording single = simulate_calibration_session(rig, one);
  ASSERT_EQ(single.sensors[0].frames.size(), 8u);
  for (size_t pose = 0; pose < 8; ++pose)
    EXPECT_EQ(single.sensors[0].frames[pose].raw, fused.sensors[0].frames[4 * pose].raw) << "pose " << pose;
  EXPECT_NE(fused.sensors[0].frames[0].raw, fused.sensors[0].frames[1].raw);  // independent noise

  SensorCalibrationOptions co;
  co.min_frames = 2;
  const SensorCalibrationResult a = calibrate_sensor(single.sensors[0], *single.chessboard, co);
  co.frames_per_pose = 4;
  const SensorCalibrationResult b = calibrate_sensor(fused.sensors[0], *fused.chessboard, co);
  EXPECT_GE(b.observations.size(), a.observations.size());
  EXPECT_GE(b.observations.size(), 7u);
  EXPECT_EQ(b.observations.back().frame % 4, 0);
  // Depth noise of the corners (bilinear, ×2.5 on black squares) halves with four frames.
  EXPECT_LT(b.rms_before_mm, 0.7 * a.rms_before_mm) << "single " << a.rms_before_mm << " fused " << b.rms_before_mm;

  // rig.json keeps frames_per_pose; a frame count that is not a whole number of poses is refused.
  const auto dir = temp_dir("calibration_frames_per_pose");
  write_recording(dir / "rec", fused);
  EXPECT_EQ(read_recording(dir / "rec").frames_per_pose, 4);
  SensorRecording odd = fused.sensors[0];
  odd.frames.pop_back();
  odd.ir_frames.pop_back();
  const std::string m = test::error_message([&] { calibrate_sensor(odd, *fused.chessboard, co); });
  EXPECT_NE(m.find("not a whole number of board poses of 4 frames"), std::string::npos) << m;
}

}  // namespace
}  // namespace socketsmith::scan
