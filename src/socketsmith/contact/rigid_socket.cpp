#include "socketsmith/contact/rigid_socket.h"

#include <cmath>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_checks.h"

namespace socketsmith::contact {

RigidSocket::~RigidSocket() = default;
RigidSocket::RigidSocket(RigidSocket&&) noexcept = default;
RigidSocket& RigidSocket::operator=(RigidSocket&&) noexcept = default;

RigidSocket::RigidSocket(geometry::TriMesh solid, const geometry::LimbFrame& frame, double density)
    : solid_(std::move(solid)) {
  require(std::isfinite(density) && density > 0, "socket density {} kg/m^3 must be positive", density);
  const auto rep = geometry::check_mesh(solid_);
  require(rep.non_finite_vertices == 0, "the socket has {} vertices with NaN/inf coordinates", rep.non_finite_vertices);
  require<TopologyError>(rep.is_closed(),
                         "the socket surface is not closed ({} boundary edges): contact needs a closed solid with "
                         "inner and outer walls (repair it, or give the wall a thickness)",
                         rep.boundary_edges);
  require<TopologyError>(rep.is_manifold() && rep.is_oriented(),
                         "the socket surface is not a manifold, consistently oriented solid ({} non-manifold, {} "
                         "misoriented edges): repair it",
                         rep.non_manifold_edges, rep.inconsistently_oriented_edges);
  // Mass properties of the (outward) closed solid: signed tetrahedra from the origin.
  double vol = 0;
  Vec3 c = Vec3::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();  // ∫ x xᵀ dV
  for (const auto& t : solid_.triangles) {
    const Vec3 &a = solid_.vertices[t[0]], &b = solid_.vertices[t[1]], &d = solid_.vertices[t[2]];
    const double v = a.dot(b.cross(d)) / 6.0;
    vol += v;
    c += v * (a + b + d) / 4.0;
    // ∫ over the tetrahedron (0, a, b, d) of x xᵀ = v/20 (Σ p pᵀ + (Σ p)(Σ p)ᵀ) with p over the 4 vertices.
    const Vec3 s = a + b + d;
    second += v / 20.0 * (a * a.transpose() + b * b.transpose() + d * d.transpose() + s * s.transpose());
  }
  require<TopologyError>(vol > 0, "the socket solid is inside-out or empty (volume {:.3g} m^3): flip its triangles", vol);
  com_ = c / vol;
  mass_ = density * vol;
  const Eigen::Matrix3d cov = density * (second - vol * com_ * com_.transpose());
  inertia_ = cov.trace() * Eigen::Matrix3d::Identity() - cov;
  // The socket must surround the limb's axis: horizontal rays from the axis, at three heights of
  // the socket, hit a wall that faces them in (nearly) every direction.
  const geometry::SurfaceQuery all(solid_);
  double hmin = 1e30, hmax = -1e30;
  for (const auto& v : solid_.vertices) {
    const double h = frame.to_cylindrical(v).h;
    hmin = std::min(hmin, h);
    hmax = std::max(hmax, h);
  }
  for (double f : {0.3, 0.5, 0.7}) {
    const Vec3 o = frame.on_axis(hmin + f * (hmax - hmin));
    int facing = 0;
    for (int k = 0; k < 8; ++k) {
      const Vec3 dir = frame.radial(2 * 3.14159265358979 * k / 8.0);
      const auto hit = all.first_hit(o, dir);
      if (!hit) continue;
      const auto& t = solid_.triangles[hit->triangle];
      const Vec3 n = (solid_.vertices[t[1]] - solid_.vertices[t[0]]).cross(solid_.vertices[t[2]] - solid_.vertices[t[0]]);
      facing += n.dot(dir) < 0 ? 1 : 0;
    }
    require(facing >= 7,
            "the socket does not surround the limb: from the limb's axis at {:.0f} % of the socket's height only {} of 8 "
            "directions meet its inner wall (place it around the stump, check its units and the limb frame)",
            100 * f, facing);
  }
  // Inner wall: triangles visible from the limb axis (the cavity is star-shaped about its axis),
  // from origins on the axis no higher than the socket (else the brim's top is "seen").

  for (int i = 0; i < solid_.num_triangles(); ++i) {
    const auto& t = solid_.triangles[i];
    const Vec3 a = solid_.vertices[t[0]], b = solid_.vertices[t[1]], d = solid_.vertices[t[2]];
    const Vec3 ctr = (a + b + d) / 3.0;
    Vec3 n = (b - a).cross(d - a);
    if (n.norm() <= 0) continue;
    n.normalize();
    const auto cy = frame.to_cylindrical(ctr);
    bool inner = false;
    for (double lift : {0.0, 0.3, 1.0}) {
      const double ho = cy.h + lift * std::max(cy.rho, 0.01);
      if (lift > 0 && ho > hmax - 1e-6) continue;
      const Vec3 o = frame.on_axis(ho);
      const Vec3 dir = ctr - o;
      if (dir.norm() < 1e-9 || dir.dot(n) >= 0) continue;  // must face the origin (normal into the cavity)
      const auto hit = all.first_hit(o, dir);
      if (hit && (hit->triangle == i || std::abs(hit->distance - dir.norm()) < 1e-7)) {
        inner = true;
        break;
      }
    }
    if (!inner) continue;
    inner_.triangles.push_back(t);
    inner_normals_.push_back(n);
  }
  inner_.vertices = solid_.vertices;
  require(inner_.num_triangles() > 0,
          "the socket does not surround the limb: no part of it is seen from the limb's axis (place it around the "
          "stump, check its units)");
  query_ = std::make_unique<geometry::SurfaceQuery>(inner_);
}

Gap RigidSocket::gap(const Vec3& p) const {
  Gap g;
  const Vec3 q = p - translation_;  // in the solid's coordinates
  const auto hit = query_->closest_point(q);
  if (hit.triangle < 0) return g;
  const Vec3& n = inner_normals_[hit.triangle];
  const Vec3 d = q - hit.point;
  const double along_signed = d.dot(n);
  g.point = hit.point + translation_;
  g.triangle = hit.triangle;
  // Valid when the offset is (nearly) along the face normal: the projection falls on the wall, not
  // past its rim (a node above the brim is not in contact with the lip's edge).
  const double along = std::abs(along_signed), across = (d - along_signed * n).norm();
  g.valid = across <= 0.5 * along + 1e-5;
  // Gap and normal from the distance function (|d|, d/|d|), signed by the face: continuous when the
  // closest point moves across an edge between two faces (face normals would jump there and
  // Newton would stall).
  const double dist = d.norm();
  // Where on the triangle is the closest point: barycentric coordinates ≈ 0 mark edges/vertices.
  const auto& tri = inner_.triangles[hit.triangle];
  const Vec3 a = inner_.vertices[tri[0]], b = inner_.vertices[tri[1]], c = inner_.vertices[tri[2]];
  const Vec3 v0 = b - a, v1 = c - a, v2 = hit.point - a;
  const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0), d21 = v2.dot(v1);
  const double den = d00 * d11 - d01 * d01;
  double bary[3] = {1.0 / 3, 1.0 / 3, 1.0 / 3};
  if (den > 0) {
    bary[1] = (d11 * d20 - d01 * d21) / den;
    bary[2] = (d00 * d21 - d01 * d20) / den;
    bary[0] = 1.0 - bary[1] - bary[2];
  }
  int zeros = 0, zero_at = -1;
  for (int k = 0; k < 3; ++k)
    if (bary[k] < 1e-9) {
      ++zeros;
      zero_at = k;
    }
  g.on_face = zeros == 0 || dist < 1e-15;
  if (g.on_face) {
    g.stiffness_shape = n * n.transpose();
  } else if (zeros == 1) {
    const Vec3 e = (inner_.vertices[tri[(zero_at + 2) % 3]] - inner_.vertices[tri[(zero_at + 1) % 3]]).normalized();
    g.stiffness_shape = Eigen::Matrix3d::Identity() - e * e.transpose();
  } else {
    g.stiffness_shape = Eigen::Matrix3d::Identity();
  }
  if (dist > 1e-12) {
    const double sign = along_signed >= 0 ? 1.0 : -1.0;
    g.gap_m = sign * dist;
    g.normal = sign * d / dist;
  } else {
    g.gap_m = 0.0;
    g.normal = n;
  }
  return g;
}

}  // namespace socketsmith::contact
