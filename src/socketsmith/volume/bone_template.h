#pragma once
/// @file bone_template.h
/// Anatomical bone template of a residual limb, placed from skin measurements.
///
/// The same shape functions make the "true" bones of the parametric limb generator
/// (limb_generator.h) and the bones estimated from a scanned skin (estimate_bones): a scan has no
/// bones, so they are placed from what the skin tells — its length along the axis, the radii of
/// its cross-sections measured by rays from the axis, and the knee joint line.
///
/// Each bone is a generalised cylinder in the limb frame (see geometry/limb_frame.h): a
/// centreline (a(h), m(h)) in the anterior/medial plane, a cross-section radius rho(phi, h)
/// about it (phi from anterior towards medial, like theta) and rounded ellipsoidal end caps,
/// optionally bevelled (sheared) at the distal end. Meshes are closed, manifold, outward and free
/// of self-intersections by construction (rings in increasing height, each star-shaped about
/// the centreline). Sizes are in metres.
///
/// Transtibial template: residual tibia (plateau at the joint line tapering into a rounded
/// triangular shaft with its crest anterior, tuberosity, bevelled distal cut), fibula
/// (postero-lateral, head below the lateral condyle, shorter than the tibia), and — when the skin
/// extends above the joint line — the distal femur (condyles with the intercondylar notch) and
/// the patella. Transfemoral: the residual femur (anterior-lateral of the centre, widening
/// towards the trochanters, rounded cut). The shapes, their sizes and sources are in
/// bone_anatomy.h; this file meshes them, measures the skin and fits the bones inside it.

#include <string>
#include <vector>

#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::volume {

/// A closed surface with a name (a bone, the skin), as the shells of a multi-shell STL.
struct NamedMesh {
  std::string name;        ///< e.g. "tibia", "fibula (estimated)"
  geometry::TriMesh mesh;  ///< closed, outward, metres
};

/// Smallest soft-tissue thickness kept between a bone and the skin [m].
inline constexpr double kMinBoneClearance_m = 0.003;
/// Smallest gap kept between two bones (joint spaces, interosseous space) [m].
inline constexpr double kMinBoneGap_m = 0.0015;

/// Radius of the skin measured from the limb axis, r(theta, h), on a regular grid: heights
/// h_k = h_lo_m + k (h_hi_m - h_lo_m) / (num_heights - 1), angles theta_j = 2 pi j / num_angles.
/// Each sample is the distance from the axis to the nearest skin crossing of the ray at angle
/// theta in the plane h = h_k (the plane section of the skin triangles).
struct SkinRadii {
  double bottom_m = 0.0;  ///< lowest skin height (the distal end) [m]
  double top_m = 0.0;     ///< proximal end: the lowest point of the open boundary, or the top of a closed skin [m]
  double h_lo_m = 0.0;    ///< first sampled height [m]
  double h_hi_m = 0.0;    ///< last sampled height [m]
  int num_heights = 0;
  int num_angles = 0;
  std::vector<double> radius_m;  ///< num_heights × num_angles, row-major by height [m]

  /// Bilinear interpolation, periodic in theta, clamped to [h_lo_m, h_hi_m] in h [m].
  /// @throws InvalidInputError on an empty or inconsistent table.
  double radius(double theta, double h) const;
  /// Medio-lateral width r(+pi/2) + r(-pi/2) at height h [m].
  double width_ml(double h) const;
};

/// Measures SkinRadii of @p skin in @p frame (num_heights × num_angles rays).
/// Rays that miss (the axis outside a section) take the value of the nearest ray that hits.
/// @pre skin is closed, or open only at its proximal end; frame is orthonormal.
/// @throws InvalidInputError when the skin is empty, has non-finite coordinates, or no ray hits.
SkinRadii measure_skin_radii(const geometry::TriMesh& skin, const geometry::LimbFrame& frame,
                             int num_heights = 64, int num_angles = 72);

