// The closed loop's landmark-zone steps (pipeline::ZoneSteps) on a synthetic wall whose zone answers
// linearly: the slope measured from one correction to the next, the secant step that removes the
// zone's excess, and what is not believed (a wall that hardly moved, a slope of the wrong sign, a
// loaded zone at the stump's end). The wall's node-scale roughness (node_scale_part, wall_roughness,
// cap_node_scale_part) on a grid of nodes.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "socketsmith/core/errors.h"
#include "socketsmith/pipeline/closed_loop_correction.h"

namespace socketsmith::pipeline {
namespace {

/// Four skin nodes; the zone holds nodes 1 and 2 (areas 1 and 3: means weigh 1/4, 3/4). Its excess
/// answers the zone's mean wall offset with a slope kSlope [Pa/m] (moving out relieves) — softer than
/// what the correction the loop computes assumes, and that correction at the zone is its neighbours'.
constexpr double kSlope = -1e7;
struct Wall {
  std::vector<double> offset = std::vector<double>(4, 0.0);
  double excess0 = -6000;  // the zone's excess at offset 0 [Pa]: it presses too little
  std::vector<double> excess() const {
    const double d = 0.25 * offset[1] + 0.75 * offset[2];
    const double e = excess0 + kSlope * d;
    return {500.0, e, e, -500.0};  // the zone's nodes alike; the others off the zone
  }
  void move(const std::vector<double>& c) {
    for (size_t i = 0; i < c.size(); ++i) offset[i] += c[i];
  }
};
const std::vector<LandmarkZone> kZones{{"GT", {1, 2}, 4.0}};
const std::vector<double> kArea{1.0, 1.0, 3.0, 1.0};
const std::vector<char> kLoaded{0}, kRelieved{1};  // the zone's design: a load, a relief
const Eigen::Vector3d kAxis(0, 0, 1);
// On the stump's side: normals across the axis (one 50° from it, still a side).
const std::vector<Eigen::Vector3d> kSide{{1, 0, 0}, {0, 1, 0}, {std::sin(0.87), 0, std::cos(0.87)}, {-1, 0, 0}};
double zone_mean(const std::vector<double>& v) { return 0.25 * v[1] + 0.75 * v[2]; }

TEST(ZoneSteps, a_zone_whose_correction_is_its_neighbours_reaches_its_design_by_its_own_secant) {
  Wall wall;
  ZoneSteps steps(kZones, kLoaded, kArea, kSide, kAxis);
  // The loop's correction: outwards at the zone (its neighbours press too much), though the zone
  // itself presses too little. Unmeasured, the zone takes it as it is.
  std::vector<double> c{2e-4, 3e-4, 1e-4, -1e-4};
  steps.apply(wall.excess(), wall.offset, false, c);
  EXPECT_EQ(steps.slope(0), 0.0);
  EXPECT_DOUBLE_EQ(c[1], 3e-4);
  wall.move(c);
  const double after_raw = zone_mean(wall.excess());
  EXPECT_LT(after_raw, -6000);  // the neighbours' correction made the zone worse
  // The refit's answer gives the slope; the zone's mean step is then −excess / slope, the shape of
  // the correction across its nodes kept, the nodes off the zone untouched.
  c = {1e-4, 2e-4, -2e-4, 5e-5};
  steps.apply(wall.excess(), wall.offset, true, c);
  EXPECT_NEAR(steps.slope(0), kSlope, 1e-6 * std::abs(kSlope));
  EXPECT_NEAR(zone_mean(c), -after_raw / kSlope, 1e-12);
  EXPECT_NEAR(c[1] - c[2], 4e-4, 1e-15);
  EXPECT_DOUBLE_EQ(c[0], 1e-4);
  EXPECT_DOUBLE_EQ(c[3], 5e-5);
  wall.move(c);
  EXPECT_NEAR(zone_mean(wall.excess()), 0.0, 1e-6);
}

TEST(ZoneSteps, a_wall_that_hardly_moved_or_a_slope_of_the_wrong_sign_is_not_believed) {
  ZoneSteps steps(kZones, kLoaded, kArea, kSide, kAxis);
  std::vector<double> offset(4, 0.0), c(4, 0.0);
  steps.apply({0, -6000, -6000, 0}, offset, false, c);
  // Moved 10 µm (below kZoneMoved): noise, no slope.
  offset = {0, 1e-5, 1e-5, 0};
  c.assign(4, 1e-4);
  steps.apply({0, -5000, -5000, 0}, offset, true, c);
  EXPECT_EQ(steps.slope(0), 0.0);
  EXPECT_DOUBLE_EQ(c[1], 1e-4);
  // Moved out 0.2 mm and the zone pressed more: not a stiffness.
  offset = {0, 2.1e-4, 2.1e-4, 0};
  steps.apply({0, -3000, -3000, 0}, offset, true, c);
  EXPECT_EQ(steps.slope(0), 0.0);
  // Moved out 0.2 mm and it pressed 50 Pa less: softer than kMinZoneSlope, not believed either.
  offset = {0, 4.1e-4, 4.1e-4, 0};
  steps.apply({0, -3050, -3050, 0}, offset, true, c);
  EXPECT_EQ(steps.slope(0), 0.0);
  // A donning from scratch (no response) measures nothing, however far the wall moved.
  offset = {0, 1e-3, 1e-3, 0};
  steps.apply({0, -9100, -9100, 0}, offset, false, c);
  EXPECT_EQ(steps.slope(0), 0.0);
}

TEST(ZoneSteps, the_stiffer_of_the_last_two_slopes_is_used_and_the_step_is_clamped) {
  ZoneSteps steps(kZones, kLoaded, kArea, kSide, kAxis);
  std::vector<double> c(4, 0.0);
  steps.apply({0, -5000, -5000, 0}, {0, 0, 0, 0}, false, c);
  steps.apply({0, -3000, -3000, 0}, {0, -1e-4, -1e-4, 0}, true, c);  // moved in: −2e7 Pa/m
  EXPECT_NEAR(steps.slope(0), -2e7, 1.0);
  // −1e6 Pa/m next: the stiffer of the last two stays (a step on the soft one would overshoot).
  c.assign(4, 0.0);
  steps.apply({0, -2900, -2900, 0}, {0, -2e-4, -2e-4, 0}, true, c);
  EXPECT_NEAR(steps.slope(0), -2e7, 1.0);
  EXPECT_NEAR(zone_mean(c), -2900 / 2e7, 1e-12);  // inwards: it presses too little
  // −1e6 twice: the slope softens, and the step it asks (2.8 mm) is clamped.
  c.assign(4, 0.0);
  steps.apply({0, -2800, -2800, 0}, {0, -3e-4, -3e-4, 0}, true, c);
  EXPECT_NEAR(steps.slope(0), -1e6, 1e-3);
  EXPECT_NEAR(zone_mean(c), -kMaxZoneStep, 1e-15);
}

TEST(ZoneSteps, a_loaded_zone_facing_along_the_axis_is_left_to_the_loops_correction) {
  // The same zone at the distal end (its normals 30° off the axis, pointing down it).
  const std::vector<Eigen::Vector3d> end(4, Eigen::Vector3d(0.5, 0, -std::sqrt(0.75)));
  ZoneSteps steps(kZones, kLoaded, kArea, end, kAxis);
  EXPECT_TRUE(steps.end(0));
  std::vector<double> c(4, 0.0);
  steps.apply({0, -5000, -5000, 0}, {0, 0, 0, 0}, false, c);
  c = {0, 2e-4, 1e-4, 0};
  steps.apply({0, -3000, -3000, 0}, {0, -1e-4, -1e-4, 0}, true, c);
  EXPECT_EQ(steps.slope(0), 0.0);
  EXPECT_DOUBLE_EQ(c[1], 2e-4);
  EXPECT_DOUBLE_EQ(c[2], 1e-4);
  // Relieved by its design, the same end zone is stepped by its own secant: 2 kPa over after the
  // wall moved 0.1 mm out for 2 kPa less: a slope of −20 kPa/mm, a step of 0.1 mm out.
  ZoneSteps relief(kZones, kRelieved, kArea, end, kAxis);
  EXPECT_FALSE(relief.end(0));
  c.assign(4, 0.0);
  relief.apply({0, 4000, 4000, 0}, {0, 0, 0, 0}, false, c);
  c = {0, 2e-4, 1e-4, 0};
  relief.apply({0, 2000, 2000, 0}, {0, 1e-4, 1e-4, 0}, true, c);
  EXPECT_NEAR(relief.slope(0), -2e7, 1e-3);
  EXPECT_NEAR(zone_mean(c), 1e-4, 1e-15);
  EXPECT_NEAR(c[1] - c[2], 1e-4, 1e-15);  // the correction's shape kept
  EXPECT_THROW(ZoneSteps(kZones, {}, kArea, end, kAxis), InvalidInputError);
}

/// A k × k grid of nodes 4-connected, equal areas; node (x, y) is x + k y.
struct Grid {
  int k;
  std::vector<std::vector<int>> neighbours;
  std::vector<double> area;
  explicit Grid(int k_) : k(k_), neighbours(k_ * k_), area(k_ * k_, 1e-5) {
    for (int y = 0; y < k; ++y)
      for (int x = 0; x < k; ++x) {
        auto& nb = neighbours[x + k * y];
        if (x > 0) nb.push_back(x - 1 + k * y);
        if (x + 1 < k) nb.push_back(x + 1 + k * y);
        if (y > 0) nb.push_back(x + k * (y - 1));
        if (y + 1 < k) nb.push_back(x + k * (y + 1));
      }
  }
  bool interior(int i) const { return i % k > 0 && i % k < k - 1 && i / k > 0 && i / k < k - 1; }
};

TEST(WallRoughness, a_smooth_wall_has_none_a_wall_alternating_node_by_node_is_all_node_scale) {
  const Grid g(8);
  const int n = g.k * g.k;
  std::vector<char> use(n, 1);
  std::vector<double> linear(n), checker(n);
  for (int i = 0; i < n; ++i) {
    linear[i] = 1e-3 * (0.3 * (i % g.k) - 0.2 * (i / g.k));
    checker[i] = ((i % g.k + i / g.k) % 2 == 0 ? 1 : -1) * 1e-4;
  }
  const auto smooth = node_scale_part(g.neighbours, g.area, use, linear);
  const auto rough = node_scale_part(g.neighbours, g.area, use, checker);
  for (int i = 0; i < n; ++i) {
    if (!g.interior(i)) continue;
    EXPECT_NEAR(smooth[i], 0.0, 1e-15) << i;
    EXPECT_NEAR(rough[i], 2 * checker[i], 1e-15) << i;  // its neighbours all have the other sign
  }
  // Only the used nodes count: a node not used has none, a node with one used neighbour neither.
  use[0] = 0;
  use[2] = 0;
  use[g.k + 1] = 0;  // node 1's neighbours: 0, 2, k + 1 (none used)
  const auto part = node_scale_part(g.neighbours, g.area, use, checker);
  EXPECT_TRUE(std::isnan(part[0]));
  EXPECT_TRUE(std::isnan(part[1]));
  EXPECT_TRUE(std::isfinite(part[g.k + 2]));
  // The roughness of the checkerboard over the interior: every node 0.2 mm from its neighbours' mean.
  std::vector<char> inner(n, 0);
  for (int i = 0; i < n; ++i) inner[i] = g.interior(i);
  const WallRoughness w = wall_roughness(g.neighbours, g.area, inner, checker);
  EXPECT_EQ(w.nodes, 36);  // the 6 × 6 interior nodes, each with 2–4 interior neighbours
  EXPECT_NEAR(w.rms_m, 2e-4, 1e-15);
  EXPECT_NEAR(w.p99_m, 2e-4, 1e-15);
  // Its spread: the offsets' standard deviation over the used nodes (±0.1 mm, half each): all of it node-scale.
  EXPECT_NEAR(w.spread_m, 1e-4, 1e-15);
  EXPECT_NEAR(w.share(), 2.0, 1e-12);
  // A wall moved as a whole has none; a tilted one only where a node's ring is cut by the region's edge.
  EXPECT_NEAR(wall_roughness(g.neighbours, g.area, inner, std::vector<double>(n, 3e-4)).p99_m, 0.0, 1e-15);
  EXPECT_LT(wall_roughness(g.neighbours, g.area, use, linear).rms_m, 0.5 * 0.3e-3);
  EXPECT_THROW(node_scale_part(g.neighbours, g.area, std::vector<char>(3, 1), linear), InvalidInputError);
}

TEST(WallRoughness, the_cap_moves_only_the_nodes_further_from_their_neighbours_than_it) {
  const Grid g(5);
  const int n = g.k * g.k;
  std::vector<char> use(n, 1);
  std::vector<double> v(n, 1e-3);
  const int peak = 2 + 2 * g.k;  // the centre, 0.5 mm out of a flat wall
  v[peak] += 5e-4;
  std::vector<double> capped = v;
  // Its neighbours see it as a quarter (or a third) of their mean: 0.125 mm below it, under the cap.
  EXPECT_EQ(cap_node_scale_part(g.neighbours, g.area, use, 2e-4, capped), 1);
  EXPECT_NEAR(capped[peak], 1.2e-3, 1e-15);
  for (int i = 0; i < n; ++i)
    if (i != peak) {
      EXPECT_DOUBLE_EQ(capped[i], v[i]);
    }
  std::vector<double> loose = v;
  EXPECT_EQ(cap_node_scale_part(g.neighbours, g.area, use, 6e-4, loose), 0);
  EXPECT_EQ(loose, v);
  EXPECT_THROW(cap_node_scale_part(g.neighbours, g.area, use, 0.0, loose), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::pipeline
