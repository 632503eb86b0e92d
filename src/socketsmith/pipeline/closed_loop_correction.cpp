#include "socketsmith/pipeline/closed_loop_correction.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "socketsmith/core/errors.h"
#include "socketsmith/report/field_comparison.h"

namespace socketsmith::pipeline {
namespace {

using Vec3 = Eigen::Vector3d;

/// Area-weighted averages of @p v over each node and its neighbours on the skin's quads, @p passes
/// times, among the nodes where @p use is 1 (the others keep their value and are not averaged in).
std::vector<double> smooth_on_skin(const volume::SkinSurface& skin, const std::vector<char>& use, std::vector<double> v,
                                   int passes) {
  if (passes == 0) return v;
  const std::vector<std::vector<int>> nb = skin.neighbours();
  const size_t n = skin.nodes.size();
  std::vector<double> next(n);
  for (int p = 0; p < passes; ++p) {
    for (size_t i = 0; i < n; ++i) {
      if (!use[i]) {
        next[i] = v[i];
        continue;
      }
      double s = skin.area_m2[i] * v[i], w = skin.area_m2[i];
      for (int j : nb[i])
        if (use[j]) {
          s += skin.area_m2[j] * v[j];
          w += skin.area_m2[j];
        }
      next[i] = s / w;
    }
    v.swap(next);
  }
  return v;
}

/// Corrections @p c computed at the skin nodes, moved onto the wall's vertices. Donning drags the
/// skin along the wall (on the demo 5–7 mm proximally, a node spacing), so a node presses the wall
/// where it ended up, not at its own designed vertex: correcting the node's vertex moved the wall
/// under a neighbour instead. Each wall vertex @p wall takes the Gaussian-weighted sum
/// (σ = @p sigma_m, up to 3σ) of the corrections of the nodes @p used whose donned position
/// @p donned (in the socket's frame) is near it, over the sum of the weights or 1, the larger; a
/// vertex no node reaches keeps its own node's. The weights of nodes a spacing (2σ) apart sum to
/// 2π/4 ≈ 1.57 around a vertex among them (1.55 median, 0.87–0.94 at the 1st percentile on the 1.8k
/// demo), so the floor of 1 leaves those nearly as they were and fades the correction beyond the
/// last node's reach: without it a wall vertex 6 mm above the raised brim, which only a node below
/// it reached (weight 0.045), took that node's whole correction refit after refit, to the loop's
/// 5 mm clamp. (Fading only the vertices whose own node is out of the socket: generated
/// transtibial seed 6's AD +11 %, the sweep 11 of 12 against 12; 2026-12-05.)
std::vector<double> corrections_on_wall(const std::vector<Vec3>& wall, const std::vector<Vec3>& donned,
                                        const std::vector<double>& c, const std::vector<int>& used, double sigma_m) {
  const double r2 = 9 * sigma_m * sigma_m, inv = 1.0 / (2 * sigma_m * sigma_m);
  std::vector<double> out(wall.size());
  for (size_t j = 0; j < wall.size(); ++j) {
    double sw = 0, sc = 0;
    for (int i : used) {
      const double d2 = (donned[i] - wall[j]).squaredNorm();
      if (d2 > r2) continue;
      const double w = std::exp(-d2 * inv);
      sw += w;
      sc += w * c[i];
    }
    out[j] = sw > 1e-3 ? sc / std::max(sw, 1.0) : c[j];
  }
  return out;
}

}  // namespace

std::vector<double> node_scale_part(const std::vector<std::vector<int>>& neighbours, const std::vector<double>& area_m2,
                                    const std::vector<char>& use, const std::vector<double>& v) {
  require(neighbours.size() == v.size() && area_m2.size() == v.size() && use.size() == v.size(),
          "node_scale_part: {} neighbour lists, {} areas, {} flags for {} values", neighbours.size(), area_m2.size(),
          use.size(), v.size());
  std::vector<double> out(v.size(), std::numeric_limits<double>::quiet_NaN());
  for (size_t i = 0; i < v.size(); ++i) {
    if (!use[i]) continue;
    double s = 0, w = 0;
    int k = 0;
    for (int j : neighbours[i])
      if (use[j]) {
        s += area_m2[j] * v[j];
        w += area_m2[j];
        ++k;
      }
    if (k >= 2 && w > 0) out[i] = v[i] - s / w;
  }
  return out;
}

int cap_node_scale_part(const std::vector<std::vector<int>>& neighbours, const std::vector<double>& area_m2,
                        const std::vector<char>& use, double cap, std::vector<double>& v) {
  require(cap > 0, "cap_node_scale_part: cap {} (expected > 0)", cap);
  const std::vector<double> part = node_scale_part(neighbours, area_m2, use, v);
  int moved = 0;
  for (size_t i = 0; i < v.size(); ++i)
    if (std::isfinite(part[i]) && std::abs(part[i]) > cap) {
      v[i] -= std::copysign(std::abs(part[i]) - cap, part[i]);
      ++moved;
    }
  return moved;
}

WallRoughness wall_roughness(const std::vector<std::vector<int>>& neighbours, const std::vector<double>& area_m2,
                             const std::vector<char>& use, const std::vector<double>& offset) {
  const std::vector<double> zero(offset.size(), 0.0);
  // The node-scale part against nothing: its RMS and nearest-rank 99th percentile over the nodes
  // where it is defined (compare_fields skips the NaNs).
  const report::ErrorStats part = report::compare_fields(node_scale_part(neighbours, area_m2, use, offset), zero);
  std::vector<int> used;
  for (size_t i = 0; i < use.size(); ++i)
    if (use[i]) used.push_back(static_cast<int>(i));
  WallRoughness w;
  if (used.size() >= 2) w.spread_m = report::compare_fields(offset, zero, used).sd_a;
  if (part.count == 0) return w;
  w.nodes = part.count;
  w.rms_m = part.rmse;
  w.p99_m = part.p99;
  return w;
}

std::vector<Vec3> donned_in_socket(const volume::SkinSurface& skin, const contact::DonningResult& d, const Vec3& axis) {
  std::vector<Vec3> out(skin.nodes.size());
  const Vec3 stood = d.final_offset_m * axis;
  for (size_t i = 0; i < out.size(); ++i) out[i] = d.positions.segment<3>(3 * skin.nodes[i]) - stood;
  return out;
}

std::vector<double> wall_corrections(design::DesignSolver& solver, const design::DesignState& state,
                                     const std::vector<int>& in_socket,
                                     const std::vector<double>& delivered, const std::vector<double>& target,
                                     const std::vector<Vec3>& donned, const std::vector<double>& offset,
                                     double spacing, const ClosedLoopOptions& options) {
  const auto& skin = solver.skin();
  const size_t n = skin.nodes.size();
  std::vector<double> excess(n, 0.0);
  std::vector<char> use(n, 0);
  for (int i : in_socket) {
    excess[i] = delivered[i] - target[i];
    use[i] = 1;
  }
  excess = smooth_on_skin(skin, use, std::move(excess), options.smoothing_passes);
  const std::vector<double> un = solver.normal_displacement(excess, state);
  std::vector<double> corr(n);
  std::vector<Vec3> wall(n);
  for (size_t i = 0; i < n; ++i) {
    corr[i] = -options.relaxation * un[i];
    wall[i] = state.skin_positions[i] + offset[i] * state.skin_normals[i];
  }
  return corrections_on_wall(wall, donned, corr, in_socket, 0.5 * spacing);
}

ZoneSteps::ZoneSteps(const std::vector<LandmarkZone>& zones, const std::vector<char>& relieved,
                     std::vector<double> area_m2, const std::vector<Vec3>& normals, const Vec3& axis)
    : area_m2_(std::move(area_m2)) {
  require(relieved.size() == zones.size(), "ZoneSteps: {} relief flags for {} zones", relieved.size(), zones.size());
  for (size_t k = 0; k < zones.size(); ++k) {
    Vec3 n = Vec3::Zero();
    for (int i : zones[k].nodes) n += area_m2_[i] * normals[i];
    zones_.push_back({zones[k], !relieved[k] && std::abs(n.dot(axis)) > std::sqrt(0.5) * n.norm()});
  }
}

void ZoneSteps::apply(const std::vector<double>& excess, const std::vector<double>& offset, bool response,
                      std::vector<double>& correction) {
  for (auto& z : zones_) {
    if (z.end) continue;
    const double e = z.zone.mean(excess, area_m2_), d = z.zone.mean(offset, area_m2_),
                 c = z.zone.mean(correction, area_m2_);
    const double moved = d - z.offset;
    if (response && std::isfinite(z.excess) && std::abs(moved) > kZoneMoved) {
      const double seen = (e - z.excess) / moved;
      if (seen <= -kMinZoneSlope) {
        z.slope = std::min(seen, z.last_seen);
        z.last_seen = seen;
      }
    }
    z.excess = e;
    z.offset = d;
    if (z.slope == 0) continue;
    const double shift = std::clamp(-e / z.slope, -kMaxZoneStep, kMaxZoneStep) - c;
    for (int i : z.zone.nodes) correction[i] += shift;
  }
}

double mean_spacing(const std::vector<double>& area_m2, const std::vector<char>& use) {
  double sum = 0;
  int n = 0;
  for (size_t i = 0; i < area_m2.size(); ++i)
    if (use[i]) {
      sum += std::sqrt(area_m2[i]);
      ++n;
    }
  return n > 0 ? sum / n : 0.0;
}

DragBand drag_band(const design::DesignSolver& solver, const design::BrimLine& brim, const ClosedLoopResult& loop) {
  const auto& cyl = solver.skin_cylindrical();
  require(loop.ever_dragged_out.size() == cyl.size() && loop.target_pa.size() == cyl.size() &&
              loop.below_brim.size() == cyl.size(),
          "drag_band: a closed loop of {} nodes for a stump of {}", loop.target_pa.size(), cyl.size());
  const double spacing = mean_spacing(solver.skin().area_m2, loop.below_brim);
  DragBand b;
  for (size_t i = 0; i < cyl.size(); ++i) {
    if (!loop.ever_dragged_out[i] || loop.target_pa[i] <= kDragBandMinPa) continue;
    const double depth = std::max(0.0, brim.height(cyl[i].theta) - cyl[i].h) + 0.5 * spacing;
    b.lifts.push_back({cyl[i].theta, depth});
    b.node_ids.push_back(static_cast<int>(i));
    b.max_depth_m = std::max(b.max_depth_m, depth);
    b.max_designed_pa = std::max(b.max_designed_pa, loop.target_pa[i]);
  }
  return b;
}

}  // namespace socketsmith::pipeline
