// The generator's parameters: the nominal limb of either type, its seeded jitter and the ranges
// generate_limb accepts (declared in limb_generator.h).
#include "socketsmith/volume/limb_generator.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "socketsmith/core/errors.h"
#include "socketsmith/volume/shape_math.h"

namespace socketsmith::volume {

using geometry::LimbType;

namespace {

constexpr double kDeg = shape::kPi / 180.0;

/// SplitMix64 (Steele, Lea, Flood 2014): a portable, well-mixed stream from a 64-bit seed, so a
/// seed gives the same limb with every standard library.
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /// Uniform in [-1, 1).
  double symmetric() { return 2.0 * static_cast<double>(next() >> 11) * 0x1.0p-53 - 1.0; }

 private:
  std::uint64_t state_;
};

void check_range(const char* field, double value, double lo, double hi, const char* unit, const char* what = "") {
  if (!std::isfinite(value) || value < lo || value > hi)
    fail("generate_limb: {} = {} is out of range (expected {} to {}{}{})", field, value, lo, hi, unit, what);
}

/// One bone parameter's seeded jitter: ± @p amount (absolute, in the member's unit) or × (1 ± amount).
struct BoneJitter {
  double BoneTemplateParams::*member;
  double amount;
  bool relative;
  bool transfemoral_only;
};

constexpr BoneJitter kBoneJitter[] = {
    // member                                        amount       relative transfemoral only
    {&BoneTemplateParams::tibia_plateau_depth_m,     0.05,        true,    false},
    {&BoneTemplateParams::tibia_shaft_radius_m,      0.08,        true,    false},
    {&BoneTemplateParams::tibia_distal_radius_m,     0.08,        true,    false},
    {&BoneTemplateParams::tibia_end_height_m,        0.005,       false,   false},
    {&BoneTemplateParams::tibia_bevel,               0.1,         false,   false},
    {&BoneTemplateParams::crest_tissue_m,            0.002,       false,   false},
    {&BoneTemplateParams::tibia_medial_shift_m,      0.002,       false,   false},
    {&BoneTemplateParams::fibula_head_radius_m,      0.08,        true,    false},
    {&BoneTemplateParams::fibula_shaft_radius_m,     0.1,         true,    false},
    {&BoneTemplateParams::fibula_shortening_m,       0.01,        false,   false},
    {&BoneTemplateParams::fibula_angle_rad,          8.0 * kDeg,  false,   false},
    {&BoneTemplateParams::femur_condyle_width_m,     0.004,       false,   false},
    {&BoneTemplateParams::femur_condyle_depth_m,     0.003,       false,   false},
    {&BoneTemplateParams::patella_width_m,           0.07,        true,    false},
    {&BoneTemplateParams::patella_height_m,          0.07,        true,    false},
    {&BoneTemplateParams::patella_thickness_m,       0.07,        true,    false},
    {&BoneTemplateParams::patella_tissue_m,          0.0015,      false,   false},
    {&BoneTemplateParams::femur_shaft_radius_m,      0.07,        true,    false},
    {&BoneTemplateParams::femur_end_height_m,        0.015,       false,   false},
    {&BoneTemplateParams::femur_lateral_fraction,    0.05,        false,   false},
    {&BoneTemplateParams::femur_anterior_fraction,   0.04,        false,   false},
    {&BoneTemplateParams::trochanter_height_m,       0.008,       false,   true},
    {&BoneTemplateParams::trochanter_prominence_m,   0.15,        true,    true},
    {&BoneTemplateParams::ischium_radius_m,          0.1,         true,    true},
    {&BoneTemplateParams::ischium_offset_m,          0.08,        true,    true},
    {&BoneTemplateParams::ischium_angle_rad,         8.0 * kDeg,  false,   true},
    {&BoneTemplateParams::pubic_ramus_length_m,      0.08,        true,    true},
    {&BoneTemplateParams::pubic_ramus_angle_rad,     8.0 * kDeg,  false,   true},
    {&BoneTemplateParams::pubic_ramus_rise_m,        0.006,       false,   true},
};

}  // namespace

