#pragma once
/// @file error_compensation.h
/// The per-sensor error model of the thesis (§4.2.3, eqs. 26–30): a point P back-projected from
/// pixel (u, v) at depth d is corrected to P̂ = (I − ε) P with ε = diag(e_x, e_y, e_z) and each
/// rate a linear regression on (u, v, d): e_k = c_k0 + c_k1 u + c_k2 v + c_k3 d (u, v in sensor
/// pixels, d in metres). Learned by calibrate_sensor (sensor_calibration.h); stored as JSON (docs/scan.md).

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace socketsmith::scan {

/// The form of a sensor's error model.
enum class CompensationForm {
  /// The thesis's (eqs. 26–30): P̂ = (I − ε) P, ε = diag(e_x, e_y, e_z), each rate linear in (u, v, d).
  LinearUvd,
  /// Ours ("ray-poly"): the depth corrected along the ray, d̂ = d − δ(x, y, d) with δ a polynomial
  /// in the undistorted ray coordinates (x, y) = (X/Z, Y/Z) and d — 1, x, y, x², x y, y², d, d², d³
  /// (d up to the model's depth_degree, 3 by default):
  /// a radial (vignetting-like) bias and a distance-dependent ("wiggling") one are quadratic in x, y
  /// and smooth in d, which rates linear in (u, v, d) cannot follow — and the ray's lateral scale by
  /// rates a_x, a_y linear in (1, x, y, d): P̂ = (x (1 − a_x) d̂, y (1 − a_y) d̂, d̂).
  RayPolynomial,
};

/// One sensor's learned error rates.
struct ErrorCompensation {
  CompensationForm form = CompensationForm::LinearUvd;
  std::string sensor;  ///< name of the sensor it was learned for (rig.json name)
  int width = 0;       ///< image size it was learned on [px]
  int height = 0;
  /// LinearUvd: rows e_x, e_y, e_z; columns: constant, per pixel of u, per pixel of v, per metre of d.
  Eigen::Matrix<double, 3, 4> coefficients = Eigen::Matrix<double, 3, 4>::Zero();
  /// RayPolynomial: the highest power of d in δ, 1 to kMaxDepthDegree. The ToF "wiggling" error is
  /// periodic in distance (≈ 0.5 m); over a board session's 0.4–1.2 m a cubic leaves a third of its
  /// amplitude, degree 7 a hundredth (docs/scan.md).
  int depth_degree = 3;
  static constexpr int kMaxDepthDegree = 9;
  /// RayPolynomial: δ's coefficients of 1, x, y, x², x y, y², d, d², …, d^depth_degree [m, d in m].
  Eigen::VectorXd depth_polynomial = Eigen::VectorXd::Zero(9);
  /// RayPolynomial: rows a_x, a_y; columns: 1, x, y, d.
  Eigen::Matrix<double, 2, 4> lateral = Eigen::Matrix<double, 2, 4>::Zero();

  /// RayPolynomial's depth features at ray (x, y) and depth d, powers of d up to @p degree.
  static Eigen::VectorXd depth_features(double x, double y, double d, int degree) {
    Eigen::VectorXd f(6 + degree);
    f.head<6>() << 1.0, x, y, x * x, x * y, y * y;
    double dk = 1.0;
    for (int k = 1; k <= degree; ++k) f(5 + k) = dk *= d;
    return f;
  }
  /// δ(x, y, d) = depth_polynomial · depth_features(x, y, d, depth_degree) [m].
  double depth_error(double x, double y, double d) const {
    const auto& c = depth_polynomial;
    double delta = c(0) + c(1) * x + c(2) * y + c(3) * x * x + c(4) * x * y + c(5) * y * y, dk = 1.0;
    for (int k = 1; k <= depth_degree; ++k) delta += c(5 + k) * (dk *= d);
    return delta;
  }
  // What it was learned from (informative).
  int frames = 0;
  int corners = 0;
  std::string truth;  ///< how the true corner positions were estimated ("pnp" or "kabsch")

  /// ε's diagonal at pixel (u, v) and depth d [m].
  Eigen::Vector3d rates(double u, double v, double d) const {
    return coefficients * Eigen::Vector4d(1.0, u, v, d);
  }
  /// The corrected point for a sensor-frame point P seen at pixel (u, v): (I − ε(u, v, P.z)) P, or
  /// RayPolynomial's correction.
  Eigen::Vector3d apply(const Eigen::Vector3d& p, double u, double v) const {
    if (form == CompensationForm::LinearUvd) return p.cwiseProduct(Eigen::Vector3d::Ones() - rates(u, v, p.z()));
    const double x = p.x() / p.z(), y = p.y() / p.z(), d = p.z();
    const double dc = d - depth_error(x, y, d);
    const Eigen::Vector2d a = lateral * Eigen::Vector4d(1.0, x, y, d);
    return {x * (1.0 - a.x()) * dc, y * (1.0 - a.y()) * dc, dc};
  }
};

/// Writes the models of one or more sensors, atomically:
/// {"format": "socketsmith-scan-compensation", "version": 1, "model": "linear-uvd",
///  "sensors": [{"name", "width", "height", "e_x": [c0, cu, cv, cd], "e_y": […], "e_z": […],
///  "frames", "corners", "truth"}]}; a RayPolynomial sensor has "model": "ray-poly",
///  "depth_degree": n, "depth_poly": [6 + n values], "lateral_x": [4], "lateral_y": [4] instead of
///  e_x, e_y, e_z (a file without "depth_degree" has n = 3).
void write_compensation_json(const std::filesystem::path& path, const std::vector<ErrorCompensation>& models);

/// Reads a file written by write_compensation_json.
/// @throws IoError when missing; InvalidInputError for malformed JSON, a wrong format tag, or
///         non-finite coefficients.
std::vector<ErrorCompensation> read_compensation_json(const std::filesystem::path& path);

/// The model of @p sensor in @p models, checked against its image size.
/// @throws InvalidInputError "… has no model for sensor 'K3' (…)" or "… was learned on 640x480
///         frames but sensor 'K1' has 512x424 …" naming @p source (the file).
const ErrorCompensation& compensation_for(const std::vector<ErrorCompensation>& models, const std::string& sensor,
                                          int width, int height, const std::string& source);

}  // namespace socketsmith::scan
