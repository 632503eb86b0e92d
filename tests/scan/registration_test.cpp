#include "socketsmith/scan/registration.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <fmt/format.h>

#include "scan_fixtures.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"

namespace socketsmith::scan {
namespace {

constexpr double kDeg = M_PI / 180.0;

std::string message_of(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

/// Four sensors on a ring, each pair of neighbours sharing 20 exact points on a "board" between them.
struct Synthetic {
  ReferenceSet refs;
  std::vector<Eigen::Isometry3d> truth;
};
Synthetic synthetic_ring() {
  Synthetic s;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  for (const auto& sensor : default_rig(4)) {
    s.truth.push_back(sensor.world_from_sensor);
    s.refs.sensor_names.push_back(sensor.name);
  }
  for (int b = 0; b < 4; ++b) {
    const double a = -M_PI / 4 + b * M_PI / 2;  // between sensor b and b+1
    const Vec3 centre(0.15 * std::cos(a), 0.15 * std::sin(a), 0.0);
    for (int k = 0; k < 20; ++k) {
      const Vec3 w = centre + Vec3(u(rng), u(rng), 3 * u(rng));
      const int id = static_cast<int>(s.refs.point_names.size());
      s.refs.point_names.push_back(fmt::format("p{}", id));
      for (int sensor : {b, (b + 1) % 4})
        s.refs.observations.push_back({sensor, id, s.truth[static_cast<size_t>(sensor)].inverse() * w});
    }
  }
  return s;
}

std::vector<Eigen::Isometry3d> perturbed(const std::vector<Eigen::Isometry3d>& truth, double deg, double m) {
  std::vector<Eigen::Isometry3d> out = truth;
  for (size_t s = 1; s < out.size(); ++s) {
    const Vec3 axis = Vec3(1.0, 0.3 * s, -0.5).normalized();
    out[s].linear() = Eigen::AngleAxisd(deg * kDeg, axis).toRotationMatrix() * out[s].linear();
    out[s].translation() += m * Vec3(0.2, -1.0, 0.4 * s).normalized();
  }
  return out;
}

TEST(Registration, kabsch_recovers_a_rigid_transform_and_refuses_collinear_points) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  T.translation() = Vec3(0.1, -0.2, 0.3);
  std::vector<Vec3> src = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.3, 0.2, 0.9}}, dst;
  for (const Vec3& p : src) dst.push_back(T * p);
  EXPECT_TRUE(kabsch(src, dst).isApprox(T, 1e-12));
  EXPECT_THROW(kabsch({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}, {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}), InvalidInputError);
}

TEST(Registration, multiset_and_sequential_recover_exact_synthetic_poses) {
  const Synthetic s = synthetic_ring();
  const auto start = perturbed(s.truth, 4.0, 0.03);
  EXPECT_GT(pair_errors(s.refs, start).mean_m, 0.01);
  for (const RegistrationResult& r : {register_multiset(s.refs, start), register_sequential(s.refs, start)}) {
    EXPECT_TRUE(r.converged) << r.method;
    EXPECT_LT(r.final.max_m, 1e-7) << r.method;
    for (size_t k = 0; k < 4; ++k) {
      const PoseError e = pose_error(r.world_from_sensor[k], s.truth[k]);
      EXPECT_LT(e.translation_m, 1e-7) << r.method << " sensor " << k;
      EXPECT_LT(e.rotation_rad, 1e-7) << r.method << " sensor " << k;
    }
  }
}

