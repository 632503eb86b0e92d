#pragma once
/// @file limb_frame.h
/// The limb's anatomical frame and its cylindrical coordinates (rho, theta, h).
///
/// Conventions (the same for left and right limbs, so that templates of spots, brims and
/// landmarks written in (theta, h) apply to both sides):
/// - `axis` is the unit long axis pointing from the distal end towards the proximal cut;
/// - `origin` is on the axis at the level of the most distal skin point: h = 0 there, h > 0
///   proximally [m];
/// - `anterior` is a unit vector perpendicular to the axis pointing to the front of the limb;
/// - theta [rad] is measured around the axis from anterior (0) towards **medial** (+pi/2),
///   posterior is ±pi, lateral is −pi/2. For a right limb medial is the patient's left;
/// - rho [m] is the distance to the axis.

#include <array>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace socketsmith::geometry {

enum class LimbType { Transtibial, Transfemoral };
enum class Side { Right, Left };

/// "transtibial" / "transfemoral"; parse throws InvalidInputError on anything else.
std::string to_string(LimbType type);
LimbType parse_limb_type(const std::string& text);
/// "right" / "left"; parse throws InvalidInputError on anything else.
std::string to_string(Side side);
Side parse_side(const std::string& text);

/// Cylindrical coordinates in a LimbFrame.
struct Cylindrical {
  double rho = 0.0;    ///< distance to the axis [m]
  double theta = 0.0;  ///< angle from anterior towards medial [rad], in (-pi, pi]
  double h = 0.0;      ///< height above the distal end along the axis [m]
};

/// An orthonormal limb frame. See the file comment for the conventions.
struct LimbFrame {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d anterior = Eigen::Vector3d::UnitY();
  Side side = Side::Right;
  bool anterior_estimated = true;  ///< true when not given by the user nor derived from bones
  bool side_estimated = true;

  /// The patient's right as seen in this frame: anterior × axis.
  Eigen::Vector3d patient_right() const { return anterior.cross(axis).normalized(); }
  /// Unit vector towards the body's midline (perpendicular to the axis).
  Eigen::Vector3d medial() const {
    return side == Side::Right ? Eigen::Vector3d(-patient_right()) : patient_right();
  }
  Eigen::Vector3d lateral() const { return -medial(); }
  /// True when (anterior, medial, axis) is left-handed, as for a left limb: surfaces built with
  /// angles from anterior towards medial must then be flipped to stay outward.
  bool is_left_handed() const { return anterior.cross(medial()).dot(axis) < 0.0; }

  Cylindrical to_cylindrical(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d d = p - origin;
    const double h = d.dot(axis);
    const double a = d.dot(anterior);
    const double m = d.dot(medial());
    const double theta = std::atan2(m, a);
    return {std::hypot(a, m), theta <= -std::numbers::pi ? std::numbers::pi : theta, h};  // (-pi, pi]
  }
  Eigen::Vector3d from_cylindrical(const Cylindrical& c) const {
    return origin + c.h * axis + c.rho * (std::cos(c.theta) * anterior + std::sin(c.theta) * medial());
  }
  /// Unit radial direction at angle theta (perpendicular to the axis).
  Eigen::Vector3d radial(double theta) const {
    return std::cos(theta) * anterior + std::sin(theta) * medial();
  }
  /// Point on the axis at height h.
  Eigen::Vector3d on_axis(double h) const { return origin + h * axis; }
};

}  // namespace socketsmith::geometry

#include <vector>

#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::geometry {

/// A planar cross-section of a surface (the segments where the triangles cross the plane),
/// oriented so that the enclosed area is positive seen from +normal for an outward surface.
struct Slice {
  std::vector<std::array<Vec3, 2>> segments;
  double area = 0.0;                 ///< enclosed area [m^2], negative for an inside-out surface
                                     ///< (0 when the slice is empty)
  Vec3 centroid = Vec3::Zero();      ///< area centroid (meaningful when area != 0)
  double perimeter = 0.0;            ///< [m]
};

/// Intersects @p mesh with the plane through @p point with unit @p normal.
Slice slice_surface(const TriMesh& mesh, const Vec3& point, const Vec3& normal);

