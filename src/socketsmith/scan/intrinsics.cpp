#include "socketsmith/scan/intrinsics.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <set>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/json_input.h"
#include "socketsmith/core/units.h"

namespace socketsmith::scan {
namespace fs = std::filesystem;

CameraIntrinsics kinect_v2_typical_intrinsics() {
  CameraIntrinsics k;
  k.k1 = 0.09;
  k.k2 = -0.27;
  k.k3 = 0.09;
  return k;
}

void validate_intrinsics(const CameraIntrinsics& k, const std::string& what) {
  require(k.width > 0 && k.height > 0 && k.width <= 16384 && k.height <= 16384,
          "{}: image size {}x{} px is not valid (expected positive, e.g. 512x424 for a Kinect v2)", what, k.width,
          k.height);
  for (double v : {k.fx, k.fy, k.cx, k.cy, k.k1, k.k2, k.p1, k.p2, k.k3, k.depth_shift_m})
    require(std::isfinite(v), "{}: intrinsics contain a non-finite value (check the calibration file)", what);
  require(k.fx > 0.0 && k.fy > 0.0, "{}: focal length fx={} fy={} px is not positive", what, k.fx, k.fy);
  require(k.cx >= 0.0 && k.cx <= k.width && k.cy >= 0.0 && k.cy <= k.height,
          "{}: principal point ({}, {}) px lies outside the {}x{} image (check cx, cy and the size)", what, k.cx,
          k.cy, k.width, k.height);
  require(std::abs(k.depth_shift_m) < 0.5, "{}: depth shift {} mm is implausible (expected a few tens of mm at most)",
          what, k.depth_shift_m / units::mm);
}

Eigen::Vector2d project_normalised(const CameraIntrinsics& k, const Eigen::Vector2d& xy) {
  const double x = xy.x(), y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k.k1 + r2 * (k.k2 + r2 * k.k3));
  const double xd = x * radial + 2.0 * k.p1 * x * y + k.p2 * (r2 + 2.0 * x * x);
  const double yd = y * radial + k.p1 * (r2 + 2.0 * y * y) + 2.0 * k.p2 * x * y;
  return {k.fx * xd + k.cx, k.fy * yd + k.cy};
}

namespace {

/// Pixel coordinates of the normalised point @p xy and their Jacobian d(u, v)/d(x, y) (analytic).
Eigen::Vector2d project_with_jacobian(const CameraIntrinsics& k, const Eigen::Vector2d& xy, Eigen::Matrix2d& J) {
  const double x = xy.x(), y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k.k1 + r2 * (k.k2 + r2 * k.k3));
  const double dradial = k.k1 + r2 * (2.0 * k.k2 + 3.0 * r2 * k.k3);  // d radial / d r²
  const double cross = 2.0 * x * y * dradial + 2.0 * k.p1 * x + 2.0 * k.p2 * y;
  J(0, 0) = k.fx * (radial + 2.0 * x * x * dradial + 2.0 * k.p1 * y + 6.0 * k.p2 * x);
  J(0, 1) = k.fx * cross;
  J(1, 0) = k.fy * cross;
  J(1, 1) = k.fy * (radial + 2.0 * y * y * dradial + 6.0 * k.p1 * y + 2.0 * k.p2 * x);
  const double xd = x * radial + 2.0 * k.p1 * x * y + k.p2 * (r2 + 2.0 * x * x);
  const double yd = y * radial + k.p1 * (r2 + 2.0 * y * y) + 2.0 * k.p2 * x * y;
  return {k.fx * xd + k.cx, k.fy * yd + k.cy};
}

// Newton refinement of the undistortion (OpenCV's fixed-point iteration converges slowly near
// the corners of a strongly distorted Kinect v2 lens).
Eigen::Vector2d refine(const CameraIntrinsics& k, Eigen::Vector2d xy, const Eigen::Vector2d& uv, int iterations = 8) {
  Eigen::Matrix2d J;
  for (int it = 0; it < iterations; ++it) {
    const Eigen::Vector2d r = project_with_jacobian(k, xy, J) - uv;
    if (r.norm() < 1e-9) break;
    const double det = J.determinant();
    if (!(std::abs(det) > 1e-12)) break;
    xy -= J.inverse() * r;
  }
  return xy;
}

// A calibrated polynomial is only a valid lens model where it is monotonic: beyond its maximal
// distorted radius (often the corners of a Kinect v2 image) a pixel has no inverse, or one on the
// folded-back branch (negative Jacobian). Such pixels get no ray.
bool is_valid_inverse(const CameraIntrinsics& k, const Eigen::Vector2d& xy, const Eigen::Vector2d& uv) {
  if (!xy.allFinite()) return false;
  Eigen::Matrix2d J;
  if ((project_with_jacobian(k, xy, J) - uv).norm() > 1e-4) return false;
  return J.determinant() > 0.0 && J(0, 0) > 0.0 && J(1, 1) > 0.0;
}

cv::Mat camera_matrix(const CameraIntrinsics& k) {
  return (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
}
cv::Mat dist_coeffs(const CameraIntrinsics& k) { return (cv::Mat_<double>(1, 5) << k.k1, k.k2, k.p1, k.p2, k.k3); }

}  // namespace

