// Pain-threshold map: Table 7's defaults, inverse-distance weighting (exact at the landmarks,
// bounded, continuous, the analytic two-point case) and the validation messages.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <limits>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/pain_map.h"
#include "socketsmith/volume/limb_generator.h"

namespace socketsmith::design {
namespace {

using geometry::LimbType;
using Eigen::Vector3d;

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

const volume::GeneratedLimb& tt_limb() {
  static const volume::GeneratedLimb limb = volume::generate_limb(volume::default_params(LimbType::Transtibial, 3));
  return limb;
}
const volume::GeneratedLimb& tf_limb() {
  static const volume::GeneratedLimb limb = volume::generate_limb(volume::default_params(LimbType::Transfemoral, 3));
  return limb;
}

volume::Landmark landmark(const std::string& code, const Vector3d& p) {
  volume::Landmark l;
  l.code = code;
  l.position = p;
  return l;
}

TEST(PainThresholds, defaults_are_the_thesis_table_7) {
  const auto t = default_thresholds(LimbType::Transtibial);
  ASSERT_EQ(t.size(), 5u);
  EXPECT_DOUBLE_EQ(t.at("MF"), 53.7e3);
  EXPECT_DOUBLE_EQ(t.at("PT"), 189.72e3);
  EXPECT_DOUBLE_EQ(t.at("FH"), 45.85e3);
  EXPECT_DOUBLE_EQ(t.at("POP"), 60.86e3);
  EXPECT_DOUBLE_EQ(t.at("AD"), 98.77e3);
  const auto codes = required_threshold_codes(LimbType::Transtibial);
  for (const auto& [code, v] : t) EXPECT_NE(std::find(codes.begin(), codes.end(), code), codes.end()) << code;
  // Transfemoral (docs/design.md: cited, or assumed where the literature gives none).
  const auto tf = default_thresholds(LimbType::Transfemoral);
  EXPECT_EQ(required_threshold_codes(LimbType::Transfemoral),
            (std::vector<std::string>{"IS", "IR", "GT", "AL", "ST", "DF"}));
  ASSERT_EQ(tf.size(), 6u);
  EXPECT_DOUBLE_EQ(tf.at("IS"), 95.0e3);
  EXPECT_DOUBLE_EQ(tf.at("IR"), 42.9e3);
  EXPECT_DOUBLE_EQ(tf.at("GT"), 45.85e3);
  EXPECT_DOUBLE_EQ(tf.at("AL"), 34.0e3);
  EXPECT_DOUBLE_EQ(tf.at("ST"), 60.86e3);
  EXPECT_DOUBLE_EQ(tf.at("DF"), 45.85e3);
}

TEST(PainThresholds, idw_of_two_points_matches_the_hand_computation) {
  const std::vector<volume::Landmark> lms = {landmark("A", Vector3d(0, 0, 0)), landmark("B", Vector3d(0.1, 0, 0))};
  const ThresholdTable table = {{"A", 10e3}, {"B", 30e3}};
  const auto t = threshold_map({Vector3d(0.05, 0, 0), Vector3d(0.025, 0, 0), Vector3d(0.05, 0.05, 0)}, lms, table);
  EXPECT_NEAR(t[0], 20e3, 1e-9);
  // d_A = 0.025, d_B = 0.075: weights 1/d² in the ratio 9 : 1 → (9·10 + 30) / 10 kPa.
  EXPECT_NEAR(t[1], 12e3, 1e-9);
  EXPECT_NEAR(t[2], 20e3, 1e-9);  // equidistant
  // Power 1: weights 3 : 1 → (3·10 + 30) / 4 kPa.
  EXPECT_NEAR(threshold_map({Vector3d(0.025, 0, 0)}, lms, table, 1.0)[0], 15e3, 1e-9);
  // A landmark without a threshold does not count.
  auto lms3 = lms;
  lms3.push_back(landmark("C", Vector3d(0.025, 0.001, 0)));
  EXPECT_NEAR(threshold_map({Vector3d(0.025, 0, 0)}, lms3, table)[0], 12e3, 1e-9);
}

TEST(PainThresholds, idw_on_a_limb_is_exact_at_landmarks_bounded_and_continuous) {
  const auto& limb = tt_limb();
  const auto table = default_thresholds(LimbType::Transtibial);
  std::vector<Vector3d> at;
  std::vector<double> expect;
  for (const auto& l : limb.landmarks)
    if (table.count(l.code)) {
      at.push_back(l.position);
      expect.push_back(table.at(l.code));
    }
  ASSERT_EQ(at.size(), 5u);
  const auto exact = threshold_map(at, limb.landmarks, table);
  for (size_t k = 0; k < at.size(); ++k) EXPECT_EQ(exact[k], expect[k]) << k;

  // Close to a landmark: close to its value, and closer as the distance shrinks.
  for (size_t k = 0; k < at.size(); ++k) {
    const Vector3d dir = Vector3d(1, 2, 3).normalized();
    const auto near = threshold_map({at[k] + 1e-3 * dir, at[k] + 1e-4 * dir}, limb.landmarks, table);
    EXPECT_NEAR(near[0], expect[k], 0.01 * expect[k]) << k;
    EXPECT_NEAR(near[1], expect[k], 1e-4 * expect[k]) << k;
    EXPECT_LT(std::abs(near[1] - expect[k]), std::abs(near[0] - expect[k])) << k;
    EXPECT_NE(near[0], expect[k]) << k;  // not a nearest-neighbour map
  }
  // Elsewhere on the skin: strictly between the smallest and largest thresholds.
  const auto all = threshold_map(limb.skin.vertices, limb.landmarks, table);
  ASSERT_EQ(all.size(), limb.skin.vertices.size());
  const auto [lo, hi] = std::minmax_element(all.begin(), all.end());
  EXPECT_GE(*lo, 45.85e3);
  EXPECT_LE(*hi, 189.72e3);
  EXPECT_GT(*hi - *lo, 50e3);  // the map varies over the limb
}

TEST(PainThresholds, idw_rejects_no_source_and_bad_power) {
  const std::vector<volume::Landmark> lms = {landmark("A", Vector3d::Zero())};
  EXPECT_THROW(threshold_map({Vector3d::UnitX()}, lms, {{"B", 1e3}}), InvalidInputError);
  EXPECT_THROW(threshold_map({Vector3d::UnitX()}, lms, {{"A", 1e3}}, 0.0), InvalidInputError);
  EXPECT_THROW(threshold_map({Vector3d::UnitX()}, lms, {{"A", 1e3}}, std::numeric_limits<double>::quiet_NaN()),
               InvalidInputError);
}

TEST(PainThresholds, validation_names_the_landmark_and_the_fix) {
  const auto& lms = tt_limb().landmarks;
  const auto good = default_thresholds(LimbType::Transtibial);
  EXPECT_NO_THROW(validate_thresholds(good, lms, LimbType::Transtibial));
  auto with_lf = good;
  with_lf["LF"] = 70e3;  // an extra landmark of the limb is fine
  EXPECT_NO_THROW(validate_thresholds(with_lf, lms, LimbType::Transtibial));

  auto expect_msg = [&](const ThresholdTable& t, const std::vector<std::string>& parts) {
    const std::string msg = message_of([&] { validate_thresholds(t, lms, LimbType::Transtibial); });
    for (const auto& part : parts) EXPECT_NE(msg.find(part), std::string::npos) << "expected '" << part << "' in: " << msg;
    EXPECT_THROW(validate_thresholds(t, lms, LimbType::Transtibial), InvalidInputError);
  };
  auto missing = good;
  missing.erase("FH");
  expect_msg(missing, {"pain threshold missing for landmark FH", "45.85"});
  auto unknown = good;
  unknown["XYZ"] = 50e3;
  expect_msg(unknown, {"'XYZ'", "not a landmark"});
  for (double bad : {0.0, -10e3, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    auto t = good;
    t["POP"] = bad;
    expect_msg(t, {"landmark POP", "positive pressure"});
  }
  auto absurd = good;
  absurd["PT"] = 189.72e6;  // kPa read as Pa twice over: 189 720 kPa
  expect_msg(absurd, {"landmark PT", "unit", "kPa"});
  absurd["PT"] = 2.5e6;
  expect_msg(absurd, {"landmark PT", "unit"});
}

TEST(PainThresholds, transfemoral_defaults_cover_its_landmarks_and_old_codes_are_named) {
  const auto& lms = tf_limb().landmarks;
  EXPECT_NO_THROW(validate_thresholds(default_thresholds(LimbType::Transfemoral), lms, LimbType::Transfemoral));
  auto missing = default_thresholds(LimbType::Transfemoral);
  missing.erase("IS");
  const std::string msg = message_of([&] { validate_thresholds(missing, lms, LimbType::Transfemoral); });
  EXPECT_NE(msg.find("pain threshold missing for landmark IS"), std::string::npos) << msg;
  EXPECT_NE(msg.find("95.00 kPa"), std::string::npos) << msg;
  // The former code AR is named with its replacements.
  auto old = default_thresholds(LimbType::Transfemoral);
  old["AR"] = 60e3;
  const std::string ar = message_of([&] { validate_thresholds(old, lms, LimbType::Transfemoral); });
  EXPECT_NE(ar.find("IR"), std::string::npos) << ar;
  EXPECT_NE(ar.find("AL"), std::string::npos) << ar;
  // A transtibial code on a transfemoral limb is not a landmark there.
  auto wrong = default_thresholds(LimbType::Transfemoral);
  wrong["PT"] = 190e3;
  EXPECT_NE(message_of([&] { validate_thresholds(wrong, lms, LimbType::Transfemoral); }).find("not a landmark"),
            std::string::npos);
}

}  // namespace
}  // namespace socketsmith::design
