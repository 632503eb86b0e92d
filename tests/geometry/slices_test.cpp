// Slice measurements against analytic shapes: circumferences, cross-sections and slab volumes of a
// cylinder, a cone and a capsule; the slabs add up to the closed volume; the same numbers after a
// random rigid motion of shape and frame.
#include <gtest/gtest.h>

#include <cmath>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/slices.h"
#include "test_shapes.h"

namespace socketsmith::geometry {
namespace {

using test::make_capsule;
using test::make_lathe;

LimbFrame z_frame() {
  LimbFrame f;
  f.origin = Vec3::Zero();
  f.axis = Vec3::UnitZ();
  f.anterior = Vec3::UnitX();
  return f;
}

TEST(Slices, a_cylinders_circumference_area_and_slab_volumes_match_the_analytic_values) {
  const double r = 0.05, height = 0.2;
  const TriMesh cyl = make_lathe({{0, 0}, {r, 0}, {r, height}, {0, height}}, 256);
  const auto levels = measure_slices(cyl, z_frame(), slice_heights(0.01, 0.195));
  ASSERT_EQ(levels.size(), 20u);
  for (const auto& l : levels) {
    EXPECT_NEAR(l.circumference_m, 2 * M_PI * r, 0.005 * 2 * M_PI * r) << "h = " << l.h_m;
    EXPECT_NEAR(l.area_m2, M_PI * r * r, 0.005 * M_PI * r * r) << "h = " << l.h_m;
    const double slab = M_PI * r * r * (l.h_m - (&l == &levels.front() ? 0.0 : (&l - 1)->h_m));
    EXPECT_NEAR(l.slab_volume_m3, slab, 0.005 * slab) << "h = " << l.h_m;
  }
  EXPECT_NEAR(levels[7].circumference_m, 2 * 256 * r * std::sin(M_PI / 256), 1e-12);  // the polygon's exactly
  // Up to the top the slabs hold the whole closed volume.
  const auto all = measure_slices(cyl, z_frame(), slice_heights(0.01, 0.21));
  double sum = 0;
  for (const auto& l : all) sum += l.slab_volume_m3;
  EXPECT_NEAR(sum, signed_volume(cyl), 1e-12);
  EXPECT_NEAR(sum, M_PI * r * r * height, 0.01 * M_PI * r * r * height);
  EXPECT_EQ(all.back().circumference_m, 0.0);  // above the shape
}

TEST(Slices, a_cones_circumference_grows_linearly_and_its_volume_below_a_level_is_a_third_of_the_prism) {
  const double r = 0.06, height = 0.24;  // apex at the bottom, a limb-like taper
  std::vector<std::pair<double, double>> profile{{0, 0}};
  for (int k = 1; k <= 48; ++k) profile.emplace_back(r * k / 48.0, height * k / 48.0);
  profile.emplace_back(0, height);
  const TriMesh cone = make_lathe(profile, 256);
  const auto levels = measure_slices(cone, z_frame(), slice_heights(0.01, 0.235));
  for (const auto& l : levels) {
    const double rh = r * l.h_m / height;
    EXPECT_NEAR(l.circumference_m, 2 * M_PI * rh, 0.005 * 2 * M_PI * rh) << "h = " << l.h_m;
    EXPECT_NEAR(l.area_m2, M_PI * rh * rh, 0.005 * M_PI * rh * rh) << "h = " << l.h_m;
    const double v = M_PI * rh * rh * l.h_m / 3;
    EXPECT_NEAR(l.volume_below_m3, v, 0.005 * v) << "h = " << l.h_m;
  }
}

TEST(Slices, a_capsules_slabs_sum_to_its_closed_volume_within_one_percent_of_the_analytic_one) {
  const double r = 0.045, len = 0.15;
  const TriMesh cap = make_capsule(r, len, 24, 128);
  const double analytic = 4.0 / 3.0 * M_PI * r * r * r + M_PI * r * r * len;
  const auto levels = measure_slices(cap, z_frame(), slice_heights(0.01, 2 * r + len + 0.001));
  double sum = 0;
  for (const auto& l : levels) sum += l.slab_volume_m3;
  EXPECT_NEAR(sum, analytic, 0.01 * analytic);
  EXPECT_NEAR(sum, signed_volume(cap), 1e-9 * analytic);
  // Distal end: the slab below 10 mm of a sphere's cap, π h² (r − h/3).
  const double h = 0.01;
  EXPECT_NEAR(levels[0].slab_volume_m3, M_PI * h * h * (r - h / 3), 0.01 * M_PI * h * h * (r - h / 3));
}

TEST(Slices, an_open_cup_measures_below_its_opening) {
  const double r = 0.05, len = 0.15;
  const TriMesh cup = make_capsule(r, len, 24, 128, /*open_top=*/true);
  const double below = 2.0 / 3.0 * M_PI * r * r * r + M_PI * r * r * (0.15 - r);
  EXPECT_NEAR(volume_below(cup, z_frame(), 0.15), below, 0.005 * below);
  EXPECT_EQ(volume_below(cup, z_frame(), -0.01), 0.0);
}

TEST(Slices, the_numbers_do_not_change_under_a_rigid_motion_of_shape_and_frame) {
  const TriMesh cap = make_capsule(0.04, 0.12, 16, 96);
  const auto motion = test::random_rigid_motion(7);
  const TriMesh moved = test::transformed(cap, motion);
  LimbFrame f = z_frame();
  LimbFrame g;
  g.origin = motion * f.origin;
  g.axis = motion.linear() * f.axis;
  g.anterior = motion.linear() * f.anterior;
  const auto h = slice_heights(0.01, 0.19);
  const auto a = measure_slices(cap, f, h), b = measure_slices(moved, g, h);
  for (size_t k = 0; k < h.size(); ++k) {
    EXPECT_NEAR(a[k].circumference_m, b[k].circumference_m, 1e-9);
    EXPECT_NEAR(a[k].area_m2, b[k].area_m2, 1e-10);
    EXPECT_NEAR(a[k].volume_below_m3, b[k].volume_below_m3, 1e-10);
  }
}

TEST(Slices, levels_cover_the_height_and_bad_input_is_one_clear_error) {
  const auto h = slice_heights(0.01, 0.157);
  ASSERT_EQ(h.size(), 16u);
  EXPECT_NEAR(h[14], 0.15, 1e-12);
  EXPECT_DOUBLE_EQ(h.back(), 0.157);
  EXPECT_EQ(slice_heights(0.01, 0.03).size(), 3u);  // 10, 20, 30: no sliver of a last slab
  const auto msg = test::error_message<InvalidInputError>([] { slice_heights(0.0, 0.1); });
  EXPECT_NE(msg.find("step 0 mm must be positive"), std::string::npos) << msg;
  const TriMesh cap = make_capsule(0.04, 0.12, 8, 32);
  const auto msg2 = test::error_message<InvalidInputError>([&] { measure_slices(cap, z_frame(), {0.02, 0.01}); });
  EXPECT_NE(msg2.find("not above the one before"), std::string::npos) << msg2;
  const auto msg3 = test::error_message<InvalidInputError>([] { volume_below(TriMesh{}, z_frame(), 0.1); });
  EXPECT_NE(msg3.find("no triangles"), std::string::npos) << msg3;
}

}  // namespace
}  // namespace socketsmith::geometry