Eigen::Vector2d unproject_pixel(const CameraIntrinsics& k, const Eigen::Vector2d& uv) {
  const Eigen::Vector2d guess((uv.x() - k.cx) / k.fx, (uv.y() - k.cy) / k.fy);
  if (!k.has_distortion()) return guess;
  std::vector<cv::Point2d> src{{uv.x(), uv.y()}}, dst;
  cv::undistortPoints(src, dst, camera_matrix(k), dist_coeffs(k), cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 1e-10));
  const Eigen::Vector2d xy = refine(k, {dst[0].x, dst[0].y}, uv);
  return is_valid_inverse(k, xy, uv) ? xy : Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
}

RayTable make_ray_table(const CameraIntrinsics& k, int upsample) {
  validate_intrinsics(k, "make_ray_table");
  require(upsample >= 1 && upsample <= 8, "make_ray_table: upsample factor {} is out of range (expected 1 to 8)",
          upsample);
  RayTable t;
  t.width = k.width * upsample;
  t.height = k.height * upsample;
  t.upsample = upsample;
  const size_t n = static_cast<size_t>(t.width) * t.height;
  std::vector<cv::Point2d> src(n);
  for (int v = 0; v < t.height; ++v)
    for (int u = 0; u < t.width; ++u)
      src[static_cast<size_t>(v) * t.width + u] = {(u + 0.5) / upsample - 0.5, (v + 0.5) / upsample - 0.5};
  t.xy.resize(n);
  if (!k.has_distortion()) {
    for (size_t i = 0; i < n; ++i) t.xy[i] = {(src[i].x - k.cx) / k.fx, (src[i].y - k.cy) / k.fy};
    return t;
  }
  // Newton's method on each row, warm-started from the pixel to the left (neighbouring rays differ
  // by ~1/f): 2-3 steps a pixel instead of OpenCV's fixed-point iteration; OpenCV's answer only
  // where Newton does not converge (the folded-back corners of some calibrations).
  const cv::Mat K = camera_matrix(k), D = dist_coeffs(k);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < t.height; ++v) {
    Eigen::Vector2d prev = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
    for (int u = 0; u < t.width; ++u) {
      const size_t i = static_cast<size_t>(v) * t.width + u;
      const Eigen::Vector2d uv(src[i].x, src[i].y);
      Eigen::Vector2d xy = refine(k, prev.allFinite() ? prev : Eigen::Vector2d((uv.x() - k.cx) / k.fx, (uv.y() - k.cy) / k.fy), uv);
      if (!is_valid_inverse(k, xy, uv)) {
        std::vector<cv::Point2d> one{src[i]}, out;
        cv::undistortPoints(one, out, K, D, cv::noArray(), cv::noArray(),
                            cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 1e-10));
        xy = refine(k, {out[0].x, out[0].y}, uv);
      }
      const bool ok = is_valid_inverse(k, xy, uv);
      t.xy[i] = ok ? xy : Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
      prev = ok ? xy : Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
    }
  }
  return t;
}

namespace {

nlohmann::json read_json_file(const fs::path& path, const char* what) {
  std::ifstream in(path);
  if (!in) fail<IoError>("{}: cannot open '{}' (check the path in rig.json or the recording folder)", what, path.string());
  return parse_json_stream(in, path.string(), what);
}

double number(const nlohmann::json& j, const char* key, const fs::path& path, bool required, double fallback) {
  if (!j.contains(key)) {
    require(!required, "read_intrinsics_json: '{}' lacks the key '{}' (expected width, height, fx, fy, cx, cy)",
            path.string(), key);
    return fallback;
  }
  require(j.at(key).is_number(), "read_intrinsics_json: '{}': '{}' is not a number", path.string(), key);
  return j.at(key).get<double>();
}

}  // namespace

CameraIntrinsics read_intrinsics_json(const fs::path& path) {
  const nlohmann::json j = read_json_file(path, "read_intrinsics_json");
  require(j.is_object(), "read_intrinsics_json: '{}' is not a JSON object", path.string());
  static const std::set<std::string> known = {"width", "height", "fx", "fy", "cx", "cy", "k1", "k2",
                                              "p1",    "p2",     "k3", "depth_shift_mm", "comment"};
  for (const auto& [key, value] : j.items())
    require(known.count(key) > 0,
            "read_intrinsics_json: '{}' has an unknown key '{}' (expected width, height, fx, fy, cx, cy, k1, k2, p1, "
            "p2, k3, depth_shift_mm)",
            path.string(), key);
  CameraIntrinsics k;
  k.width = static_cast<int>(number(j, "width", path, true, 0));
  k.height = static_cast<int>(number(j, "height", path, true, 0));
  k.fx = number(j, "fx", path, true, 0);
  k.fy = number(j, "fy", path, true, 0);
  k.cx = number(j, "cx", path, true, 0);
  k.cy = number(j, "cy", path, true, 0);
  k.k1 = number(j, "k1", path, false, 0);
  k.k2 = number(j, "k2", path, false, 0);
  k.p1 = number(j, "p1", path, false, 0);
  k.p2 = number(j, "p2", path, false, 0);
  k.k3 = number(j, "k3", path, false, 0);
  k.depth_shift_m = number(j, "depth_shift_mm", path, false, 0) * units::mm;
  validate_intrinsics(k, "read_intrinsics_json: '" + path.string() + "'");
  return k;
}

