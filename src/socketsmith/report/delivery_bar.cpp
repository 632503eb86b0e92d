#include "socketsmith/report/delivery_bar.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "socketsmith/core/errors.h"

namespace socketsmith::report {

double landmark_deviation(double designed_ratio, double delivered_ratio, double floor_ratio) {
  require(std::isfinite(designed_ratio) && std::isfinite(delivered_ratio) && designed_ratio >= 0 &&
              delivered_ratio >= 0 && floor_ratio > 0,
          "landmark_deviation: ratios {} / {} (expected finite and ≥ 0) and floor {} (expected > 0)", designed_ratio,
          delivered_ratio, floor_ratio);
  return std::abs(delivered_ratio - designed_ratio) / std::max(designed_ratio, floor_ratio);
}

std::string describe(const DeliveryBar& bar) {
  return fmt::format("below the brim and on each path: MAE ≤ {:g} kPa, 99th percentile ≤ {:g} kPa, R ≥ {:g} where the design varies, "
                     "landmarks within {:g} %",
                     bar.mae_pa / 1e3, bar.p99_pa / 1e3, bar.r_min, 100 * bar.landmark_tolerance);
}

std::string DeliveryVerdict::summary() const {
  if (met()) return "met";
  std::string s = "not met: ";
  for (size_t k = 0; k < failing.size(); ++k) s += (k ? "; " : "") + failing[k];
  return s;
}

namespace {

struct FieldVerdict {  ///< one compared set of nodes against the bar's MAE, p99 and R
  bool mae_met = false, p99_met = false, r_judged = false, r_met = false;
  std::vector<std::string> failing;  ///< each phrase prefixed by where ("" or "back line: ")
};

FieldVerdict judge_field(const ErrorStats& s, const DeliveryBar& bar, const std::string& where) {
  FieldVerdict f;
  f.mae_met = s.mae <= bar.mae_pa;
  if (!f.mae_met) f.failing.push_back(fmt::format("{}MAE {:.2f} kPa > {:g}", where, s.mae / 1e3, bar.mae_pa / 1e3));
  f.p99_met = s.p99 <= bar.p99_pa;
  if (!f.p99_met)
    f.failing.push_back(fmt::format("{}99th percentile {:.2f} kPa > {:g}", where, s.p99 / 1e3, bar.p99_pa / 1e3));
  f.r_judged = s.sd_b >= bar.r_needs_design_sd_pa;
  f.r_met = !f.r_judged || (std::isfinite(s.r) && s.r >= bar.r_min);
  if (!f.r_met) f.failing.push_back(fmt::format("{}R {:.3f} < {:g}", where, s.r, bar.r_min));
  return f;
}

}  // namespace

DeliveryVerdict judge_delivery(const ErrorStats& s, const std::vector<LandmarkRatio>& landmarks,
                               const std::vector<PathDelivery>& paths, const DeliveryBar& bar) {
  require(s.count > 0, "judge_delivery: no node compared below the brim");
  DeliveryVerdict v;
  FieldVerdict below = judge_field(s, bar, "");
  v.mae_met = below.mae_met;
  v.p99_met = below.p99_met;
  v.r_judged = below.r_judged;
  v.r_met = below.r_met;
  v.failing = std::move(below.failing);
  v.landmarks_met = true;
  for (const auto& l : landmarks) {
    const double dev = landmark_deviation(l.designed, l.delivered, bar.landmark_floor_ratio);
    if (dev >= v.worst_landmark_deviation) {
      v.worst_landmark_deviation = dev;
      v.worst_landmark = l.code;
    }
    if (dev <= bar.landmark_tolerance) continue;
    v.landmarks_met = false;
    if (l.designed >= bar.landmark_floor_ratio)
      v.failing.push_back(fmt::format("{} {:+.0f} % ({:.3f} → {:.3f} of its threshold)", l.code,
                                      100 * (l.delivered / l.designed - 1), l.designed, l.delivered));
    else
      v.failing.push_back(fmt::format("{} {:+.3f} of its threshold ({:.3f} → {:.3f}; designed under {:g})", l.code,
                                      l.delivered - l.designed, l.designed, l.delivered, bar.landmark_floor_ratio));
  }
  for (const auto& p : paths) {
    if (p.stats.count == 0) continue;
    const FieldVerdict f = judge_field(p.stats, bar, p.name + ": ");
    if (f.failing.empty()) continue;
    v.paths_met = false;
    v.paths_failing.push_back(p.name);
    v.failing.insert(v.failing.end(), f.failing.begin(), f.failing.end());
  }
  return v;
}

nlohmann::json to_json(const DeliveryVerdict& v, const DeliveryBar& bar) {
  return {{"met", v.met()},
          {"summary", v.summary()},
          {"mae_met", v.mae_met},
          {"p99_met", v.p99_met},
          {"r_judged", v.r_judged},
          {"r_met", v.r_met},
          {"landmarks_met", v.landmarks_met},
          {"paths_met", v.paths_met},
          {"paths_failing", v.paths_failing},
          {"worst_landmark", v.worst_landmark},
          {"worst_landmark_deviation", v.worst_landmark_deviation},
          {"failing", v.failing},
          {"bar",
           {{"mae_kpa", bar.mae_pa / 1e3},
            {"p99_kpa", bar.p99_pa / 1e3},
            {"r_min", bar.r_min},
            {"r_needs_design_sd_kpa", bar.r_needs_design_sd_pa / 1e3},
            {"landmark_tolerance", bar.landmark_tolerance},
            {"landmark_floor_ratio", bar.landmark_floor_ratio}}}};
}

}  // namespace socketsmith::report
