#include "socketsmith/report/field_comparison.h"

#include <cmath>

#include <gtest/gtest.h>

#include "socketsmith/core/errors.h"

namespace socketsmith::report {
namespace {

TEST(Comparison, known_values) {
  // a − b = (1, −1, 3, −3): MAE 2, SD of |e| 1, RMSE √5, bias 0, max 3 at index 2.
  const std::vector<double> b{1, 2, 3, 4}, a{2, 1, 6, 1};
  const auto s = compare_fields(a, b);
  EXPECT_EQ(s.count, 4);
  EXPECT_DOUBLE_EQ(s.mae, 2.0);
  EXPECT_DOUBLE_EQ(s.sd, 1.0);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(5.0));
  EXPECT_DOUBLE_EQ(s.bias, 0.0);
  EXPECT_DOUBLE_EQ(s.max_error, 3.0);
  EXPECT_EQ(s.max_index, 2);
  // Pearson R by hand: mean a 2.5, mean b 2.5; Σ da db = (−.5)(−1.5)+(−1.5)(−.5)+(3.5)(.5)+(−1.5)(1.5) = 0.75+0.75+1.75−2.25 = 1
  // Σ da² = .25+2.25+12.25+2.25 = 17, Σ db² = 5 → R = 1/√85.
  EXPECT_NEAR(s.r, 1 / std::sqrt(85.0), 1e-15);
}

TEST(Comparison, linear_relation_has_r_one_and_constant_field_has_no_r) {
  const std::vector<double> b{1, 2, 3, 4, 5};
  std::vector<double> a;
  for (double v : b) a.push_back(2 * v + 1);
  EXPECT_NEAR(compare_fields(a, b).r, 1.0, 1e-14);
  for (auto& v : a) v = -v;
  EXPECT_NEAR(compare_fields(a, b).r, -1.0, 1e-14);
  EXPECT_TRUE(std::isnan(compare_fields(std::vector<double>(5, 3.0), b).r));
}

TEST(Comparison, percentiles_are_nearest_rank_and_spreads_are_population_sds) {
  // Errors 1..100 (a − b = k): the 95th percentile is 95, the 99th 99; b constant has no spread.
  std::vector<double> a, b(100, 10.0);
  for (int k = 1; k <= 100; ++k) a.push_back(10.0 + k);
  const auto s = compare_fields(a, b);
  EXPECT_DOUBLE_EQ(s.p95, 95.0);
  EXPECT_DOUBLE_EQ(s.p99, 99.0);
  EXPECT_DOUBLE_EQ(s.max_error, 100.0);
  EXPECT_DOUBLE_EQ(s.sd_b, 0.0);
  EXPECT_NEAR(s.sd_a, std::sqrt((100.0 * 100.0 - 1) / 12), 1e-12);  // SD of 1..n: sqrt((n²−1)/12)
  // Four points: the 99th percentile is the largest error, the 95th too (ceil(0.95·4) = 4).
  const auto t = compare_fields({2, 1, 6, 1}, {1, 2, 3, 4});
  EXPECT_DOUBLE_EQ(t.p99, 3.0);
  EXPECT_DOUBLE_EQ(t.p95, 3.0);
}

TEST(Comparison, subset_and_non_finite_values) {
  const std::vector<double> a{1, NAN, 5, 7}, b{1, 2, 3, 0};
  const auto s = compare_fields(a, b, {0, 1, 2});
  EXPECT_EQ(s.count, 2);
  EXPECT_DOUBLE_EQ(s.mae, 1.0);
  EXPECT_EQ(s.max_index, 2);
  EXPECT_THROW(compare_fields(a, b, {4}), InvalidInputError);
  EXPECT_THROW(compare_fields(a, {1.0}), InvalidInputError);
  const auto j = to_json(s, 1e-3, "_kpa");
  EXPECT_DOUBLE_EQ(j["mae_kpa"].get<double>(), 1e-3);
  EXPECT_TRUE(j["r"].is_null() || j["r"].is_number());
}

TEST(Comparison, band_means_weigh_by_area_and_pool_the_deeper_bands) {
  // Points in bands 0 (above the brim: left out), 1, 2, 5 and 7 with deepest 3: 5 and 7 pool into 3.
  const std::vector<int> band{0, 1, 1, 2, 5, 7, 2};
  const std::vector<double> w{9, 1, 3, 2, 1, 3, 0};  // the last point weighs nothing: left out
  const std::vector<double> f{100, 10, 20, 5, 1, 5, 1e9};
  const std::vector<double> g{0, 1, 1, 2, NAN, 3, 0};  // a non-finite value drops its point from every field
  const auto m = band_means(band, w, {f, g}, 3);
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0].band, 1);
  EXPECT_EQ(m[0].count, 2);
  EXPECT_DOUBLE_EQ(m[0].area, 4.0);
  EXPECT_DOUBLE_EQ(m[0].mean[0], (1 * 10 + 3 * 20) / 4.0);
  EXPECT_DOUBLE_EQ(m[0].mean[1], 1.0);
  EXPECT_EQ(m[1].count, 1);
  EXPECT_DOUBLE_EQ(m[1].mean[0], 5.0);
  EXPECT_EQ(m[2].band, 3);
  EXPECT_EQ(m[2].count, 1);  // band 5's point has a NaN in g
  EXPECT_DOUBLE_EQ(m[2].mean[0], 5.0);
  EXPECT_DOUBLE_EQ(m[2].mean[1], 3.0);
  // An empty band is not listed; sizes must agree.
  EXPECT_EQ(band_means({3, 3}, {1, 1}, {{1, 2}}, 5).size(), 1u);
  EXPECT_THROW(band_means(band, w, {{1.0}}, 3), InvalidInputError);
  EXPECT_THROW(band_means(band, {1.0}, {f}, 3), InvalidInputError);
  EXPECT_THROW(band_means(band, w, {f}, 0), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::report