/// Sizes and placement rules of the template [m, rad]. Defaults are adult means (OpenLimb mean
/// transtibial limb; anatomy texts). Heights are measured from the distal end of the skin.
struct BoneTemplateParams {
  // Transtibial: tibia.
  double tibia_plateau_width_m = 0.076;   ///< medio-lateral width of the plateau, [0.05, 0.10]
  double tibia_plateau_depth_m = 0.050;   ///< antero-posterior depth of the plateau, [0.035, 0.07]
  double tibia_shaft_radius_m = 0.019;    ///< mean shaft radius 70 mm below the joint line, [0.012, 0.026]
  double tibia_distal_radius_m = 0.0125;  ///< mean radius at the distal cut, [0.008, 0.02]
  double tibia_end_height_m = 0.025;      ///< distal cut of the tibia above the distal skin end, [0.012, 0.06]
  double tibia_bevel = 0.45;              ///< anterior bevel of the cut (shear dh/da), [0, 0.8]
  double crest_tissue_m = 0.008;          ///< soft tissue over the mid-shaft tibial crest, [0.005, 0.03]
  double tibia_medial_shift_m = 0.003;    ///< tibia centre medial of the mid-width of the skin, [-0.01, 0.01]
  // Transtibial: fibula.
  double fibula_head_radius_m = 0.0115;   ///< radius of the fibular head, [0.007, 0.016]
  double fibula_shaft_radius_m = 0.006;   ///< radius of the fibular shaft, [0.003, 0.01]
  double fibula_shortening_m = 0.030;     ///< the fibula ends this much above the tibia, [0.01, 0.06]
  double fibula_angle_rad = -2.18;        ///< direction of the fibula from the tibia centre (−125°: postero-lateral), [-2.8, -1.6]
  // Transtibial: distal femur and patella (only when the skin extends above the joint line).
  double femur_condyle_width_m = 0.080;   ///< medio-lateral width of the femoral condyles, [0.055, 0.105]
  double femur_condyle_depth_m = 0.056;   ///< antero-posterior depth of the condyles, [0.04, 0.075]
  double patella_width_m = 0.042;         ///< [0.03, 0.055]
  double patella_height_m = 0.042;        ///< [0.03, 0.055]
  double patella_thickness_m = 0.020;     ///< [0.014, 0.026]
  double patella_tissue_m = 0.007;        ///< skin to patella in front of it, [0.004, 0.02]
  // Femur shaft (both types) and the transfemoral residual femur.
  double femur_shaft_radius_m = 0.014;    ///< mean femoral shaft radius, [0.009, 0.02]
  double femur_end_height_m = 0.045;      ///< transfemoral: femur cut above the distal skin end, [0.02, 0.09]
  double femur_lateral_fraction = 0.35;   ///< transfemoral: proximal femur centre lateral of the axis, as a fraction of the lateral skin radius (OpenLimbTF mean limb: 0.49 at the ischial tuberosity), [0, 0.6]
  double femur_anterior_fraction = 0.12;  ///< transfemoral: femur centre anterior of the axis, fraction of the anterior skin radius, [-0.2, 0.35]
  // Transfemoral, placed from the ischial tuberosity's height (BonePlacement::ischial_height_m):
  // the greater trochanter and the lower hemipelvis (ischium with its tuberosity, the ischiopubic
  // ramus to the pubic symphysis, the ischial body up towards the acetabulum), hung on the femur
  // through the hip. Proportions from the OpenLimbTF mean limb scaled by a 0.45 m femur: seen from
  // the femur's shaft axis at the tuberosity's height, the tuberosity lies 75 mm away, 10.5°
  // posterior of medial; the symphysis 90 mm from it across the axis at 30.5° from anterior
  // towards medial (the ischial ramus angle: 32.65° ± 5.59° on 200 CT scans, Prosthet Orthot Int,
  // doi:10.1177/0309364618789439) and 40 mm higher; the acetabulum 36 mm lateral, 38 mm anterior
  // and 62 mm above the tuberosity; the trochanter's lateral prominence 35 mm above it.
  double trochanter_height_m = 0.035;      ///< the trochanter's lateral prominence above the ischial tuberosity, [0, 0.07]
  double trochanter_prominence_m = 0.015;  ///< how far it stands out of the shaft laterally, [0.005, 0.03]
  double ischium_radius_m = 0.013;         ///< radius of the tuberosity, [0.008, 0.02]
  double ischium_offset_m = 0.075;         ///< femur shaft axis to the tuberosity across the axis, [0.045, 0.1]
  double ischium_angle_rad = -0.18;        ///< direction of that offset from medial towards anterior (−10.5°: posterior of medial), [−0.8, 0.4]
  double min_ischial_tissue_m = 0.012;     ///< the tuberosity is pulled towards the femur to keep this much tissue, [0.005, 0.04]
  double pubic_ramus_length_m = 0.09;      ///< tuberosity to pubic symphysis across the axis, [0.06, 0.12]
  double pubic_ramus_angle_rad = 0.53;     ///< direction of that span from anterior towards medial (30.5°), [0.2, 1.0]
  double pubic_ramus_rise_m = 0.04;        ///< the symphysis above the tuberosity, [0.015, 0.06]
};

