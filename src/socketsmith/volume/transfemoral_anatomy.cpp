#include "socketsmith/volume/transfemoral_anatomy.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"

namespace socketsmith::volume {
namespace {

using geometry::TriMesh;

/// Area-weighted mean and principal direction (largest spread) of a surface's triangles.
std::pair<Vec3, Vec3> principal_direction(const TriMesh& m) {
  const std::optional<Vec3> centroid = geometry::area_centroid(m);
  require(centroid.has_value(), "femur_shaft_axis: the femur has no area (expected a closed bone surface)");
  const Vec3 mean = *centroid;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int t = 0; t < m.num_triangles(); ++t) {
    const auto& tri = m.triangles[t];
    const Vec3 c = (m.vertices[tri[0]] + m.vertices[tri[1]] + m.vertices[tri[2]]) / 3.0 - mean;
    cov += geometry::triangle_area(m, t) * c * c.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  return {mean, eig.eigenvectors().col(2).normalized()};
}

Vec3 perpendicular(const Vec3& v, const Vec3& axis) { return v - v.dot(axis) * axis; }

}  // namespace

FemurAxis femur_shaft_axis(const TriMesh& femur, const Vec3& proximal_hint) {
  require(femur.num_triangles() >= 8, "femur_shaft_axis: the femur has {} triangles (expected a closed bone surface)",
          femur.num_triangles());
  auto [point, dir] = principal_direction(femur);
  if ((proximal_hint - point).dot(dir) < 0.0) dir = -dir;
  for (int round = 0; round < 2; ++round) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const auto& v : femur.vertices) {
      const double h = (v - point).dot(dir);
      lo = std::min(lo, h);
      hi = std::max(hi, h);
    }
    double width = 0.0;
    for (const auto& v : femur.vertices) width = std::max(width, perpendicular(v - point, dir).norm());
    require(hi - lo >= 1.5 * width,
            "femur_shaft_axis: the femur is {:.0f} mm long and reaches {:.0f} mm from its own axis: not an elongated "
            "bone (is the shell named femur the femur?)",
            (hi - lo) * 1e3, width * 1e3);
    std::vector<Vec3> centroids;
    for (int k = 0; k <= 10; ++k) {
      const double h = lo + (0.15 + 0.05 * k) * (hi - lo);
      const geometry::Slice s = geometry::slice_surface(femur, point + h * dir, dir);
      if (s.area != 0.0) centroids.push_back(s.centroid);
    }
    require(centroids.size() >= 3,
            "femur_shaft_axis: only {} sections of the femur could be taken (expected a closed bone surface)",
            centroids.size());
    Vec3 mean = Vec3::Zero();
    for (const auto& c : centroids) mean += c;
    mean /= static_cast<double>(centroids.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& c : centroids) cov += (c - mean) * (c - mean).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    Vec3 d = eig.eigenvectors().col(2).normalized();
    if (d.dot(dir) < 0.0) d = -d;
    point = mean;
    dir = d;
  }
  FemurAxis a;
  a.point = point;
  a.direction = dir;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& v : femur.vertices) {
    const double h = (v - point).dot(dir);
    if (h < lo) {
      lo = h;
      a.distal_end = v;
    }
    if (h > hi) {
      hi = h;
      a.proximal_end = v;
    }
  }
  a.length_m = hi - lo;
  return a;
}

