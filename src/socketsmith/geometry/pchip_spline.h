#pragma once
/// @file pchip_spline.h
/// Monotone piecewise-cubic Hermite interpolation (Fritsch & Carlson 1980, SIAM J. Numer. Anal.
/// 17(2); the slopes of scipy's PchipInterpolator): between two knots the curve never leaves
/// the range of their values, so a profile through monotone data stays monotone (unlike a cubic
/// spline, no overshoot next to a plateau). Compare akima_spline.h, which follows the data more
/// closely but may leave a monotone run.

#include <vector>

namespace socketsmith::geometry {

/// PCHIP through knots (x_k, y_k) with strictly increasing x, continued linearly (end value and
/// end slope) outside them. Interior slopes: weighted harmonic mean of the neighbouring secants,
/// zero at a local extremum; end slopes: the three-point formula, limited to keep monotonicity.
class PchipSpline {
 public:
  /// @pre x.size() == y.size() >= 2, x strictly increasing.
  /// @throws InvalidInputError otherwise.
  PchipSpline(std::vector<double> x, std::vector<double> y);
  /// Value at @p x (any real number; linear outside the knots).
  double operator()(double x) const;

 private:
  std::vector<double> x_, y_, d_;
};

}  // namespace socketsmith::geometry
