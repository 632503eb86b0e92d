#include "socketsmith/geometry/pchip_spline.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "socketsmith/core/errors.h"

namespace socketsmith::geometry {

PchipSpline::PchipSpline(std::vector<double> x, std::vector<double> y) : x_(std::move(x)), y_(std::move(y)), d_(x_.size(), 0.0) {
  const std::size_t n = x_.size();
  require(n >= 2 && y_.size() == n, "PchipSpline: {} knots and {} values (expected at least 2 of each, as many)", n, y_.size());
  std::vector<double> h(n - 1), delta(n - 1);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    h[k] = x_[k + 1] - x_[k];
    require(h[k] > 0.0, "PchipSpline: knots must increase strictly (x[{}] = {}, x[{}] = {})", k, x_[k], k + 1, x_[k + 1]);
    delta[k] = (y_[k + 1] - y_[k]) / h[k];
  }
  if (n == 2) {
    d_[0] = d_[1] = delta[0];
    return;
  }
  for (std::size_t k = 1; k + 1 < n; ++k) {
    if (delta[k - 1] * delta[k] <= 0.0) continue;
    const double w1 = 2.0 * h[k] + h[k - 1], w2 = h[k] + 2.0 * h[k - 1];
    d_[k] = (w1 + w2) / (w1 / delta[k - 1] + w2 / delta[k]);
  }
  auto end_slope = [](double h0, double h1, double m0, double m1) {
    double d = ((2.0 * h0 + h1) * m0 - h0 * m1) / (h0 + h1);
    if (d * m0 <= 0.0) d = 0.0;
    else if (m0 * m1 <= 0.0 && std::abs(d) > 3.0 * std::abs(m0)) d = 3.0 * m0;
    return d;
  };
  d_[0] = end_slope(h[0], h[1], delta[0], delta[1]);
  d_[n - 1] = end_slope(h[n - 2], h[n - 3], delta[n - 2], delta[n - 3]);
}

double PchipSpline::operator()(double x) const {
  const std::size_t n = x_.size();
  if (x <= x_[0]) return y_[0] + d_[0] * (x - x_[0]);
  if (x >= x_[n - 1]) return y_[n - 1] + d_[n - 1] * (x - x_[n - 1]);
  const std::size_t k = static_cast<std::size_t>(std::upper_bound(x_.begin(), x_.end(), x) - x_.begin()) - 1;
  const double h = x_[k + 1] - x_[k], t = (x - x_[k]) / h;
  const double t2 = t * t, t3 = t2 * t;
  return (2 * t3 - 3 * t2 + 1) * y_[k] + (t3 - 2 * t2 + t) * h * d_[k] + (-2 * t3 + 3 * t2) * y_[k + 1] +
         (t3 - t2) * h * d_[k + 1];
}

}  // namespace socketsmith::geometry
