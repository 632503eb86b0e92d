#pragma once
/// @file transfemoral_anatomy.h
/// The bony anatomy of a transfemoral limb that sets its frame and its socket: the femur's shaft
/// axis, the hemipelvis's ischial tuberosity and pubic symphysis, the greater trochanter, and the
/// limb frame (axis, anterior, medial, side) they give.
///
/// Why bones and not the skin: a transfemoral skin is short, wide at the top and cut obliquely
/// from the hip to the groin, so its principal axis can lie 35–60° off the thigh (measured on the
/// OpenLimbTF mean limb: 34°; on a shortened copy 49°), and a thigh section has no sharp feature
/// that says where the front is. The femur is long and straight; the hemipelvis is asymmetric:
/// seen from the femur at the height of the ischial tuberosity, the tuberosity lies
/// postero-medially and the pubic symphysis antero-medially, so their directions' sum points
/// medially and their difference anteriorly (on the OpenLimbTF mean limb: 1–4° from the file's
/// frame, whose front the pubis and the anterior iliac spine show).

#include <optional>

#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::volume {

using Vec3 = Eigen::Vector3d;

/// The femur's shaft axis.
struct FemurAxis {
  Vec3 point = Vec3::Zero();            ///< on the axis: the mean of the fitted section centroids [m]
  Vec3 direction = Vec3::UnitZ();       ///< unit, from the distal end towards the hip
  Vec3 distal_end = Vec3::Zero();       ///< the femur's most distal vertex along `direction` [m]
  Vec3 proximal_end = Vec3::Zero();     ///< its most proximal vertex [m]
  double length_m = 0.0;                ///< extent along `direction` [m]
  /// The point of the axis line at the height of @p p (the foot of the perpendicular) [m].
  Vec3 at_height_of(const Vec3& p) const { return point + (p - point).dot(direction) * direction; }
};

/// Fits the shaft axis of a femur: the line through the centroids of 11 sections normal to the
/// femur's principal direction between 15 % and 65 % of its length from the distal end (the
/// shaft, away from the cut and from the trochanters, neck and head), two rounds. The direction
/// points from the distal end towards @p proximal_hint (a point known to be proximal: the
/// hemipelvis, or the skin's open rim).
/// @throws InvalidInputError when the femur is not a closed, elongated surface (length < 2 ×
///         width), or no section of it can be taken.
FemurAxis femur_shaft_axis(const geometry::TriMesh& femur, const Vec3& proximal_hint);

/// Points of the hemipelvis that matter to a socket [m].
struct PelvisPoints {
  Vec3 ischial_tuberosity = Vec3::Zero();  ///< its lowest vertex along the femur axis
  Vec3 symphysis = Vec3::Zero();           ///< pubic symphysis: of the vertices less than 60 mm above
                                           ///< the tuberosity, the farthest from the femur's axis
  Vec3 ramus = Vec3::Zero();               ///< the inferior ischial ramus: a third of the way from the
                                           ///< tuberosity to the symphysis, on the bone
};

/// Finds the ischial tuberosity, the ischial ramus and the pubic symphysis on a hemipelvis.
/// @throws InvalidInputError when the hemipelvis is empty or has no vertex within 60 mm above its
///         lowest point other than it.
PelvisPoints pelvis_points(const geometry::TriMesh& hemipelvis, const FemurAxis& femur);

/// The ischial ramus angle: the ischiopubic ramus (tuberosity to symphysis) against the
/// mid-sagittal plane in the transverse plane, 32.65° ± 5.59° on 200 CT scans (Prosthet Orthot Int,
/// doi:10.1177/0309364618789439); 30.5° on the OpenLimbTF mean limb.
inline constexpr double kIschialRamusAngle_rad = 32.65 * 3.14159265358979323846 / 180.0;

/// Anterior and medial directions (unit, perpendicular to @p axis) and the side, from the femur
/// and the hemipelvis. The side: u_t, u_s = the unit directions from the femur's axis (at the
/// tuberosity's height) to the tuberosity and to the symphysis, perpendicular to the axis; medial
/// ∝ u_t + u_s, and the side is the one for which it is u_s − u_t turned towards the body's
/// midline (right: medial = axis × anterior). The front: the ischiopubic ramus (tuberosity →
/// symphysis, across the axis) turned back towards lateral by kIschialRamusAngle_rad — on the
/// OpenLimbTF mean limb 2° from its frame, where the femur-centred bisector u_s − u_t is 9° off
/// (the tuberosity lies 10.5° behind medial, the symphysis 28° in front of it).
struct PelvicDirections {
  Vec3 anterior = Vec3::UnitY();
  Vec3 medial = Vec3::UnitX();
  geometry::Side side = geometry::Side::Right;
  double bisector_difference_deg = 0.0;  ///< between the ramus front and the bisector u_s − u_t, for the notes
};
PelvicDirections pelvic_directions(const FemurAxis& femur, const PelvisPoints& pelvis, const Vec3& axis);

/// The greater trochanter: the femur's most lateral vertex (from its shaft axis, along
/// −frame.medial()) between heights @p h_lo and @p h_hi of @p frame [m]; nullopt when the femur
/// has no vertex in that band (a femur cut below the trochanter).
std::optional<Vec3> greater_trochanter(const geometry::TriMesh& femur, const FemurAxis& axis,
                                       const geometry::LimbFrame& frame, double h_lo, double h_hi);

/// The bony points a transfemoral limb's landmarks and brims are placed from (world) [m].
struct TransfemoralPoints {
  Vec3 ischial_tuberosity = Vec3::Zero();
  Vec3 ischial_ramus = Vec3::Zero();
  Vec3 symphysis = Vec3::Zero();
  std::optional<Vec3> greater_trochanter;  ///< nullopt: the femur ends below it
  Vec3 femur_distal_end = Vec3::Zero();
  bool estimated = false;                  ///< the hemipelvis is the template's, not the patient's
};

/// The points of a femur (with its shaft axis) and a hemipelvis in @p frame: pelvis_points, the
/// femur's distal end, and the greater trochanter searched from 20 mm below to 80 mm above the
/// ischial tuberosity (greater_trochanter).
TransfemoralPoints transfemoral_points(const geometry::TriMesh& femur, const FemurAxis& axis,
                                       const geometry::TriMesh& hemipelvis, const geometry::LimbFrame& frame);

}  // namespace socketsmith::volume
