#include "socketsmith/scan/chessboard.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "socketsmith/core/errors.h"

namespace socketsmith::scan {
namespace {

/// 8-bit view of an IR frame: linear, the 99th percentile of the non-zero amplitudes at 255.
cv::Mat to_8bit(const IrImage& ir) {
  std::vector<std::uint16_t> nonzero;
  nonzero.reserve(ir.value.size());
  for (std::uint16_t x : ir.value)
    if (x > 0) nonzero.push_back(x);
  double top = 1.0;
  if (!nonzero.empty()) {
    auto q = nonzero.begin() + static_cast<std::ptrdiff_t>(0.99 * (nonzero.size() - 1));
    std::nth_element(nonzero.begin(), q, nonzero.end());
    top = std::max<double>(1.0, *q);
  }
  cv::Mat m16(ir.height, ir.width, CV_16UC1, const_cast<std::uint16_t*>(ir.value.data()));
  cv::Mat m8;
  m16.convertTo(m8, CV_8U, 255.0 / top);
  return m8;
}

double sample(const cv::Mat& m, const cv::Point2f& p) {
  const int x = std::clamp(static_cast<int>(std::lround(p.x)), 0, m.cols - 1);
  const int y = std::clamp(static_cast<int>(std::lround(p.y)), 0, m.rows - 1);
  return m.at<std::uint8_t>(y, x);
}

}  // namespace

int ChessboardDetection::count_with_depth() const {
  return static_cast<int>(std::count_if(corners.begin(), corners.end(), [](const auto& c) { return c.has_depth(); }));
}

namespace {

void check_inputs(const IrImage& ir, const ChessboardPattern& p, int upsample) {
  validate_pattern(p, "find_chessboard_corners");
  require(upsample >= 1 && upsample <= 8, "find_chessboard_corners: upsample factor {} is out of range (expected 1 to 8)",
          upsample);
  require(ir.width > 0 && ir.height > 0 && ir.value.size() == static_cast<size_t>(ir.width) * ir.height,
          "find_chessboard_corners: the IR image is empty or inconsistent ({}x{}, {} values)", ir.width, ir.height,
          ir.value.size());
}

cv::Mat upsampled_8bit(const IrImage& ir, int upsample) {
  cv::Mat img = to_8bit(ir);
  if (upsample > 1) cv::resize(img, img, cv::Size(ir.width * upsample, ir.height * upsample), 0, 0, cv::INTER_LINEAR);
  return img;
}

/// Corners in the @p upsample-times up-sampled image @p img (grid order), or empty when not found.
std::vector<cv::Point2f> find_on(const cv::Mat& img, const ChessboardPattern& p, int upsample) {
  const int C = p.inner_cols, R = p.inner_rows;
  std::vector<cv::Point2f> pts;
  if (!cv::findChessboardCorners(img, cv::Size(C, R), pts, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK) ||
      static_cast<int>(pts.size()) != C * R)
    return {};
  // Refinement window: a third of the smallest corner spacing, 2 to 10 px of the up-sampled image.
  double spacing = 1e9;
  for (int j = 0; j < R; ++j)
    for (int i = 0; i < C; ++i) {
      const cv::Point2f& a = pts[static_cast<size_t>(j * C + i)];
      if (i + 1 < C) spacing = std::min<double>(spacing, cv::norm(pts[static_cast<size_t>(j * C + i + 1)] - a));
      if (j + 1 < R) spacing = std::min<double>(spacing, cv::norm(pts[static_cast<size_t>((j + 1) * C + i)] - a));
    }
  const int half = std::clamp(static_cast<int>(spacing / 3.0), 2, 10);
  // Refined on a lightly blurred copy (σ = half a sensor pixel): smoother gradients, less bias.
  cv::Mat smooth;
  cv::GaussianBlur(img, smooth, cv::Size(0, 0), 0.5 * upsample);
  cv::cornerSubPix(smooth, pts, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-3));
  auto at = [&](int i, int j) -> cv::Point2f& { return pts[static_cast<size_t>(j * C + i)]; };
  // Unmirror: the grid's i axis × j axis must point into the image (u right, v down).
  const cv::Point2f a = at(1, 0) - at(0, 0), b = at(0, 1) - at(0, 0);
  if (a.x * b.y - a.y * b.x < 0.0)
    for (int j = 0; j < R; ++j) std::reverse(pts.begin() + j * C, pts.begin() + (j + 1) * C);
  // Half turn: corner (0, 0) touches the black corner square (outside the grid, diagonally); the
  // square beside it (between corners (0, 0) and (1, 0), outside the grid) is white.
  const cv::Point2f out_i = 0.5f * (at(0, 0) - at(1, 0)), out_j = 0.5f * (at(0, 0) - at(0, 1));
  const cv::Point2f corner_square = at(0, 0) + out_i + out_j, side_square = at(0, 0) - out_i + out_j;
  if (sample(img, corner_square) > sample(img, side_square)) std::reverse(pts.begin(), pts.end());
  return pts;
}

std::vector<Eigen::Vector2d> to_sensor_pixels(const std::vector<cv::Point2f>& pts, int upsample) {
  std::vector<Eigen::Vector2d> out;
  out.reserve(pts.size());
  for (const cv::Point2f& q : pts) out.emplace_back((q.x + 0.5) / upsample - 0.5, (q.y + 0.5) / upsample - 0.5);
  return out;
}

}  // namespace

