#pragma once
/// @file bone_anatomy.h
/// The anatomy of the bone template (internal header of bone_template.cpp): the shape of every
/// template bone as a generalised cylinder placed from the skin's radii, with the sizes, heights,
/// tissue thicknesses and proportions it is built from. Sources, as cited with the values:
/// BoneTemplateParams' defaults are adult means (the OpenLimb mean transtibial limb, the
/// OpenLimbTF mean transfemoral limb, anatomy texts; the ischial ramus angle from 200 CT scans,
/// Prosthet Orthot Int, doi:10.1177/0309364618789439); the shape functions' own literals (where
/// the plateau blends into the shaft, the tuberosity's bump, the crest's tissue, the fibula's
/// gaps, the condyles' notch, the trochanter's prominence) are read from the same mean limbs.
/// Meshing the shapes and fitting them inside a skin is bone_template.cpp's work.

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/volume/bone_template.h"

namespace socketsmith::volume::detail {

/// A bone as a generalised cylinder in the limb frame: centreline (a(h), m(h)) in the
/// anterior/medial plane, radius rho(phi, h) about it (phi from anterior towards medial),
/// ellipsoidal caps, optional distal bevel (a shear h += bevel * (a - a_c) fading upwards).
struct BoneShape {
  std::string name;
  double h_bottom = 0.0;    ///< apex of the distal cap [m]
  double h_top = 0.0;       ///< apex of the proximal cap [m]
  double cap_bottom = 0.005;  ///< height of the distal cap [m]
  double cap_top = 0.005;     ///< height of the proximal cap [m]
  std::function<Eigen::Vector2d(double)> centre;  ///< (a, m) at h [m]
  std::function<double(double, double)> radius;   ///< rho(phi, h) [m]
  double bevel = 0.0;         ///< shear dh/da of the distal end
  double bevel_fade_m = 0.02; ///< height over which the bevel fades out [m]
  int columns = 48;           ///< vertices per ring of the body
  int rows = 40;              ///< rings
};

/// The lower hemipelvis of the OpenLimbTF mean limb scaled by a 0.45 m femur (see
/// BoneTemplateParams): its proportions are those of this pubic ramus length (tuberosity to
/// symphysis) [m], and scale with BoneTemplateParams::pubic_ramus_length_m.
inline constexpr double kReferencePubicRamus_m = 0.09;
/// The acetabulum from the ischial tuberosity's centre at kReferencePubicRamus_m: anterior,
/// medial (negative: lateral) and up [m].
inline constexpr double kAcetabulumAnterior_m = 0.038;
inline constexpr double kAcetabulumMedial_m = -0.036;
inline constexpr double kAcetabulumRise_m = 0.062;
/// Radii of the ischiopubic ramus at the symphysis and of the ischial body, as fractions of the
/// tuberosity's radius.
inline constexpr double kRamusRadiusFraction = 0.6;
inline constexpr double kIschialBodyRadiusFraction = 0.9;

/// The bone's name with the placement's suffix, e.g. "tibia (estimated)".
std::string bone_name(const char* base, const BonePlacement& placement);

/// Transtibial template: tibia, fibula (when 30 mm of it fit), patella and distal femur (when the
/// skin extends far enough above the joint line), in this order. See build_bone_template.
/// @throws InvalidInputError when the knee height lies outside the skin or leaves no room for
///         40 mm of tibia.
std::vector<BoneShape> transtibial_bone_shapes(const SkinRadii& skin, const BoneTemplateParams& params,
                                               const BonePlacement& placement);

/// Transfemoral template: the residual femur (with its greater trochanter when
/// placement.ischial_height_m >= 0). @throws InvalidInputError on a skin too short for 50 mm of femur.
std::vector<BoneShape> transfemoral_bone_shapes(const SkinRadii& skin, const BoneTemplateParams& params,
                                                const BonePlacement& placement);

}  // namespace socketsmith::volume::detail