/// Throws InvalidInputError naming the first field of @p params outside its documented range.
void validate(const BoneTemplateParams& params);

/// @p params with every bone size (plateau, condyles, shaft and head radii, patella) multiplied
/// by @p factor; heights, tissue thicknesses, fractions and angles unchanged. Sizes are clamped to
/// their documented ranges.
BoneTemplateParams scaled_bone_sizes(const BoneTemplateParams& params, double factor);

/// Where the template goes in the limb.
struct BonePlacement {
  geometry::LimbType type = geometry::LimbType::Transtibial;
  double knee_height_m = 0.15;  ///< transtibial knee joint line (frame height) [m]; unused for transfemoral
  double shrink = 1.0;          ///< (0, 1]: bone radii and caps scaled about the centrelines, ends pulled in
  std::string name_suffix;      ///< appended to every bone name, e.g. " (estimated)"
  /// Transfemoral: height of the ischial tuberosity (frame height) [m]; ≥ 0 adds the greater
  /// trochanter to the femur and builds the hemipelvis; < 0: the femur alone, widening at the top.
  double ischial_height_m = -1.0;
};

/// The lower hemipelvis of the transfemoral template, named "hemipelvis" + suffix: one closed tube
/// swept along a smooth curve from the pubic symphysis down the ischiopubic ramus to the ischial
/// tuberosity (its lowest point, at placement.ischial_height_m) and up the ischial body towards the
/// acetabulum, 60 mm past @p skin's top. The tuberosity lies ischium_offset_m from
/// @p femur_axis_point (the femur's shaft axis at the tuberosity's height), pulled towards it when
/// less than min_ischial_tissue_m of tissue would cover it; the symphysis lies where it lies in
/// the OpenLimbTF mean limb, which is often outside a thigh's skin — like a CT hemipelvis, it is
/// meant to be clipped to the stump (prepare_limb keeps what lies 5 mm inside the skin). Radii:
/// tuberosity ischium_radius_m, ramus 0.6 ×, ischial body 0.9 ×, all times placement.shrink.
/// @throws InvalidInputError when placement.ischial_height_m is outside the skin's height range.
NamedMesh build_hemipelvis_template(const SkinRadii& skin, const geometry::LimbFrame& frame,
                                    const BoneTemplateParams& params, const BonePlacement& placement,
                                    const geometry::Vec3& femur_axis_point);

/// Builds the template bones in @p frame, placed from @p skin. Transtibial: tibia (its cut
/// lowered when needed to keep 40 mm of tibia, but at least 12 mm above the distal end), fibula
/// (omitted when less than 30 mm of it would remain), and femur (when the skin reaches ≥ 35 mm
/// above the joint line) and patella (≥ 12 mm + its height + 8 mm); transfemoral: femur (its cut
/// lowered when needed to keep 50 mm of femur; with placement.ischial_height_m ≥ 0 its greater
/// trochanter) and then the hemipelvis (build_hemipelvis_template). Does not check clearances: see
/// fit_bone_template.
/// @throws InvalidInputError on invalid params or a placement outside the skin's height range.
std::vector<NamedMesh> build_bone_template(const SkinRadii& skin, const geometry::LimbFrame& frame,
                                           const BoneTemplateParams& params, const BonePlacement& placement);

