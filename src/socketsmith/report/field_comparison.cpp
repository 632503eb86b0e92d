#include "socketsmith/report/field_comparison.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "socketsmith/core/errors.h"

namespace socketsmith::report {

ErrorStats compare_fields(const std::vector<double>& a, const std::vector<double>& b, const std::vector<int>& subset) {
  require(a.size() == b.size(), "compare_fields: the fields have {} and {} values (expected the same points)", a.size(),
          b.size());
  const int n = static_cast<int>(a.size());
  std::vector<int> idx = subset;
  if (idx.empty()) {
    idx.resize(n);
    for (int i = 0; i < n; ++i) idx[i] = i;
  }
  ErrorStats s;
  double sa = 0, sb = 0, se = 0, se2 = 0, sd = 0;
  std::vector<double> abs_err;
  abs_err.reserve(idx.size());
  for (int i : idx) {
    require(i >= 0 && i < n, "compare_fields: subset index {} is out of range ({} values)", i, n);
    if (!std::isfinite(a[i]) || !std::isfinite(b[i])) continue;
    const double d = a[i] - b[i], e = std::abs(d);
    ++s.count;
    abs_err.push_back(e);
    sa += a[i];
    sb += b[i];
    se += e;
    se2 += e * e;
    sd += d;
    if (e > s.max_error || s.max_index < 0) {
      s.max_error = e;
      s.max_index = i;
    }
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (s.count == 0) {
    s.mae = s.sd = s.rmse = s.bias = s.r = s.mean_a = s.mean_b = s.p95 = s.p99 = s.sd_a = s.sd_b = nan;
    return s;
  }
  const double c = s.count;
  s.mean_a = sa / c;
  s.mean_b = sb / c;
  s.mae = se / c;
  s.bias = sd / c;
  s.rmse = std::sqrt(se2 / c);
  s.sd = std::sqrt(std::max(0.0, se2 / c - s.mae * s.mae));
  double saa = 0, sbb = 0, sab = 0;
  for (int i : idx) {
    if (!std::isfinite(a[i]) || !std::isfinite(b[i])) continue;
    const double da = a[i] - s.mean_a, db = b[i] - s.mean_b;
    saa += da * da;
    sbb += db * db;
    sab += da * db;
  }
  s.r = (s.count >= 2 && saa > 0 && sbb > 0) ? sab / std::sqrt(saa * sbb) : nan;
  s.sd_a = std::sqrt(saa / c);
  s.sd_b = std::sqrt(sbb / c);
  // Nearest-rank percentiles: the smallest error that at least q of the points do not exceed.
  std::sort(abs_err.begin(), abs_err.end());
  const auto rank = [&](double q) { return abs_err[static_cast<size_t>(std::max(0.0, std::ceil(q * c) - 1))]; };
  s.p95 = rank(0.95);
  s.p99 = rank(0.99);
  return s;
}

nlohmann::json to_json(const ErrorStats& s, double scale, const std::string& suffix) {
  const auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  return {{"count", s.count},
          {"mae" + suffix, num(s.mae * scale)},
          {"sd" + suffix, num(s.sd * scale)},
          {"rmse" + suffix, num(s.rmse * scale)},
          {"bias" + suffix, num(s.bias * scale)},
          {"r", num(s.r)},
          {"max_err" + suffix, num(s.max_error * scale)},
          {"max_index", s.max_index},
          {"p95" + suffix, num(s.p95 * scale)},
          {"p99" + suffix, num(s.p99 * scale)},
          {"mean_a" + suffix, num(s.mean_a * scale)},
          {"mean_b" + suffix, num(s.mean_b * scale)},
          {"sd_a" + suffix, num(s.sd_a * scale)},
          {"sd_b" + suffix, num(s.sd_b * scale)}};
}

std::vector<BandMeans> band_means(const std::vector<int>& band, const std::vector<double>& weight,
                                  const std::vector<std::vector<double>>& fields, int deepest) {
  require(deepest >= 1, "band_means: deepest band {} (expected ≥ 1)", deepest);
  require(weight.size() == band.size(), "band_means: {} weights for {} points", weight.size(), band.size());
  for (const auto& f : fields)
    require(f.size() == band.size(), "band_means: a field has {} values for {} points", f.size(), band.size());
  std::vector<BandMeans> sums(deepest);
  for (auto& b : sums) b.mean.assign(fields.size(), 0.0);
  for (size_t i = 0; i < band.size(); ++i) {
    if (band[i] < 1 || !(weight[i] > 0)) continue;
    const bool finite = std::all_of(fields.begin(), fields.end(), [&](const auto& f) { return std::isfinite(f[i]); });
    if (!finite) continue;
    BandMeans& b = sums[std::min(band[i], deepest) - 1];
    ++b.count;
    b.area += weight[i];
    for (size_t k = 0; k < fields.size(); ++k) b.mean[k] += weight[i] * fields[k][i];
  }
  std::vector<BandMeans> listed;
  for (int k = 0; k < deepest; ++k) {
    BandMeans b = sums[k];
    if (b.count == 0) continue;
    b.band = k + 1;
    for (double& m : b.mean) m /= b.area;
    listed.push_back(std::move(b));
  }
  return listed;
}

}  // namespace socketsmith::report