void write_intrinsics_json(const fs::path& path, const CameraIntrinsics& k) {
  validate_intrinsics(k, "write_intrinsics_json");
  nlohmann::ordered_json j;
  j["width"] = k.width;
  j["height"] = k.height;
  j["fx"] = k.fx;
  j["fy"] = k.fy;
  j["cx"] = k.cx;
  j["cy"] = k.cy;
  j["k1"] = k.k1;
  j["k2"] = k.k2;
  j["p1"] = k.p1;
  j["p2"] = k.p2;
  j["k3"] = k.k3;
  j["depth_shift_mm"] = k.depth_shift_m / units::mm;
  write_text_atomically(path, j.dump(2) + "\n");
}

CameraIntrinsics read_kinect2_calibration(const fs::path& path) {
  const fs::path ir = fs::is_directory(path) ? path / "calib_ir.yaml" : path;
  if (!fs::exists(ir))
    fail<IoError>("read_kinect2_calibration: '{}' not found (expected an iai_kinect2 folder with calib_ir.yaml)",
                  ir.string());
  CameraIntrinsics k;
  try {
    cv::FileStorage fsr(ir.string(), cv::FileStorage::READ);
    if (!fsr.isOpened()) fail<IoError>("read_kinect2_calibration: cannot open '{}'", ir.string());
    cv::Mat K, D;
    fsr["cameraMatrix"] >> K;
    fsr["distortionCoefficients"] >> D;
    require(K.rows == 3 && K.cols == 3,
            "read_kinect2_calibration: '{}' has no 3x3 cameraMatrix (expected an iai_kinect2 calib_ir.yaml)",
            ir.string());
    K.convertTo(K, CV_64F);
    k.fx = K.at<double>(0, 0);
    k.fy = K.at<double>(1, 1);
    k.cx = K.at<double>(0, 2);
    k.cy = K.at<double>(1, 2);
    k.k1 = k.k2 = k.p1 = k.p2 = k.k3 = 0.0;
    if (!D.empty()) {
      D.convertTo(D, CV_64F);
      const int n = static_cast<int>(D.total());
      double* c[5] = {&k.k1, &k.k2, &k.p1, &k.p2, &k.k3};
      for (int i = 0; i < std::min(n, 5); ++i) *c[i] = D.at<double>(i);
    }
    const fs::path depth = ir.parent_path() / "calib_depth.yaml";
    if (fs::exists(depth)) {
      cv::FileStorage fsd(depth.string(), cv::FileStorage::READ);
      double shift_mm = 0.0;
      if (fsd.isOpened() && !fsd["depthShift"].empty()) fsd["depthShift"] >> shift_mm;
      k.depth_shift_m = shift_mm * units::mm;
    }
  } catch (const cv::Exception& e) {
    fail("read_kinect2_calibration: '{}' is not a valid OpenCV YAML calibration ({})", ir.string(), e.what());
  }
  k.width = 512;
  k.height = 424;
  validate_intrinsics(k, "read_kinect2_calibration: '" + ir.string() + "'");
  return k;
}

CameraIntrinsics read_open3d_intrinsics(const fs::path& path) {
  const nlohmann::json j = read_json_file(path, "read_open3d_intrinsics");
  require(j.is_object() && j.contains("intrinsic_matrix") && j["intrinsic_matrix"].is_array() &&
              j["intrinsic_matrix"].size() == 9 && j.contains("width") && j.contains("height"),
          "read_open3d_intrinsics: '{}' lacks width, height or a 9-number intrinsic_matrix", path.string());
  const auto& m = j["intrinsic_matrix"];  // column-major 3x3
  CameraIntrinsics k;
  k.width = j["width"].get<int>();
  k.height = j["height"].get<int>();
  k.fx = m[0].get<double>();
  k.fy = m[4].get<double>();
  k.cx = m[6].get<double>();
  k.cy = m[7].get<double>();
  k.k1 = k.k2 = k.p1 = k.p2 = k.k3 = 0.0;
  validate_intrinsics(k, "read_open3d_intrinsics: '" + path.string() + "'");
  return k;
}

CameraIntrinsics read_intrinsics(const fs::path& path) {
  if (fs::is_directory(path)) return read_kinect2_calibration(path);
  const std::string ext = path.extension().string();
  if (ext == ".yaml" || ext == ".yml") return read_kinect2_calibration(path);
  if (!fs::exists(path))
    fail<IoError>("read_intrinsics: intrinsics file '{}' is missing (write intrinsics.json beside the depth frames, "
                  "see docs/scan.md)",
                  path.string());
  const nlohmann::json j = read_json_file(path, "read_intrinsics");
  if (j.is_object() && j.contains("intrinsic_matrix")) return read_open3d_intrinsics(path);
  return read_intrinsics_json(path);
}

}  // namespace socketsmith::scan
