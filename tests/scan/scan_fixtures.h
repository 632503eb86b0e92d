#pragma once
/// @file scan_fixtures.h
/// Shared helpers of the scan tests: temporary folders, the shared data folder, cylinder errors.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "socketsmith/geometry/tri_mesh.h"
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
  RadialError e;
  double sum2 = 0.0, sum = 0.0;
  std::vector<Vec3> samples = mesh.vertices;
  for (const auto& t : mesh.triangles)
    samples.push_back((mesh.vertices[static_cast<size_t>(t[0])] + mesh.vertices[static_cast<size_t>(t[1])] +
                       mesh.vertices[static_cast<size_t>(t[2])]) / 3.0);
  for (const auto& v : samples) {
    if (std::abs(v.z()) > half_band_m) continue;
    const double d = std::hypot(v.x(), v.y()) - radius_m;
    sum2 += d * d;
    sum += d;
    e.max_m = std::max(e.max_m, std::abs(d));
    ++e.count;
  }
  if (e.count > 0) {
    e.rms_m = std::sqrt(sum2 / e.count);
    e.mean_m = sum / e.count;
  }
  return e;
}

}  // namespace socketsmith::scan::test
