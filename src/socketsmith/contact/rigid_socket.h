#pragma once
/// @file rigid_socket.h
/// A rigid socket for contact: a closed socket solid (inner wall, outer wall, brim lip), its mass
/// properties, the inner wall that touches the stump, and gap queries of points against that wall.
///
/// Only the **inner wall** is a contact surface: a node of the stump that has passed through it —
/// however deep, even beyond the outer wall — is pushed back towards the cavity along the inner
/// wall's normal, never out through the outer wall (the thesis's node-to-triangle test, eqs. 11–12,
/// against both walls would push deep nodes the wrong way).

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/surface_query.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::contact {

using Vec3 = Eigen::Vector3d;

/// Result of a gap query of one point against the inner wall.
struct Gap {
  bool valid = false;        ///< the point faces the wall (its projection lies on it, not beyond the rim)
  double gap_m = 0.0;        ///< signed distance along the wall normal: > 0 in the cavity, < 0 penetrated
  Vec3 normal = Vec3::Zero();  ///< unit normal of the wall at the closest point, pointing into the cavity
  Vec3 point = Vec3::Zero();   ///< closest point on the wall (socket at its current pose) [m]
  int triangle = -1;
  /// The closest point lies inside a face (else on an edge or a vertex, where the contact force
  /// acts like a spring towards that point and has stiffness across the normal too).
  bool on_face = true;
  /// ∂(gap · normal)/∂x: n nᵀ inside a face, I − e eᵀ on an edge of direction e, I at a vertex —
  /// the penalty force's stiffness per unit penalty k A.
  Eigen::Matrix3d stiffness_shape = Eigen::Matrix3d::Zero();
};

/// A rigid obstacle the stump's nodes may touch, at a translation from its rest pose.
class Obstacle {
 public:
  virtual ~Obstacle() = default;
  /// Gap of point @p p (world) against the obstacle at the current translation.
  virtual Gap gap(const Vec3& p) const = 0;
  void set_translation(const Vec3& t) { translation_ = t; }
  const Vec3& translation() const { return translation_; }

 protected:
  Vec3 translation_ = Vec3::Zero();
};

/// A rigid plane: gap = (p − point − t)·normal, the unit normal pointing to the free side (e.g.
/// the bottom face of the thesis's rigid box: normal −z, the cube below it).
class PlaneObstacle : public Obstacle {
 public:
  PlaneObstacle(const Vec3& point, const Vec3& normal) : point_(point), normal_(normal.normalized()) {}
  Gap gap(const Vec3& p) const override {
    Gap g;
    g.valid = true;
    g.normal = normal_;
    g.gap_m = (p - point_ - translation_).dot(normal_);
    g.point = p - g.gap_m * normal_;
    g.stiffness_shape = normal_ * normal_.transpose();
    return g;
  }

 private:
  Vec3 point_, normal_;
};

class RigidSocket : public Obstacle {
 public:
  /// @param solid closed, consistently oriented socket solid [m] (outward normals)
  /// @param frame the limb frame the socket is placed in (axis: the donning direction)
  /// @param density_kg_m3 material density for the mass properties (PLA/PETG ≈ 1250)
  /// @throws TopologyError when the solid is not closed; InvalidInputError when it does not
  ///         surround the limb's axis (no inner wall is visible from the axis).
  RigidSocket(geometry::TriMesh solid, const geometry::LimbFrame& frame, double density_kg_m3 = 1250.0);
  ~RigidSocket();
  RigidSocket(RigidSocket&&) noexcept;
  RigidSocket& operator=(RigidSocket&&) noexcept;

  const geometry::TriMesh& solid() const { return solid_; }
  /// The inner wall: triangles of the solid seen from the limb axis (the cavity's surface).
  const geometry::TriMesh& inner_wall() const { return inner_; }
  int inner_triangles() const { return inner_.num_triangles(); }

  double mass_kg() const { return mass_; }
  const Vec3& centre_of_mass() const { return com_; }   ///< at the rest pose [m]
  const Eigen::Matrix3d& inertia() const { return inertia_; }  ///< about the centre of mass [kg m²]

  /// Gap of point @p p (world) against the inner wall at the current translation (donning moves
  /// the socket along the axis; rotations are not needed by the scenarios).
  Gap gap(const Vec3& p) const override;

 private:
  geometry::TriMesh solid_, inner_;
  std::vector<Vec3> inner_normals_;  // outward normals of the solid = into the cavity
  std::unique_ptr<geometry::SurfaceQuery> query_;
  double mass_ = 0.0;
  Vec3 com_ = Vec3::Zero();
  Eigen::Matrix3d inertia_ = Eigen::Matrix3d::Zero();
};

}  // namespace socketsmith::contact
