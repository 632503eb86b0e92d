#include "socketsmith/report/delivery_bar.h"

#include <cmath>

#include <gtest/gtest.h>

#include "socketsmith/core/errors.h"

namespace socketsmith::report {
namespace {

// A design varying from 2 to 20 kPa (SD 5.5 kPa) delivered with a uniform error e at every node
// but the last k, which are off by big: MAE, p99 and R known by hand.
ErrorStats delivered_with(double e_pa, int k_big, double big_pa) {
  std::vector<double> design, delivered;
  for (int i = 0; i < 100; ++i) {
    design.push_back(2000.0 + 180.0 * (i % 101));
    delivered.push_back(design.back() + (i >= 100 - k_big ? big_pa : e_pa));
  }
  return compare_fields(delivered, design);
}

TEST(DeliveryBar, a_landmark_is_held_to_a_tenth_of_its_design_or_of_the_floor) {
  EXPECT_NEAR(landmark_deviation(0.5, 0.55), 0.1, 1e-15);
  EXPECT_NEAR(landmark_deviation(0.5, 0.45), 0.1, 1e-15);
  // Designed at 0.02 of its threshold: measured against the floor 0.1, so +0.005 is 5 %, not 25 %.
  EXPECT_NEAR(landmark_deviation(0.02, 0.025), 0.05, 1e-15);
  EXPECT_NEAR(landmark_deviation(0.02, 0.025, 0.01), 0.25, 1e-15);
  EXPECT_THROW(landmark_deviation(-0.1, 0.2), InvalidInputError);
  EXPECT_THROW(landmark_deviation(0.1, std::nan("")), InvalidInputError);
}

TEST(DeliveryBar, each_item_is_judged_and_named_when_missed) {
  // Uniform 1 kPa error everywhere: MAE 1, p99 1, R 1; landmarks 4 % and 0.005 of a low one.
  const auto good = judge_delivery(delivered_with(1000.0, 0, 0.0), {{"PT", 0.50, 0.52}, {"DT", 0.02, 0.025}});
  EXPECT_TRUE(good.met()) << good.summary();
  EXPECT_EQ(good.summary(), "met");
  EXPECT_TRUE(good.r_judged);
  EXPECT_EQ(good.worst_landmark, "DT");
  EXPECT_NEAR(good.worst_landmark_deviation, 0.05, 1e-12);

  // 3 nodes of 100 off by 9 kPa: p99 9 kPa > 4, MAE 0.561 kPa and R 0.970 still within; POP 12 % over.
  const auto bad = judge_delivery(delivered_with(300.0, 3, 9000.0), {{"POP", 0.25, 0.28}, {"FH", 0.30, 0.31}});
  EXPECT_TRUE(bad.mae_met);
  EXPECT_FALSE(bad.p99_met);
  EXPECT_FALSE(bad.landmarks_met);
  EXPECT_FALSE(bad.met());
  ASSERT_EQ(bad.failing.size(), 2u);
  EXPECT_EQ(bad.failing[0], "99th percentile 9.00 kPa > 4");
  EXPECT_EQ(bad.failing[1], "POP +12 % (0.250 → 0.280 of its threshold)");
  EXPECT_EQ(bad.summary(), "not met: 99th percentile 9.00 kPa > 4; POP +12 % (0.250 → 0.280 of its threshold)");

  // A landmark designed under the floor is named by its change in threshold units.
  const auto low = judge_delivery(delivered_with(0.0, 0, 0.0), {{"DT", 0.014, 0.030}});
  ASSERT_EQ(low.failing.size(), 1u);
  EXPECT_EQ(low.failing[0], "DT +0.016 of its threshold (0.014 → 0.030; designed under 0.1)");
}

TEST(DeliveryBar, r_is_judged_only_where_the_design_varies) {
  // A flat 10 kPa design delivered with noise of ±0.5 kPa: R near 0, but it measures noise only.
  std::vector<double> design(200, 10000.0), delivered;
  for (int i = 0; i < 200; ++i) delivered.push_back(10000.0 + (i % 2 ? 500.0 : -500.0) * (1 + (i % 7) / 7.0));
  const auto flat = judge_delivery(compare_fields(delivered, design), {});
  EXPECT_FALSE(flat.r_judged);
  EXPECT_TRUE(flat.r_met);
  EXPECT_TRUE(flat.met()) << flat.summary();
  // ±1.4 kPa of noise on a varying design: judged once its SD reaches 2 kPa, and R 0.929 fails.
  std::vector<double> varying, noisy;
  for (int i = 0; i < 200; ++i) {
    varying.push_back(10000.0 + (i % 10) * 500.0);               // SD 1.44 kPa: too flat to judge
    noisy.push_back(varying.back() + (i % 3 - 1) * 1400.0);
  }
  EXPECT_FALSE(judge_delivery(compare_fields(noisy, varying), {}).r_judged);
  for (auto& v : varying) v = 10000.0 + (v - 10000.0) * 2;      // SD 2.87 kPa
  for (int i = 0; i < 200; ++i) noisy[i] = varying[i] + (i % 3 - 1) * 1400.0;
  const auto judged = judge_delivery(compare_fields(noisy, varying), {});
  EXPECT_TRUE(judged.r_judged);
  EXPECT_FALSE(judged.r_met);
  EXPECT_NE(judged.summary().find("R 0."), std::string::npos) << judged.summary();
  EXPECT_THROW(judge_delivery(ErrorStats{}, {}), InvalidInputError);
}

TEST(DeliveryBar, each_path_is_held_to_the_same_bar_as_the_nodes_below_the_brim) {
  // Below the brim within the bar; the back line's 20 nodes hold one 6 kPa error: its 99th percentile
  // (its largest error) fails while the nodes below the brim, 100 of them with 1 off, keep theirs.
  const ErrorStats below = delivered_with(300.0, 1, 6000.0);
  ASSERT_LE(below.p99, 6000.0);
  std::vector<double> design, delivered;
  for (int i = 0; i < 20; ++i) {
    design.push_back(2000.0 + 900.0 * i);  // SD 5.2 kPa: R judged
    delivered.push_back(design.back() + (i == 19 ? 6000.0 : 200.0));
  }
  const ErrorStats back = compare_fields(delivered, design);
  // The mid circumference nearly flat (SD 0.6 kPa) and noisy: R not judged there, MAE and p99 within.
  std::vector<double> flat, noisy;
  for (int i = 0; i < 30; ++i) {
    flat.push_back(10000.0 + (i % 3) * 700.0);
    noisy.push_back(flat.back() + (i % 2 ? 600.0 : -600.0));
  }
  const ErrorStats mid = compare_fields(noisy, flat);
  const auto with_paths = judge_delivery(delivered_with(300.0, 0, 0.0), {}, {{"back line", back}, {"mid circumference", mid}});
  EXPECT_TRUE(with_paths.mae_met && with_paths.p99_met && with_paths.r_met && with_paths.landmarks_met);
  EXPECT_FALSE(with_paths.paths_met);
  EXPECT_FALSE(with_paths.met());
  ASSERT_EQ(with_paths.paths_failing, std::vector<std::string>{"back line"});
  EXPECT_EQ(with_paths.summary(), "not met: back line: 99th percentile 6.00 kPa > 4");
  // The same without the back line: met; a path with no node is skipped.
  const auto mid_only = judge_delivery(delivered_with(300.0, 0, 0.0), {}, {{"mid circumference", mid}, {"front line", {}}});
  EXPECT_TRUE(mid_only.met()) << mid_only.summary();
  // A path designed from 2 to 9.6 kPa (SD 2.3 kPa) delivered with ±1.4 kPa of noise: MAE and p99
  // within, R ≈ 0.85: it fails on R alone.
  std::vector<double> gentle, jittered;
  for (int i = 0; i < 20; ++i) {
    gentle.push_back(2000.0 + 400.0 * i);
    jittered.push_back(gentle.back() + (i % 2 ? 1400.0 : -1400.0));
  }
  const auto r_only = judge_delivery(delivered_with(300.0, 0, 0.0), {}, {{"front line", compare_fields(jittered, gentle)}});
  EXPECT_FALSE(r_only.paths_met);
  ASSERT_EQ(r_only.failing.size(), 1u) << r_only.summary();
  EXPECT_EQ(r_only.failing[0].rfind("front line: R 0.", 0), 0u) << r_only.summary();
  const auto j = to_json(with_paths);
  EXPECT_FALSE(j.at("paths_met").get<bool>());
  EXPECT_EQ(j.at("paths_failing").at(0).get<std::string>(), "back line");
}

TEST(DeliveryBar, its_words_are_its_numbers) {
  EXPECT_EQ(describe(), "below the brim and on each path: MAE ≤ 1.5 kPa, 99th percentile ≤ 4 kPa, R ≥ 0.95 where the design varies, "
                        "landmarks within 10 %");
  DeliveryBar b;
  b.p99_pa = 3500;
  b.landmark_tolerance = 0.05;
  EXPECT_EQ(describe(b), "below the brim and on each path: MAE ≤ 1.5 kPa, 99th percentile ≤ 3.5 kPa, R ≥ 0.95 where the design varies, "
                         "landmarks within 5 %");
}

TEST(DeliveryBar, its_json_carries_the_verdict_and_the_bar) {
  const auto v = judge_delivery(delivered_with(300.0, 3, 9000.0), {{"POP", 0.25, 0.28}});
  const auto j = to_json(v);
  EXPECT_FALSE(j.at("met").get<bool>());
  EXPECT_EQ(j.at("summary").get<std::string>(), v.summary());
  EXPECT_TRUE(j.at("mae_met").get<bool>());
  EXPECT_EQ(j.at("worst_landmark").get<std::string>(), "POP");
  EXPECT_EQ(j.at("failing").size(), 2u);
  EXPECT_DOUBLE_EQ(j.at("bar").at("p99_kpa").get<double>(), 4.0);
  EXPECT_DOUBLE_EQ(j.at("bar").at("landmark_floor_ratio").get<double>(), 0.1);
}

}  // namespace
}  // namespace socketsmith::report
