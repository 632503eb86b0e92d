#pragma once
/// @file landmarks.h
/// Anatomical landmarks (zones) on the skin of a residual limb.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/geometry/limb_frame.h"

namespace socketsmith::volume {

/// One landmark zone: a point on the skin and a radius of influence.
struct Landmark {
  std::string code;   ///< short code used in case files: "PT", "MF", "LF", "FH", "POP", "AD", ...
  std::string name;   ///< human-readable, e.g. "patellar tendon"
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< on the skin [m]
  geometry::Cylindrical cylindrical;                   ///< in the limb frame
  double radius_m = 0.02;  ///< zone radius (for drawing and tagging surface nodes)
  bool estimated = true;   ///< placed automatically (false when given by the user / generator truth)
};

}  // namespace socketsmith::volume

#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/volume/bone_template.h"
#include "socketsmith/volume/transfemoral_anatomy.h"

namespace socketsmith::volume {

/// The landmark codes of a limb type, in a fixed order (transtibial: PT, MF, LF, FH, POP, AD, TC,
/// DT; transfemoral: IS, IR, GT, AL, ST, DF).
std::vector<std::string> landmark_codes(geometry::LimbType type);

/// Places the landmarks of @p type on the closed skin from the limb frame and the bones (found by
/// name: "tibia", "fibula", "patella", "femur", estimated or not). Each landmark is put at a
/// (theta, h) given by anatomy — e.g. the patellar tendon anterior, 15 mm below the patella or
/// 25 mm below the tibial plateau — and projected onto the skin along the ray from the axis.
/// Transfemoral limbs take their bony points in @p transfemoral (place_transfemoral_landmarks);
/// without them the landmarks are put at fixed places below the cut (IS at 150°, 75 mm below it).
/// @throws InvalidInputError when the skin cannot be hit from the axis at a landmark's height.
std::vector<Landmark> place_landmarks(const geometry::TriMesh& closed_skin, const geometry::LimbFrame& frame,
                                      geometry::LimbType type, const std::vector<NamedMesh>& bones,
                                      double cut_height_m, const TransfemoralPoints* transfemoral = nullptr);

/// The transfemoral landmarks from the bony points, each on the skin along the ray from the axis
/// at the (θ, h) of its anatomy: IS ischial tuberosity (over the tuberosity), IR ischial ramus
/// (over the ramus point), GT greater trochanter (over its lateral prominence; 35 mm above IS at
/// −90° when the femur ends below it), AL adductor longus tendon (at the symphysis's angle, 30°–75°,
/// 5 mm above IS: where it crosses the brim), ST Scarpa's (femoral) triangle (at 0.4 × AL's angle,
/// 20 mm above IS), DF the skin point nearest the femur's distal end. Every landmark is kept at
/// least 10 mm below @p cut_height_m.
std::vector<Landmark> place_transfemoral_landmarks(const geometry::TriMesh& closed_skin,
                                                   const geometry::LimbFrame& frame, const TransfemoralPoints& points,
                                                   double cut_height_m);

/// Replaces the landmark with the same code by @p given (user override from a case file):
/// its position is projected onto the skin and its cylindrical coordinates recomputed.
/// @throws InvalidInputError for an unknown code or a point farther than 20 mm from the skin.
void override_landmark(std::vector<Landmark>& landmarks, const geometry::TriMesh& closed_skin,
                       const geometry::LimbFrame& frame, const Landmark& given);

}  // namespace socketsmith::volume
