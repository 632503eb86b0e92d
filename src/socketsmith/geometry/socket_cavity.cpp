#include "socketsmith/geometry/socket_cavity.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Eigenvalues>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/surface_query.h"

namespace socketsmith::geometry {
namespace {

std::pair<double, double> height_span(const TriMesh& solid, const LimbFrame& frame) {
  double lo = 1e30, hi = -1e30;
  for (const auto& v : solid.vertices) {
    const double h = frame.to_cylindrical(v).h;
    lo = std::min(lo, h);
    hi = std::max(hi, h);
  }
  return {lo, hi};
}

Vec3 raw_normal(const TriMesh& m, int t) {
  const auto& tri = m.triangles[t];
  return (m.vertices[tri[1]] - m.vertices[tri[0]]).cross(m.vertices[tri[2]] - m.vertices[tri[0]]);
}

}  // namespace

bool surrounds_axis(const TriMesh& solid, const LimbFrame& frame, int* facing_out) {
  const SurfaceQuery all(solid);
  const auto [hmin, hmax] = height_span(solid, frame);
  int fewest = 8;
  for (double f : {0.3, 0.5, 0.7}) {
    const Vec3 o = frame.on_axis(hmin + f * (hmax - hmin));
    int facing = 0;
    for (int k = 0; k < 8; ++k) {
      const Vec3 dir = frame.radial(2 * std::numbers::pi * k / 8.0);
      const auto hit = all.first_hit(o, dir);
      if (!hit) continue;
      facing += raw_normal(solid, hit->triangle).dot(dir) < 0 ? 1 : 0;
    }
    fewest = std::min(fewest, facing);
  }
  if (facing_out) *facing_out = fewest;
  return fewest >= 7;
}

std::vector<int> cavity_triangles(const TriMesh& solid, const LimbFrame& frame) {
  const SurfaceQuery all(solid);
  const double hmax = height_span(solid, frame).second;
  std::vector<int> out;
  for (int i = 0; i < solid.num_triangles(); ++i) {
    const auto& t = solid.triangles[i];
    const Vec3 a = solid.vertices[t[0]], b = solid.vertices[t[1]], d = solid.vertices[t[2]];
    const Vec3 ctr = (a + b + d) / 3.0;
    Vec3 n = (b - a).cross(d - a);
    if (n.norm() <= 0) continue;
    n.normalize();
    const auto cy = frame.to_cylindrical(ctr);
    for (double lift : {0.0, 0.3, 1.0}) {
      const double ho = cy.h + lift * std::max(cy.rho, 0.01);
      if (lift > 0 && ho > hmax - 1e-6) continue;
      const Vec3 o = frame.on_axis(ho);
      const Vec3 dir = ctr - o;
      if (dir.norm() < 1e-9 || dir.dot(n) >= 0) continue;  // must face the origin (normal into the cavity)
      if (all.first_hit(o, frame.axis)) continue;             // the origin is in the wall or below the socket
      const auto hit = all.first_hit(o, dir);
      if (hit && (hit->triangle == i || std::abs(hit->distance - dir.norm()) < 1e-7)) {
        out.push_back(i);
        break;
      }
    }
  }
  return out;
}

TriMesh submesh(const TriMesh& mesh, const std::vector<int>& ids) {
  TriMesh out;
  std::vector<int> map(mesh.vertices.size(), -1);
  for (int t : ids) {
    std::array<int, 3> tri{};
    for (int k = 0; k < 3; ++k) {
      int& m = map[mesh.triangles[t][k]];
      if (m < 0) {
        m = out.num_vertices();
        out.vertices.push_back(mesh.vertices[mesh.triangles[t][k]]);
      }
      tri[k] = m;
    }
    out.triangles.push_back(tri);
  }
  return out;
}

LimbFrame estimate_socket_frame(const TriMesh& solid) {
  require(solid.num_vertices() >= 4 && solid.num_triangles() >= 4, "socket frame: the socket has {} triangles",
          solid.num_triangles());
  Vec3 mean = Vec3::Zero();
  for (const auto& v : solid.vertices) mean += v;
  mean /= static_cast<double>(solid.num_vertices());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& v : solid.vertices) cov += (v - mean) * (v - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  const Vec3 axis = eig.eigenvectors().col(2).normalized();
  const Aabb box = bounding_box(solid);
  const SurfaceQuery all(solid);
  const Vec3 c = box.center();
  const bool up_open = !all.first_hit(c, axis).has_value();
  const bool down_open = !all.first_hit(c, -axis).has_value();
  require(up_open != down_open,
          "the socket does not open at one end of its long axis (open towards {} ends): not a socket solid — give a "
          "closed socket with its inner and outer walls, or compare it as a surface",
          static_cast<int>(up_open) + static_cast<int>(down_open));
  LimbFrame f;
  f.axis = up_open ? axis : Vec3(-axis);
  f.anterior = eig.eigenvectors().col(0).normalized();
  f.origin = c;
  f.origin = f.on_axis(height_span(solid, f).first);
  f.anterior_estimated = f.side_estimated = true;
  int facing = 0;
  require(surrounds_axis(solid, f, &facing),
          "the socket does not surround its own long axis (only {} of 8 directions from it meet an inner wall): not a "
          "socket solid",
          facing);
  return f;
}

TriMesh cavity_surface(const TriMesh& solid, const LimbFrame& frame) {
  int facing = 0;
  require(surrounds_axis(solid, frame, &facing),
          "the socket does not surround the limb's axis (only {} of 8 directions from it meet its inner wall): place it "
          "around the limb, check its units",
          facing);
  TriMesh cavity = submesh(solid, cavity_triangles(solid, frame));
  require(!cavity.empty(), "the socket has no inner wall seen from the limb's axis: place it around the limb");
  flip_orientation(cavity);
  return cavity;
}

}  // namespace socketsmith::geometry
