#pragma once
/// @file error_compensation.h
/// The per-sensor error model of the thesis (§4.2.3, eqs. 26–30): a point P back-projected from
/// pixel (u, v) at depth d is corrected to P̂ = (I − ε) P with ε = diag(e_x, e_y, e_z) and each
/// rate a linear regression on (u, v, d): e_k = c_k0 + c_k1 u + c_k2 v + c_k3 d (u, v in sensor
/// pixels, d in metres). Learned by calibrate_sensor (calibration.h); stored as JSON (docs/scan.md).

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace socketsmith::scan {

/// One sensor's learned error rates.
struct ErrorCompensation {
  std::string sensor;  ///< name of the sensor it was learned for (rig.json name)
  int width = 0;       ///< image size it was learned on [px]
  int height = 0;
  /// Rows e_x, e_y, e_z; columns: constant, per pixel of u, per pixel of v, per metre of d.
  Eigen::Matrix<double, 3, 4> coefficients = Eigen::Matrix<double, 3, 4>::Zero();
  // What it was learned from (informative).
  int frames = 0;
  int corners = 0;
  std::string truth;  ///< how the true corner positions were estimated ("pnp" or "kabsch")

  /// ε's diagonal at pixel (u, v) and depth d [m].
  Eigen::Vector3d rates(double u, double v, double d) const {
    return coefficients * Eigen::Vector4d(1.0, u, v, d);
  }
  /// P̂ = (I − ε(u, v, P.z)) P for a sensor-frame point P seen at pixel (u, v).
  Eigen::Vector3d apply(const Eigen::Vector3d& p, double u, double v) const {
    return p.cwiseProduct(Eigen::Vector3d::Ones() - rates(u, v, p.z()));
  }
};

/// Writes the models of one or more sensors, atomically:
/// {"format": "socketsmith-scan-compensation", "version": 1, "model": "linear-uvd",
///  "sensors": [{"name", "width", "height", "e_x": [c0, cu, cv, cd], "e_y": […], "e_z": […],
///  "frames", "corners", "truth"}]}.
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
