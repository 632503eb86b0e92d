// The rigid socket: mass properties of an analytic shell, the inner wall seen from the axis, gaps
// against it (also for nodes pushed beyond the outer wall), bad sockets rejected.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <iostream>
#include <numbers>
#include <vector>

#include "socketsmith/contact/rigid_socket.h"
#include "socketsmith/core/errors.h"

namespace socketsmith::contact {
namespace {

/// A closed tube (open-ended cup without bottom would not be closed): inner radius ri, outer ro,
/// from z = 0 to z = H, with an annular top and bottom: a thick-walled pipe.
geometry::TriMesh pipe(double ri, double ro, double H, int seg = 96) {
  geometry::TriMesh m;
  for (int k = 0; k < seg; ++k) {
    const double a = 2 * std::numbers::pi * k / seg;
    const Vec3 d(std::cos(a), std::sin(a), 0);
    m.vertices.push_back(ri * d);                   // 4k: inner bottom
    m.vertices.push_back(ri * d + Vec3(0, 0, H));   // 4k+1: inner top
    m.vertices.push_back(ro * d);                   // 4k+2: outer bottom
    m.vertices.push_back(ro * d + Vec3(0, 0, H));   // 4k+3: outer top
  }
  for (int k = 0; k < seg; ++k) {
    const int a = 4 * k, b = 4 * ((k + 1) % seg);
    // outer wall (normal outward)
    m.triangles.push_back({a + 2, b + 2, b + 3});
    m.triangles.push_back({a + 2, b + 3, a + 3});
    // inner wall (normal towards the axis)
    m.triangles.push_back({a, a + 1, b + 1});
    m.triangles.push_back({a, b + 1, b});
    // top annulus (normal +z)
    m.triangles.push_back({a + 1, a + 3, b + 3});
    m.triangles.push_back({a + 1, b + 3, b + 1});
    // bottom annulus (normal −z)
    m.triangles.push_back({a, b, b + 2});
    m.triangles.push_back({a, b + 2, a + 2});
  }
  return m;
}

/// A pipe whose walls are cut into @p rings rows of quads (a socket's wall is meshed finely both
/// ways): @p ring(r, a) gives ring r's inner and outer radii and height at the angle a.
template <class Ring>
geometry::TriMesh profiled_pipe(int seg, int rings, Ring ring) {
  geometry::TriMesh m;
  const auto in = [&](int r, int k) { return 2 * ((r * seg) + (k % seg)); };
  for (int r = 0; r <= rings; ++r)
    for (int k = 0; k < seg; ++k) {
      const double a = 2 * std::numbers::pi * k / seg;
      const std::array<double, 3> p = ring(r, a);
      const Vec3 d(std::cos(a), std::sin(a), 0), z(0, 0, p[2]);
      m.vertices.push_back(p[0] * d + z);  // in(r, k)
      m.vertices.push_back(p[1] * d + z);  // in(r, k) + 1: outer
    }
  for (int k = 0; k < seg; ++k) {
    for (int r = 0; r < rings; ++r) {
      const int a = in(r, k), b = in(r, k + 1), c = in(r + 1, k + 1), e = in(r + 1, k);
      m.triangles.push_back({a, e, c});  // inner wall (normal towards the axis)
      m.triangles.push_back({a, c, b});
      m.triangles.push_back({a + 1, b + 1, c + 1});  // outer wall
      m.triangles.push_back({a + 1, c + 1, e + 1});
    }
    const int a = in(rings, k), b = in(rings, k + 1);  // top annulus
    m.triangles.push_back({a, a + 1, b + 1});
    m.triangles.push_back({a, b + 1, b});
    const int a0 = in(0, k), b0 = in(0, k + 1);  // bottom annulus
    m.triangles.push_back({a0, b0, b0 + 1});
    m.triangles.push_back({a0, b0 + 1, a0 + 1});
  }
  return m;
}

/// The thick-walled pipe of radii ri, ro and height H with its walls cut into @p rings rows.
geometry::TriMesh ringed_pipe(double ri, double ro, double H, int seg, int rings) {
  return profiled_pipe(seg, rings, [&](int r, double) { return std::array<double, 3>{ri, ro, H * r / rings}; });
}

geometry::LimbFrame z_frame() {
  geometry::LimbFrame f;
  f.origin = Vec3::Zero();
  f.axis = Vec3::UnitZ();
  f.anterior = Vec3::UnitX();
  return f;
}

/// A 50 mm pipe (5 mm wall) whose rim slopes from 230 mm (front, +x) to 170 mm (back), its last
/// ring folded 2 mm out and 0.5 mm down; smoothed wall. folded_rim(a): the rim's height.
double folded_rim(double a) { return 0.2 + 0.03 * std::cos(a); }
RigidSocket folded_rim_socket() {
  const double ri = 0.05, ro = 0.055;
  RigidSocket s(profiled_pipe(48, 41, [&](int r, double a) {
                  return r <= 40 ? std::array<double, 3>{ri, ro, folded_rim(a) * r / 40}
                                 : std::array<double, 3>{ri + 0.002, ro + 0.002, folded_rim(a) - 0.0005};
                }),
                z_frame());
  s.set_smooth_wall(true);
  return s;
}

TEST(RigidSocket, mass_properties_and_inner_wall_of_a_pipe) {
  const double ri = 0.05, ro = 0.055, H = 0.2, rho = 1250;
  const RigidSocket s(pipe(ri, ro, H), z_frame(), rho);
  const double seg_area = 0.5 * 96 * std::sin(2 * std::numbers::pi / 96);  // polygon area / r²
  const double vol = seg_area * (ro * ro - ri * ri) * H;
  EXPECT_NEAR(s.mass_kg(), rho * vol, 1e-9 * rho * vol);
  EXPECT_NEAR(s.centre_of_mass().z(), H / 2, 1e-9);
  EXPECT_NEAR(s.centre_of_mass().head<2>().norm(), 0.0, 1e-9);
  // Thin-walled tube about its axis: I_zz ≈ m (ri² + ro²) / 2.
  EXPECT_NEAR(s.inertia()(2, 2), s.mass_kg() * (ri * ri + ro * ro) / 2, 0.01 * s.mass_kg() * ro * ro);
  EXPECT_EQ(s.inner_triangles(), 2 * 96);  // exactly the inner wall
}

TEST(RigidSocket, gaps_against_the_inner_wall_even_beyond_the_outer_wall) {
  RigidSocket s(pipe(0.05, 0.055, 0.2), z_frame());
  const double inner = 0.05 * std::cos(std::numbers::pi / 96);  // mid-facet radius
  const Vec3 d(std::cos(std::numbers::pi / 96), std::sin(std::numbers::pi / 96), 0);  // mid-facet direction
  auto g = s.gap(0.03 * d + Vec3(0, 0, 0.1));  // in the cavity
  EXPECT_TRUE(g.valid);
  EXPECT_NEAR(g.gap_m, inner - 0.03, 1e-9);
  EXPECT_NEAR(g.normal.dot(d), -1.0, 1e-9);
  g = s.gap(0.052 * d + Vec3(0, 0, 0.1));  // inside the wall material
  EXPECT_NEAR(g.gap_m, inner - 0.052, 1e-9);
  g = s.gap(0.07 * d + Vec3(0, 0, 0.1));  // pushed through beyond the outer wall: still pushed back inwards
  EXPECT_TRUE(g.valid);
  EXPECT_NEAR(g.gap_m, inner - 0.07, 1e-9);
  EXPECT_NEAR(g.normal.dot(d), -1.0, 1e-9);
  g = s.gap(0.03 * d + Vec3(0, 0, 0.3));  // above the rim: not facing the wall
  EXPECT_FALSE(g.valid);
  s.set_translation(Vec3(0, 0, 0.15));  // the socket moved up: the same point is now inside it
  g = s.gap(0.03 * d + Vec3(0, 0, 0.3));
  EXPECT_TRUE(g.valid);
  EXPECT_NEAR(g.gap_m, inner - 0.03, 1e-9);
}

// The smoothed wall: within a fraction of the facets' sagitta of them on average, its normal turns
// smoothly where the facets' normals jump, and its force is the gradient of its penalty energy.
TEST(RigidSocket, smoothed_wall_follows_the_facets_and_turns_smoothly_across_their_edges) {
  const double ri = 0.05, H = 0.2;
  const int seg = 48;
  RigidSocket s(ringed_pipe(ri, 0.055, H, seg, 40), z_frame());
  ASSERT_FALSE(s.smooth_wall());
  const double dphi = 2 * std::numbers::pi / seg, sagitta = ri * (1 - std::cos(dphi / 2));
  const auto at = [&](double r, double phi, double z) { return Vec3(r * std::cos(phi), r * std::sin(phi), z); };
  // Gaps of points 0.1 mm beyond the wall at many angles, faceted and smoothed.
  double mean_diff = 0, max_diff = 0, max_turn = 0;
  for (int k = 0; k < 4 * seg; ++k) {
    const double phi = dphi * k / 4.0 + 0.01;
    for (double z : {0.06, 0.1, 0.14}) {
      const Vec3 p = at(ri + 1e-4, phi, z);
      s.set_smooth_wall(false);
      const Gap gf = s.gap(p);
      s.set_smooth_wall(true);
      const Gap gs = s.gap(p);
      ASSERT_TRUE(gf.valid && gs.valid);
      mean_diff += (gs.gap_m - gf.gap_m) / (4 * seg * 3);
      max_diff = std::max(max_diff, std::abs(gs.gap_m - gf.gap_m));
      EXPECT_GT(gs.normal.dot(-Vec3(std::cos(phi), std::sin(phi), 0)), 0.99995);  // radial (facets: ≤ 0.9979)
    }
  }
  EXPECT_LT(std::abs(mean_diff), 0.2 * sagitta) << "sagitta " << sagitta;
  EXPECT_LT(max_diff, 1.5 * sagitta) << "sagitta " << sagitta;
  for (double eps : {1e-4, 1e-3}) {
    const Vec3 a = at(ri + 1e-4, -eps, 0.1), b = at(ri + 1e-4, eps, 0.1);
    s.set_smooth_wall(true);
    const double turn = std::acos(std::min(1.0, s.gap(a).normal.dot(s.gap(b).normal)));
    max_turn = std::max(max_turn, turn / (2 * eps));  // [rad per rad of phi]
  }
  // Across the facets' edge at phi = 0 the smooth normal turns with the wall (1 rad per rad of
  // phi); the faceted one turns by the whole kink dphi within the point's depth (0.1 mm) of it.
  EXPECT_LT(max_turn, 1.5);
  s.set_smooth_wall(false);
  const double facet_turn = std::acos(std::min(1.0, s.gap(at(ri + 1e-4, -1e-4, 0.1)).normal.dot(
                                                        s.gap(at(ri + 1e-4, 1e-4, 0.1)).normal))) / 2e-4;
  EXPECT_GT(facet_turn, 100.0);
  // ½ g² is the penalty energy per k A: its gradient g |∇g| n is the force direction used.
  s.set_smooth_wall(true);
  const Vec3 p = at(ri + 2e-4, 0.3, 0.1);
  const Gap g = s.gap(p);
  for (const Vec3& dir : {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1), Vec3(0.6, -0.8, 0)}) {
    const double h = 1e-7;
    const double fd = (s.gap(p + h * dir).gap_m - s.gap(p - h * dir).gap_m) / (2 * h);
    EXPECT_NEAR(fd, g.gradient_norm * g.normal.dot(dir), 1e-5) << dir.transpose();
    EXPECT_NEAR(dir.dot(g.stiffness_shape * dir), std::pow(g.gradient_norm * g.normal.dot(dir), 2), 1e-9);
  }
  EXPECT_NEAR(g.gradient_norm, 1.0, 0.05);
}

// A point near the wall is laid onto it (CalculiX's shell on socketsmith's wall): on the smoothed
// wall of a ringed pipe the gap there vanishes, the point moved along the wall's normal (radially),
// the normal given points out of the cavity; beyond the reach, nothing.
TEST(RigidSocket, a_point_near_the_wall_is_laid_onto_it) {
  const double ri = 0.05;
  RigidSocket s(ringed_pipe(ri, 0.055, 0.2, 48, 40), z_frame());
  s.set_smooth_wall(true);
  for (const double r : {ri - 2e-3, ri - 1e-4, ri + 1e-3}) {
    const Vec3 p(r * std::cos(0.3), r * std::sin(0.3), 0.1);
    const auto on = s.onto_wall(p);
    ASSERT_TRUE(on.has_value()) << r;
    EXPECT_NEAR(s.gap(on->first).gap_m, 0.0, 1e-8);
    const Vec3 radial(std::cos(0.3), std::sin(0.3), 0);
    const Vec3 moved = on->first - p;
    EXPECT_LT(moved.cross(radial).norm(), 1e-3 * moved.norm() + 1e-12);  // along the radius
    EXPECT_GT(on->second.dot(radial), 0.9999);                     // out of the cavity
  }
  EXPECT_FALSE(s.onto_wall(Vec3(0.04, 0, 0.1)).has_value());  // 10 mm inside the wall: out of reach
  EXPECT_TRUE(s.onto_wall(Vec3(0.04, 0, 0.1), 0.012).has_value());
}

// A socket designed on a stump has its wall's vertices where the skin's nodes are: the smoothed
// wall fitted to those nodes' footprints gives the nodes the facets' gap (what CalculiX and the
// printed socket give them), where the wall through the facets on average lies a sagitta inside
// the facets at the vertices and pressed the nodes a third harder (docs/contact.md).
TEST(RigidSocket, smoothed_wall_fitted_to_the_skin_gives_its_nodes_the_facets_gap) {
  const double ri = 0.05, H = 0.2;
  const int seg = 24;
  RigidSocket s(ringed_pipe(ri, 0.055, H, seg, 20), z_frame());
  const double dphi = 2 * std::numbers::pi / seg, sagitta = ri * (1 - std::cos(dphi / 2));
  const auto at = [&](double r, double phi, double z) { return Vec3(r * std::cos(phi), r * std::sin(phi), z); };
  // Skin nodes at rest 1 mm outside the wall, at its vertices' angles and heights.
  std::vector<Vec3> skin;
  for (int k = 0; k < seg; ++k)
    for (int r = 4; r <= 16; ++r) skin.push_back(at(ri + 0.001, dphi * k, H * r / 20));
  const auto worst = [&](const std::vector<Vec3>& points) {
    double mean = 0, most = 0;
    for (const Vec3& p : points) {
      s.set_smooth_wall(false);
      const double f = s.gap(p).gap_m;
      s.set_smooth_wall(true);
      const Gap g = s.gap(p);
      EXPECT_TRUE(g.valid);
      mean += (g.gap_m - f) / static_cast<double>(points.size());
      most = std::max(most, std::abs(g.gap_m - f));
    }
    return std::pair{mean, most};
  };
  // Through the facets on average: a node at a vertex is inside the smoothed wall by most of a sagitta.
  const auto [mean0, most0] = worst(skin);
  EXPECT_LT(mean0, -0.5 * sagitta) << "sagitta " << sagitta;
  s.fit_smooth_wall_to(skin);
  const auto [mean1, most1] = worst(skin);
  EXPECT_LT(std::abs(mean1), 0.05 * sagitta) << "sagitta " << sagitta;
  EXPECT_LT(most1, 0.15 * sagitta) << "sagitta " << sagitta;
  // Nodes in the middle of the facets now find the smoothed wall outside them (the price), by
  // less than a sagitta and a half.
  std::vector<Vec3> between;
  for (int k = 0; k < seg; ++k) between.push_back(at(ri + 0.001, dphi * (k + 0.5), 0.1));
  const auto [mean2, most2] = worst(between);
  EXPECT_GT(mean2, 0.0);
  EXPECT_LT(most2, 1.5 * sagitta);
  std::cout << "sagitta " << sagitta * 1e3 << " mm; smoothed minus faceted gap at the nodes, mean / largest: " << mean0 * 1e3
            << " / " << most0 * 1e3 << " mm through the facets on average, " << mean1 * 1e3 << " / " << most1 * 1e3
            << " fitted; between the nodes " << mean2 * 1e3 << " / " << most2 * 1e3 << "\n";
  // A wall corrected while it is worn keeps the fit.
  s.replace_solid(ringed_pipe(ri, 0.055, H, seg, 20));
  EXPECT_NEAR(worst(skin).first, mean1, 1e-12);
  // Nodes far from the wall do not count: the wall stays through the facets on average.
  s.fit_smooth_wall_to({Vec3(0, 0, 0.1)});
  EXPECT_NEAR(worst(skin).first, mean0, 1e-12);
}

// A coarse, strongly curved wall (a hexagonal pipe: its facets' normals 60° apart, each vertex's
// support reaching the next corner): the smoothed gap stays continuous, with the gradient it reports,
// where the closest facet switches. Choosing the vertices by the closest facet's normal made it jump
// there by up to a tenth of a millimetre, and a donning's Newton stalled on the jump.
TEST(RigidSocket, smoothed_wall_is_continuous_where_the_closest_facet_switches_on_a_coarse_wall) {
  const double ri = 0.05, H = 0.2;
  const int seg = 6;
  RigidSocket s(ringed_pipe(ri, 0.056, H, seg, 4), z_frame());
  s.set_smooth_wall(true);
  const double apothem = ri * std::cos(std::numbers::pi / seg);
  // 1.5 mm beyond the hexagon's wall at angle phi (the wall's distance from the axis varies; the
  // smoothed wall rounds the corners off by about 0.5 mm).
  const auto beyond = [&](double phi) -> Vec3 {
    const double sector = 2 * std::numbers::pi / seg;
    const double rel = phi - sector * (std::floor(phi / sector) + 0.5);  // from the face's middle
    return (apothem / std::cos(rel) + 1.5e-3) * Vec3(std::cos(phi), std::sin(phi), 0) + Vec3(0, 0, 0.1);
  };
  const int n = 6000;
  double worst_slope = 0, worst_fd = 0, gap_min = 1, gap_max = -1;
  Vec3 p_prev = beyond(0.0);
  Gap g_prev = s.gap(p_prev);
  for (int i = 1; i <= n; ++i) {
    const Vec3 p = beyond(2 * std::numbers::pi * i / n);
    const Gap g = s.gap(p);
    ASSERT_TRUE(std::isfinite(g.gap_m)) << i;
    gap_min = std::min(gap_min, g.gap_m);
    gap_max = std::max(gap_max, g.gap_m);
    // The change of the gap between neighbouring points (52 µm apart, and 0.26 µm apart where it is
    // steep): bounded by the gradient's size (≈ 1); a jump of 1 µm gives a slope of 4 there.
    const double slope = std::abs(g.gap_m - g_prev.gap_m) / (p - p_prev).norm();
    if (slope > 0.3) {
      // Steep here: look between the two points 200 times closer (a jump's slope grows with it).
      Gap sub_prev = g_prev;
      for (int k = 1; k <= 200; ++k) {
        const Vec3 q = beyond(2 * std::numbers::pi * (i - 1 + k / 200.0) / n);
        const Gap sub = s.gap(q);
        worst_slope = std::max(worst_slope, std::abs(sub.gap_m - sub_prev.gap_m) / ((p - p_prev).norm() / 200));
        sub_prev = sub;
      }
    }
    worst_slope = std::max(worst_slope, slope);
    if (i % 50 == 0) {
      // The reported gradient is the gap's: central differences in three directions.
      for (int a = 0; a < 3; ++a) {
        const double h = 1e-7;
        const Vec3 e = Vec3::Unit(a);
        const double fd = (s.gap(p + h * e).gap_m - s.gap(p - h * e).gap_m) / (2 * h);
        worst_fd = std::max(worst_fd, std::abs(fd - g.gradient_norm * g.normal[a]));
      }
    }
    p_prev = p;
    g_prev = g;
  }
  std::cout << "gap " << gap_min << " .. " << gap_max << " m, slope " << worst_slope << ", gradient error " << worst_fd << "\n";
  EXPECT_LT(worst_slope, 2.0);
  EXPECT_LT(worst_fd, 1e-4);
}

// Past the rim the wall ends in its lip, a half-round of half the wall's thickness: a node pressed
// into the wall just below the rim and moving up over it is pushed by the wall, then by the lip,
// with no jump of the penalty energy ½ gap² and with the force its gradient; above the lip nothing
// touches it (the inner wall's extension does not reach past the rim).
TEST(RigidSocket, smoothed_wall_hands_over_to_the_lip_past_the_rim) {
  const double ri = 0.05, H = 0.2;
  RigidSocket s(ringed_pipe(ri, 0.055, H, 48, 40), z_frame());
  s.set_smooth_wall(true);
  EXPECT_NEAR(s.lip_radius_m(), 0.0025, 1e-4);  // half the 5 mm wall
  const double r = s.lip_radius_m();
  const auto energy = [&](const Vec3& p) {
    const Gap g = s.gap(p);
    return g.valid && g.gap_m < 0 ? 0.5 * g.gap_m * g.gap_m : 0.0;
  };
  // 1 mm behind the wall along a direction through a vertex of the 48-gon (there the facets lie
  // cos(π/48) · 1 mm from the point), from 4 mm below the rim (z = H) to 5 mm above it.
  const Vec3 dir(std::cos(4 * std::numbers::pi / 48), std::sin(4 * std::numbers::pi / 48), 0);
  const double behind = 1e-3 * std::cos(std::numbers::pi / 48);
  double worst_step = 0, worst_fd = 0, worst_lip = 0;
  const int n = 4000;
  double e_prev = energy((ri + 1e-3) * dir + Vec3(0, 0, H - 0.004));
  for (int i = 1; i <= n; ++i) {
    const double z = -0.004 + 0.009 * i / n;  // above the rim
    const Vec3 p = (ri + 1e-3) * dir + Vec3(0, 0, H + z);
    const Gap g = s.gap(p);
    const double e = energy(p);
    worst_step = std::max(worst_step, std::abs(e - e_prev));
    e_prev = e;
    if (z < -0.002) {
      EXPECT_NEAR(g.gap_m, -behind, 1e-4) << z;  // the wall
    }
    if (z > 0.001) {  // the lip: a tube of radius r about the rim moved r into the wall
      const double lip = std::hypot(r - 1e-3, z) - r;  // 1 mm behind the rim's vertex
      worst_lip = std::max(worst_lip, std::abs((g.valid ? g.gap_m : 1.0) - lip));
    }
    if (i % 20 == 0 && g.valid && g.gap_m < 0) {
      const Vec3 force = -g.gap_m * g.gradient_norm * g.normal;
      for (int a = 0; a < 3; ++a) {
        const double h = 1e-8;
        const Vec3 e3 = Vec3::Unit(a);
        const double fd = -(energy(p + h * e3) - energy(p - h * e3)) / (2 * h);
        worst_fd = std::max(worst_fd, std::abs(fd - force[a]) / 1e-3);  // relative to gap · 1
      }
    }
  }
  std::cout << "energy step " << worst_step << ", force error " << worst_fd << ", lip gap error " << worst_lip << " m\n";
  // ½ (1 mm)² = 5e-7 falls to 0 over ~2 mm of the path (steps of 2.25 µm: ~1e-9 each); a jump is ~1e-7.
  EXPECT_LT(worst_step, 1e-8);
  EXPECT_LT(worst_fd, 1e-4);
  EXPECT_LT(worst_lip, 1e-4);
  const Gap above = s.gap((ri + 1e-3) * dir + Vec3(0, 0, H + 0.006));
  EXPECT_FALSE(above.valid && above.gap_m < 0);
  // Far behind the wall's extension, 5 mm above the rim (where a limb widens above the brim): the
  // lip is 8 mm away, no contact (the facets' closest point, on the rim, counted it 13 mm deep).
  const Gap wide = s.gap((ri + 0.012) * dir + Vec3(0, 0, H + 0.005));
  EXPECT_FALSE(wide.valid && wide.gap_m < 0) << wide.gap_m;
}

// A node on the lip's outer side (behind its centre line) that moves down below the rim's level:
// past the rim only the lip holds it, below the rim the wall's extension, 2|a| deeper there; the
// lip's energy hands back to the wall's over an angle about the centre line, with no jump (the
// generated transfemoral limb of seed 10 stalled on a node whose gap went from −0.10 to −3.85 mm
// for a step of 3 nm) and the force the energy's gradient.
TEST(RigidSocket, a_node_on_the_lips_outer_side_goes_below_the_rim_without_a_jump) {
  const double ri = 0.05, H = 0.2;
  RigidSocket s(ringed_pipe(ri, 0.055, H, 48, 40), z_frame());
  s.set_smooth_wall(true);
  const double r = s.lip_radius_m();
  const auto energy = [&](const Vec3& p) {
    const Gap g = s.gap(p);
    return g.valid && g.gap_m < 0 ? 0.5 * g.gap_m * g.gap_m : 0.0;
  };
  // The force −gap ∇gap against the central difference of ½ gap², relative to a gap of 1 mm.
  const auto force_error = [&](const Vec3& p, const Gap& g) {
    const Vec3 force = -g.gap_m * g.gradient_norm * g.normal;
    double worst = 0;
    for (int a = 0; a < 3; ++a) {
      const double h = 1e-8;
      const Vec3 e3 = Vec3::Unit(a);
      const double fd = -(energy(p + h * e3) - energy(p - h * e3)) / (2 * h);
      worst = std::max(worst, std::abs(fd - force[a]) / 1e-3);
    }
    return worst;
  };
  // 4 mm behind the inner wall (1.5 mm behind the lip's centre line), from 2 mm above the rim to
  // 3 mm below it, in steps of 0.5 µm.
  const Vec3 dir(std::cos(4 * std::numbers::pi / 48), std::sin(4 * std::numbers::pi / 48), 0);
  const double behind = 0.004;
  double worst_step = 0, worst_fd = 0;
  const int n = 10000;
  double e_prev = energy((ri + behind) * dir + Vec3(0, 0, H + 0.002));
  for (int i = 1; i <= n; ++i) {
    const double z = 0.002 - 0.005 * i / n;
    const Vec3 p = (ri + behind) * dir + Vec3(0, 0, H + z);
    const Gap g = s.gap(p);
    const double e = energy(p);
    worst_step = std::max(worst_step, std::abs(e - e_prev));
    e_prev = e;
    if (z > 0.0005) {  // past the rim behind the centre line: the lip alone
      EXPECT_NEAR(g.gap_m, std::hypot(behind - r, z) - r, 1e-4) << z;
    }
    // (At the rim's level the hand-back starts: the energy is C¹ there, its curvature jumps, and a
    // central difference across it is off by h times that curvature.)
    if (i % 20 == 0 && g.valid && g.gap_m < 0 && std::abs(z) > 1e-6) worst_fd = std::max(worst_fd, force_error(p, g));
  }
  // Where the hand-back fades out with the distance D from the centre line (1.5–2.5 r; here 4.5 mm
  // behind it, within 0.45 mm below the rim: inside the 6° hand-back): the lip's share lifts the gap
  // above the wall's, and the force is still the energy's gradient, the fade's slope included.
  double worst_fade = 0;
  int lifted = 0;
  const double wall_here = -(r + 0.0045) * std::cos(std::numbers::pi / 48);
  for (int i = 0; i <= 50; ++i) {
    const double z = -0.00002 - 0.0004 * i / 50;
    const Vec3 p = (ri + r + 0.0045) * dir + Vec3(0, 0, H + z);
    const Gap g = s.gap(p);
    if (!(g.valid && g.gap_m < 0)) continue;
    if (g.gap_m > wall_here + 1e-5) ++lifted;
    worst_fade = std::max(worst_fade, force_error(p, g));
  }
  std::cout << "force error where the hand-back fades " << worst_fade << " (" << lifted << " of 51 points lifted)\n";
  EXPECT_GT(lifted, 10);
  EXPECT_LT(worst_fade, 1e-4);
  const Gap deep = s.gap((ri + behind) * dir + Vec3(0, 0, H - 0.003));
  std::cout << "energy step " << worst_step << ", force error " << worst_fd << ", gap 3 mm below the rim "
            << deep.gap_m << " m\n";
  // ½ (4 mm)² = 8e-6 is the wall's energy below the rim, ½ (1 mm)² the lip's at its level: the jump
  // was 7.5e-6 at one step; the hand-back over 6° about the centre line (0.15 mm of the path here)
  // changes it by ≤ 4e-8 a step of 0.5 µm.
  EXPECT_LT(worst_step, 1e-7);
  EXPECT_LT(worst_fd, 1e-4);
  EXPECT_NEAR(deep.gap_m, -behind * std::cos(std::numbers::pi / 48), 2e-4);  // the wall's, well below the rim
}

// The lip's centre line on a trim line that rises and falls (±25 mm around a 50 mm pipe, the wall
// flared 5 mm over its top 20 mm): its closest point is the global one. Newton hopping from the
// nearest chord's segment to its neighbours stopped at a local closest point there, and a point on
// the wall just below the rim was 1.9 or 3.2 mm from the centre line for a move of 5 µm — its
// depth 0.61 or 0.04 mm, back and forth (a line search stalls on such a jump).
TEST(RigidSocket, the_lip_of_a_rising_and_falling_flared_rim_has_no_jump) {
  const double ri = 0.05, H = 0.2, flare = 0.005, zone = 0.02, tilt = 0.025;
  const auto top = [&](double a) { return H + tilt * std::cos(2 * a); };
  const auto rad = [&](double z, double a) {
    const double t = std::clamp((z - (top(a) - zone)) / zone, 0.0, 1.0);
    return ri + flare * t * t * (3 - 2 * t);
  };
  RigidSocket s(profiled_pipe(64, 50, [&](int r, double a) {
                  const double z = top(a) * r / 50;
                  return std::array<double, 3>{rad(z, a), rad(z, a) + 0.005, z};
                }),
                z_frame());
  s.set_smooth_wall(true);
  const auto depth = [&](const Vec3& p) {
    const Gap g = s.gap(p);
    return g.valid && g.gap_m < 0 ? -g.gap_m : 0.0;
  };
  // Radially through the wall at the rim's height, where the rim falls steeply, in steps of 1 µm.
  double worst = 0, deepest = 0;
  for (const double ang : {0.45, 0.49, 0.53}) {
    const Vec3 dir(std::cos(ang), std::sin(ang), 0), up(0, 0, top(ang));
    double prev = depth((ri + 0.006) * dir + up);
    for (int i = 1; i <= 3000; ++i) {
      const double d = depth((ri + 0.006 + 1e-6 * i) * dir + up);
      worst = std::max(worst, std::abs(d - prev));
      deepest = std::max(deepest, d);
      prev = d;
    }
  }
  std::cout << "largest depth step " << worst * 1e6 << " µm in steps of 1 µm (deepest " << deepest * 1e3 << " mm)\n";
  EXPECT_GT(deepest, 5e-4);  // the lines cross the lip
  EXPECT_LT(worst, 2e-5);    // the jump was 0.57 mm
}

// "Past the rim" is a half-space through the lip's centre line; where the wall's last ring folds
// out and down (a steep trim line, a curled brim) the direction past the rim tilted down, and a
// node pressed 1 mm into the wall 9-20 mm below the rim counted as behind the lip, its gap +3.6 to
// +14.5 mm, no force (the clinical AAOP example: a node left 1-4 mm deep in the wall at no
// pressure). The lip's frame is now levelled: the wall pushes such a node.
TEST(RigidSocket, a_node_in_the_wall_well_below_a_folded_rim_is_pushed_by_the_wall) {
  const double ri = 0.05;
  RigidSocket s = folded_rim_socket();
  const Vec3 dir(-1, 0, 0);  // the back, where the rim is lowest
  // From 6 mm below the rim (above it the smoothed wall rounds off the fold's corner) to 20 mm.
  for (double below = 0.006; below <= 0.02; below += 0.0005) {
    const Vec3 p = (ri + 1e-3) * dir + Vec3(0, 0, folded_rim(std::numbers::pi) - below);
    const Gap g = s.gap(p);
    EXPECT_TRUE(g.valid) << below;
    EXPECT_NEAR(g.gap_m, -1e-3, 1e-4) << below;
    EXPECT_GT(g.normal.dot(-dir), 0.99) << below;  // towards the axis
    for (int a = 0; a < 3; ++a) {  // the gradient is the gap's, the lip's fade included
      const double h = 1e-7;
      const double fd = (s.gap(p + h * Vec3::Unit(a)).gap_m - s.gap(p - h * Vec3::Unit(a)).gap_m) / (2 * h);
      EXPECT_NEAR(fd, g.gradient_norm * g.normal[a], 1e-4) << below << " " << a;
    }
  }
}

// A point in the cavity level with the ridge where a folded rim turns over (the wall up, then 2 mm
// out and 0.5 mm down: more than 90°) is equally close to both faces of the ridge's edge; signed by
// the face the query returned it was in the cavity by one and behind the wall by the other, its
// gap +d or −d for moves of 1e-15 m (4.9 mm deep, then free: a line search cannot cross that). The
// edge's pseudo-normal (its faces' mean) gives one side.
TEST(RigidSocket, a_point_level_with_a_folded_rims_ridge_has_one_side) {
  const double ri = 0.05;
  RigidSocket s = folded_rim_socket();
  const auto depth = [&](const Vec3& p) {
    const Gap g = s.gap(p);
    return g.valid && g.gap_m < 0 ? -g.gap_m : 0.0;
  };
  // Radially from 15 mm inside the wall to 2 mm behind it, level with the ridge and 4.5 mm above
  // it, at 24 angles; each point against the same point moved 1e-12 m along x, y and z.
  double worst = 0;
  for (int k = 0; k < 24; ++k) {
    const double ang = 0.05 + 2 * std::numbers::pi * k / 24;
    const Vec3 dir(std::cos(ang), std::sin(ang), 0);
    for (const double dz : {0.0, 0.0045}) {
      const Vec3 from = (ri - 0.015) * dir + Vec3(0, 0, folded_rim(ang) + dz),
                 to = (ri + 0.002) * dir + Vec3(0, 0, folded_rim(ang) + dz);
      for (int i = 0; i <= 1700; ++i) {
        const Vec3 p = from + (to - from) * (i / 1700.0);
        const double d = depth(p);
        for (int a = 0; a < 3; ++a) worst = std::max(worst, std::abs(depth(p + 1e-12 * Vec3::Unit(a)) - d));
      }
    }
  }
  std::cout << "largest change of depth for a move of 1e-12 m: " << worst * 1e6 << " µm\n";
  EXPECT_LT(worst, 1e-6);
}

// Behind the lip's centre line the lip alone counted past the rim however far from it, and just
// below the rim's level the wall alone: a node far behind the lip (deeper in the wall than the
// lip, or beyond the outer wall) crossing the level of its nearest rim point went from the wall's
// depth to the lip's gap (the AAOP example at 8k nodes: "its gap 6637 → −1634 µm" over 0.1 µm,
// the corrected socket's refit stalled). Far from the lip the wall now keeps its share at the
// level on both sides and hands over to the lip by kLipBlendAngle above it. And a point exactly
// on a facet (distance 0) took the facets' gap, 0, in place of the lip's (0 · NaN in the blend).
TEST(RigidSocket, a_node_far_behind_the_lip_crosses_the_rims_level_without_a_jump) {
  const double ri = 0.05, H = 0.2;
  RigidSocket s(ringed_pipe(ri, ri + 0.005, H, 48, 40), z_frame());
  s.set_smooth_wall(true);
  const auto depth = [&](const Vec3& p) {
    const Gap g = s.gap(p);
    return g.valid && g.gap_m < 0 ? -g.gap_m : 0.0;
  };
  // The lip's centre line 2.5 mm behind the inner wall (half the 5 mm wall): 1.5, 4 and 6.5 mm
  // behind it, the lip near, fading and far.
  for (const double behind : {0.004, 0.0065, 0.009})
    for (const double ang : {0.03, 1.1, 2.5}) {
      const Vec3 dir(std::cos(ang), std::sin(ang), 0), p = (ri + behind) * dir + Vec3(0, 0, H);
      const double below = depth(p - 1e-9 * Vec3::UnitZ()), above = depth(p + 1e-9 * Vec3::UnitZ());
      EXPECT_NEAR(above, below, 1e-6) << behind << " " << ang;
      for (const double up : {2e-4, 8e-4, 2e-3}) {  // the gradient is the gap's, the handover included
        const Vec3 q = p + up * Vec3::UnitZ();
        const Gap g = s.gap(q);
        for (int a = 0; a < 3; ++a) {
          const double h = 1e-7;
          const double fd = (s.gap(q + h * Vec3::Unit(a)).gap_m - s.gap(q - h * Vec3::Unit(a)).gap_m) / (2 * h);
          EXPECT_NEAR(fd, g.gradient_norm * g.normal[a], 1e-4) << behind << " " << up << " " << a;
        }
      }
    }
  // Each rim vertex itself (distance 0 to the facets) against the same point moved 1 nm.
  double worst = 0;
  for (const auto& v : s.inner_wall().vertices)
    if (std::abs(v.z() - H) < 1e-12)
      worst = std::max(worst, std::abs(depth(v) - depth(v + 1e-9 * Vec3(1, 1, 1).normalized())));
  EXPECT_LT(worst, 1e-6);
}

TEST(RigidSocket, rejects_open_and_misplaced_sockets) {
  auto open = pipe(0.05, 0.055, 0.2);
  open.triangles.resize(open.triangles.size() - 8);
  EXPECT_THROW(RigidSocket(open, z_frame()), TopologyError);
  geometry::LimbFrame far = z_frame();
  far.origin = Vec3(1.0, 0, 0);  // the limb's axis 1 m away: the socket does not surround it
  try {
    RigidSocket s(pipe(0.05, 0.055, 0.2), far);
    ADD_FAILURE() << "no error";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("does not surround the limb"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace socketsmith::contact
