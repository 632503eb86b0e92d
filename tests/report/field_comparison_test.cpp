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

}  // namespace
}  // namespace socketsmith::report
