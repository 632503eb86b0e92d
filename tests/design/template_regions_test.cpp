// A design read against its brim template: regions from the landmarks, area-weighted means, the
// axial load per node (normal component + the friction the design counts on) summing to the
// radar's F_z, the distal fifth, the coefficient of variation, and the first criteria.
#include <gtest/gtest.h>

#include <cmath>

#include "socketsmith/core/errors.h"
#include "socketsmith/design/template_regions.h"

namespace socketsmith::design {
namespace {
using Vec3 = Eigen::Vector3d;

volume::Landmark landmark(const std::string& code, const Vec3& p, double radius) {
  volume::Landmark l;
  l.code = code;
  l.position = p;
  l.radius_m = radius;
  return l;
}

/// Five skin nodes on a limb along +z of length 0.2 m: one at the patellar tendon (tolerant), one
/// at the fibular head (sensitive), one at the distal end (normal straight down), one on the side
/// wall facing out horizontally, one above the brim.
struct Sample {
  std::vector<Vec3> pos{{0, 0.05, 0.15}, {-0.05, 0, 0.14}, {0, 0, 0.0}, {0.05, 0, 0.08}, {0, 0.05, 0.19}};
  std::vector<Vec3> normal{{0, 1, 0}, {-1, 0, 0}, {0, 0, -1}, {1, 0, 0}, {0, 1, 0}};
  std::vector<double> area{2e-4, 1e-4, 1e-4, 1e-4, 1e-4};
  std::vector<double> p{30e3, 10e3, 8e3, 12e3, 50e3};
  std::vector<char> above{0, 0, 0, 0, 1};
  std::vector<volume::Landmark> marks{landmark("PT", {0, 0.05, 0.15}, 0.01), landmark("FH", {-0.05, 0, 0.14}, 0.01),
                                      landmark("POP", {0, -0.05, 0.15}, 0.01)};
  SkinLoads loads() const { return {&pos, &normal, &area, &p, &above}; }
  geometry::LimbFrame frame() const { return {}; }  // origin 0, axis +z, anterior +y
};

TEST(TemplateRegions, ptb_regions_means_axial_shares_and_criteria) {
  Sample s;
  const double mu = 0.5;
  const TemplateCheck c = check_template(BrimTemplate::Ptb, s.marks, s.loads(), s.frame(), 0.2, mu);
  // Axial load: the distal node's normal force (8 kPa × 1 cm²) plus μ p A on the three side nodes
  // below the brim and on the one above it (it presses too: F_z counts every node).
  const double distal = 8e3 * 1e-4, side = mu * (30e3 * 2e-4 + 10e3 * 1e-4 + 12e3 * 1e-4), above = mu * 50e3 * 1e-4;
  EXPECT_NEAR(c.total_axial_n, distal + side + above, 1e-9);
  EXPECT_EQ(c.tolerant.nodes, 1);  // POP has no node near it
  EXPECT_EQ(c.sensitive.nodes, 1);
  EXPECT_EQ(c.tolerant.codes, (std::vector<std::string>{"PT", "POP"}));
  EXPECT_NEAR(c.tolerant.mean_pa, 30e3, 1e-9);
  EXPECT_NEAR(c.sensitive.mean_pa, 10e3, 1e-9);
  EXPECT_NEAR(c.tolerant_to_sensitive, 3.0, 1e-12);
  EXPECT_NEAR(c.tolerant.axial_share, mu * 30e3 * 2e-4 / c.total_axial_n, 1e-12);
  // Distal fifth: heights ≤ 40 mm — the distal node only.
  EXPECT_EQ(c.distal_fifth.nodes, 1);
  EXPECT_NEAR(c.distal_fifth.axial_share, distal / c.total_axial_n, 1e-12);
  EXPECT_EQ(c.below_brim.nodes, 4);
  EXPECT_NEAR(c.below_brim.mean_pa, (30e3 * 2 + 10e3 + 8e3 + 12e3) / 5.0, 1e-9);
  EXPECT_TRUE(c.applies);
  // Tolerant 3 × sensitive holds; the distal fifth carries 0.8 / (0.8 + 4.1 + 2.5) N = 11 % > 10 %.
  EXPECT_FALSE(c.met);
  EXPECT_NE(c.summary.find("at most 10 %: no"), std::string::npos) << c.summary;
  // Less distal pressure: met.
  s.p[2] = 2e3;
  EXPECT_TRUE(check_template(BrimTemplate::Ptb, s.marks, s.loads(), s.frame(), 0.2, mu).met);
  // Sensitive regions loaded as much as the tolerant: not met.
  s.p[1] = 25e3;
  EXPECT_FALSE(check_template(BrimTemplate::PtbSc, s.marks, s.loads(), s.frame(), 0.2, mu).met);
}

TEST(TemplateRegions, tsb_asks_for_a_uniform_field_and_other_templates_have_no_table) {
  Sample s;
  s.p = {10e3, 10e3, 10e3, 10e3, 50e3};  // uniform below the brim
  const auto tsb = check_template(BrimTemplate::Tsb, s.marks, s.loads(), s.frame(), 0.2, 0.5);
  EXPECT_TRUE(tsb.applies);
  EXPECT_NEAR(tsb.cv_below_brim, 0.0, 1e-12);
  EXPECT_TRUE(tsb.met);
  s.p = {30e3, 2e3, 2e3, 2e3, 0};
  const auto uneven = check_template(BrimTemplate::Tsb, s.marks, s.loads(), s.frame(), 0.2, 0.5);
  // Area-weighted: mean (60 + 6) / 5 = 13.2 kPa, SD sqrt((2 × 16.8² + 3 × 11.2²) / 5) = 13.72 kPa.
  EXPECT_NEAR(uneven.cv_below_brim, std::sqrt((2 * 16.8 * 16.8 + 3 * 11.2 * 11.2) / 5) / 13.2, 1e-9);
  EXPECT_FALSE(uneven.met);
  const auto custom = check_template(BrimTemplate::Custom, s.marks, s.loads(), s.frame(), 0.2, 0.5);
  EXPECT_FALSE(custom.applies);
  EXPECT_FALSE(custom.met);
}

TEST(TemplateRegions, rejects_mismatched_arrays_and_a_bad_length) {
  Sample s;
  s.area.pop_back();
  EXPECT_THROW(check_template(BrimTemplate::Ptb, s.marks, s.loads(), s.frame(), 0.2, 0.5), InvalidInputError);
  Sample t;
  EXPECT_THROW(check_template(BrimTemplate::Ptb, t.marks, t.loads(), t.frame(), 0.0, 0.5), InvalidInputError);
  EXPECT_THROW(check_template(BrimTemplate::Ptb, t.marks, SkinLoads{}, t.frame(), 0.2, 0.5), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::design
