// Round numbers: the tick steps (1, 2, 5 × 10^k) and the finer tops of axes and colour ranges,
// across decades, with values that are round but for rounding errors, and without a round
// number to find.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "socketsmith/report/nice_number.h"

namespace socketsmith::report {
namespace {

struct Case {
  double value, expected;
};

TEST(NiceNumber, tick_steps_are_the_smallest_one_two_five_above) {
  // 0.2 * (1 + 1e-12) is 0.2 but for rounding errors: it stays 0.2, not 0.5.
  for (const Case& c : {Case{0.7, 1.0}, Case{1.0, 1.0}, Case{1.01, 2.0}, Case{3.0, 5.0}, Case{5.5, 10.0},
                        Case{0.0031, 0.005}, Case{240.0, 500.0}, Case{0.1 + 0.2, 0.5}, Case{0.2 * (1 + 1e-12), 0.2}})
    EXPECT_DOUBLE_EQ(nice_ceil(c.value, NiceMantissas::OneTwoFive), c.expected) << c.value;
}

TEST(NiceNumber, axis_tops_use_the_finer_mantissas) {
  for (const Case& c : {Case{1.1, 1.2}, Case{1.3, 1.5}, Case{2.2, 2.5}, Case{3.5, 4.0}, Case{7.0, 8.0}, Case{8.5, 10.0},
                        Case{0.045, 0.05}, Case{130.0, 150.0}})
    EXPECT_DOUBLE_EQ(nice_ceil(c.value), c.expected) << c.value;
  for (double v = 1e-6; v < 1e6; v *= 1.37) {
    const double n = nice_ceil(v);
    EXPECT_GE(n, v * (1 - 1e-9));
    EXPECT_LE(n, 4.0 / 3.0 * v * (1 + 1e-12)) << v;  // the widest gaps: 3 -> 4 and 6 -> 8
  }
}

TEST(NiceNumber, returns_what_has_no_round_number_unchanged) {
  EXPECT_EQ(nice_ceil(0.0), 0.0);
  EXPECT_EQ(nice_ceil(-3.0), -3.0);
  EXPECT_EQ(nice_ceil(std::numeric_limits<double>::infinity()), std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::isnan(nice_ceil(std::nan(""), NiceMantissas::OneTwoFive)));
}

}  // namespace
}  // namespace socketsmith::report
