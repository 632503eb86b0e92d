// Pressure spots (thesis Tables 5–6): the key functions against their formulas, periodicity in θ,
// the four spot types, the summed field, validation messages and the type names.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <numbers>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/spots.h"

namespace socketsmith::design {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = units::deg, kMm = units::mm;

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

/// Table 5's formulas written out independently of the library.
double cos_formula(double x, double x0, double r) {
  return std::abs(x - x0) <= r ? 0.5 * (1.0 + std::cos(kPi * (x - x0) / r)) : 0.0;
}
double sig_formula(double x, double x1, double x2, double l) {
  return 1.0 / (1.0 + std::exp(-l * (x - x1))) * 1.0 / (1.0 + std::exp(l * (x - x2)));
}

TEST(KeyFunctions, cos_is_one_at_the_centre_zero_at_the_ends_and_outside) {
  const double x0 = 0.07, r = 0.02;
  EXPECT_DOUBLE_EQ(key_cos(x0, x0, r), 1.0);
  EXPECT_NEAR(key_cos(x0 + r, x0, r), 0.0, 1e-15);
  EXPECT_NEAR(key_cos(x0 - r, x0, r), 0.0, 1e-15);
  EXPECT_EQ(key_cos(x0 + 1.001 * r, x0, r), 0.0);
  EXPECT_EQ(key_cos(x0 - 3 * r, x0, r), 0.0);
  EXPECT_NEAR(key_cos(x0 + 0.5 * r, x0, r), 0.5, 1e-14);
  for (double x : {0.051, 0.06, 0.0733, 0.085, 0.0899}) EXPECT_NEAR(key_cos(x, x0, r), cos_formula(x, x0, r), 1e-14) << x;
}

TEST(KeyFunctions, sig_is_one_inside_half_at_the_edges_and_follows_the_formula) {
  const double x1 = 0.02, x2 = 0.08, l = 400.0;
  EXPECT_NEAR(key_sig(0.05, x1, x2, l), 1.0, 2e-5);  // 1 − 2e^{−12}
  // At an edge one factor is exactly ½, the other is the far logistic.
  EXPECT_NEAR(key_sig(x1, x1, x2, l), 0.5 / (1.0 + std::exp(l * (x1 - x2))), 1e-15);
  EXPECT_NEAR(key_sig(x2, x1, x2, l), 0.5 / (1.0 + std::exp(-l * (x2 - x1))), 1e-15);
  EXPECT_NEAR(key_sig(x1, x1, x2, l), 0.5, 1e-9);
  EXPECT_LT(key_sig(0.0, x1, x2, l), 1e-3);
  EXPECT_LT(key_sig(0.1, x1, x2, l), 1e-3);
  for (double x : {0.0, 0.015, 0.021, 0.05, 0.079, 0.09})
    EXPECT_NEAR(key_sig(x, x1, x2, l), sig_formula(x, x1, x2, l), 1e-14) << x;
  // A soft sigmoid (λ small): the formula, not a clipped version of it.
  EXPECT_NEAR(key_sig(0.05, x1, x2, 30.0), sig_formula(0.05, x1, x2, 30.0), 1e-14);
  EXPECT_LT(key_sig(0.05, x1, x2, 30.0), 0.6);  // (1 + e^{−0.9})^{−2} ≈ 0.505
  // No overflow far outside with a steep λ.
  EXPECT_EQ(key_sig(-10.0, x1, x2, 1e4), 0.0);
  EXPECT_TRUE(std::isfinite(key_sig(10.0, x1, x2, 1e4)));
}

TEST(KeyFunctions, rmp_is_one_below_linear_between_zero_above) {
  const double x1 = 0.02, x2 = 0.06;
  EXPECT_EQ(key_rmp(0.0, x1, x2), 1.0);
  EXPECT_EQ(key_rmp(0.019, x1, x2), 1.0);
  EXPECT_DOUBLE_EQ(key_rmp(x1, x1, x2), 1.0);
  EXPECT_NEAR(key_rmp(0.03, x1, x2), 0.75, 1e-14);
  EXPECT_NEAR(key_rmp(0.04, x1, x2), 0.5, 1e-14);
  EXPECT_NEAR(key_rmp(x2, x1, x2), 0.0, 1e-15);
  EXPECT_EQ(key_rmp(0.07, x1, x2), 0.0);
}

TEST(KeyFunctions, wrap_angle_maps_into_minus_pi_exclusive_to_pi) {
  EXPECT_NEAR(wrap_angle(kPi), kPi, 1e-15);
  EXPECT_NEAR(wrap_angle(-kPi), kPi, 1e-15);
  EXPECT_NEAR(wrap_angle(3 * kPi), kPi, 1e-12);
  EXPECT_NEAR(wrap_angle(2 * kPi + 0.1), 0.1, 1e-12);
  EXPECT_NEAR(wrap_angle(-190 * kDeg), 170 * kDeg, 1e-12);
  EXPECT_NEAR(wrap_angle(-0.3), -0.3, 1e-15);
}

Spot cos2(double a, double theta0, double r_theta, double h0, double r_h) {
  Spot s;
  s.name = "c";
  s.type = SpotType::Cos2;
  s.amplitude_pa = a;
  s.theta0 = theta0;
  s.r_theta = r_theta;
  s.h0 = h0;
  s.r_h = r_h;
  return s;
}

TEST(Spots, cos2_is_the_product_of_two_cos_and_reaches_across_the_seam) {
  const Spot s = cos2(20e3, 170 * kDeg, 30 * kDeg, 0.06, 0.02);
  EXPECT_DOUBLE_EQ(spot_pressure(s, 170 * kDeg, 0.06), 20e3);
  // −170° is 20° from 170° across ±180°.
  EXPECT_NEAR(spot_shape(s, -170 * kDeg, 0.06), cos_formula(20, 0, 30), 1e-12);
  EXPECT_NEAR(spot_shape(s, -170 * kDeg, 0.06), 0.25, 1e-12);
  EXPECT_NEAR(spot_shape(s, 190 * kDeg, 0.06), 0.25, 1e-12);  // unwrapped input, same point
  EXPECT_NEAR(spot_shape(s, -150 * kDeg, 0.06), 0.0, 1e-12);
  EXPECT_EQ(spot_shape(s, -120 * kDeg, 0.06), 0.0);
  EXPECT_EQ(spot_shape(s, 0.0, 0.06), 0.0);
  // Product with COS in h.
  EXPECT_NEAR(spot_pressure(s, -170 * kDeg, 0.07), 20e3 * 0.25 * 0.5, 1e-8);
  EXPECT_EQ(spot_pressure(s, 170 * kDeg, 0.081), 0.0);
}

TEST(Spots, sig2_sector_may_cross_the_seam) {
  Spot s;
  s.name = "posterior";
  s.type = SpotType::Sig2;
  s.amplitude_pa = 1.0;
  s.theta1 = 150 * kDeg;
  s.theta2 = -150 * kDeg;  // 60° through 180°
  s.lambda_theta = 40.0;
  s.h1 = 0.02;
  s.h2 = 0.08;
  s.lambda_h = 400.0;
  const double fh = key_sig(0.05, s.h1, s.h2, s.lambda_h);
  EXPECT_GT(spot_shape(s, kPi, 0.05), 0.99);
  EXPECT_GT(spot_shape(s, -kPi + 1e-9, 0.05), 0.99);
  EXPECT_GT(spot_shape(s, 165 * kDeg, 0.05), 0.99);
  EXPECT_GT(spot_shape(s, -165 * kDeg, 0.05), 0.99);
  EXPECT_LT(spot_shape(s, 0.0, 0.05), 1e-6);
  EXPECT_LT(spot_shape(s, 90 * kDeg, 0.05), 1e-6);
  EXPECT_LT(spot_shape(s, -90 * kDeg, 0.05), 1e-6);
  // Edges: half (times the far factor), as SIG's formula on the unwrapped interval.
  const double w = 60 * kDeg;
  EXPECT_NEAR(spot_shape(s, 150 * kDeg, 0.05), fh * sig_formula(-w / 2, -w / 2, w / 2, 40.0), 1e-12);
  EXPECT_NEAR(spot_shape(s, -150 * kDeg, 0.05), fh * sig_formula(w / 2, -w / 2, w / 2, 40.0), 1e-12);
  EXPECT_NEAR(spot_shape(s, 170 * kDeg, 0.05), fh * sig_formula(20 * kDeg, 0, w, 40.0), 1e-12);
  // The complementary sector (−150° → 150°) is the other 300°.
  std::swap(s.theta1, s.theta2);
  EXPECT_LT(spot_shape(s, kPi, 0.05), 1e-6);
  EXPECT_GT(spot_shape(s, 0.0, 0.05), 0.99);
  double theta = 0, h = 0;
  std::swap(s.theta1, s.theta2);
  spot_centre(s, theta, h);
  EXPECT_NEAR(std::abs(wrap_angle(theta - kPi)), 0.0, 1e-12);
  EXPECT_NEAR(h, 0.05, 1e-15);
}

TEST(Spots, cos_sig_and_grad_follow_their_key_functions) {
  Spot cs;
  cs.type = SpotType::CosSig;
  cs.amplitude_pa = 8e3;
  cs.theta0 = -60 * kDeg;
  cs.r_theta = 30 * kDeg;
  cs.h1 = 0.03;
  cs.h2 = 0.09;
  cs.lambda_h = 200;
  for (double th : {-80.0, -60.0, -45.0, -31.0, 0.0})
    for (double h : {0.0, 0.03, 0.06, 0.1})
      EXPECT_NEAR(spot_pressure(cs, th * kDeg, h), 8e3 * cos_formula(th, -60, 30) * sig_formula(h, 0.03, 0.09, 200), 1e-9)
          << th << " " << h;

  Spot g;
  g.type = SpotType::Grad;
  g.amplitude_pa = 5e3;
  g.h1 = 0.02;
  g.h2 = 0.06;
  for (double th : {-179.0, -90.0, 0.0, 45.0, 180.0}) {  // no θ dependence
    EXPECT_DOUBLE_EQ(spot_pressure(g, th * kDeg, 0.0), 5e3);
    EXPECT_DOUBLE_EQ(spot_pressure(g, th * kDeg, 0.019), 5e3);  // full below h1
    EXPECT_NEAR(spot_pressure(g, th * kDeg, 0.05), 5e3 * 0.25, 1e-9);
    EXPECT_EQ(spot_pressure(g, th * kDeg, 0.061), 0.0);
  }
}

TEST(Spots, field_is_the_sum_of_the_enabled_spots) {
  const Spot a = cos2(10e3, 0.0, 40 * kDeg, 0.05, 0.03);
  const Spot b = cos2(4e3, 20 * kDeg, 60 * kDeg, 0.06, 0.04);
  Spot off = cos2(100e3, 10 * kDeg, 60 * kDeg, 0.05, 0.05);
  off.enabled = false;
  EXPECT_EQ(spot_pressure(off, 10 * kDeg, 0.05), 0.0);
  EXPECT_DOUBLE_EQ(spot_shape(off, 10 * kDeg, 0.05), 1.0);  // the shape is there, the pressure is not
  for (double th : {-30.0, 0.0, 10.0, 35.0})
    for (double h : {0.03, 0.05, 0.07}) {
      const double expect = 10e3 * cos_formula(th, 0, 40) * cos_formula(h, 0.05, 0.03) +
                            4e3 * cos_formula(th, 20, 60) * cos_formula(h, 0.06, 0.04);
      EXPECT_NEAR(field_pressure({a, b, off}, th * kDeg, h), expect, 1e-8) << th << " " << h;
    }
  EXPECT_EQ(field_pressure({}, 0.0, 0.05), 0.0);
}

TEST(SpotValidation, valid_spots_pass_and_each_bad_field_is_named) {
  const double L = 0.15;
  Spot s = cos2(10e3, 0.0, 30 * kDeg, 0.08, 0.02);
  s.name = "PT";
  EXPECT_NO_THROW(validate_spot(s, L));

  auto expect_msg = [&](const Spot& bad, const std::string& part) {
    const std::string msg = message_of([&] { validate_spot(bad, L); });
    EXPECT_NE(msg.find(part), std::string::npos) << "expected '" << part << "' in: " << msg;
    EXPECT_NE(msg.find("PT"), std::string::npos) << msg;  // names the spot
    EXPECT_THROW(validate_spot(bad, L), InvalidInputError);
  };
  Spot above = s;
  above.h0 = 0.3;  // 300 mm on a 150 mm limb
  expect_msg(above, "off the limb");
  expect_msg(above, "h0_mm");
  Spot below = s;
  below.h0 = -0.05;
  expect_msg(below, "off the limb");
  Spot neg = s;
  neg.amplitude_pa = -1e3;
  expect_msg(neg, "negative");
  Spot zero_w = s;
  zero_w.r_theta = 0.0;
  expect_msg(zero_w, "r_theta");
  Spot neg_w = s;
  neg_w.r_theta = -0.1;
  expect_msg(neg_w, "r_theta");
  Spot wide = s;
  wide.r_theta = 4.0;  // > π
  expect_msg(wide, "r_theta");
  Spot rh = s;
  rh.r_h = 0.0;
  expect_msg(rh, "r_h");
  Spot nan_a = s;
  nan_a.amplitude_pa = std::numeric_limits<double>::quiet_NaN();
  expect_msg(nan_a, "not a finite number");
  Spot nan_t = s;
  nan_t.theta0 = std::numeric_limits<double>::quiet_NaN();
  expect_msg(nan_t, "theta0");
  Spot nan_h = s;
  nan_h.h0 = std::numeric_limits<double>::quiet_NaN();
  expect_msg(nan_h, "not a finite number");

  Spot g;
  g.name = "PT";
  g.type = SpotType::Grad;
  g.amplitude_pa = 5e3;
  g.h1 = 0.02;
  g.h2 = 0.05;
  EXPECT_NO_THROW(validate_spot(g, L));
  Spot inv = g;
  inv.h2 = inv.h1;
  expect_msg(inv, "must be above h1");
  inv.h2 = 0.01;
  expect_msg(inv, "must be above h1");

  Spot sg;
  sg.name = "PT";
  sg.type = SpotType::Sig2;
  sg.amplitude_pa = 1e3;
  EXPECT_NO_THROW(validate_spot(sg, L));
  Spot lam = sg;
  lam.lambda_h = -1;
  expect_msg(lam, "lambda_h");
  lam = sg;
  lam.lambda_theta = 0;
  expect_msg(lam, "lambda_theta");
  Spot empty = sg;
  empty.theta2 = empty.theta1;  // a zero-width sector
  expect_msg(empty, "empty sector");
}

TEST(SpotType, names_round_trip_and_unknown_names_list_the_valid_ones) {
  for (auto t : {SpotType::Cos2, SpotType::Sig2, SpotType::CosSig, SpotType::Grad}) EXPECT_EQ(parse_spot_type(to_string(t)), t);
  EXPECT_EQ(to_string(SpotType::CosSig), "cos-sig");
  EXPECT_EQ(parse_spot_type("COS2"), SpotType::Cos2);
  EXPECT_EQ(parse_spot_type("GRAD"), SpotType::Grad);
  const std::string msg = message_of([] { parse_spot_type("cos3"); });
  EXPECT_NE(msg.find("'cos3'"), std::string::npos) << msg;
  for (const char* name : {"cos2", "sig2", "cos-sig", "grad"}) EXPECT_NE(msg.find(name), std::string::npos) << msg;
  EXPECT_THROW(parse_spot_type(""), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::design
