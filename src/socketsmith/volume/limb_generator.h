#pragma once
/// @file limb_generator.h
/// Seeded parametric residual limb (transtibial or transfemoral): skin, bones, frame and
/// landmarks — the project's embedded sample limb, on which the whole pipeline (meshing,
/// pressure design, socket printing) can run without any scan.
///
/// Conventions: SI units; the world frame is the returned LimbFrame (axis +z from the distal
/// end towards the proximal cut, distal end on the axis at z = 0 so h = z, anterior +y, medial
/// −x for a right limb and +x for a left one). Left and right limbs of the same seed are mirror
/// images (x → −x) with the same (theta, h) everywhere. The skin is a closed surface, or open with
/// exactly one boundary loop in the plane of the proximal cut; bones are closed shells strictly
/// inside the skin with at least kMinBoneClearance_m of soft tissue. Deterministic given the
/// parameters (and therefore the seed) on a given platform.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/volume/bone_template.h"
#include "socketsmith/volume/landmarks.h"
#include "socketsmith/volume/transfemoral_anatomy.h"

namespace socketsmith::volume {

/// Shape of the generated limb. Defaults are the nominal transtibial limb (close to the OpenLimb
/// mean transtibial limb); default_params gives the nominal values of either type and jitters
/// them from a seed.
struct LimbShapeParams {
  geometry::LimbType type = geometry::LimbType::Transtibial;
  geometry::Side side = geometry::Side::Right;
  std::uint64_t seed = 0;  ///< the seed default_params used (recorded in the sidecar only)
  /// Transtibial: knee joint line to the distal end; transfemoral: the ischial tuberosity's level
  /// to the distal end (the clinical residual length) [m]. Transtibial [0.06, 0.30], transfemoral
  /// [0.10, 0.45].
  double residual_length_m = 0.15;
  /// Skin kept above the knee joint line (transtibial, [0, 0.12]) or above the ischial tuberosity
  /// (transfemoral, over the buttock and the groin, [0, 0.15]) up to the proximal cut, like a scan
  /// or a cast [m].
  double proximal_extension_m = 0.07;
  /// Circumference at the knee joint line (transtibial, [0.26, 0.60]) or at the ischial
  /// tuberosity's level (transfemoral, [0.30, 0.80]) [m]. Above the knee the transtibial
  /// circumference grows by 0.09 (1 − exp(−dh / 25 mm)) + 0.4 dh/m (patella and condyles: +6 % at
  /// 23 mm, +11 % at 70 mm); above the tuberosity the transfemoral one by 0.5 dh/m.
  double proximal_circumference_m = 0.35;
  /// Circumference at the top of the rounded distal end, h = distal_cap_height_m [m], in
  /// [0.5, 1.1] × proximal_circumference_m.
  double distal_circumference_m = 0.27;
  /// Height of the rounded distal end (a superelliptic cap, not a flat cut) [m], [0.01, 0.09]
  /// and at most half the residual length.
  double distal_cap_height_m = 0.035;
  /// Taper profile, [0, 1]: 0 = conical (circumference linear in h between the distal and
  /// proximal values, elliptic distal cap); 1 = bulbous (full almost down to the cap, blunt
  /// superelliptic cap of exponent 3).
  double bulbousness = 0.3;
  /// Antero-posterior over medio-lateral diameter of the shank or thigh sections, [0.6, 1.3].
  /// Transtibial sections round off to 1 at the knee (condyles, patella).
  double ap_ml_ratio = 0.90;
  /// Transtibial: depth of the flat antero-medial face (the subcutaneous tibia) relative to the
  /// ellipse, along the face's normal, [0, 0.3]. The face starts at the tibial crest (theta = 0),
  /// where its corner with the rounder antero-lateral side (tibialis anterior) makes the crest
  /// ridge. Ignored for transfemoral.
  double anterior_flattening = 0.12;
  /// Calf fullness: extra radius of the postero-medial (and 0.3 × of the postero-lateral) muscle
  /// bulge relative to the ellipse (transtibial); extra radius of the posterior half (hamstrings)
  /// for transfemoral, [0, 0.4].
  double posterior_fullness = 0.12;
  /// Open proximal end (a boundary loop at the cut, like a scan) or a planar cap.
  bool open_proximal = true;
  /// Skin vertices per ring, [24, 256]; rings are spaced alike (5–10k skin vertices at 96).
  int ring_vertices = 96;
  /// Bone sizes and placement rules (the generator's truth). The sizes are those of a limb of
  /// nominal circumference (0.35 m at the knee, 0.48 m at the thigh) and are multiplied by
  /// proximal_circumference_m / nominal, clamped to [0.7, 1.3] (scaled_bone_sizes).
  BoneTemplateParams bones;
};

/// Nominal parameters of @p type jittered from @p seed (seed 0: the nominal values exactly).
/// Uniform jitter (its half-width in brackets): transtibial residual 0.15 m (±0.02) below the
/// knee + 0.07 m (±0.01) above, circumference 0.35 m (±6 %) at the knee and 0.77 (±0.06) of it
/// distally, cap 0.035 m (±0.005); transfemoral residual 0.27 m (±0.03) below the ischial
/// tuberosity + 0.09 m (±0.01) above, circumference 0.48 m (±6 %) at the tuberosity and 0.71
/// (±0.06) of it distally, cap 0.05 m (±0.008); the hemipelvis's and trochanter's proportions
/// (BoneTemplateParams: ±8–15 %, the tuberosity's angle ±10°, tissue ±6 mm); bulbousness 0.3
/// (±0.25), AP/ML 0.90 (±0.05), anterior flattening 0.12 (±0.03), posterior fullness 0.12
/// (±0.04); bone sizes ±5–10 %, tibia cut 0.025 m (±0.005), fibula 0.03 m (±0.01) shorter,
/// femur cut 0.045 m (±0.015). The side stays Right. Portable: its own SplitMix64 generator.
LimbShapeParams default_params(geometry::LimbType type, std::uint64_t seed);

/// Throws InvalidInputError naming the first field of @p params outside its documented range.
void validate(const LimbShapeParams& params);

/// Valid residual_length_m of @p type [m]: transtibial [0.06, 0.30], transfemoral [0.10, 0.45].
std::pair<double, double> residual_length_range(geometry::LimbType type);

/// A generated residual limb: the truth for every later stage.
struct GeneratedLimb {
  geometry::TriMesh skin;           ///< outward; open (one boundary loop at the cut) or capped
  /// "tibia", "fibula", "patella", "femur" (transtibial) / "femur", "hemipelvis" (transfemoral:
  /// the hemipelvis is whole, as in a CT scan, and reaches out of the skin at the pubis and above
  /// its top; the limb model clips it to the stump).
  std::vector<NamedMesh> bones;
  geometry::LimbFrame frame;        ///< the truth (anterior_estimated = side_estimated = false)
  std::vector<Landmark> landmarks;  ///< the truth (estimated = false), on the skin
  /// Transfemoral: the truth of the bony points the landmarks are placed from.
  std::optional<TransfemoralPoints> transfemoral;
  LimbShapeParams params;           ///< what made it
  double cut_height_m = 0.0;        ///< h of the proximal cut plane [m]
  double skin_volume_m3 = 0.0;      ///< volume enclosed by the skin closed by its planar cap [m^3]
  int first_cap_triangle = -1;      ///< closed skin: skin triangles from here on are the planar cap; -1 when open
};

/// Generates the limb of @p params. Well under a second.
/// @throws InvalidInputError on invalid params (validate).
GeneratedLimb generate_limb(const LimbShapeParams& params);

/// The skin and every bone concatenated into one multi-shell mesh (as in a real multi-shell STL),
/// skin first, then the bones in order.
geometry::TriMesh merge_shells(const GeneratedLimb& limb);

/// The sidecar of a generated limb: type, side, seed, params (SI), frame, landmarks (positions
/// and radii in mm, theta in degrees, h and rho in mm), shells (names, vertex and triangle
/// counts, volumes) and bone names.
nlohmann::json limb_sidecar_json(const GeneratedLimb& limb);

/// Writes limb_sidecar_json(@p limb) to @p path atomically (temporary file + rename).
/// @throws IoError when the file cannot be written.
void write_limb_sidecar(const std::filesystem::path& path, const GeneratedLimb& limb);

}  // namespace socketsmith::volume
