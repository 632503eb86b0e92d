// The full limb scans of docs/VALIDATION.md "Limb scans" (validation label): the generated limb and
// OpenLimb's mean transtibial skin, real Kinect v2 intrinsics, default errors, 2 mm sampling.
#include <gtest/gtest.h>

#include <filesystem>

#include "scan_fixtures.h"
#include "socketsmith/core/log.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/scan/accuracy.h"
#include "socketsmith/volume/limb_generator.h"

namespace socketsmith::scan {
namespace {

void check_limb(const geometry::TriMesh& limb, const char* what) {
  LimbScanOptions o;
  o.intrinsics = test::rig_intrinsics();
  const LimbScanResult r = run_limb_scan_experiment(limb, o);
  const ScanAccuracy& a = r.accuracy;
  log::info("{}: watertight {}, symmetric RMS {:.3f} mm (signed {:+.3f}, max {:.2f}), seen {:.1f} %", what,
            r.reconstruction.check.is_valid_closed_surface(), a.symmetric.rms_m * 1e3, a.symmetric.signed_mean_m * 1e3,
            a.symmetric.max_m * 1e3, 100 * a.seen_area_fraction);
  EXPECT_TRUE(r.reconstruction.check.is_valid_closed_surface()) << what << ": " << r.reconstruction.message << " (" << fmt::format("{}", fmt::join(r.reconstruction.check.problems(), "; ")) << ")";
  EXPECT_GT(a.seen_area_fraction, 0.95) << what;
  // Measured 1.63 (generated) and 1.58 mm (OpenLimb): the 1.5 mm goal needs the learned depth
  // compensation (the error is the sensors' uncompensated bias: signed mean ≈ −1.5 mm).
  EXPECT_LT(a.symmetric.rms_m, 1.75e-3) << what;
}

TEST(LimbScanValidation, generated_transtibial_limb) {
  check_limb(volume::generate_limb(volume::default_params(geometry::LimbType::Transtibial, 1)).skin,
             "generated transtibial limb");
}

TEST(LimbScanValidation, openlimb_mean_transtibial_skin) {
  const auto path = test::shared_data() / "limbs" / "transtibial" / "openlimb_tt_mean_skin_mm.stl";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared/data is absent (needs openlimb_tt_mean_skin_mm.stl)";
  geometry::MeshReadOptions ro;
  ro.unit = units::LengthUnit::Millimetre;
  check_limb(geometry::read_mesh(path, ro), "OpenLimb mean transtibial skin");
}

}  // namespace
}  // namespace socketsmith::scan
