#include "socketsmith/scan/sensor_calibration.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/Dense>
#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "socketsmith/core/errors.h"

namespace socketsmith::scan {
namespace {

using Vec3 = Eigen::Vector3d;

/// Inner corner (i, j) of the ideal board in its own frame (z = 0), origin at corner (0, 0).
Vec3 ideal_corner(const ChessboardPattern& p, int i, int j) { return {i * p.square_m, j * p.square_m, 0.0}; }

/// Thesis eqs. 31–35: the ideal grid rigidly fitted (SVD) to the measured corners about the
/// "focal centre" C, the board point on the optical axis: C is where the principal point's ray
/// meets the plane of an affine fit P ≈ O + i A + j B of the measured corners, (i_c, j_c) its grid
/// coordinates (eq. 31), and truth = C + R (G − G(i_c, j_c)) (eqs. 33–35). Anchoring at the axis
/// keeps lateral errors proportional to X and Y, as eq. 29's rates assume.
std::vector<Vec3> kabsch_truth(const ChessboardDetection& det) {
  std::vector<const ChessboardCorner*> valid;
  for (const ChessboardCorner& c : det.corners)
    if (c.has_depth()) valid.push_back(&c);
  Eigen::MatrixXd M(static_cast<long>(valid.size()), 3), P(static_cast<long>(valid.size()), 3);
  for (size_t q = 0; q < valid.size(); ++q) {
    M.row(static_cast<long>(q)) << 1.0, valid[q]->i, valid[q]->j;
    P.row(static_cast<long>(q)) = valid[q]->point.transpose();
  }
  const Eigen::Matrix3d X = M.colPivHouseholderQr().solve(P);  // rows: O, A, B
  const Vec3 O = X.row(0).transpose(), A = X.row(1).transpose(), B = X.row(2).transpose();
  const Vec3 n = A.cross(B).normalized();
  const Vec3 C(0.0, 0.0, n.dot(O) / n.z());
  Eigen::Matrix<double, 3, 2> AB;
  AB << A, B;
  const Eigen::Vector2d ij = AB.colPivHouseholderQr().solve(C - O);
  const Vec3 Gc(ij.x() * det.pattern.square_m, ij.y() * det.pattern.square_m, 0.0);
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (const ChessboardCorner* c : valid) H += (ideal_corner(det.pattern, c->i, c->j) - Gc) * (c->point - C).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
  const Eigen::Matrix3d R = svd.matrixV() * D * svd.matrixU().transpose();
  std::vector<Vec3> truth;
  for (const ChessboardCorner& c : det.corners) truth.push_back(C + R * (ideal_corner(det.pattern, c.i, c.j) - Gc));
  return truth;
}

cv::Mat camera_matrix(double fx, double fy, const CameraIntrinsics& k) {
  return (cv::Mat_<double>(3, 3) << fx, 0, k.cx, 0, fy, k.cy, 0, 0, 1);
}

cv::Mat distortion(const CameraIntrinsics& k) { return (cv::Mat_<double>(1, 5) << k.k1, k.k2, k.p1, k.p2, k.k3); }

std::vector<cv::Point3f> object_points(const ChessboardPattern& p) {
  std::vector<cv::Point3f> obj;
  for (int j = 0; j < p.inner_rows; ++j)
    for (int i = 0; i < p.inner_cols; ++i) {
      const Vec3 g = ideal_corner(p, i, j);
      obj.emplace_back(static_cast<float>(g.x()), static_cast<float>(g.y()), 0.0f);
    }
  return obj;
}

std::vector<cv::Point2f> image_points(const ChessboardDetection& det) {
  std::vector<cv::Point2f> img;
  for (const ChessboardCorner& c : det.corners)
    img.emplace_back(static_cast<float>(c.uv.x()), static_cast<float>(c.uv.y()));
  return img;
}

std::vector<Vec3> posed_grid(const ChessboardPattern& p, const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat Rcv;
  cv::Rodrigues(rvec, Rcv);
  Eigen::Matrix3d R;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) R(a, b) = Rcv.at<double>(a, b);
  const Vec3 t(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  std::vector<Vec3> out;
  for (int j = 0; j < p.inner_rows; ++j)
    for (int i = 0; i < p.inner_cols; ++i) out.push_back(R * ideal_corner(p, i, j) + t);
  return out;
}

double rms_distance(const std::vector<BoardObservation>& obs, const ErrorCompensation* model) {
  double sum = 0.0;
  int n = 0;
  for (const BoardObservation& o : obs) {
    const std::vector<Vec3> pts = compensated_corners(o.detection, model);
    for (size_t c = 0; c < pts.size(); ++c)
      if (o.detection.corners[c].has_depth()) {
        sum += (pts[c] - o.truth[c]).squaredNorm();
        ++n;
      }
  }
  return n > 0 ? std::sqrt(sum / n) * 1e3 : 0.0;
}

/// Least squares A x ≈ b with the columns scaled to unit norm (u, v are hundreds of pixels, d ≈ 1 m).
Eigen::VectorXd solve_scaled(const Eigen::MatrixXd& A, const Eigen::VectorXd& b) {
  const Eigen::VectorXd scale = A.colwise().norm().transpose().cwiseMax(1e-12);
  const Eigen::VectorXd x = (A * scale.cwiseInverse().asDiagonal()).colPivHouseholderQr().solve(b);
  return x.cwiseQuotient(scale);
}

/// Least squares of r_k = (c_k · [1, u, v, d]) P_k per axis over the samples kept by @p keep.
Eigen::Matrix<double, 3, 4> fit_rates(const std::vector<Eigen::Vector4d>& features, const std::vector<Vec3>& measured,
                                      const std::vector<Vec3>& truth, const std::vector<char>& keep) {
  Eigen::Matrix<double, 3, 4> c;
  const long n = std::count(keep.begin(), keep.end(), 1);
  for (int k = 0; k < 3; ++k) {
    Eigen::MatrixXd A(n, 4);
    Eigen::VectorXd b(n);
    long row = 0;
    for (size_t s = 0; s < features.size(); ++s) {
      if (!keep[s]) continue;
      A.row(row) = features[s].transpose() * measured[s][k];
      b(row) = measured[s][k] - truth[s][k];
      ++row;
    }
    c.row(k) = solve_scaled(A, b).transpose();
  }
  return c;
}

/// CompensationForm::RayPolynomial by least squares over the samples kept by @p keep: the depth
/// error d − T_z on δ's features, and each ray coordinate's error x − T_x / T_z = a_x x on
/// (1, x, y, d)·x (the depth correction moves a point along its ray, so the two are separate).
void fit_ray_polynomial(const std::vector<Vec3>& measured, const std::vector<Vec3>& truth, const std::vector<char>& keep,
                        int depth_degree, ErrorCompensation& m) {
  const long n = std::count(keep.begin(), keep.end(), 1);
  Eigen::MatrixXd A(n, 6 + depth_degree), Lx(n, 4), Ly(n, 4);
  Eigen::VectorXd b(n), bx(n), by(n);
  long row = 0;
  for (size_t s = 0; s < measured.size(); ++s) {
    if (!keep[s]) continue;
    const Vec3& p = measured[s];
    const Vec3& t = truth[s];
    const double x = p.x() / p.z(), y = p.y() / p.z(), d = p.z();
    A.row(row) = ErrorCompensation::depth_features(x, y, d, depth_degree).transpose();
    b(row) = d - t.z();
    const Eigen::Vector4d g(1.0, x, y, d);
    Lx.row(row) = g.transpose() * x;
    bx(row) = x - t.x() / t.z();
    Ly.row(row) = g.transpose() * y;
    by(row) = y - t.y() / t.z();
    ++row;
  }
  m.form = CompensationForm::RayPolynomial;
  m.depth_degree = depth_degree;
  m.depth_polynomial = solve_scaled(A, b);
  m.lateral.row(0) = solve_scaled(Lx, bx).transpose();
  m.lateral.row(1) = solve_scaled(Ly, by).transpose();
}


void check_calibration_inputs(const SensorRecording& sensor, const ChessboardPattern& pattern,
                              const SensorCalibrationOptions& o) {
  validate_pattern(pattern, "calibrate_sensor");
  require(o.min_frames >= 1, "calibrate_sensor: min_frames {} must be at least 1", o.min_frames);
  require(o.depth_degree >= 1 && o.depth_degree <= ErrorCompensation::kMaxDepthDegree,
          "calibrate_sensor: depth degree {} (expected 1 to {})", o.depth_degree, ErrorCompensation::kMaxDepthDegree);
  require(!sensor.ir_frames.empty(),
          "calibrate_sensor: sensor '{}' has no IR frames (expected {}/ir_0000.png ... beside the depth frames: the "
          "chessboard is found in the IR image)",
          sensor.name, sensor.name);
  require(sensor.ir_frames.size() == sensor.frames.size(), "calibrate_sensor: sensor '{}' has {} IR and {} depth frames",
          sensor.name, sensor.ir_frames.size(), sensor.frames.size());
  const int per_pose = o.frames_per_pose;
  require(per_pose >= 1, "calibrate_sensor: {} frames per board pose (expected at least 1)", per_pose);
  require(sensor.frames.size() % static_cast<size_t>(per_pose) == 0,
          "calibrate_sensor: sensor '{}' has {} frames, not a whole number of board poses of {} frames each (check "
          "frames_per_pose in rig.json or --frames-per-pose)",
          sensor.name, sensor.frames.size(), per_pose);
}

/// The name of the board pose starting at frame @p f in the messages: "<sensor>/ir_<n>.png", or the
/// first and last frame's names when a pose has several frames.
std::string board_pose_name(const SensorRecording& sensor, int f, int per_pose) {
  const auto name_of = [&](int q) {
    return fmt::format("{}/{}", sensor.name,
                       q < static_cast<int>(sensor.frame_files.size())
                           ? "ir_" + sensor.frame_files[static_cast<size_t>(q)].substr(6)
                           : fmt::format("ir_{:04d}.png", q));
  };
  return per_pose == 1 ? name_of(f) : name_of(f) + " to " + name_of(f + per_pose - 1);
}

/// Finds the board in each pose's mean IR image and fused depth (progress 0 to 0.8): the poses with
/// at least 6 corners with depth go to r.observations, the others to r.skipped with the reason.
/// Returns the number of poses.
int observe_board_poses(const SensorRecording& sensor, const ChessboardPattern& pattern,
                        const SensorCalibrationOptions& o, const ProgressCallback& progress, SensorCalibrationResult& r) {
  const int per_pose = o.frames_per_pose;
  const int n = static_cast<int>(sensor.frames.size()) / per_pose;
  for (int pose = 0; pose < n; ++pose) {
    const int f = pose * per_pose;
    const std::string file = board_pose_name(sensor, f, per_pose);
    try {
      BoardObservation ob;
      ob.frame = f;
      const auto first = static_cast<std::ptrdiff_t>(f), last = first + per_pose;
      const IrImage ir = mean_of_ir_frames({sensor.ir_frames.begin() + first, sensor.ir_frames.begin() + last});
      const DepthImage depth = fuse_frames({sensor.frames.begin() + first, sensor.frames.begin() + last}, o.fusion);
      ob.detection = detect_chessboard(ir, depth, sensor.intrinsics, pattern, o.chessboard, file);
      if (ob.detection.count_with_depth() < 6) {
        r.skipped.push_back(fmt::format("{}: only {} corners have depth", file, ob.detection.count_with_depth()));
      } else {
        r.observations.push_back(std::move(ob));
      }
    } catch (const InvalidInputError& e) {
      r.skipped.push_back(e.what());
    }
    if (!report_progress(progress, 0.8 * (pose + 1) / n, "finding chessboard corners")) break;
  }
  return n;
}

/// TruthEstimate::Pnp: OpenCV's camera calibration over all board poses (focal lengths refined,
/// the distortion too if asked); each observation's truth is the ideal grid at its pose.
void pnp_truth(const SensorRecording& sensor, const ChessboardPattern& pattern, const SensorCalibrationOptions& o,
               SensorCalibrationResult& r) {
  const CameraIntrinsics& k = sensor.intrinsics;
  std::vector<std::vector<cv::Point3f>> obj(r.observations.size(), object_points(pattern));
  std::vector<std::vector<cv::Point2f>> img;
  for (const BoardObservation& ob : r.observations) img.push_back(image_points(ob.detection));
  cv::Mat K = camera_matrix(k.fx, k.fy, k), dist = distortion(k);
  std::vector<cv::Mat> rvecs, tvecs;
  const int flags = cv::CALIB_USE_INTRINSIC_GUESS | cv::CALIB_FIX_PRINCIPAL_POINT | cv::CALIB_FIX_TANGENT_DIST |
                    (o.refine_distortion ? 0 : cv::CALIB_FIX_K1 | cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3);
  cv::calibrateCamera(obj, img, cv::Size(k.width, k.height), K, dist, rvecs, tvecs, flags);
  r.fx = K.at<double>(0, 0);
  r.fy = K.at<double>(1, 1);
  require(std::abs(r.fx / k.fx - 1.0) < 0.2 && std::abs(r.fy / k.fy - 1.0) < 0.2,
          "calibrate_sensor: sensor '{}': the board frames give focal lengths {:.1f}, {:.1f} px, far from the "
          "intrinsics' {:.1f}, {:.1f} (wrong intrinsics or --square-mm?)",
          sensor.name, r.fx, r.fy, k.fx, k.fy);
  for (size_t q = 0; q < r.observations.size(); ++q) r.observations[q].truth = posed_grid(pattern, rvecs[q], tvecs[q]);
}

/// The fit's samples: every corner with depth, its features [1, u, v, d], measured and true point.
struct CornerSamples {
  std::vector<Eigen::Vector4d> features;
  std::vector<Vec3> measured, truth;
};

CornerSamples corner_samples(const std::vector<BoardObservation>& observations, const std::string& sensor_name) {
  CornerSamples cs;
  for (const BoardObservation& ob : observations)
    for (size_t c = 0; c < ob.detection.corners.size(); ++c) {
      const ChessboardCorner& cc = ob.detection.corners[c];
      if (!cc.has_depth()) continue;
      cs.features.emplace_back(1.0, cc.uv.x(), cc.uv.y(), cc.point.z());
      cs.measured.push_back(cc.point);
      cs.truth.push_back(ob.truth[c]);
    }
  require(cs.features.size() >= 20, "calibrate_sensor: sensor '{}': only {} corners with depth (expected at least 20)",
          sensor_name, cs.features.size());
  return cs;
}

/// Fits the error model of form o.form to the samples, then refits without gross outliers
/// (residual norm beyond median + 5 MAD) if at least 20 remain; @p keep says which were used.
ErrorCompensation fit_without_outliers(const CornerSamples& cs, const SensorCalibrationOptions& o, std::vector<char>& keep) {
  const std::vector<Eigen::Vector4d>& features = cs.features;
  const std::vector<Vec3>& measured = cs.measured;
  const std::vector<Vec3>& truth = cs.truth;
  auto fit = [&](const std::vector<char>& used) {
    ErrorCompensation m;
    if (o.form == CompensationForm::RayPolynomial) fit_ray_polynomial(measured, truth, used, o.depth_degree, m);
    else m.coefficients = fit_rates(features, measured, truth, used);
    return m;
  };
  keep.assign(features.size(), 1);
  ErrorCompensation model = fit(keep);
  std::vector<double> res(features.size());
  for (size_t s = 0; s < features.size(); ++s)
    res[s] = (model.apply(measured[s], features[s](1), features[s](2)) - truth[s]).norm();
  std::vector<double> sorted = res;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
  const double med = sorted[sorted.size() / 2];
  for (double& x : sorted) x = std::abs(x - med);
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
  const double mad = sorted[sorted.size() / 2];
  for (size_t s = 0; s < res.size(); ++s) keep[s] = res[s] <= med + 5.0 * 1.4826 * mad + 1e-9 ? 1 : 0;
  if (std::count(keep.begin(), keep.end(), 1) >= 20) model = fit(keep);
  return model;
}

}  // namespace

std::vector<Vec3> compensated_corners(const ChessboardDetection& det, const ErrorCompensation* model) {
  std::vector<Vec3> out;
  for (const ChessboardCorner& c : det.corners)
    out.push_back(model != nullptr && c.has_depth() ? model->apply(c.point, c.uv.x(), c.uv.y()) : c.point);
  return out;
}

void EdgeErrors::add(const ChessboardDetection& det, const std::vector<Vec3>& pts) {
  require(pts.size() == det.corners.size(), "EdgeErrors: {} points for {} corners", pts.size(), det.corners.size());
  const int C = det.pattern.inner_cols, R = det.pattern.inner_rows;
  auto idx = [&](int i, int j) { return static_cast<size_t>(j * C + i); };
  auto edge = [&](int i0, int j0, int i1, int j1, bool on_border) {
    if (!det.corners[idx(i0, j0)].has_depth() || !det.corners[idx(i1, j1)].has_depth()) return;
    const double e = std::abs((pts[idx(i1, j1)] - pts[idx(i0, j0)]).norm() - det.pattern.square_m) * 1e3;
    all.push_back(e);
    if (on_border) border.push_back(e);
  };
  for (int j = 0; j < R; ++j)
    for (int i = 0; i < C; ++i) {
      if (i + 1 < C) edge(i, j, i + 1, j, j == 0 || j == R - 1);
      if (j + 1 < R) edge(i, j, i, j + 1, i == 0 || i == C - 1);
    }
}

DimensionStats EdgeErrors::stats() const {
  DimensionStats s;
  s.count = static_cast<int>(all.size());
  if (all.empty()) return s;
  for (double e : all) s.mean_mm += e;
  s.mean_mm /= static_cast<double>(all.size());
  for (double e : all) s.sd_mm += (e - s.mean_mm) * (e - s.mean_mm);
  s.sd_mm = all.size() > 1 ? std::sqrt(s.sd_mm / static_cast<double>(all.size() - 1)) : 0.0;
  for (double e : border) s.border_mean_mm += e;
  if (!border.empty()) s.border_mean_mm /= static_cast<double>(border.size());
  return s;
}

TrainingDimensionErrors training_dimension_errors(const SensorCalibrationResult& r) {
  EdgeErrors before, after;
  for (const auto& ob : r.observations) {
    before.add(ob.detection, compensated_corners(ob.detection, nullptr));
    after.add(ob.detection, compensated_corners(ob.detection, &r.model));
  }
  return {before.stats(), after.stats()};
}

SensorCalibrationResult calibrate_sensor(const SensorRecording& sensor, const ChessboardPattern& pattern,
                                         const SensorCalibrationOptions& o, const ProgressCallback& progress) {
  check_calibration_inputs(sensor, pattern, o);
  const int per_pose = o.frames_per_pose;
  SensorCalibrationResult r;
  const int n = observe_board_poses(sensor, pattern, o, progress, r);
  require(static_cast<int>(r.observations.size()) >= o.min_frames,
          "calibrate_sensor: sensor '{}': the board was found in {} of {} {} (expected at least {}; the thesis used "
          "about 50 frames at 50-100 cm){}",
          sensor.name, r.observations.size(), n, per_pose == 1 ? "frames" : "board poses", o.min_frames,
          r.skipped.empty() ? std::string() : "; first problem: " + r.skipped.front());
  const CameraIntrinsics& k = sensor.intrinsics;
  r.fx = k.fx;
  r.fy = k.fy;
  if (o.truth == TruthEstimate::Pnp) {
    pnp_truth(sensor, pattern, o, r);
  } else {
    for (BoardObservation& ob : r.observations) ob.truth = kabsch_truth(ob.detection);
  }
  const CornerSamples samples = corner_samples(r.observations, sensor.name);
  std::vector<char> keep;
  r.model = fit_without_outliers(samples, o, keep);
  r.model.sensor = sensor.name;
  r.model.width = k.width;
  r.model.height = k.height;
  r.model.frames = static_cast<int>(r.observations.size());
  r.model.corners = static_cast<int>(std::count(keep.begin(), keep.end(), 1));
  r.model.truth = o.truth == TruthEstimate::Pnp ? "pnp" : "kabsch";
  r.rms_before_mm = rms_distance(r.observations, nullptr);
  r.rms_after_mm = rms_distance(r.observations, &r.model);
  report_progress(progress, 1.0, "error model fitted");
  return r;
}

}  // namespace socketsmith::scan
