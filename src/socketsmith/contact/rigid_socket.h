#pragma once
/// @file rigid_socket.h
/// A rigid socket for contact: a closed socket solid (inner wall, outer wall, brim lip), its mass
/// properties, the inner wall that touches the stump, and gap queries of points against that wall.
///
/// The **inner wall** is the contact surface (and, on the smoothed wall, the brim's lip past its
/// rim): a node of the stump that has passed through it — however deep, even beyond the outer
/// wall — is pushed back towards the cavity along the inner wall's normal, never out through the
/// outer wall (the thesis's node-to-triangle test, eqs. 11–12, against both walls would push deep
/// nodes the wrong way).

#include <array>
#include <cmath>
#include <memory>
#include <optional>
#include <utility>
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
  /// |∇gap| (1 for the distance to a faceted wall; ≈ 1 on the smoothed wall, whose gap is not an
  /// exact distance): the penalty force is k A (−gap) |∇gap| along the normal, the gradient of
  /// ½ k A gap² (stiffness_shape is then ∇gap ∇gapᵀ).
  double gradient_norm = 1.0;
  /// Whether the point faces the wall is decided continuously (the smoothed wall and its lip: the
  /// gap itself is continuous over the rim), not by the faceted wall's all-or-nothing cone.
  bool graded = false;
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
  /// Moves the plane itself (a change of the obstacle's geometry, as RigidSocket::replace_solid;
  /// then ContactSolver::obstacle_changed).
  void set_point(const Vec3& point) { point_ = point; }

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

  /// Replaces the socket's solid by @p solid (same frame, density, translation and wall mode), as
  /// the constructor checks and builds it: a socket whose wall was corrected while it is worn.
  /// @throws as the constructor; the socket is unchanged when it throws.
  void replace_solid(geometry::TriMesh solid);

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

  /// Smoothed wall (off by default): near the wall (within 3 mm of its facets) the gap is a smooth
  /// implicit surface through the inner wall's vertices instead of the distance to its facets —
  /// g(p) = Σ w_j (p − v_j)·n_j / Σ w_j over the wall's vertices v_j with their (angle-weighted)
  /// normals n_j and weights w_j = (1 − |p − v_j|²/ρ_j²)⁴ (ρ_j twice the mean length of the edges
  /// at v_j). Planar parts of the wall are reproduced exactly, curved ones within a fraction of
  /// their facets' sagitta; the gap's gradient turns smoothly where the facets' normals jump, so a
  /// node sliding along the wall does not cross kinks (Newton stalled at them: docs/contact.md).
  /// Past the rim the wall ends in its lip, a half-round of lip_radius_m() along the rim (the
  /// sockets socket_builder makes have one): a point there is in contact when it is inside that
  /// tube, and the wall's gap hands over to the lip's smoothly just past the rim.
  void set_smooth_wall(bool on) { smooth_ = on; }
  /// The lip's radius: half the wall's thickness (median from the inner wall), 1–5 mm [m].
  double lip_radius_m() const { return lip_radius_; }
  bool smooth_wall() const { return smooth_; }
  /// Fits the smoothed wall to the facets where a stump touches them: @p points are the skin's
  /// nodes at rest (world = solid coordinates, the socket at its designed pose); each vertex
  /// surface's offset is set, between the surface through the vertices and the one through the
  /// facets on average, so that the smoothed gap vanishes at the nodes' footprints on the facets
  /// (their closest points, within 10 mm) as far as it can. The
  /// nodes sit near the wall's vertices when the socket was designed on this stump, where a wall
  /// passing through the facets on average lies inside them by the facets' sagitta (0.2–0.5 mm
  /// on a 3k stump's 8 mm facets): that socket pressed a third more than its facets (docs/contact.md,
  /// "The smoothed wall's level"). Kept by replace_solid; no points: through the facets on average.
  void fit_smooth_wall_to(std::vector<Vec3> points);
  /// Point @p p within @p reach_m of the contact wall (the smoothed one when on) moved onto it, with
  /// the wall's normal there pointing out of the cavity; nothing farther away or where the gap is
  /// not defined. Newton on the gap along its gradient: a path along the gradient, not the exact
  /// closest point (CalculiX's socket shell is laid on socketsmith's wall with it).
  std::optional<std::pair<Vec3, Vec3>> onto_wall(const Vec3& p, double reach_m = 3e-3) const;

 private:
  /// The smoothed gap at @p q (g: the facets' gap there), or nothing where no vertex's support covers q.
  std::optional<Gap> smooth_gap(const Vec3& q, Gap g) const;
  /// Calls visit(j, q − v_j, u_j) for every wall vertex j whose support holds @p q (u_j = 1 −
  /// |q − v_j|²/ρ_j² > 0), from the 27 grid cells about q.
  template <class Visit>
  void for_vertex_support(const Vec3& q, Visit&& visit) const {
    Eigen::Vector3i c;
    for (int a = 0; a < 3; ++a) c[a] = static_cast<int>(std::floor((q[a] - grid_lo_[a]) / cell_));
    const Eigen::Vector3i lo = (c.array() - 1).max(0);
    const Eigen::Vector3i hi = (c + Eigen::Vector3i::Ones()).cwiseMin(grid_dim_ - Eigen::Vector3i::Ones());
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int x = lo[0]; x <= hi[0]; ++x) {
          const int cell = (z * grid_dim_[1] + y) * grid_dim_[0] + x;
          for (int k = cell_start_[cell]; k < cell_start_[cell + 1]; ++k) {
            const int j = cell_items_[k];
            const Vec3 d = q - wall_v_[j];
            const double u = 1.0 - d.squaredNorm() / wall_rho2_[j];
            if (u > 0) visit(j, d, u);
          }
        }
  }
  /// The closest point of @p q (solid coordinates) on the lip: the rounded edge along the inner
  /// wall's rims, a tube of lip_radius_ about the rim moved lip_radius_ into the wall.
  struct LipHit {
    Vec3 centre, normal, beyond, direction;  // closest point on the centre line; wall normal, past-the-rim direction there; (q − centre)/|q − centre|
    double gap_m = 0.0;                      // |q − centre| − radius
    double past_m = 0.0;                     // (q − centre) · beyond: > 0 past the rim
  };
  std::optional<LipHit> lip_hit(const Vec3& q) const;
  /// Point @p c, first and second derivatives of lip segment @p k's Hermite curve at parameter @p t.
  void lip_curve(int k, double t, Vec3& c, Vec3& dc, Vec3& ddc) const;
  /// The parameter in [0, 1] of @p q's closest point on lip segment @p k (Newton from the best of a
  /// few samples and @p t0, kept on the segment).
  double closest_on_lip_segment(int k, const Vec3& q, double t0) const;
  // The constructor's steps, in order.
  /// Mass, centre of mass and inertia of the (outward) closed solid.
  void mass_properties();
  /// The inner wall (the triangles seen from the limb's axis) and its query structure; the
  /// solid's triangles that form it. @throws InvalidInputError when the socket does not surround the limb.
  std::vector<int> find_inner_wall();
  /// The smoothed wall's vertices (per used vertex an angle-weighted normal and a support radius
  /// from its edges); each solid vertex's index among them (−1: none).
  std::vector<int> smooth_wall_vertices();
  /// Each wall vertex's local quadric over its tangent plane (wall_h_), fitted to its neighbours.
  void fit_vertex_quadrics(const std::vector<int>& wall_of);
  /// The uniform grid over the wall's vertices (cell: the largest support radius).
  void build_vertex_grid();
  /// The offsets wall_c_ that make the smoothed wall pass through the facets on average.
  void centre_vertex_surfaces(const std::vector<int>& wall_of);
  /// @p wall_of: each solid vertex's index among the wall's vertices (−1: none); @p cavity: the
  /// solid's triangles that form the inner wall.
  void build_lip(const std::vector<int>& wall_of, const std::vector<int>& cavity);
  /// @p wall: the wall's gap at q (valid where q faces it); @p on_rim: q's closest point on the
  /// facets is on the rim. The gap with the lip taken over past the rim.
  Gap with_lip(const Vec3& q, Gap wall, bool on_rim) const;

  geometry::LimbFrame frame_;
  double density_ = 0.0;
  geometry::TriMesh solid_, inner_;
  std::vector<Vec3> inner_normals_;  // outward normals of the solid = into the cavity
  // The inner wall's edge pseudo-normals (the side of a point whose closest point is on an edge):
  // per triangle, its two faces' mean normal for the edge opposite each corner. A vertex's is its
  // angle-weighted normal, wall_n_[wall_of_[v]].
  std::vector<std::array<Vec3, 3>> tri_edge_normals_;
  std::vector<int> wall_of_;  // per mesh vertex: its index among the smoothed wall's vertices (−1: none)
  std::unique_ptr<geometry::SurfaceQuery> query_;
  bool smooth_ = false;
  // The smoothed wall: the inner wall's vertices, their normals and squared support radii, and a
  // uniform grid of them (cell = the largest radius; a query looks at its 27 cells).
  std::vector<Vec3> wall_v_, wall_n_;
  std::vector<double> wall_rho2_, wall_c_;  // squared support radii; offsets of the vertex surfaces
  std::vector<double> wall_c_facets_;       // the offsets through the facets on average
  std::vector<Vec3> fit_points_;            // the skin nodes the wall is fitted to (fit_smooth_wall_to)
  std::vector<Eigen::Matrix3d> wall_h_;     // curvature of each vertex's quadric (tangential)
  double cell_ = 1.0;
  Vec3 grid_lo_ = Vec3::Zero();
  Eigen::Vector3i grid_dim_ = Eigen::Vector3i::Zero();
  std::vector<int> cell_start_, cell_items_;
  // The lip: its centre line per rim vertex (the rim moved lip_radius_ along −normal), the wall's
  // normal and the past-the-rim direction there, and the rim's segments.
  std::vector<Vec3> lip_o_, lip_n_, lip_b_;
  std::vector<std::pair<int, int>> lip_seg_;
  std::vector<Vec3> lip_t_;                     // unit tangent of the centre line at each vertex
  double lip_radius_ = 0.002;
  std::vector<char> rim_vertex_;  // per mesh vertex: on the inner wall's boundary
  double mass_ = 0.0;
  Vec3 com_ = Vec3::Zero();
  Eigen::Matrix3d inertia_ = Eigen::Matrix3d::Zero();
};

}  // namespace socketsmith::contact
