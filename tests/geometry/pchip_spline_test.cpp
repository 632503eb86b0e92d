// PCHIP: interpolation of the knots, monotone data stays monotone without overshoot, linear
// continuation outside the knots, bad knots rejected.
#include <gtest/gtest.h>

#include <vector>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/pchip_spline.h"

namespace socketsmith::geometry {
namespace {

TEST(PchipSpline, interpolates_and_preserves_monotonicity) {
  const std::vector<double> x{0.0, 1.0, 2.0, 3.0, 4.0}, y{0.0, 0.1, 0.9, 1.0, 1.0};
  const PchipSpline f(x, y);
  for (std::size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(f(x[i]), y[i], 1e-14);
  double prev = f(0.0);
  for (double t = 0.01; t <= 4.0; t += 0.01) {
    EXPECT_GE(f(t), prev - 1e-14);
    EXPECT_LE(f(t), 1.0 + 1e-14);  // no overshoot on the plateau
    prev = f(t);
  }
  // Linear continuation outside the knots.
  EXPECT_NEAR(f(5.0) - f(4.0), f(6.0) - f(5.0), 1e-14);
  EXPECT_THROW(PchipSpline({0.0, 0.0}, {1.0, 2.0}), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::geometry
