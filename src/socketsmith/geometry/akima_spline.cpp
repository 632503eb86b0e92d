#include "socketsmith/geometry/akima_spline.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

#include "socketsmith/core/errors.h"

namespace socketsmith::geometry {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

/// Akima slope from the four secant slopes around a knot: m_{i−2}, m_{i−1}, m_i, m_{i+1}.
double akima_slope(double mm2, double mm1, double m0, double mp1) {
  const double w1 = std::abs(mp1 - m0), w2 = std::abs(mm1 - mm2);
  const double scale = std::max({std::abs(mm2), std::abs(mm1), std::abs(m0), std::abs(mp1), 1e-300});
  if (w1 + w2 <= 1e-12 * scale) return 0.5 * (mm1 + m0);
  return (w1 * mm1 + w2 * m0) / (w1 + w2);
}

/// Cubic Hermite value and derivative on [x0, x1].
void hermite(double x0, double x1, double y0, double y1, double t0, double t1, double x, double* value,
             double* derivative) {
  const double dx = x1 - x0, s = (x - x0) / dx;
  const double m = (y1 - y0) / dx;
  // y = y0 + t0 (x − x0) + c2 (x − x0)^2 + c3 (x − x0)^3 (Akima 1970, eq. 4)
  const double c2 = (3.0 * m - 2.0 * t0 - t1) / dx;
  const double c3 = (t0 + t1 - 2.0 * m) / (dx * dx);
  const double u = s * dx;
  if (value) *value = y0 + u * (t0 + u * (c2 + u * c3));
  if (derivative) *derivative = t0 + u * (2.0 * c2 + 3.0 * c3 * u);
}

void check_input(const char* who, const std::vector<double>& x, const std::vector<double>& y) {
  require(x.size() == y.size(), "{}: {} key abscissae but {} values (expected the same count)", who, x.size(),
          y.size());
  require(x.size() >= 3, "{}: {} key points (at least 3 are needed)", who, x.size());
  for (std::size_t i = 0; i < x.size(); ++i)
    require(std::isfinite(x[i]) && std::isfinite(y[i]), "{}: key point {} = ({}, {}) is not finite", who, i, x[i],
            y[i]);
}

/// Appends the key points (@p x, @p y) to @p xs, @p ys in increasing x.
void append_sorted(const std::vector<double>& x, const std::vector<double>& y, std::vector<double>& xs,
                   std::vector<double>& ys) {
  std::vector<int> order(x.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return x[a] < x[b]; });
  for (int i : order) {
    xs.push_back(x[i]);
    ys.push_back(y[i]);
  }
}

}  // namespace

PeriodicAkimaSpline::PeriodicAkimaSpline(const std::vector<double>& theta, const std::vector<double>& h) {
  check_input("PeriodicAkimaSpline", theta, h);
  const int n = static_cast<int>(theta.size());
  std::vector<double> wrapped(n);
  for (int i = 0; i < n; ++i) {
    double a = std::remainder(theta[i], kTwoPi);  // [−pi, pi]
    if (a >= std::numbers::pi) a -= kTwoPi;
    wrapped[i] = a;
  }
  append_sorted(wrapped, h, x_, y_);
  for (int i = 0; i < n; ++i) {
    const double gap = i + 1 < n ? x_[i + 1] - x_[i] : x_[0] + kTwoPi - x_[i];
    require(gap > 1e-9, "PeriodicAkimaSpline: two key points at the same angle {:.6f} rad (modulo 2 pi); "
            "remove or move one", x_[i]);
  }
  std::vector<double> m(n);  // secant slope of segment i: [x_i, x_{i+1}] (periodic)
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    const double dx = (j == 0 ? x_[0] + kTwoPi : x_[j]) - x_[i];
    m[i] = (y_[j] - y_[i]) / dx;
  }
  auto M = [&](int i) { return m[((i % n) + n) % n]; };
  t_.resize(n);
  for (int i = 0; i < n; ++i) t_[i] = akima_slope(M(i - 2), M(i - 1), M(i), M(i + 1));
  x_.push_back(x_[0] + kTwoPi);  // closing knot
  y_.push_back(y_[0]);
}

int PeriodicAkimaSpline::segment(double& theta) const {
  require(!x_.empty(), "PeriodicAkimaSpline: evaluated before being built from key points");
  require(std::isfinite(theta), "PeriodicAkimaSpline: angle {} is not finite", theta);
  double a = std::fmod(theta - x_[0], kTwoPi);
  if (a < 0) a += kTwoPi;
  theta = x_[0] + a;
  const int n = static_cast<int>(x_.size()) - 1;
  const auto it = std::upper_bound(x_.begin(), x_.begin() + n, theta);
  return std::clamp(static_cast<int>(it - x_.begin()) - 1, 0, n - 1);
}

double PeriodicAkimaSpline::value(double theta) const {
  const int i = segment(theta);
  const int n = static_cast<int>(t_.size());
  double v = 0;
  hermite(x_[i], x_[i + 1], y_[i], y_[i + 1], t_[i], t_[(i + 1) % n], theta, &v, nullptr);
  return v;
}

double PeriodicAkimaSpline::derivative(double theta) const {
  const int i = segment(theta);
  const int n = static_cast<int>(t_.size());
  double d = 0;
  hermite(x_[i], x_[i + 1], y_[i], y_[i + 1], t_[i], t_[(i + 1) % n], theta, nullptr, &d);
  return d;
}

AkimaSpline::AkimaSpline(const std::vector<double>& x, const std::vector<double>& y) {
  check_input("AkimaSpline", x, y);
  const int n = static_cast<int>(x.size());
  append_sorted(x, y, x_, y_);
  const double span = x_.back() - x_.front();
  for (int i = 0; i + 1 < n; ++i)
    require(x_[i + 1] - x_[i] > 1e-12 * std::max(span, 1e-300),
            "AkimaSpline: two key points at the same abscissa {}; remove or move one", x_[i]);
  // Secant slopes with two extrapolated slopes at each end: index k + 2 holds m_k.
  std::vector<double> m(n + 3);
  for (int i = 0; i + 1 < n; ++i) m[i + 2] = (y_[i + 1] - y_[i]) / (x_[i + 1] - x_[i]);
  m[1] = 2.0 * m[2] - m[3];
  m[0] = 2.0 * m[1] - m[2];
  m[n + 1] = 2.0 * m[n] - m[n - 1];
  m[n + 2] = 2.0 * m[n + 1] - m[n];
  t_.resize(n);
  for (int i = 0; i < n; ++i) t_[i] = akima_slope(m[i], m[i + 1], m[i + 2], m[i + 3]);
}

int AkimaSpline::segment(double x) const {
  require(!x_.empty(), "AkimaSpline: evaluated before being built from key points");
  require(std::isfinite(x), "AkimaSpline: abscissa {} is not finite", x);
  const int n = static_cast<int>(x_.size());
  const auto it = std::upper_bound(x_.begin(), x_.end(), x);
  return std::clamp(static_cast<int>(it - x_.begin()) - 1, 0, n - 2);
}

double AkimaSpline::value(double x) const {
  const int i = segment(x);
  double v = 0;
  hermite(x_[i], x_[i + 1], y_[i], y_[i + 1], t_[i], t_[i + 1], x, &v, nullptr);
  return v;
}

double AkimaSpline::derivative(double x) const {
  const int i = segment(x);
  double d = 0;
  hermite(x_[i], x_[i + 1], y_[i], y_[i + 1], t_[i], t_[i + 1], x, nullptr, &d);
  return d;
}

}  // namespace socketsmith::geometry
