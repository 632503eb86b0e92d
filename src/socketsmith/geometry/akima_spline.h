#pragma once
/// @file akima_spline.h
/// Akima (1970) interpolating splines: C1 piecewise cubics whose slopes come from the local
/// data only, so a step in the data does not ring (no overshoot next to a flat run). The
/// periodic variant interpolates closed curves h(theta) with period 2 pi — the brim line.
///
/// Slope at key point i from the secant slopes m_j of the segments [x_j, x_{j+1}]
/// (Akima 1970, eq. 1):
///   t_i = (|m_{i+1} − m_i| m_{i−1} + |m_{i−1} − m_{i−2}| m_i) / (|m_{i+1} − m_i| + |m_{i−1} − m_{i−2}|),
///   t_i = (m_{i−1} + m_i) / 2 when both weights vanish;
/// then a cubic Hermite polynomial on each segment.

#include <vector>

namespace socketsmith::geometry {

/// Periodic Akima spline through key points (theta_k, h_k), period 2 pi.
class PeriodicAkimaSpline {
 public:
  /// Empty spline (value() throws until built).
  PeriodicAkimaSpline() = default;
  /// @param theta key angles [rad], any order, any range (wrapped to [−pi, pi)); sorted internally.
  /// @param h values at the key angles (any unit; the brim uses metres).
  /// @throws InvalidInputError when sizes differ, fewer than 3 points, a value is not finite, or two
  ///         angles coincide modulo 2 pi (within 1e-9 rad).
  PeriodicAkimaSpline(const std::vector<double>& theta, const std::vector<double>& h);

  /// Value at @p theta [rad], any real number (wrapped with period 2 pi).
  double value(double theta) const;
  /// d value / d theta at @p theta [unit of h per rad].
  double derivative(double theta) const;
  /// Sorted key angles in [−pi, pi) and their values, slopes.
  const std::vector<double>& knots() const { return x_; }
  const std::vector<double>& values() const { return y_; }
  const std::vector<double>& slopes() const { return t_; }
  bool empty() const { return x_.empty(); }

 private:
  int segment(double& theta) const;  // wraps theta into [x_0, x_0 + 2 pi) and finds its segment
  std::vector<double> x_, y_, t_;    // n knots (+ the wrapped first knot appended to x_, y_)
};

/// Non-periodic Akima spline y(x) on [x_0, x_{n−1}], with Akima's end extrapolation of the secant
/// slopes (m_{−1} = 2 m_0 − m_1, m_{−2} = 2 m_{−1} − m_0, alike at the end). Outside the knots the
/// end cubics are extended.
class AkimaSpline {
 public:
  AkimaSpline() = default;
  /// @throws InvalidInputError when sizes differ, fewer than 3 points, a value is not finite, or two
  ///         abscissae coincide (within 1e-12 relative).
  AkimaSpline(const std::vector<double>& x, const std::vector<double>& y);
  double value(double x) const;
  double derivative(double x) const;
  const std::vector<double>& knots() const { return x_; }

 private:
  int segment(double x) const;
  std::vector<double> x_, y_, t_;
};

}  // namespace socketsmith::geometry