TEST(Registration, noiseless_box_poses_recovered_to_half_a_millimetre_and_a_tenth_of_a_degree) {
  RegistrationExperimentOptions o;
  o.intrinsics = test::rig_intrinsics();
  o.simulation.error.scale = 0.0;
  o.simulation.depth_scale_m = 1e-4;  // 0.1 mm raw units: no 1 mm quantisation
  const RegistrationExperimentResult r = run_registration_experiment(o);
  EXPECT_EQ(r.refs.point_names.size(), 4u * 44u);  // four boards of 4 x 11 inner corners, each seen twice
  EXPECT_TRUE(r.multiset.converged);
  for (size_t k = 1; k < 4; ++k) {
    const PoseError e = r.multiset_pose_errors[k];
    log::info("noiseless box, {}: multi-set pose error {:.3f} mm, {:.4f} deg (start {:.0f} mm, {:.1f} deg)",
              r.rig[k].name, e.translation_m * 1e3, e.rotation_rad / kDeg, r.measured_pose_errors[k].translation_m * 1e3,
              r.measured_pose_errors[k].rotation_rad / kDeg);
    EXPECT_LT(e.translation_m, 0.5e-3);
    EXPECT_LT(e.rotation_rad, 0.1 * kDeg);
  }
  EXPECT_LT(r.multiset.final.mean_m, 0.5e-3);
}

TEST(Registration, multiset_beats_sequential_on_a_noisy_box) {
  RegistrationExperimentOptions o;
  o.intrinsics = test::rig_intrinsics();
  // A stand-in learned model per unit: every depth 0.4 % too far (e_z = 0.004).
  for (int k = 0; k < 4; ++k) {
    ErrorCompensation m;
    m.sensor = "K" + std::to_string(k + 1);
    m.width = 512;
    m.height = 424;
    m.coefficients(2, 0) = 0.004;
    o.compensation.push_back(m);
  }
  const RegistrationExperimentResult r = run_registration_experiment(o);
  // The compensated reference points are the same corners with z scaled by 1 − 0.004.
  ASSERT_EQ(r.refs_compensated.observations.size(), r.refs.observations.size());
  for (size_t i = 0; i < r.refs.observations.size(); i += 37)
    EXPECT_NEAR(r.refs_compensated.observations[i].p.z(), 0.996 * r.refs.observations[i].p.z(), 1e-9);
  EXPECT_TRUE(r.multiset_compensated.converged);
  log::info("noisy box: pair error mean/max sequential {:.3f}/{:.3f} mm, multi-set {:.3f}/{:.3f} mm, true poses "
            "{:.3f}/{:.3f} mm",
            r.sequential.final.mean_m * 1e3, r.sequential.final.max_m * 1e3, r.multiset.final.mean_m * 1e3,
            r.multiset.final.max_m * 1e3, r.truth_errors.mean_m * 1e3, r.truth_errors.max_m * 1e3);
  EXPECT_GT(r.sequential.initial.mean_m, 0.01);  // the hand-measured poses are cm off
  EXPECT_LT(r.multiset.final.mean_m, r.sequential.final.mean_m);
  EXPECT_LT(r.multiset.final.max_m, r.sequential.final.max_m);
  EXPECT_LT(r.multiset.final.mean_m, 3e-3);
}

TEST(Registration, local_plane_reference_points_are_closer_to_the_true_corners_than_bilinear_ones) {
  // Random errors only (no bias to learn): what separates the two corner depths is the noise of the
  // corners' pixels, seen at 45° on the box.
  RegistrationExperimentOptions o;
  o.intrinsics = test::rig_intrinsics();
  o.simulation.error = scale_systematic_errors(SensorErrorModel{}, 0.0);
  o.pose_error_deg = 0.0;
  o.pose_error_m = 0.0;
  double along[2] = {0.0, 0.0};
  PairErrors at_truth[2];
  for (const int plane : {0, 1}) {
    o.detection.chessboard.corner_depth = plane ? CornerDepth::LocalPlane : CornerDepth::Bilinear;
    const RegistrationExperimentResult r = run_registration_experiment(o);
    ASSERT_EQ(r.accuracy.size(), 4u);
    for (const ReferenceAccuracy& a : r.accuracy) {
      EXPECT_GT(a.points, 60) << a.sensor;
      along[plane] += a.along_rms_m / 4;
    }
    at_truth[plane] = r.truth_errors;
  }
  log::info("reference points along the ray: bilinear {:.2f} mm RMS, local plane {:.2f} mm; pairs at the true poses "
            "{:.2f} -> {:.2f} mm", along[0] * 1e3, along[1] * 1e3, at_truth[0].mean_m * 1e3, at_truth[1].mean_m * 1e3);
  EXPECT_LT(along[1], 0.5 * along[0]);
  EXPECT_LT(at_truth[1].mean_m, 0.6 * at_truth[0].mean_m);
}

