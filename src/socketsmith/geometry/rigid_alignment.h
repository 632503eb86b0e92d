#pragma once
/// @file rigid_alignment.h
/// Rigid alignment of two surfaces: a rigid transform (rotation + translation), the least-squares
/// transform between matched points (Kabsch), and ICP (iterative closest point, point-to-plane)
/// of a moving surface onto a fixed one.
///
/// ICP here minimises Σ w_i (n_i·(R p_i + t − q_i) − δ)² over R, t and a **uniform normal offset**
/// δ, for samples p_i of the moving surface, their closest points q_i on the fixed one and the
/// fixed surface's normal n_i there (Chen & Medioni 1992; the linearised rotation of Low 2004).
/// The free δ is what makes two scans of a swollen and a shrunk limb comparable: a plain ICP of a
/// limb against a copy grown by 2 mm slides the copy 2 mm along the axis (an open scan is a cup,
/// and a translation along the axis closes the gap at its end), hiding the change it is asked to
/// show; with δ free the copy stays put and δ = 2 mm. Pairs are kept when the closest point lies
/// inside a face (not on the fixed surface's open rim or a crease: the offset must be along the
/// face's normal within 45°), within max_distance_m, and within 3 robust standard deviations of δ
/// (after the first iterations), and only where the caller's filter accepts the sample (a crop).

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "socketsmith/geometry/surface_query.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::geometry {

/// x ↦ R x + t.
struct RigidTransform {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< proper rotation (det +1)
  Vec3 translation = Vec3::Zero();                         ///< [m]

  Vec3 apply(const Vec3& p) const { return rotation * p + translation; }
  /// The transform of @p then this: x ↦ this(first(x)).
  RigidTransform after(const RigidTransform& first) const {
    return {rotation * first.rotation, rotation * first.translation + translation};
  }
  RigidTransform inverse() const { return {rotation.transpose(), -(rotation.transpose() * translation)}; }
  /// Rotation angle [rad], in [0, π].
  double angle_rad() const;
};

/// @p mesh with every vertex moved by @p transform.
TriMesh transformed(const TriMesh& mesh, const RigidTransform& transform);

/// The rotation by @p angle_rad about the line through @p point along @p axis (any length > 0).
RigidTransform rotation_about(const Vec3& point, const Vec3& axis, double angle_rad);

/// The rigid transform T minimising Σ |T(from_i) − to_i|² (Kabsch / Umeyama without scale).
/// @throws InvalidInputError for fewer than 3 pairs, different counts, non-finite points, or
///         points (nearly) on one line (the rotation about it is not determined).
RigidTransform kabsch(const std::vector<Vec3>& from, const std::vector<Vec3>& to);

/// Settings of align_icp.
struct IcpOptions {
  int max_iterations = 80;             ///< [1, 1000]
  int max_samples = 6000;              ///< moving-surface vertices used at most (evenly strided), [100, 10⁷]
  double max_distance_m = 0.03;        ///< pairs farther apart are never used [m], > 0
  double convergence_m = 1e-8;         ///< stop when the update moves no sample more than this [m], > 0
  bool solve_offset = true;            ///< solve the uniform normal offset δ (file comment); false: δ = 0
  double outlier_sigmas = 3.0;         ///< after 3 iterations, drop pairs beyond this many robust SDs of δ, > 0
};

/// What align_icp found.
struct IcpResult {
  RigidTransform transform;   ///< moving → fixed
  double offset_m = 0.0;      ///< δ: the uniform normal offset of the moving surface from the fixed one [m]
  double rms_m = 0.0;         ///< RMS of n·(R p + t − q) − δ over the pairs kept (the fit's residual) [m]
  double rms_distance_m = 0.0;  ///< RMS of |R p + t − q| over the pairs kept [m]
  int pairs = 0;              ///< pairs kept in the last iteration
  int samples = 0;            ///< samples accepted by the filter
  int iterations = 0;
  bool converged = false;
  std::string message;        ///< why it stopped
};

/// Aligns @p moving onto the surface of @p fixed, starting from @p initial. Samples are the moving
/// surface's vertices (strided to max_samples); @p use_sample, when given, is asked for each
/// sample's position in the fixed surface's frame (after the current transform) and can drop it —
/// e.g. above a crop height. A rotation the surfaces do not determine (a surface of revolution
/// about its axis) is held by a small Tikhonov term rather than drifting.
/// @throws InvalidInputError for options out of range, an empty or non-finite moving mesh, or
///         fewer than 12 usable pairs at the start (the surfaces do not overlap: seed them closer).
IcpResult align_icp(const TriMesh& moving, const SurfaceQuery& fixed, const RigidTransform& initial,
                    const IcpOptions& options = {}, const std::function<bool(const Vec3&)>& use_sample = {});

/// Area-weighted unit vertex normals of @p mesh (zero for a vertex of degenerate triangles only).
std::vector<Vec3> vertex_normals(const TriMesh& mesh);

/// @p mesh with every vertex moved by @p distance_m along its area-weighted vertex normal
/// (outward for an outward surface when > 0): a uniform swelling (> 0) or shrinking (< 0) of a
/// smooth surface. Not an exact offset surface: where the radius of curvature is below
/// |distance_m| the result folds.
/// @throws InvalidInputError for a non-finite distance or a mesh with non-finite vertices.
TriMesh offset_along_normals(const TriMesh& mesh, double distance_m);

}  // namespace socketsmith::geometry
