#include "socketsmith/geometry/rigid_alignment.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/SVD>

#include "socketsmith/core/errors.h"

namespace socketsmith::geometry {
namespace {

/// exp of the skew matrix of @p w (Rodrigues).
Eigen::Matrix3d rotation_exp(const Vec3& w) {
  const double a = w.norm();
  if (a < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

double median_of(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

double RigidTransform::angle_rad() const {
  return std::acos(std::clamp(0.5 * (rotation.trace() - 1.0), -1.0, 1.0));
}

TriMesh transformed(const TriMesh& mesh, const RigidTransform& transform) {
  TriMesh out = mesh;
  for (auto& v : out.vertices) v = transform.apply(v);
  return out;
}

RigidTransform rotation_about(const Vec3& point, const Vec3& axis, double angle_rad) {
  require(axis.allFinite() && axis.norm() > 0 && std::isfinite(angle_rad) && point.allFinite(),
          "rotation_about: the axis must be a non-zero direction and the angle and point finite");
  RigidTransform t;
  t.rotation = Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
  t.translation = point - t.rotation * point;
  return t;
}

RigidTransform kabsch(const std::vector<Vec3>& from, const std::vector<Vec3>& to) {
  require(from.size() == to.size(), "kabsch: {} points to match with {} (expected pairs)", from.size(), to.size());
  require(from.size() >= 3, "kabsch: {} point pairs (expected at least 3, not on one line)", from.size());
  Vec3 cf = Vec3::Zero(), ct = Vec3::Zero();
  for (size_t i = 0; i < from.size(); ++i) {
    require(from[i].allFinite() && to[i].allFinite(), "kabsch: point pair {} is not finite", i);
    cf += from[i];
    ct += to[i];
  }
  cf /= static_cast<double>(from.size());
  ct /= static_cast<double>(to.size());
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  double spread = 0;
  for (size_t i = 0; i < from.size(); ++i) {
    h += (from[i] - cf) * (to[i] - ct).transpose();
    spread += (from[i] - cf).squaredNorm();
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const auto& sv = svd.singularValues();
  require(spread > 0 && sv(1) > 1e-9 * sv(0) + 1e-30,
          "kabsch: the {} points lie on one line (or coincide): the rotation about it is not determined; give points "
          "spread over the surface",
          from.size());
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0) d(2, 2) = -1;
  RigidTransform t;
  t.rotation = svd.matrixV() * d * svd.matrixU().transpose();
  t.translation = ct - t.rotation * cf;
  return t;
}

namespace {

/// One ICP correspondence: a moved sample @p x, the normal @p n of the fixed face it found, the
/// signed normal distance @p nd and the distance @p dist to the closest point [m].
struct IcpPair {
  Vec3 x, n;
  double nd, dist;
};

void check_icp_inputs(const TriMesh& moving, const IcpOptions& o) {
  require(o.max_iterations >= 1 && o.max_iterations <= 1000, "align_icp: {} iterations (expected 1-1000)",
          o.max_iterations);
  require(o.max_samples >= 100 && o.max_samples <= 10000000, "align_icp: {} samples (expected 100-10^7)", o.max_samples);
  require(std::isfinite(o.max_distance_m) && o.max_distance_m > 0, "align_icp: max distance {} mm must be positive",
          o.max_distance_m * 1e3);
  require(std::isfinite(o.convergence_m) && o.convergence_m > 0, "align_icp: convergence {} mm must be positive",
          o.convergence_m * 1e3);
  require(std::isfinite(o.outlier_sigmas) && o.outlier_sigmas > 0, "align_icp: outlier bound {} SD must be positive",
          o.outlier_sigmas);
  require(moving.num_vertices() > 0, "align_icp: the moving surface has no vertices");
  for (const auto& v : moving.vertices)
    require(v.allFinite(), "align_icp: the moving surface has a vertex with NaN/inf coordinates; repair it");
}

/// The moving surface's samples (every stride-th vertex, at most max_samples) with each one's last
/// closest point on the fixed surface, the hint for the next search.
struct IcpSamples {
  std::vector<Vec3> points;
  std::vector<SurfaceHit> hints;
  std::vector<char> has_hint;

  IcpSamples(const TriMesh& moving, int max_samples) {
    const int nv = moving.num_vertices();
    const int stride = std::max(1, (nv + max_samples - 1) / max_samples);
    for (int v = 0; v < nv; v += stride) points.push_back(moving.vertices[v]);
    hints.resize(points.size());
    has_hint.assign(points.size(), 0);
  }
};

/// Pairs the samples, moved by the current transform, with the fixed surface: drops those beyond
/// max_distance_m, those meeting a rim or crease rather than a face, and (from the fourth
/// iteration) the outliers beyond outlier_sigmas robust SDs. Returns how many samples use_sample
/// accepted.
int match_icp_pairs(IcpSamples& s, const SurfaceQuery& fixed, const std::vector<Vec3>& face_n,
                    const IcpOptions& o, const std::function<bool(const Vec3&)>& use_sample,
                    const IcpResult& res, double sigma, int it, std::vector<IcpPair>& pairs) {
  const double cos_limit = std::cos(45.0 * 3.14159265358979 / 180.0);
  constexpr double kSigmaFloor = 1e-4;  // [m] the outlier bound never drops below 3 × 0.1 mm
  pairs.clear();
  int accepted = 0;
  for (size_t i = 0; i < s.points.size(); ++i) {
    const Vec3 x = res.transform.apply(s.points[i]);
    if (use_sample && !use_sample(x)) continue;
    ++accepted;
    const SurfaceHit hit = s.has_hint[i] ? fixed.closest_point(x, s.hints[i]) : fixed.closest_point(x);
    s.hints[i] = hit;
    s.has_hint[i] = 1;
    if (hit.triangle < 0) continue;
    const Vec3 d = x - hit.point;
    const double dist = d.norm();
    if (dist > o.max_distance_m) continue;
    const Vec3& n = face_n[hit.triangle];
    const double nd = n.dot(d);
    if (dist > 1e-9 && std::abs(nd) < cos_limit * dist) continue;  // on a rim or crease, not a face
    if (sigma >= 0 && it >= 3 && std::abs(nd - res.offset_m) > o.outlier_sigmas * std::max(sigma, kSigmaFloor))
      continue;
    pairs.push_back({x, n, nd, dist});
  }
  return accepted;
}

/// One point-to-plane step: the rotation @p w and translation @p tau [m] about the pairs'
/// centroid @p c (and the offset in u(6) when solved), from the linearised normal equations.
struct IcpStep {
  Eigen::VectorXd u;
  Vec3 c;
  double reach_m = 0;  ///< the farthest pair from c: turns a rotation into a displacement
};

/// Solves the step and records the pairs' residual statistics in @p res and @p sigma.
IcpStep solve_icp_step(const std::vector<IcpPair>& pairs, const IcpOptions& o, IcpResult& res,
                       double& sigma) {
  const int nu = o.solve_offset ? 7 : 6;
  IcpStep step;
  Vec3 c = Vec3::Zero();
  for (const auto& p : pairs) c += p.x;
  c /= static_cast<double>(pairs.size());
  Eigen::MatrixXd ata = Eigen::MatrixXd::Zero(nu, nu);
  Eigen::VectorXd atb = Eigen::VectorXd::Zero(nu);
  double reach = 0;
  std::vector<double> resid;
  resid.reserve(pairs.size());
  double sum_r2 = 0, sum_d2 = 0;
  for (const auto& p : pairs) {
    Eigen::Matrix<double, 7, 1> row;
    row.head<3>() = (p.x - c).cross(p.n);
    row.segment<3>(3) = p.n;
    row(6) = -1.0;
    const auto r = row.head(nu);
    ata += r * r.transpose();
    atb += r * (-p.nd);
    reach = std::max(reach, (p.x - c).norm());
    const double ri = p.nd - (o.solve_offset ? res.offset_m : 0.0);
    resid.push_back(std::abs(ri));
    sum_r2 += ri * ri;
    sum_d2 += p.dist * p.dist;
  }
  res.rms_m = std::sqrt(sum_r2 / static_cast<double>(pairs.size()));
  res.rms_distance_m = std::sqrt(sum_d2 / static_cast<double>(pairs.size()));
  sigma = 1.4826 * median_of(resid);
  // A small Tikhonov term on the rotation holds a direction the surfaces do not determine (a
  // surface of revolution about its axis); the determined ones move 1e-6 of their step less.
  const double rot_scale = (ata(0, 0) + ata(1, 1) + ata(2, 2)) / 3.0;
  for (int k = 0; k < 3; ++k) ata(k, k) += 1e-6 * rot_scale + 1e-300;
  step.u = ata.ldlt().solve(atb);
  step.c = c;
  step.reach_m = reach;
  return step;
}

}  // namespace

IcpResult align_icp(const TriMesh& moving, const SurfaceQuery& fixed, const RigidTransform& initial,
                    const IcpOptions& o, const std::function<bool(const Vec3&)>& use_sample) {
  check_icp_inputs(moving, o);
  const TriMesh& fm = fixed.mesh();
  std::vector<Vec3> face_n(fm.triangles.size());
  for (int t = 0; t < fm.num_triangles(); ++t) face_n[t] = triangle_normal(fm, t);
  IcpSamples samples(moving, o.max_samples);

  IcpResult res;
  res.transform = initial;
  double sigma = -1;  // robust SD of the residuals of the last iteration (−1: not yet)
  std::vector<IcpPair> pairs;
  for (int it = 0; it < o.max_iterations; ++it) {
    res.samples = match_icp_pairs(samples, fixed, face_n, o, use_sample, res, sigma, it, pairs);
    res.pairs = static_cast<int>(pairs.size());
    require(it > 0 || pairs.size() >= 12,
            "align_icp: only {} of {} samples found the other surface within {:.0f} mm: the surfaces do not overlap "
            "(seed the alignment closer, check the units and the crop height)",
            pairs.size(), samples.points.size(), o.max_distance_m * 1e3);
    if (pairs.size() < 12) {
      res.message = fmt::format("stopped: only {} pairs left after {} iterations", pairs.size(), it);
      break;
    }
    const IcpStep step = solve_icp_step(pairs, o, res, sigma);
    const Eigen::VectorXd& u = step.u;
    if (!u.allFinite()) {
      res.message = "stopped: the alignment's normal equations are singular (the surfaces do not fix a rigid motion)";
      break;
    }
    const Vec3 w = u.head<3>(), tau = u.segment<3>(3);
    if (o.solve_offset) res.offset_m = u(6);
    const Eigen::Matrix3d r_inc = rotation_exp(w);
    res.transform.rotation = r_inc * res.transform.rotation;
    res.transform.translation = r_inc * (res.transform.translation - step.c) + step.c + tau;
    res.iterations = it + 1;
    const double move = w.norm() * step.reach_m + tau.norm();
    if (move <= o.convergence_m) {
      res.converged = true;
      res.message = fmt::format("converged in {} iterations", it + 1);
      break;
    }
  }
  if (!res.converged && res.message.empty())
    res.message = fmt::format("stopped at the iteration cap ({}) before the update fell below {:.2g} mm",
                              o.max_iterations, o.convergence_m * 1e3);
  return res;
}

std::vector<Vec3> vertex_normals(const TriMesh& mesh) {
  std::vector<Vec3> n(mesh.vertices.size(), Vec3::Zero());
  for (const auto& t : mesh.triangles) {
    const Vec3 a = (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
    for (int v : t) n[v] += a;  // |a| = twice the area: area weighting
  }
  for (auto& v : n)
    if (v.norm() > 0) v.normalize();
  return n;
}

TriMesh offset_along_normals(const TriMesh& mesh, double distance_m) {
  require(std::isfinite(distance_m), "offset_along_normals: distance {} is not finite", distance_m);
  for (const auto& v : mesh.vertices)
    require(v.allFinite(), "offset_along_normals: the surface has a vertex with NaN/inf coordinates; repair it");
  const auto n = vertex_normals(mesh);
  TriMesh out = mesh;
  for (size_t v = 0; v < out.vertices.size(); ++v) out.vertices[v] += distance_m * n[v];
  return out;
}

}  // namespace socketsmith::geometry