TEST(Registration, sensors_that_share_no_board_give_a_clear_error) {
  RegistrationExperimentOptions o;
  o.intrinsics = test::rig_intrinsics();
  o.box_yaw_deg = 0.0;  // each sensor sees one board head-on, its neighbours' boards edge-on
  const std::string m = message_of([&] { run_registration_experiment(o); });
  EXPECT_NE(m.find("reference point(s)"), std::string::npos) << m;
  EXPECT_NE(m.find("do not overlap"), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  // The synthetic ring with sensor K3's observations gone.
  Synthetic s = synthetic_ring();
  std::vector<ReferenceObservation> kept;
  for (const auto& ob : s.refs.observations)
    if (ob.sensor != 2) kept.push_back(ob);
  s.refs.observations = kept;
  const std::string m2 = message_of([&] { register_multiset(s.refs, s.truth); });
  EXPECT_NE(m2.find("sensor 'K3' shares 0 reference point(s)"), std::string::npos) << m2;
}

TEST(Registration, boards_too_noisy_in_one_ir_frame_are_found_in_the_mean_of_the_frames) {
  // The box at three times the default errors (as the configuration whose raw chessboard errors
  // reach the thesis's), 10 frames per sensor (a third of a second): the reference points come
  // from the mean of the IR frames; from the first IR frame alone some sensor misses its boards.
  SimulationOptions so;
  so.seed = 1;
  so.frames = 10;
  so.error.scale = 3.0;
  const Scene box = make_box_scene(Vec3(0.30, 0.30, 0.70), Eigen::Isometry3d(Eigen::AngleAxisd(M_PI / 4, Vec3::UnitZ())));
  const std::vector<SimulatedSensor> rig = default_rig(4, 0.75, 0.0, Vec3::Zero(), test::rig_intrinsics());
  const Recording rec = simulate_recording(box, rig, so);
  std::vector<Eigen::Isometry3d> poses;
  for (const auto& sensor : rig) poses.push_back(sensor.world_from_sensor);
  const ReferenceSet refs = box_reference_points(rec, poses);
  std::vector<int> per_sensor(4, 0);
  for (const auto& ob : refs.observations) ++per_sensor[static_cast<size_t>(ob.sensor)];
  for (int n : per_sensor) EXPECT_GE(n, 44);  // a whole 4 x 11 board at least
  Recording first = rec;
  for (auto& sr : first.sensors) {
    sr.frames.resize(1);
    sr.ir_frames.resize(1);
  }
  const std::string m = message_of([&] { box_reference_points(first, poses); });
  EXPECT_NE(m.find("chessboard not found in"), std::string::npos) << m;
}

TEST(Registration, rig_file_round_trip_replaces_poses_by_name) {
  const auto dir = test::temp_dir("rig_file");
  const Synthetic s = synthetic_ring();
  const auto moved = perturbed(s.truth, 2.0, 0.01);
  write_rig_file(dir / "rig.json", s.refs.sensor_names, moved, R"({"method": "test"})");
  Recording rec;
  for (size_t k = 0; k < 4; ++k) {
    SensorRecording sr;
    sr.name = s.refs.sensor_names[k];
    sr.world_from_sensor = s.truth[k];
    rec.sensors.push_back(sr);
  }
  apply_rig_file(rec, dir / "rig.json");
  for (size_t k = 0; k < 4; ++k) EXPECT_TRUE(rec.sensors[k].world_from_sensor.isApprox(moved[k], 1e-12));
  rec.sensors[2].name = "K9";
  const std::string m = message_of([&] { apply_rig_file(rec, dir / "rig.json"); });
  EXPECT_NE(m.find("has no sensor named 'K9'"), std::string::npos) << m;
  EXPECT_THROW(apply_rig_file(rec, dir / "missing.json"), IoError);
}

}  // namespace
}  // namespace socketsmith::scan
