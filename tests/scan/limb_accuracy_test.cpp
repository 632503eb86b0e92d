#include "socketsmith/scan/accuracy.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "scan_fixtures.h"
#include "socketsmith/core/log.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/volume/limb_generator.h"

namespace socketsmith::scan {
namespace {

TEST(SurfaceSampling, samples_cover_the_area_and_distances_are_signed) {
  const geometry::TriMesh cyl = make_cylinder(0.16, 0.2, Vec3::Zero(), 128, 8);
  const auto samples = sample_surface(cyl, 2e-3);
  double area = 0.0;
  for (const auto& s : samples) area += s.weight;
  EXPECT_NEAR(area, geometry::surface_area(cyl), 1e-9);
  // A cylinder 1 mm larger in radius measured against the original: 1 mm everywhere on the side,
  // outside (+), and the original sampled against it: also +1 mm (the original is inside it).
  const geometry::TriMesh bigger = make_cylinder(0.162, 0.2, Vec3::Zero(), 128, 8);
  AccuracyOptions o;
  o.sample_spacing_m = 5e-3;
  o.region_top_m = 0.09;  // the caps at ±0.1 m stay out of the region
  const std::vector<SimulatedSensor> rig = default_rig(4);
  const ScanAccuracy a = measure_scan_accuracy(bigger, -1, cyl, rig, o);
  // The bottom caps (z = −0.1) are below the region's top: their distance is 0 (same plane).
  EXPECT_GT(a.reconstructed_to_original.signed_mean_m, 0.5e-3);
  EXPECT_LT(a.reconstructed_to_original.max_m, 1.1e-3);
  EXPECT_GT(a.seen_area_fraction, 0.7);  // the bottom cap faces the floor: unseen
  EXPECT_LT(a.seen_area_fraction, 0.95);
  EXPECT_NEAR(a.seen_original_to_reconstructed.rms_m, 1.0e-3, 0.05e-3);
  EXPECT_NEAR(a.seen_original_to_reconstructed.signed_mean_m, 1.0e-3, 0.05e-3);
}

/// The generated transtibial skin with the real Kinect v2 intrinsics (typical ones without ../shared).
LimbScanOptions limb_options(double noise_scale) {
  LimbScanOptions o;
  o.intrinsics = test::rig_intrinsics();
  o.simulation.error.scale = noise_scale;
  o.simulation.seed = 1;
  o.accuracy.sample_spacing_m = 4e-3;
  return o;
}

geometry::TriMesh generated_skin() {
  return volume::generate_limb(volume::default_params(geometry::LimbType::Transtibial, 1)).skin;
}

/// @p limb scanned with limb_options(@p noise_scale): its accuracy logged as @p what, its surface
/// checked closed.
LimbScanResult scanned(const geometry::TriMesh& limb, double noise_scale, const char* what) {
  LimbScanResult r = run_limb_scan_experiment(limb, limb_options(noise_scale));
  const ScanAccuracy& a = r.accuracy;
  log::info("{}: symmetric RMS {:.3f} mm (max {:.2f}, signed {:+.3f}), seen {:.1f} %", what, a.symmetric.rms_m * 1e3,
            a.symmetric.max_m * 1e3, a.symmetric.signed_mean_m * 1e3, 100 * a.seen_area_fraction);
  EXPECT_TRUE(r.reconstruction.check.is_valid_closed_surface()) << what << ": " << r.reconstruction.message;
  return r;
}

TEST(LimbScan, noise_free_scan_of_the_generated_limb_is_watertight_and_sub_mm_and_a_wrong_pose_shows) {
  const LimbScanResult r = scanned(generated_skin(), 0.0, "noise-free generated limb");
  const ScanAccuracy& a = r.accuracy;
  EXPECT_GT(a.seen_area_fraction, 0.9);
  EXPECT_LT(a.symmetric.rms_m, 0.8e-3);
  EXPECT_LT(a.symmetric.p95_m, 1.5e-3);

  // The same frames with K2's pose in rig.json turned by 0.5 degrees about its own vertical axis
  // (its cloud sweeps ~6 mm sideways at the limb): the fused surface doubles up and the measure
  // sees it.
  Recording wrong = r.recording;
  Eigen::Isometry3d& pose = wrong.sensors[1].world_from_sensor;
  pose = pose * Eigen::AngleAxisd(0.5 * M_PI / 180.0, Vec3::UnitY());
  const ReconstructionResult rw = reconstruct_recording(wrong);
  AccuracyOptions ao = limb_options(0.0).accuracy;
  ao.region_top_m = rw.cut_height_m;
  const ScanAccuracy aw = measure_scan_accuracy(rw.mesh, rw.first_cap_triangle, r.original, r.rig, ao);
  log::info("K2 turned by 0.5 deg: symmetric RMS {:.3f} mm (max {:.2f})", aw.symmetric.rms_m * 1e3,
            aw.symmetric.max_m * 1e3);
  EXPECT_GT(aw.symmetric.rms_m, 0.8e-3);
}

// Measured 1.636 mm RMS (signed −1.529 mm), seen 98.5 %: the validation's bar of 1.75 mm holds here.
TEST(LimbScan, default_noise_scan_of_the_generated_limb_within_the_validation_bar) {
  const LimbScanResult r = scanned(generated_skin(), 1.0, "default-noise generated limb");
  const ScanAccuracy& a = r.accuracy;
  EXPECT_LT(a.symmetric.rms_m, 1.75e-3);
  EXPECT_GT(a.seen_area_fraction, 0.97);
  // Without compensation the error is mostly the sensors' depth bias: the surface shrinks.
  EXPECT_LT(a.symmetric.signed_mean_m, -0.5e-3);
}

// LimbScanValidation's real-limb check (label validation, 2 mm sampling) reduced for the default
// run: OpenLimb's mean transtibial skin, real intrinsics, default errors, seed 1, samples every 4 mm.
// Measured: 1.570 mm RMS (signed −1.475 mm), seen 98.2 % (at 2 mm: 1.57 / −1.48 mm, docs/VALIDATION.md).
// The bars are these with a margin, the RMS's upper one the validation's 1.75 mm; a lower RMS than
// 1.4 mm would mean the default errors were not applied (noise-free: 0.65 mm).
TEST(LimbScan, reduced_default_noise_scan_of_openlimbs_mean_skin_meets_its_measured_bars) {
  const auto path = test::shared_data() / "limbs" / "transtibial" / "openlimb_tt_mean_skin_mm.stl";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared/data is absent (needs openlimb_tt_mean_skin_mm.stl)";
  if (test::rig_intrinsics().empty()) GTEST_SKIP() << "../shared/data is absent (needs kinect2_calibration)";
  geometry::MeshReadOptions ro;
  ro.unit = units::LengthUnit::Millimetre;
  const LimbScanResult r = scanned(geometry::read_mesh(path, ro), 1.0, "default-noise OpenLimb mean skin");
  const ScanAccuracy& a = r.accuracy;
  EXPECT_GT(a.seen_area_fraction, 0.97);
  EXPECT_LT(a.symmetric.rms_m, 1.75e-3);
  EXPECT_GT(a.symmetric.rms_m, 1.4e-3);
  EXPECT_NEAR(a.symmetric.signed_mean_m, -1.475e-3, 0.2e-3);
}

}  // namespace
}  // namespace socketsmith::scan
