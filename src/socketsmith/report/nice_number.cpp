#include "socketsmith/report/nice_number.h"

#include <array>
#include <cmath>
#include <span>

namespace socketsmith::report {

double nice_ceil(double v, NiceMantissas mantissas) {
  static constexpr std::array<double, 4> kOneTwoFive{1.0, 2.0, 5.0, 10.0};
  static constexpr std::array<double, 11> kFine{1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0};
  if (!std::isfinite(v) || !(v > 0)) return v;
  const std::span<const double> ms = mantissas == NiceMantissas::OneTwoFive ? std::span<const double>(kOneTwoFive)
                                                                            : std::span<const double>(kFine);
  const double p = std::pow(10.0, std::floor(std::log10(v)));
  for (const double m : ms)
    if (m * p >= v * (1 - 1e-9)) return m * p;
  return 10 * p;  // v just below the next power of ten, where floor(log10) rounded down
}

}  // namespace socketsmith::report