std::optional<std::vector<Eigen::Vector2d>> find_chessboard_corners(const IrImage& ir, const ChessboardPattern& p,
                                                                     int upsample) {
  check_inputs(ir, p, upsample);
  const std::vector<cv::Point2f> pts = find_on(upsampled_8bit(ir, upsample), p, upsample);
  if (pts.empty()) return std::nullopt;
  return to_sensor_pixels(pts, upsample);
}

std::vector<std::vector<Eigen::Vector2d>> find_all_chessboard_corners(const IrImage& ir, const ChessboardPattern& p,
                                                                      int upsample, int max_boards) {
  check_inputs(ir, p, upsample);
  require(max_boards >= 1, "find_all_chessboard_corners: max_boards {} must be at least 1", max_boards);
  cv::Mat img = upsampled_8bit(ir, upsample);
  std::vector<std::vector<Eigen::Vector2d>> boards;
  const int C = p.inner_cols, R = p.inner_rows;
  while (static_cast<int>(boards.size()) < max_boards) {
    const std::vector<cv::Point2f> pts = find_on(img, p, upsample);
    if (pts.empty()) break;
    boards.push_back(to_sensor_pixels(pts, upsample));
    // Mask the squares: the grid's outline pushed out by one square, filled with mid grey.
    auto at = [&](int i, int j) { return pts[static_cast<size_t>(j * C + i)]; };
    auto out = [&](int i, int j, int di, int dj) {
      return at(i, j) + 1.2f * (at(i, j) - at(i - di, j)) + 1.2f * (at(i, j) - at(i, j - dj));
    };
    std::vector<cv::Point> quad = {out(0, 0, -1, -1), out(C - 1, 0, 1, -1), out(C - 1, R - 1, 1, 1),
                                   out(0, R - 1, -1, 1)};
    cv::fillConvexPoly(img, quad, cv::Scalar(128));
  }
  return boards;
}

double bilinear_depth(const DepthImage& depth, double depth_shift_m, const Eigen::Vector2d& uv, double max_jump_m) {
  const int u0 = static_cast<int>(std::floor(uv.x())), v0 = static_cast<int>(std::floor(uv.y()));
  if (u0 < 0 || v0 < 0 || u0 + 1 >= depth.width || v0 + 1 >= depth.height) return 0.0;
  const std::uint16_t r[4] = {depth.at(u0, v0), depth.at(u0 + 1, v0), depth.at(u0, v0 + 1), depth.at(u0 + 1, v0 + 1)};
  if (std::any_of(r, r + 4, [](std::uint16_t x) { return x == 0; })) return 0.0;
  const auto [lo, hi] = std::minmax({r[0], r[1], r[2], r[3]});
  if ((hi - lo) * depth.scale_m > max_jump_m) return 0.0;
  const double fu = uv.x() - u0, fv = uv.y() - v0;
  const double raw = (1 - fv) * ((1 - fu) * r[0] + fu * r[1]) + fv * ((1 - fu) * r[2] + fu * r[3]);
  return raw * depth.scale_m + depth_shift_m;
}