PelvisPoints pelvis_points(const TriMesh& pelvis, const FemurAxis& femur) {
  require(!pelvis.vertices.empty(), "pelvis_points: the hemipelvis has no vertex");
  const Vec3& d = femur.direction;
  PelvisPoints p;
  double low = std::numeric_limits<double>::infinity();
  for (const auto& v : pelvis.vertices)
    if (v.dot(d) < low) {
      low = v.dot(d);
      p.ischial_tuberosity = v;
    }
  double far = -1.0;
  for (const auto& v : pelvis.vertices) {
    if (v.dot(d) > low + 0.06) continue;
    const double r = perpendicular(v - femur.point, d).norm();
    if (r > far) {
      far = r;
      p.symphysis = v;
    }
  }
  require((p.symphysis - p.ischial_tuberosity).norm() > 0.01,
          "pelvis_points: the hemipelvis has nothing within 60 mm above its lowest point but that point (expected an "
          "ischium and a pubic ramus)");
  // The ramus: the bone vertex nearest to a third of the way from the tuberosity to the symphysis.
  const Vec3 target = p.ischial_tuberosity + (p.symphysis - p.ischial_tuberosity) / 3.0;
  double best = std::numeric_limits<double>::infinity();
  for (const auto& v : pelvis.vertices)
    if ((v - target).squaredNorm() < best) {
      best = (v - target).squaredNorm();
      p.ramus = v;
    }
  return p;
}

PelvicDirections pelvic_directions(const FemurAxis& femur, const PelvisPoints& pelvis, const Vec3& axis) {
  const Vec3 f = femur.at_height_of(pelvis.ischial_tuberosity);
  const Vec3 ut = perpendicular(pelvis.ischial_tuberosity - f, axis);
  const Vec3 us = perpendicular(pelvis.symphysis - f, axis);
  require(ut.norm() > 0.005 && us.norm() > 0.005,
          "pelvic_directions: the ischial tuberosity or the pubic symphysis lies on the femur's axis (the hemipelvis "
          "is not beside the femur: check that both come from the same scan)");
  const Vec3 m0 = (ut.normalized() + us.normalized()).normalized();
  const Vec3 a0 = (us.normalized() - ut.normalized()).normalized();
  PelvicDirections out;
  // Right limb: medial = axis × anterior (theta grows from anterior towards medial about the axis).
  out.side = axis.cross(a0).dot(m0) >= 0.0 ? geometry::Side::Right : geometry::Side::Left;
  const double s = out.side == geometry::Side::Right ? 1.0 : -1.0;
  const Vec3 ramus = perpendicular(pelvis.symphysis - pelvis.ischial_tuberosity, axis);
  require(ramus.norm() > 0.005,
          "pelvic_directions: the pubic symphysis lies straight above the ischial tuberosity (expected the ramus to run "
          "forwards: check the hemipelvis)");
  const Vec3 r = ramus.normalized();
  // Turn the ramus towards lateral (about the axis: −s) by the ramus angle.
  out.anterior = (std::cos(kIschialRamusAngle_rad) * r - s * std::sin(kIschialRamusAngle_rad) * axis.cross(r)).normalized();
  out.medial = s * axis.cross(out.anterior);
  out.bisector_difference_deg = std::acos(std::clamp(out.anterior.dot(a0), -1.0, 1.0)) / units::deg;
  return out;
}

std::optional<Vec3> greater_trochanter(const TriMesh& femur, const FemurAxis& axis, const geometry::LimbFrame& frame,
                                       double h_lo, double h_hi) {
  const Vec3 lateral = frame.lateral();
  std::optional<Vec3> best;
  double best_l = -std::numeric_limits<double>::infinity();
  for (const auto& v : femur.vertices) {
    const double h = frame.to_cylindrical(v).h;
    if (h < h_lo || h > h_hi) continue;
    const double l = (v - axis.at_height_of(v)).dot(lateral);
    if (l > best_l) {
      best_l = l;
      best = v;
    }
  }
  return best;
}

TransfemoralPoints transfemoral_points(const TriMesh& femur, const FemurAxis& axis, const TriMesh& hemipelvis,
                                       const geometry::LimbFrame& frame) {
  const PelvisPoints p = pelvis_points(hemipelvis, axis);
  TransfemoralPoints out;
  out.ischial_tuberosity = p.ischial_tuberosity;
  out.ischial_ramus = p.ramus;
  out.symphysis = p.symphysis;
  out.femur_distal_end = axis.distal_end;
  const double h = frame.to_cylindrical(p.ischial_tuberosity).h;
  out.greater_trochanter = greater_trochanter(femur, axis, frame, h - 0.02, h + 0.08);
  return out;
}

}  // namespace socketsmith::volume