/// Result of fit_bone_template.
struct BoneFitResult {
  std::vector<NamedMesh> bones;
  std::vector<double> shrink;          ///< shrink factor finally used for each bone
  double min_skin_clearance_m = 0.0;   ///< smallest skin–bone distance (vertex–triangle, both ways), capped at 20 mm
  double min_bone_gap_m = 0.0;         ///< smallest bone–bone distance, capped at 20 mm (+inf with one bone)
};

/// Builds the template and shrinks the offending bones (factor 0.93 per step, each bone on its
/// own) until every bone lies inside @p skin with at least @p min_clearance_m of tissue and the
/// bones are at least kMinBoneGap_m apart. @p placement.shrink is the starting factor. The
/// transfemoral hemipelvis (last, when placement.ischial_height_m ≥ 0) is not held inside the skin
/// (it is clipped later, see build_hemipelvis_template); it is shrunk only to keep its gap to the
/// femur.
/// @throws InvalidInputError when no shrink factor ≥ 0.25 satisfies the clearances (a skin too
///         thin for the bones), naming the bone and the height.
BoneFitResult fit_bone_template(const geometry::TriMesh& skin, const SkinRadii& radii,
                                const geometry::LimbFrame& frame, const BoneTemplateParams& params,
                                const BonePlacement& placement, double min_clearance_m = kMinBoneClearance_m);

/// Knee joint line of a transtibial skin estimated from its length alone: the proximal
/// 32 % of the measured length (clamped to 30–100 mm) is taken to lie above the joint line, as
/// in typical transtibial scans which include the knee up to the distal thigh [m].
double estimate_knee_height(const SkinRadii& skin);

/// Options of estimate_bones.
struct BoneEstimateOptions {
  double knee_height_m = -1.0;                    ///< > 0: the known joint line height; otherwise estimated
  double ischial_height_m = -1.0;                 ///< transfemoral, ≥ 0: add the trochanter and the hemipelvis there
  double min_clearance_m = kMinBoneClearance_m;   ///< soft tissue kept between skin and bones [m]
};

/// Estimates the bones of a residual limb from its skin alone: the anatomical template scaled to
/// the skin (plateau width 69 % of the medio-lateral skin width at the knee line, tibia cut at
/// 17 % of the residual length above the distal end; transfemoral femur cut at 16 % of the
/// length) and fitted inside it with at least min_clearance_m of tissue. Bones are named
/// "tibia (estimated)", "fibula (estimated)", "femur (estimated)", "patella (estimated)".
/// @param closed_skin the skin, closed (or open only at its proximal cut), outward, metres.
/// @param frame its limb frame (axis, anterior, side).
/// @throws InvalidInputError on an empty or non-finite skin, a skin open away from its proximal
///         end, or a skin too thin to hold the bones.
std::vector<NamedMesh> estimate_bones(const geometry::TriMesh& closed_skin, const geometry::LimbFrame& frame,
                                      geometry::LimbType type, const BoneEstimateOptions& options = {});

namespace detail {

/// A closed tube swept along the uniform cubic B-spline of @p control points (clamped at both
/// ends, so it starts and ends at the first and last point), with radius interpolated along the
/// control polygon from @p radii (one per control point) [m], rounded hemispherical ends. Rings of
/// @p ring_vertices vertices about every @p spacing_m of arc length, oriented by parallel transport
/// (rotation-minimising frames), outward. The curve's radius of curvature must exceed the tube's
/// radius for the surface to be free of self-intersections (the caller's choice of points).
/// @throws InvalidInputError for fewer than 2 points, a size mismatch, or a non-positive radius.
geometry::TriMesh sweep_tube(const std::vector<geometry::Vec3>& control, const std::vector<double>& radii,
                             int ring_vertices = 24, double spacing_m = 0.003);

}  // namespace detail

}  // namespace socketsmith::volume