/// Long axis, distal end and origin of a limb surface (open at the proximal cut or closed).
/// The first guess is, for an open surface, the line from the skin point farthest from the open
/// rim's centroid (the distal end) to that centroid — it does not depend on the surface's
/// principal axis, which on a short transfemoral skin cut obliquely from the hip to the groin lies
/// 35–60° off the thigh — and, for a closed surface, the principal direction of the area-weighted
/// surface (PCA). It is then refined as the line through the centroids of cross-sections between
/// 20 % and 80 % of the length (three rounds, each turning it by at most 25°). The distal end is
/// the end opposite the open boundary (or, on a closed surface, the end with the smaller
/// cross-section). The anterior direction is only a placeholder perpendicular to the axis
/// (anterior_estimated = true): set it from bones, the user, or estimate_anterior_from_skin.
/// @throws InvalidInputError when the surface is not elongated like a limb (length < 1.2 × width)
///         or does not taper to a distal end.
LimbFrame estimate_limb_axis(const TriMesh& skin);

/// The limb frame of a skin whose long-axis direction is known (from the femur, or given by the
/// user): the axis is ±@p axis_direction — pointing towards the open rim on an open surface, as
/// given on a closed one — through the mean centroid of the skin's cross-sections normal to it
/// between 20 % and 80 % of its closed part; the origin lies on it at the height of the most
/// distal skin point. The anterior direction is a placeholder, as in estimate_limb_axis.
/// @throws InvalidInputError for a zero or non-finite direction, or a surface that does not taper
///         to a distal end in that frame ("not a residual limb").
LimbFrame limb_frame_along(const TriMesh& skin, const Vec3& axis_direction);

/// Heuristic anterior direction of a transfemoral limb from its skin alone (a thigh has no crest).
/// A thigh scan's open rim runs from the hip (laterally, highest) down to the groin (medially,
/// lowest): when the first harmonic of the rim's height around the axis rises by at least 20 mm,
/// its lowest direction is taken as medial. The outline of the sections between 25 % and 60 % of
/// the closed part is skewed towards the fuller posterior thigh (hamstrings): of the two directions
/// perpendicular to medial, the front is the one away from the skew, and that sets the side
/// (unless @p side_given: then frame.side turns medial into anterior).
/// Without an oblique rim the front is taken opposite the skew and the side is kept. Callers must
/// label the result as an estimate.
struct ThighFrontEstimate {
  Vec3 anterior = Vec3::UnitY();  ///< unit, perpendicular to the axis
  bool side_found = false;        ///< the side follows from the rim and the skew (else: as given or unknown)
  Side side = Side::Right;        ///< when side_found
  std::string how;                ///< a short description for the notes
};
ThighFrontEstimate estimate_anterior_from_thigh(const TriMesh& skin, const LimbFrame& frame, bool side_given);

/// Centroid of the open boundary's vertices (the rim of a scan) [m]; nullopt for a closed surface.
std::optional<Vec3> open_rim_centroid(const TriMesh& skin);

/// Highest h below which every cross-section of the skin is a closed curve: the lowest vertex of
/// the open boundary (in h) for an open surface, the top of the surface for a closed one [m].
double lowest_open_boundary_height(const TriMesh& skin, const LimbFrame& frame);

/// Sets frame.anterior to the unit vector perpendicular to the axis closest to @p direction.
/// @throws InvalidInputError when @p direction is (nearly) parallel to the axis.
void set_anterior(LimbFrame& frame, const Vec3& direction);

/// Heuristic anterior direction of a transtibial limb from its skin alone, for frame.side: the
/// outline of mid-stump sections is skewed towards the postero-medial calf bulge (measured: at
/// theta = 113–120 deg on six generated limbs, 129 deg on the real OpenLimb limb); anterior is
/// taken 120 deg from the skew direction, towards lateral. A wrong side mirrors the error.
/// Callers must label it as an estimate and let the user override it.
Vec3 estimate_anterior_from_skin(const TriMesh& skin, const LimbFrame& frame);

}  // namespace socketsmith::geometry
