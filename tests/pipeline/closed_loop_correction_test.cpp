// The closed loop's landmark-zone steps (pipeline::ZoneSteps) on a synthetic wall whose zone answers
// linearly: the slope measured from one correction to the next, the secant step that removes the
// zone's excess, and what is not believed (a wall that hardly moved, a slope of the wrong sign, a
// loaded zone at the stump's end).
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

}  // namespace
}  // namespace socketsmith::pipeline