LimbShapeParams default_params(LimbType type, std::uint64_t seed) {
  LimbShapeParams p;
  p.type = type;
  p.seed = seed;
  const bool tt = type == LimbType::Transtibial;
  if (!tt) {
    p.residual_length_m = 0.27;
    p.proximal_extension_m = 0.09;
    p.proximal_circumference_m = 0.48;
    p.distal_circumference_m = 0.71 * 0.48;
    p.distal_cap_height_m = 0.05;
    p.ap_ml_ratio = 0.90;
    p.anterior_flattening = 0.0;
  }
  if (seed == 0) return p;
  SplitMix64 rng(seed * 0x2545F4914F6CDD1Dull + (tt ? 0x1234567ull : 0x7654321ull));
  auto jitter = [&](double& x, double half) { x += half * rng.symmetric(); };
  auto jitter_rel = [&](double& x, double rel) { x *= 1.0 + rel * rng.symmetric(); };
  jitter(p.residual_length_m, tt ? 0.02 : 0.03);
  jitter(p.proximal_extension_m, 0.01);
  jitter_rel(p.proximal_circumference_m, 0.06);
  double ratio = tt ? 0.77 : 0.71;
  jitter(ratio, 0.06);
  p.distal_circumference_m = ratio * p.proximal_circumference_m;
  jitter(p.distal_cap_height_m, tt ? 0.005 : 0.008);
  jitter(p.bulbousness, 0.25);
  jitter(p.ap_ml_ratio, 0.05);
  if (tt) jitter(p.anterior_flattening, 0.03);
  else rng.next();
  jitter(p.posterior_fullness, 0.04);
  BoneTemplateParams& b = p.bones;
  jitter(b.tibia_plateau_width_m, 0.004);
  b.tibia_plateau_depth_m = 0.66 * b.tibia_plateau_width_m;
  // The bones' jitter, in the order the seed's draws are taken (a new row goes at the end).
  for (const BoneJitter& j : kBoneJitter) {
    if (j.transfemoral_only && tt) continue;
    if (j.relative) jitter_rel(b.*j.member, j.amount);
    else jitter(b.*j.member, j.amount);
  }
  return p;
}

std::pair<double, double> residual_length_range(LimbType type) {
  return type == LimbType::Transtibial ? std::pair{0.06, 0.30} : std::pair{0.10, 0.45};
}

void validate(const LimbShapeParams& p) {
  const bool tt = p.type == LimbType::Transtibial;
  const auto [lo, hi] = residual_length_range(p.type);
  check_range("residual_length_m", p.residual_length_m, lo, hi, " m", tt ? " for a transtibial limb" : " for a transfemoral limb");
  if (tt) check_range("proximal_extension_m", p.proximal_extension_m, 0.0, 0.12, " m");
  else check_range("proximal_extension_m", p.proximal_extension_m, 0.0, 0.15, " m", " above the ischial tuberosity");
  if (tt) check_range("proximal_circumference_m", p.proximal_circumference_m, 0.26, 0.60, " m", " for a transtibial limb");
  else check_range("proximal_circumference_m", p.proximal_circumference_m, 0.30, 0.80, " m", " for a transfemoral limb");
  check_range("distal_circumference_m", p.distal_circumference_m, 0.5 * p.proximal_circumference_m,
              1.1 * p.proximal_circumference_m, " m", ", 0.5 to 1.1 × the proximal circumference");
  check_range("distal_cap_height_m", p.distal_cap_height_m, 0.01, std::min(0.09, 0.5 * p.residual_length_m), " m",
              ", at most half the residual length");
  check_range("bulbousness", p.bulbousness, 0.0, 1.0, "");
  check_range("ap_ml_ratio", p.ap_ml_ratio, 0.6, 1.3, "");
  check_range("anterior_flattening", p.anterior_flattening, 0.0, 0.3, "");
  check_range("posterior_fullness", p.posterior_fullness, 0.0, 0.4, "");
  check_range("ring_vertices", p.ring_vertices, 24, 256, "");
  validate(p.bones);
}

}  // namespace socketsmith::volume
