#pragma once
/// @file scan_fixtures.h
/// Shared helpers of the scan tests: temporary folders, the shared data folder, cylinder errors.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/scan/experiments.h"
#include "socketsmith/scan/intrinsics.h"

namespace socketsmith::scan::test {

using Vec3 = geometry::Vec3;

inline std::filesystem::path shared_data() { return std::filesystem::path(SOCKETSMITH_SHARED_DATA_DIR); }

/// The real Kinect v2 intrinsics of four iai_kinect2 units when the shared data is present (else
/// empty: typical intrinsics).
inline std::vector<CameraIntrinsics> rig_intrinsics() {
  const auto root = shared_data() / "kinect2_calibration";
  std::vector<CameraIntrinsics> k;
  for (const char* serial : {"001530565347", "002061565347", "004429261047", "017436750747"})
    if (std::filesystem::exists(root / serial / "calib_ir.yaml")) k.push_back(read_kinect2_calibration(root / serial));
  if (k.size() != 4) k.clear();
  return k;
}

/// What @p fn throws as a socketsmith::Error, or "no error".
template <class Fn>
std::string error_message(Fn&& fn) {
  try {
    fn();
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

/// A fresh folder under the build tree for one test.
inline std::filesystem::path temp_dir(const std::string& name) {
  const auto dir = std::filesystem::path(SOCKETSMITH_BINARY_DIR) / "test_tmp" / "scan" / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

/// Radial error of a reconstructed z-axis cylinder within |z| <= half_band_m, sampled at the
/// vertices and the triangle centroids (so coarse facets count too).
struct RadialError {
  double rms_m = 0.0, max_m = 0.0, mean_m = 0.0;
  int count = 0;
};
inline RadialError cylinder_radial_error(const geometry::TriMesh& mesh, double radius_m, double half_band_m) {
  const SurfaceError e = cylinder_error(mesh, radius_m, half_band_m);  // scan/experiments.h, in mm
  return {e.rmse_mm * 1e-3, e.max_mm * 1e-3, e.mean_mm * 1e-3, e.count};
}

}  // namespace socketsmith::scan::test