double local_plane_depth(const DepthImage& depth, double depth_shift_m, const Eigen::Vector2d& uv, double radius_px,
                         double max_jump_m) {
  const int r = static_cast<int>(std::ceil(radius_px));
  const int u_lo = static_cast<int>(std::floor(uv.x())) - r, v_lo = static_cast<int>(std::floor(uv.y())) - r;
  struct Px {
    double du, dv, d;
  };
  std::vector<Px> px;
  int window = 0;
  for (int v = v_lo; v <= v_lo + 2 * r + 1; ++v)
    for (int u = u_lo; u <= u_lo + 2 * r + 1; ++u) {
      const double du = u - uv.x(), dv = v - uv.y();
      if (du * du + dv * dv > radius_px * radius_px) continue;
      ++window;
      if (u < 0 || v < 0 || u >= depth.width || v >= depth.height || depth.at(u, v) == 0) continue;
      px.push_back({du, dv, depth.at(u, v) * depth.scale_m + depth_shift_m});
    }
  const size_t min_pixels = std::max<size_t>(12, static_cast<size_t>(window / 2));
  if (px.size() < min_pixels) return 0.0;
  // Pixels far from the window's median depth (flying pixels, another surface) are not the board.
  std::vector<double> ds;
  for (const Px& p : px) ds.push_back(p.d);
  std::nth_element(ds.begin(), ds.begin() + static_cast<std::ptrdiff_t>(ds.size() / 2), ds.end());
  const double median = ds[ds.size() / 2];
  std::vector<char> keep(px.size());
  for (size_t q = 0; q < px.size(); ++q) keep[q] = std::abs(px[q].d - median) <= max_jump_m ? 1 : 0;
  // 1/d = a + b du + c dv (a plane seen through a pinhole), refitted without residuals beyond 3.5 σ.
  Eigen::Vector3d abc = Eigen::Vector3d::Zero();
  for (int pass = 0; pass < 3; ++pass) {
    Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
    Eigen::Vector3d Atb = Eigen::Vector3d::Zero();
    size_t n = 0;
    for (size_t q = 0; q < px.size(); ++q) {
      if (!keep[q]) continue;
      const Eigen::Vector3d row(1.0, px[q].du, px[q].dv);
      AtA += row * row.transpose();
      Atb += row / px[q].d;
      ++n;
    }
    if (n < min_pixels) return 0.0;
    abc = AtA.ldlt().solve(Atb);
    if (!(abc.x() > 0.0)) return 0.0;
    // Residuals in depth: d − 1/(a + b du + c dv); σ from their median absolute value.
    std::vector<double> res(px.size()), kept;
    for (size_t q = 0; q < px.size(); ++q) {
      res[q] = px[q].d - 1.0 / (abc.x() + abc.y() * px[q].du + abc.z() * px[q].dv);
      if (keep[q]) kept.push_back(std::abs(res[q]));
    }
    std::nth_element(kept.begin(), kept.begin() + static_cast<std::ptrdiff_t>(kept.size() / 2), kept.end());
    const double sigma = std::max(1.4826 * kept[kept.size() / 2], 0.5 * depth.scale_m);
    for (size_t q = 0; q < px.size(); ++q) keep[q] = std::abs(res[q]) <= 3.5 * sigma ? 1 : 0;
  }
  return 1.0 / abc.x();
}

ChessboardDetection corners_to_3d(const std::vector<Eigen::Vector2d>& uv, const DepthImage& depth,
                                  const CameraIntrinsics& k, const ChessboardPattern& pattern,
                                  const ChessboardOptions& o) {
  validate_pattern(pattern, "corners_to_3d");
  require(uv.size() == static_cast<size_t>(pattern.inner_cols * pattern.inner_rows),
          "corners_to_3d: {} corners for a {}x{} pattern", uv.size(), pattern.inner_cols, pattern.inner_rows);
  require(o.max_depth_jump_m > 0.0, "corners_to_3d: max_depth_jump_m {} must be positive", o.max_depth_jump_m);
  require(o.plane_radius_px >= 2.0 && o.plane_radius_px <= 30.0,
          "corners_to_3d: plane_radius_px {} is out of range (expected 2 to 30 pixels)", o.plane_radius_px);
  ChessboardDetection det;
  det.pattern = pattern;
  for (int j = 0; j < pattern.inner_rows; ++j)
    for (int i = 0; i < pattern.inner_cols; ++i) {
      ChessboardCorner c;
      c.i = i;
      c.j = j;
      c.uv = uv[static_cast<size_t>(j * pattern.inner_cols + i)];
      c.depth_m = o.corner_depth == CornerDepth::LocalPlane
                      ? local_plane_depth(depth, k.depth_shift_m, c.uv, o.plane_radius_px, o.max_depth_jump_m)
                      : bilinear_depth(depth, k.depth_shift_m, c.uv, o.max_depth_jump_m);
      if (c.has_depth()) {
        const Eigen::Vector2d xy = unproject_pixel(k, c.uv);
        if (std::isfinite(xy.x())) c.point = Eigen::Vector3d(xy.x() * c.depth_m, xy.y() * c.depth_m, c.depth_m);
        else c.depth_m = 0.0;
      }
      det.corners.push_back(c);
    }
  return det;
}

ChessboardDetection detect_chessboard(const IrImage& ir, const DepthImage& depth, const CameraIntrinsics& k,
                                      const ChessboardPattern& pattern, const ChessboardOptions& o,
                                      const std::string& what) {
  validate_intrinsics(k, "detect_chessboard");
  require(ir.width == depth.width && ir.height == depth.height && depth.width == k.width && depth.height == k.height,
          "detect_chessboard: {}: IR {}x{}, depth {}x{} and intrinsics {}x{} differ (IR must be pixel-aligned with "
          "depth)",
          what, ir.width, ir.height, depth.width, depth.height, k.width, k.height);
  const auto uv = find_chessboard_corners(ir, pattern, o.upsample);
  if (!uv)
    fail("chessboard not found in {} (expected {}x{} inner corners: check --pattern, that the whole board and its white "
         "margin are in view, and the exposure)",
         what, pattern.inner_cols, pattern.inner_rows);
  return corners_to_3d(*uv, depth, k, pattern, o);
}

}  // namespace socketsmith::scan
