// The smoothed wall fitted to the facets where the stump's skin touches them (RigidSocket,
// rigid_socket.h): per-vertex offsets of the vertex surfaces, so that the smoothed gap vanishes at
// the skin nodes' footprints on the facets; points laid onto that wall.
#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>
#include <vector>

#include "socketsmith/contact/rigid_socket.h"
#include "socketsmith/core/log.h"

namespace socketsmith::contact {
namespace {
// A skin node farther than this from the facets does not count (above the brim, or far from a
// socket that does not fit): only the footprints of nodes the wall can reach are fitted.
constexpr double kFitReach = 0.01;  // [m]
// Sweeps of the fit, and the share a vertex needs before it moves fully (a vertex that holds a
// small part of a single footprint moves a little, not by that footprint's whole residual). With
// a share floor of 1 the 1.8k demo's closed loop ends where it did on the averaged wall (MAE 0.67,
// 99th percentile 6.4 kPa); with 0.25 the same fit left it at 6.6 (docs/contact.md).
constexpr int kFitSweeps = 6;
constexpr double kFitShareFloor = 1.0;
}  // namespace

void RigidSocket::fit_smooth_wall_to(std::vector<Vec3> points) {
  fit_points_ = std::move(points);
  wall_c_ = wall_c_facets_;
  if (fit_points_.empty() || wall_v_.empty()) return;
  // The footprints: each point's closest point on the facets, where the faceted gap is zero.
  std::vector<Vec3> feet;
  std::vector<int> tri;
  for (const Vec3& p : fit_points_) {
    const auto hit = query_->closest_point(p);
    if (hit.triangle < 0 || hit.distance > kFitReach) continue;
    feet.push_back(hit.point);
    tri.push_back(hit.triangle);
  }
  if (feet.empty()) return;
  const auto residuals = [&](double& max_abs, double& mean_abs) {
    std::vector<double> r(feet.size(), 0.0);
    max_abs = mean_abs = 0.0;
    for (size_t i = 0; i < feet.size(); ++i) {
      Gap on;
      on.triangle = tri[i];
      if (const std::optional<Gap> s = smooth_gap(feet[i], on)) r[i] = s->gap_m;
      max_abs = std::max(max_abs, std::abs(r[i]));
      mean_abs += std::abs(r[i]) / static_cast<double>(feet.size());
    }
    return r;
  };
  // A footprint's residual falls on the vertices whose supports hold it, by their share of it (the
  // shares do not change with the offsets: found once).
  std::vector<std::vector<std::pair<int, double>>> shares(feet.size());
  std::vector<double> den(wall_v_.size(), 0.0);
  for (size_t i = 0; i < feet.size(); ++i) {
    double total = 0;
    for_vertex_support(feet[i], [&](int j, const Vec3&, double u) {
      shares[i].emplace_back(j, u * u * u * u);
      total += u * u * u * u;
    });
    for (auto& [j, w] : shares[i]) {
      w /= total;
      den[j] += w;
    }
  }
  double max0 = 0, mean0 = 0, max1 = 0, mean1 = 0;
  std::vector<double> r = residuals(max0, mean0);
  for (int sweep = 0; sweep < kFitSweeps; ++sweep) {
    std::vector<double> num(wall_v_.size(), 0.0);
    for (size_t i = 0; i < feet.size(); ++i)
      for (const auto& [j, w] : shares[i]) num[j] += w * r[i];
    for (size_t j = 0; j < wall_c_.size(); ++j) {
      if (den[j] > 0) wall_c_[j] += num[j] / (den[j] + kFitShareFloor);
      // Between the surface through the vertices (c = 0) and the one through the facets on
      // average: the fit chooses where between them the wall lies, and adds no bumps of its own
      // (unbounded, it raised a distal node of the 1.8k demo from 12 to 29 kPa in the closed loop).
      wall_c_[j] = std::clamp(wall_c_[j], std::min(0.0, wall_c_facets_[j]), std::max(0.0, wall_c_facets_[j]));
    }
    r = residuals(max1, mean1);
  }
  log::debug("socket wall: smoothed wall fitted to {} skin footprints on the facets: gap there {:.3f} mm on average, "
             "{:.3f} at most (through the facets on average: {:.3f}, {:.3f})",
             feet.size(), mean1 * 1e3, max1 * 1e3, mean0 * 1e3, max0 * 1e3);
}

std::optional<std::pair<Vec3, Vec3>> RigidSocket::onto_wall(const Vec3& p, double reach_m) const {
  Vec3 q = p;
  constexpr int kSteps = 8;
  for (int it = 0; it < kSteps; ++it) {
    const Gap g = gap(q);
    if (!g.valid || std::abs(g.gap_m) > reach_m || !(g.gradient_norm > 0)) return std::nullopt;
    if (std::abs(g.gap_m) < 1e-8 || it == kSteps - 1) return std::pair<Vec3, Vec3>{q, -g.normal};
    q -= g.gap_m / g.gradient_norm * g.normal;  // the wall lies gap/|∇gap| behind q along its normal
  }
  return std::nullopt;
}

}  // namespace socketsmith::contact
