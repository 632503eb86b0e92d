#include "socketsmith/calculix/standing_pose.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>

namespace socketsmith::calculix {
namespace {

bool is_reference_set(const DatBlock& b) {
  return b.set.size() == 3 && std::toupper(static_cast<unsigned char>(b.set[0])) == 'R' &&
         std::toupper(static_cast<unsigned char>(b.set[1])) == 'E' && std::toupper(static_cast<unsigned char>(b.set[2])) == 'F';
}

/// The reference node's value along @p direction in a printed block (its rows local to the node's
/// *TRANSFORM when ccx says so: then the load is the local z).
double along(const DatBlock& b, const Vec3& direction) {
  const auto& r = b.rows[0];
  return b.local ? r[3] : Vec3(r[1], r[2], r[3]).dot(direction);
}

}  // namespace

StandingPose standing_pose(const std::vector<DatBlock>& dat, double load_n, const Vec3& direction) {
  StandingPose p;
  std::vector<std::array<double, 3>> series;  // time, force, displacement from step 1's end on
  for (const auto& b : dat) {
    if (b.time < 1.0 - 1e-9 || b.rows.empty() || b.rows[0].size() < 4 || !is_reference_set(b)) continue;
    const bool force = b.title.starts_with("forces"), disp = b.title.starts_with("displacements");
    if (!force && !disp) continue;
    if (series.empty() || std::abs(series.back()[0] - b.time) > 1e-9)
      series.push_back({b.time, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()});
    series.back()[force ? 1 : 2] = along(b, direction);
  }
  std::erase_if(series, [](const auto& e) { return std::isnan(e[1]); });
  if (series.empty() || std::abs(series[0][0] - 1.0) > 1e-9) return p;
  p.donned_force_n = series[0][1];
  p.last_time = series.back()[0];
  p.last_force_n = series.back()[1];
  p.last_displacement_m = std::isnan(series.back()[2]) || std::isnan(series[0][2]) ? 0.0 : series.back()[2] - series[0][2];
  for (size_t i = 0; i < series.size() && !p.reached; ++i) {
    const auto& a = series[i == 0 ? 0 : i - 1];
    const auto& b = series[i];
    const double fa = a[1] - load_n, fb = b[1] - load_n;
    if (!(fa == 0 || fb == 0 || (fa < 0) != (fb < 0)) || (i == 0 && fa != 0)) continue;
    p.reached = true;
    p.time_a = a[0];
    p.time_b = b[0];
    p.weight = fa == fb ? 0.0 : fa / (fa - fb);
    const double ua = std::isnan(a[2]) ? 0.0 : a[2], ub = std::isnan(b[2]) ? 0.0 : b[2];
    p.displacement_m = (1 - p.weight) * ua + p.weight * ub - (std::isnan(series[0][2]) ? 0.0 : series[0][2]);
  }
  return p;
}

double standing_retry_travel_m(const StandingPose& p, double travel_m, double load_n) {
  const double none = std::numeric_limits<double>::quiet_NaN();
  if (std::isnan(p.donned_force_n) || travel_m == 0 || p.reached) return none;
  const double need = load_n - p.donned_force_n;  // pushing on (> 0) raises the reaction
  const double pushed = p.last_time > 1.0 ? p.last_displacement_m : 0.0;
  if ((need > 0) != (travel_m > 0)) {
    // The wrong way: as far as the step's own stiffness asks for, else as far as the first push.
    const double k = std::abs(pushed) > 0 ? std::abs(p.last_force_n - p.donned_force_n) / std::abs(pushed) : 0.0;
    const double reach = k > 0 ? std::max(std::abs(travel_m), 1.5 * std::abs(need) / k) : std::abs(travel_m);
    return std::copysign(reach, need);
  }
  if (p.last_time < 2.0 - 1e-6) return none;  // ccx gave up on the way: it would again
  const double gained = p.last_force_n - p.donned_force_n;
  const double factor = gained * need > 0 ? std::clamp(1.5 * need / gained, 1.5, 4.0) : 2.0;
  return factor * travel_m;
}

}  // namespace socketsmith::calculix
