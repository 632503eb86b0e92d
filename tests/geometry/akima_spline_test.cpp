// Akima splines: interpolation, C1 continuity (also across the periodic seam), exactness on
// linear/constant data, no overshoot on a step, derivatives by finite differences, bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/akima_spline.h"

namespace socketsmith::geometry {
namespace {

constexpr double kPi = std::numbers::pi;

// An irregular brim-like data set, deliberately unsorted and with angles outside (−pi, pi].
const std::vector<double> kTheta = {0.1, 2.0, -2.5, 3.3, -0.9, 1.0, -1.7, 0.55, 2.7 + 2 * kPi};
const std::vector<double> kH = {0.16, 0.15, 0.14, 0.12, 0.18, 0.19, 0.175, 0.17, 0.13};

TEST(PeriodicAkimaSpline, reproduces_its_key_points_in_any_order_and_wrapping) {
  const PeriodicAkimaSpline s(kTheta, kH);
  for (std::size_t i = 0; i < kTheta.size(); ++i) {
    EXPECT_NEAR(s.value(kTheta[i]), kH[i], 1e-12) << "key " << i;
    EXPECT_NEAR(s.value(kTheta[i] + 2 * kPi), kH[i], 1e-12);
    EXPECT_NEAR(s.value(kTheta[i] - 4 * kPi), kH[i], 1e-12);
  }
  ASSERT_EQ(s.knots().size(), kTheta.size() + 1);
  for (std::size_t i = 0; i + 1 < s.knots().size(); ++i) EXPECT_LT(s.knots()[i], s.knots()[i + 1]);
}

TEST(PeriodicAkimaSpline, is_c1_everywhere_including_the_period_seam) {
  const PeriodicAkimaSpline s(kTheta, kH);
  std::vector<double> probes = s.knots();  // knots are where the cubics meet
  probes.push_back(kPi);
  probes.push_back(-kPi);
  const double e = 1e-7;
  for (double x : probes) {
    EXPECT_NEAR(s.value(x - e), s.value(x + e), 1e-6) << "value jump at " << x;
    EXPECT_NEAR(s.derivative(x - e), s.derivative(x + e), 1e-5) << "slope jump at " << x;
  }
  // Value and slope match across one whole period.
  EXPECT_NEAR(s.value(-kPi + 1e-12), s.value(kPi), 1e-9);
  EXPECT_NEAR(s.derivative(-kPi + 1e-12), s.derivative(kPi), 1e-8);
}

TEST(PeriodicAkimaSpline, derivative_matches_finite_differences) {
  const PeriodicAkimaSpline s(kTheta, kH);
  const double e = 1e-6;
  for (double x = -7.0; x < 7.0; x += 0.173) {
    const double fd = (s.value(x + e) - s.value(x - e)) / (2 * e);
    EXPECT_NEAR(s.derivative(x), fd, 1e-6) << "at " << x;
  }
}

TEST(PeriodicAkimaSpline, reproduces_a_constant_exactly) {
  const PeriodicAkimaSpline s({0.0, 1.0, 2.5, -2.0, -0.5}, {0.2, 0.2, 0.2, 0.2, 0.2});
  for (double x = -4; x < 4; x += 0.01) {
    EXPECT_DOUBLE_EQ(s.value(x), 0.2);
    EXPECT_NEAR(s.derivative(x), 0.0, 1e-15);
  }
}

TEST(PeriodicAkimaSpline, does_not_overshoot_a_step) {
  // Flat low half, flat high half: Akima's slopes are zero on the flats, so the curve stays in
  // [low, high] and is exactly flat between flat neighbours (a natural cubic spline rings here).
  std::vector<double> th, h;
  for (int k = 0; k < 12; ++k) {
    th.push_back(-kPi + 2 * kPi * k / 12);
    h.push_back(k < 6 ? 0.10 : 0.15);
  }
  const PeriodicAkimaSpline s(th, h);
  for (double x = -kPi; x <= kPi; x += 0.002) {
    EXPECT_GE(s.value(x), 0.10 - 1e-12) << x;
    EXPECT_LE(s.value(x), 0.15 + 1e-12) << x;
  }
  EXPECT_DOUBLE_EQ(s.value(th[2] + 0.2), 0.10);  // inside the low flat run
  EXPECT_DOUBLE_EQ(s.value(th[8] + 0.2), 0.15);
}

TEST(PeriodicAkimaSpline, rejects_bad_key_points) {
  EXPECT_THROW(PeriodicAkimaSpline({0.0, 1.0}, {1.0, 2.0}), InvalidInputError);
  EXPECT_THROW(PeriodicAkimaSpline({0.0, 1.0, 2.0}, {1.0, 2.0}), InvalidInputError);
  EXPECT_THROW(PeriodicAkimaSpline({0.0, 1.0, 2.0}, {1.0, NAN, 2.0}), InvalidInputError);
  try {
    PeriodicAkimaSpline({0.0, 1.0, 2.0 * kPi}, {1.0, 2.0, 3.0});  // 0 and 2 pi are the same angle
    FAIL() << "duplicate angle accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("same angle"), std::string::npos) << e.what();
  }
  EXPECT_THROW(PeriodicAkimaSpline().value(0.0), InvalidInputError);
}

TEST(AkimaSpline, reproduces_a_linear_function_exactly_and_extrapolates_it) {
  const AkimaSpline s({0.3, -1.0, 2.0, 0.0, 1.1}, {0.3 * 2 + 1, -1.0, 5.0, 1.0, 3.2});
  for (double x = -2; x < 3; x += 0.01) {
    EXPECT_NEAR(s.value(x), 2 * x + 1, 1e-12);
    EXPECT_NEAR(s.derivative(x), 2.0, 1e-12);
  }
}

TEST(AkimaSpline, interpolates_without_overshoot_and_has_fd_derivative) {
  const std::vector<double> x = {0, 1, 2, 3, 4, 5, 6, 7}, y = {0, 0, 0, 0, 1, 1, 1, 1};
  const AkimaSpline s(x, y);
  for (std::size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(s.value(x[i]), y[i], 1e-14);
  for (double t = 0; t <= 7; t += 0.01) {
    EXPECT_GE(s.value(t), -1e-14);
    EXPECT_LE(s.value(t), 1 + 1e-14);
  }
  const double e = 1e-6;
  for (double t = 0.05; t < 7; t += 0.1)
    EXPECT_NEAR(s.derivative(t), (s.value(t + e) - s.value(t - e)) / (2 * e), 1e-6);
  EXPECT_THROW(AkimaSpline({0, 1, 1}, {0, 1, 2}), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::geometry
