// Socket builder: an analytic capsule (wall thickness, shell volume, rim height), a generated
// transtibial limb with its PTB brim, and the bad inputs of the issue. Issue 22: the wall is at
// least 0.95 × the asked thickness everywhere but the brim band, pad and attachment included,
// checked by socket_check.h's own distances; the platform is flat and its holes are where the
// options put them.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/ischial_check.h"
#include "socketsmith/design/socket_builder.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/geometry/surface_query.h"
#include "socketsmith/volume/limb_generator.h"
#include "socket_check.h"

namespace socketsmith::design {
namespace {

using geometry::TriMesh;
using geometry::Vec3;
constexpr double kPi = std::numbers::pi, kMm = units::mm;

/// Closed capsule along +z: hemisphere of radius R centred at z = R (distal end at z = 0), a
/// cylinder up to z = H, a flat top cap. Outward triangles. @p cone_half_angle > 0: a pointed
/// distal end instead of the hemisphere, a cone of that half-angle with its apex at z = 0.
TriMesh capsule(double R, double H, int seg = 96, int lat = 24, int rings = 60, double cone_half_angle = 0) {
  TriMesh m;
  m.vertices.push_back({0, 0, 0});
  std::vector<double> zs, rs;
  const double z_cyl = cone_half_angle > 0 ? R / std::tan(cone_half_angle) : R;
  for (int i = 1; i <= lat; ++i) {
    const double a = 0.5 * kPi * i / lat;  // from the pole
    zs.push_back(cone_half_angle > 0 ? z_cyl * i / lat : R - R * std::cos(a));
    rs.push_back(cone_half_angle > 0 ? R * i / lat : R * std::sin(a));
  }
  for (int i = 1; i <= rings; ++i) {
    zs.push_back(z_cyl + (H - z_cyl) * i / rings);
    rs.push_back(R);
  }
  for (std::size_t r = 0; r < zs.size(); ++r)
    for (int k = 0; k < seg; ++k) {
      const double t = 2 * kPi * (k + 0.5 * (r % 2)) / seg;
      m.vertices.push_back({rs[r] * std::cos(t), rs[r] * std::sin(t), zs[r]});
    }
  m.vertices.push_back({0, 0, H});
  const int top = m.num_vertices() - 1;
  auto id = [&](int r, int k) { return 1 + r * seg + ((k % seg) + seg) % seg; };
  for (int k = 0; k < seg; ++k) m.triangles.push_back({0, id(0, k), id(0, k + 1)});
  for (int r = 0; r + 1 < static_cast<int>(zs.size()); ++r)
    for (int k = 0; k < seg; ++k) {
      const int off = r % 2;  // staggered rings
      m.triangles.push_back({id(r, k), id(r + 1, k - 1 + off), id(r + 1, k + off)});
      m.triangles.push_back({id(r, k), id(r + 1, k + off), id(r, k + 1)});
    }
  const int last = static_cast<int>(zs.size()) - 1;
  for (int k = 0; k < seg; ++k) m.triangles.push_back({top, id(last, k + 1), id(last, k)});
  geometry::flip_orientation(m);  // written clockwise seen from outside above
  EXPECT_GT(geometry::signed_volume(m), 0.0);
  return m;
}

geometry::LimbFrame z_frame() {
  geometry::LimbFrame f;
  f.origin = Vec3::Zero();
  f.axis = Vec3::UnitZ();
  f.anterior = Vec3::UnitY();
  return f;
}

BrimLine flat_brim(double h) {
  std::vector<BrimKeyPoint> p;
  for (int k = 0; k < 8; ++k) p.push_back({"", -kPi + 2 * kPi * k / 8, h});
  return brim_from_key_points(p);
}

/// Points sampled uniformly on the triangles of @p m that pass @p keep (by centroid).
template <class Keep>
std::vector<Vec3> sample(const TriMesh& m, Keep keep, int per_triangle = 2) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Vec3> out;
  for (const auto& t : m.triangles) {
    const Vec3 a = m.vertices[t[0]], b = m.vertices[t[1]], c = m.vertices[t[2]];
    if (!keep((a + b + c) / 3)) continue;
    for (int s = 0; s < per_triangle; ++s) {
      double x = u(rng), y = u(rng);
      if (x + y > 1) x = 1 - x, y = 1 - y;
      out.push_back(a + x * (b - a) + y * (c - a));
    }
  }
  return out;
}

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(SocketBuilder, capsule_wall_has_the_requested_thickness_volume_and_rim_height) {
  const double R = 0.05, H = 0.2, t = 0.005, brim_h = 0.151;
  const TriMesh inner = capsule(R, H);
  SocketOptions o;
  o.thickness_m = t;
  o.undeformed_skin = &inner;
  const SocketResult r = build_socket(inner, z_frame(), flat_brim(brim_h), o);

  const geometry::MeshCheckReport rep = geometry::check_mesh(r.solid);
  EXPECT_TRUE(rep.is_valid_closed_surface()) << (rep.problems().empty() ? "" : rep.problems().front());
  EXPECT_EQ(rep.connected_components, 1);
  // Outer wall (radius > R + t/2, below the lip): distance to the analytic inner surface and to
  // the inner mesh.
  const geometry::SurfaceQuery inner_q(inner);
  const auto pts = sample(r.solid, [&](const Vec3& c) { return c.norm() > 0 && std::hypot(c.x(), c.y()) > R + 0.5 * t - 1e-9 && c.z() < brim_h - 1e-3 && (c.z() > R || (c - Vec3(0, 0, R)).norm() > R + 0.5 * t); });
  ASSERT_GT(pts.size(), 1000u);
  double lo = 1, hi = 0;
  for (const auto& p : pts) {
    const double d = inner_q.closest_point(p).distance;
    lo = std::min(lo, d);
    hi = std::max(hi, d);
  }
  EXPECT_NEAR(lo, t, 0.1 * kMm);
  EXPECT_NEAR(hi, t, 0.1 * kMm);
  EXPECT_NEAR(r.min_thickness_m, t, 0.1 * kMm);
  EXPECT_NEAR(r.max_thickness_m, t, 0.1 * kMm);
  // Shell volume: hemispherical shell + cylindrical shell + half-round lip (Pappus).
  const double shell = 2.0 / 3 * kPi * (std::pow(R + t, 3) - std::pow(R, 3)) +
                       kPi * ((R + t) * (R + t) - R * R) * (brim_h - R) + (kPi * t * t / 8) * 2 * kPi * (R + t / 2);
  EXPECT_NEAR(r.shell_volume_m3 / shell, 1.0, 0.01) << r.shell_volume_m3 * 1e6 << " vs " << shell * 1e6 << " cm^3";
  const double cavity = 2.0 / 3 * kPi * R * R * R + kPi * R * R * (brim_h - R);
  EXPECT_NEAR(r.cavity_volume_m3 / cavity, 1.0, 0.01);
  // Rim on the brim; the lip's top is half a wall above it.
  EXPECT_LT(r.max_rim_error_m, 0.01 * kMm);
  double top = 0;
  for (const auto& v : r.solid.vertices) top = std::max(top, v.z());
  EXPECT_NEAR(top, brim_h + t / 2, 0.05 * kMm);
  // Circumferences every 10 mm below the rim, against the undeformed (same) surface: 0 % reduction.
  ASSERT_EQ(r.levels.size(), 15u);
  EXPECT_NEAR(r.levels.back().inner_circumference_m, 2 * kPi * R, 0.002 * 2 * kPi * R);
  for (const auto& l : r.levels) EXPECT_NEAR(l.reduction_percent, 0.0, 1e-9);
  EXPECT_EQ(r.inner_triangles, r.outer_triangles);
  EXPECT_GT(r.lip_triangles, 0);
  // Independent distances: the whole outer wall within 0.95–1.02 × t of the inner wall.
  const auto check = wall_check::check_socket(r, inner, z_frame(), flat_brim(brim_h), o);
  EXPECT_TRUE(check.failures.empty()) << check.text();
  EXPECT_GT(check.wall.min_ratio, 0.98) << check.text();
  EXPECT_LT(check.wall.median_m, 1.01 * t) << check.text();
  EXPECT_NEAR(r.median_thickness_m, t, 0.02 * kMm);
  EXPECT_GE(r.min_thickness_ratio, 0.99);
  // The thickness field: NaN on the inner wall, ≈ t on the outer wall.
  ASSERT_EQ(r.vertex_thickness_m.size(), r.solid.vertices.size());
  std::vector<int> kind(r.solid.vertices.size(), -1);  // 0 inner, 1 outer only
  for (int f = 0; f < r.solid.num_triangles(); ++f)
    for (int v : r.solid.triangles[f]) {
      if (r.face_kind[f] == SocketFace::Inner) kind[v] = 0;
      else if (r.face_kind[f] == SocketFace::Outer && kind[v] != 0) kind[v] = 1;
    }
  for (int v = 0; v < r.solid.num_vertices(); ++v) {
    if (kind[v] == 0) {
      EXPECT_TRUE(std::isnan(r.vertex_thickness_m[v])) << v;
    } else if (kind[v] == 1) {
      EXPECT_NEAR(r.vertex_thickness_m[v], t, 0.02 * t) << v;
    }
  }
}

TEST(SocketBuilder, capsule_with_a_wavy_brim_a_flat_lip_and_a_distal_pad_built_outward) {
  const double R = 0.05, H = 0.2, t = 0.004;
  const TriMesh inner = capsule(R, H, 64, 16, 50);
  std::vector<BrimKeyPoint> p;
  for (int k = 0; k < 10; ++k) {
    const double th = -kPi + 2 * kPi * k / 10;
    p.push_back({"", th, 0.14 + 0.02 * std::sin(2 * th)});
  }
  const BrimLine brim = brim_from_key_points(p);
  SocketOptions o;
  o.thickness_m = t;
  o.round_brim = false;
  o.distal_pad = true;
  o.distal_pad_diameter_m = 0.03;
  o.alignment = {0.0, 0.0};  // the pad normal to the limb's axis
  o.subdivisions = 1;
  const SocketResult r = build_socket(inner, z_frame(), brim, o);
  EXPECT_TRUE(geometry::check_mesh(r.solid).is_valid_closed_surface());
  EXPECT_LT(r.max_rim_error_m, 0.01 * kMm);
  EXPECT_NEAR(r.rim_min_h_m, brim.min_height(), 0.2 * kMm);
  EXPECT_NEAR(r.rim_max_h_m, brim.max_height(), 0.2 * kMm);
  // The pad lies below the wall (half a millimetre below its lowest point, z = −t), a 30 mm disc
  // on the axis; the distal wall keeps its thickness.
  ASSERT_TRUE(r.platform.is_built);
  EXPECT_NEAR(r.platform.centre.z(), -t - 0.5 * kMm, 0.05 * kMm);
  EXPECT_NEAR(r.platform.normal.z(), -1.0, 1e-12);
  EXPECT_DOUBLE_EQ(r.platform.diameter_m, 0.03);
  const auto check = wall_check::check_socket(r, geometry::TriMesh(inner), z_frame(), brim, o);
  EXPECT_TRUE(check.failures.empty()) << check.text();
  EXPECT_LT(check.flatness_m, 1e-9);
  // Thicker than the wall at the pad only: the median stays the wall.
  EXPECT_NEAR(r.median_thickness_m, t, 0.05 * kMm);
  EXPECT_GT(r.max_thickness_m, t + 0.4 * kMm);
}

TEST(SocketBuilder, a_pointed_distal_end_gets_its_full_pad_below_the_wall) {
  // A 30° cone: the outer wall reaches the pad's 15 mm radius 20 mm above the apex, so the pad's
  // block climbs the cone; the wall above it keeps its thickness (the old builder pushed the
  // outer wall in there).
  const double R = 0.04, H = 0.2, t = 0.005;
  const TriMesh inner = capsule(R, H, 64, 16, 40, 30 * kPi / 180);
  SocketOptions o;
  o.thickness_m = t;
  o.distal_pad = true;
  o.distal_pad_diameter_m = 0.03;
  const SocketResult r = build_socket(inner, z_frame(), flat_brim(0.15), o);
  ASSERT_TRUE(r.platform.is_built);
  EXPECT_GT(r.platform.max_height_m, 0.015);
  const auto check = wall_check::check_socket(r, inner, z_frame(), flat_brim(0.15), o);
  EXPECT_TRUE(check.failures.empty()) << check.text();
}

TEST(SocketBuilder, a_four_hole_attachment_is_flat_aligned_and_drilled_where_asked) {
  const double R = 0.05, H = 0.2, t = 0.005;
  const TriMesh inner = capsule(R, H, 96, 24, 60);
  SocketOptions o;
  o.thickness_m = t;
  o.alignment = {7 * units::deg, -4 * units::deg};
  o.attachment.enabled = true;
  o.attachment.rotation_rad = 15 * units::deg;
  o.attachment.offset_anterior_m = 3 * kMm;
  o.attachment.offset_medial_m = -2 * kMm;
  const BrimLine brim = flat_brim(0.15);
  const SocketResult r = build_socket(inner, z_frame(), brim, o);
  const auto check = wall_check::check_socket(r, inner, z_frame(), brim, o);
  EXPECT_TRUE(check.failures.empty()) << check.text();
  EXPECT_GE(check.min_hole_depth_m, o.attachment.platform_thickness_m - 0.02 * kMm);
  // The builder reports the same holes as the independent expectation.
  const auto e = wall_check::expected_platform(z_frame(), o);
  ASSERT_EQ(r.platform.hole_centres.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d q = e.xy(r.platform.hole_centres[k]);
    EXPECT_NEAR((q - e.holes[k]).norm(), 0.0, 1e-9) << k;
  }
  EXPECT_NEAR(r.platform.normal.dot(-e.up), 1.0, 1e-12);
  EXPECT_NEAR(r.platform.hole_diameter_m, 6.6 * kMm, 1e-12);
  EXPECT_GE(r.platform.min_hole_depth_m, o.attachment.platform_thickness_m - 1e-9);
  EXPECT_GE(r.platform.smallest_feature_m, o.min_feature_m);
  // Every hole face is a bore; the flat face is the lowest part of the socket.
  EXPECT_GT(std::count(r.face_kind.begin(), r.face_kind.end(), SocketFace::Hole), 4 * 24 - 1);
  EXPECT_GT(std::count(r.face_kind.begin(), r.face_kind.end(), SocketFace::Platform), 10);
}

TEST(SocketBuilder, a_variable_wall_is_thicker_distally_and_thinner_at_the_brim) {
  const double R = 0.05, H = 0.2, brim_h = 0.15;
  const TriMesh inner = capsule(R, H, 96, 24, 60);
  SocketOptions o;
  o.thickness_m = 0.005;
  o.distal_thickness_m = 0.008;
  o.brim_thickness_m = 0.004;
  const SocketResult r = build_socket(inner, z_frame(), flat_brim(brim_h), o);
  const auto check = wall_check::check_socket(r, inner, z_frame(), flat_brim(brim_h), o);
  EXPECT_TRUE(check.failures.empty()) << check.text();
  // On the cylinder (radius R + wall), the wall follows 8 + (4 − 8) h / 150 mm.
  for (const auto& v : r.solid.vertices) {
    const double rho = std::hypot(v.x(), v.y());
    if (v.z() < R + 0.01 || v.z() > brim_h - 0.01 || rho < R + 1e-3) continue;
    const double asked = 0.008 - 0.004 * v.z() / brim_h;
    EXPECT_NEAR(rho - R, asked, 0.03 * asked) << "at z = " << v.z();
  }
  EXPECT_DOUBLE_EQ(asked_thickness_m(o, 0.0, brim_h), 0.008);
  EXPECT_DOUBLE_EQ(asked_thickness_m(o, brim_h, brim_h), 0.004);
  EXPECT_DOUBLE_EQ(asked_thickness_m(o, 0.5 * brim_h, brim_h), 0.006);
}

TEST(SocketBuilder, generated_limb_with_a_ptb_brim_gives_a_valid_solid_of_even_thickness) {
  const volume::GeneratedLimb limb = volume::generate_limb(volume::default_params(geometry::LimbType::Transtibial, 0));
  const BrimLine brim = make_brim(BrimTemplate::Ptb, geometry::LimbType::Transtibial, limb.landmarks, limb.cut_height_m);
  const SocketResult r = build_socket(limb.skin, limb.frame, brim);  // open at the cut, above the brim
  const geometry::MeshCheckReport rep = geometry::check_mesh(r.solid);
  EXPECT_TRUE(rep.is_valid_closed_surface()) << (rep.problems().empty() ? "" : rep.problems().front());
  EXPECT_GT(r.shell_volume_m3, 0.0);
  EXPECT_NEAR(r.mean_thickness_m, 5 * kMm, 0.1 * kMm);
  EXPECT_GT(r.min_thickness_m, 0.99 * 5 * kMm);
  EXPECT_LT(r.max_thickness_m, 5.3 * kMm);
  EXPECT_LT(r.max_rim_error_m, 0.05 * kMm);
  const auto check = wall_check::check_socket(r, limb.skin, limb.frame, brim, SocketOptions{});
  EXPECT_TRUE(check.failures.empty()) << check.text();
  // Independent check: outer-wall samples lie ~5 mm outside the skin.
  const geometry::SurfaceQuery skin(limb.skin);
  geometry::TriMesh outer;
  outer.vertices = r.solid.vertices;
  outer.triangles.assign(r.solid.triangles.begin() + r.inner_triangles,
                         r.solid.triangles.begin() + r.inner_triangles + r.outer_triangles);
  double lo = 1, sum = 0;
  const auto pts = sample(outer, [](const Vec3&) { return true; }, 1);
  for (const auto& q : pts) {
    const double d = skin.closest_point(q).distance;
    lo = std::min(lo, d);
    sum += d;
  }
  EXPECT_GT(lo, 0.95 * 5 * kMm);
  EXPECT_NEAR(sum / pts.size(), 5 * kMm, 0.15 * kMm);
  const auto tmp = std::filesystem::temp_directory_path() / "socketsmith_socket_test.stl";
  write_socket_stl(tmp, r);
  geometry::MeshReadOptions ro;
  ro.unit = units::LengthUnit::Millimetre;
  const TriMesh back = geometry::read_mesh(tmp, ro);
  EXPECT_NEAR(geometry::signed_volume(back) / r.shell_volume_m3, 1.0, 1e-3);
  std::filesystem::remove(tmp);
}

// A 15 mm deep, 3 mm wide circumferential groove under a 20 mm wall: the normal offset folds over
// itself there however smooth its normals (0, 4 and 16 passes); the builder refuses it in one line
// instead of returning a broken solid. (This test accepted either outcome before.)
TEST(SocketBuilder, a_sharp_groove_deeper_than_the_wall_is_refused_after_every_smoothing_attempt) {
  TriMesh inner = capsule(0.05, 0.2, 64, 16, 120);
  for (auto& v : inner.vertices) {
    const double g = 1.0 - 0.3 * std::exp(-std::pow((v.z() - 0.11) / 0.003, 2));
    v.x() *= g;
    v.y() *= g;
  }
  SocketOptions o;
  o.thickness_m = 0.02;
  o.normal_smoothing_iterations = 0;
  const std::string m = message_of([&] { build_socket(inner, z_frame(), flat_brim(0.16), o); });
  EXPECT_NE(m.find("the 20.0 mm offset of the stump surface still fails after 16 normal-smoothing passes (it "
                   "self-intersects); use a thinner wall or smooth the stump surface"),
            std::string::npos)
      << m;
}

// The retry: a 2.5 mm deep, 3 mm wide groove under a 5 mm wall. The plain offset (0 smoothing
// passes) self-intersects; the second attempt (4 passes) is valid. The solid returned must be the
// retried one, free of self-intersections by an independent test (find_self_intersections, not
// the CGAL check the builder uses), with the asked wall.
TEST(SocketBuilder, a_groove_the_plain_offset_folds_over_is_retried_with_smoother_normals) {
  TriMesh inner = capsule(0.05, 0.2, 64, 16, 120);
  for (auto& v : inner.vertices) {
    const double g = 1.0 - 0.05 * std::exp(-std::pow((v.z() - 0.11) / 0.003, 2));
    v.x() *= g;
    v.y() *= g;
  }
  SocketOptions o;
  o.thickness_m = 0.005;
  o.normal_smoothing_iterations = 0;
  const SocketResult r = build_socket(inner, z_frame(), flat_brim(0.16), o);
  ASSERT_EQ(r.notes.size(), 2u);
  EXPECT_EQ(r.notes[0], "offset with 0 normal-smoothing passes failed (it self-intersects); retrying with more smoothing");
  EXPECT_NE(r.notes[1].find("the offset needed 4 normal-smoothing passes"), std::string::npos) << r.notes[1];
  EXPECT_EQ(r.normal_smoothing_used, 4);
  EXPECT_TRUE(geometry::check_mesh(r.solid).is_valid_closed_surface());
  EXPECT_EQ(geometry::find_self_intersections(r.solid).pairs, 0);
  EXPECT_GT(r.min_thickness_m, 0.95 * o.thickness_m);
  EXPECT_LT(r.median_thickness_m, 1.02 * o.thickness_m);
}

// A brim passing within a fraction of a micrometre of a ring of vertices (a corrected socket's raised
// brim can): each such vertex is a rim vertex itself, and the wall has no µm-scale edges around it.
// Before, the curve crossed each of the vertex's edges 1/1000 of an edge from it (the clamp that
// keeps a cut triangle from degenerating): rim vertices 3 µm apart, whose lips — each with its own
// corrected wall offset — folded over one another on the AAOP example (socket_builder.cpp).
TEST(SocketBuilder, a_brim_through_a_ring_of_vertices_makes_them_rim_vertices_without_micrometre_edges) {
  const TriMesh inner = capsule(0.05, 0.2);  // rings 2.5 mm apart on the cylinder, ring 40 at z = 0.15
  for (const double dz : {1e-7, -1e-7, 2e-6}) {
    SocketOptions o;
    o.thickness_m = 0.005;
    const BrimLine brim = flat_brim(0.15 + dz);
    const SocketResult r = build_socket(inner, z_frame(), brim, o);
    double shortest = 1;
    for (std::size_t f = 0; f < r.solid.triangles.size(); ++f) {
      if (r.face_kind[f] != SocketFace::Inner) continue;
      const auto& t = r.solid.triangles[f];
      if (r.solid.vertices[t[0]].z() < 0.14) continue;  // the rim's rows only (the pole's are short)
      for (int k = 0; k < 3; ++k)
        shortest = std::min(shortest, (r.solid.vertices[t[k]] - r.solid.vertices[t[(k + 1) % 3]]).norm());
    }
    EXPECT_GT(shortest, 1 * kMm) << "brim " << dz * 1e6 << " µm off the ring";
    EXPECT_LT(r.max_rim_error_m, 0.005 * kMm);
    EXPECT_NEAR(r.rim_max_h_m, 0.15, 0.005 * kMm);
    const auto check = wall_check::check_socket(r, inner, z_frame(), brim, o);
    EXPECT_TRUE(check.failures.empty()) << check.text();
  }
}

// Circumference reduction (the prosthetist's rectification check) against the limb: a socket
// cavity that is the capsule shrunk radially by 3 % is 3 % smaller around at every level (a
// polygon scaled by 0.97 has 0.97 of the perimeter), and the limb's circumference is the
// capsule's 2πR on the cylinder. A sign or ratio mistake in reduction_percent fails here; the
// capsule test above only saw 0 %.
TEST(SocketBuilder, a_radially_shrunk_capsule_reads_a_3_percent_circumference_reduction_at_every_level) {
  const double R = 0.05, H = 0.2, brim_h = 0.151;
  const TriMesh limb = capsule(R, H);
  TriMesh cavity = limb;
  for (auto& v : cavity.vertices) {
    v.x() *= 0.97;
    v.y() *= 0.97;
  }
  SocketOptions o;
  o.thickness_m = 0.005;
  o.undeformed_skin = &limb;
  const SocketResult r = build_socket(cavity, z_frame(), flat_brim(brim_h), o);
  ASSERT_EQ(r.levels.size(), 15u);
  for (const auto& l : r.levels) {
    EXPECT_NEAR(l.reduction_percent, 3.0, 0.01) << "h " << l.h_m / kMm << " mm";
    EXPECT_NEAR(l.inner_circumference_m, 0.97 * l.limb_circumference_m, 1e-6) << "h " << l.h_m / kMm << " mm";
    if (l.h_m > R) {
      EXPECT_NEAR(l.limb_circumference_m, 2 * kPi * R, 0.002 * 2 * kPi * R) << "h " << l.h_m / kMm;
    }
  }
}

TEST(SocketBuilder, bad_inputs_give_one_line_errors) {
  const TriMesh inner = capsule(0.05, 0.2, 32, 8, 20);
  const auto f = z_frame();
  const BrimLine brim = flat_brim(0.15);
  for (double t : {0.0, -0.005, std::nan("")}) {
    SocketOptions o;
    o.thickness_m = t;
    const std::string msg = message_of([&] { build_socket(inner, f, brim, o); });
    EXPECT_NE(msg.find("thickness_m"), std::string::npos) << msg;
    EXPECT_THROW(build_socket(inner, f, brim, o), InvalidInputError);
  }
  const std::string above = message_of([&] { build_socket(inner, f, flat_brim(0.25), {}); });
  EXPECT_NE(above.find("above the top of the stump surface"), std::string::npos) << above;
  EXPECT_THROW(build_socket(inner, f, flat_brim(0.25), {}), InvalidInputError);
  // A hole below the brim.
  TriMesh holed = inner;
  holed.triangles.erase(holed.triangles.begin() + 300, holed.triangles.begin() + 302);
  const std::string open = message_of([&] { build_socket(holed, f, brim, {}); });
  EXPECT_NE(open.find("open below the brim"), std::string::npos) << open;
  EXPECT_THROW(build_socket(holed, f, brim, {}), TopologyError);
  // Inside-out.
  TriMesh flipped = inner;
  geometry::flip_orientation(flipped);
  EXPECT_NE(message_of([&] { build_socket(flipped, f, brim, {}); }).find("inside-out"), std::string::npos);
  EXPECT_THROW(write_socket_stl("/tmp/x.stl", SocketResult{}), InvalidInputError);
  // Attachment and alignment out of range: one line naming the field and the fix.
  auto attach = [] {
    SocketOptions o;
    o.attachment.enabled = true;
    return o;
  };
  SocketOptions narrow = attach();
  narrow.attachment.hole_diameter_m = 5 * kMm;
  EXPECT_NE(message_of([&] { build_socket(inner, f, brim, narrow); }).find("narrower than its 6.0 mm bolt"), std::string::npos);
  SocketOptions close = attach();
  close.attachment.hole_spacing_m = 7 * kMm;
  EXPECT_NE(message_of([&] { build_socket(inner, f, brim, close); }).find("widen the spacing"), std::string::npos);
  SocketOptions small = attach();
  small.attachment.platform_diameter_m = 40 * kMm;
  const std::string small_msg = message_of([&] { build_socket(inner, f, brim, small); });
  EXPECT_NE(small_msg.find("make platform_diameter_mm at least"), std::string::npos) << small_msg;
  SocketOptions wide = attach();
  wide.attachment.platform_diameter_m = 0.14;
  const std::string wide_msg = message_of([&] { build_socket(inner, f, brim, wide); });
  EXPECT_NE(wide_msg.find("wider than the socket's distal end"), std::string::npos) << wide_msg;
  SocketOptions tilted;
  tilted.alignment.flexion_rad = 40 * units::deg;
  EXPECT_NE(message_of([&] { build_socket(inner, f, brim, tilted); }).find("socket flexion 40.0°"), std::string::npos);
  SocketOptions thin;
  thin.thickness_m = 0.5 * kMm;
  EXPECT_NE(message_of([&] { build_socket(inner, f, brim, thin); }).find("below the smallest printable feature"),
            std::string::npos);
  EXPECT_NE(message_of([] { (void)clearance_hole_diameter_m("M7"); }).find("M4, M5, M6 or M8"), std::string::npos);
  EXPECT_DOUBLE_EQ(clearance_hole_diameter_m("M6"), 6.6 * kMm);
  EXPECT_DOUBLE_EQ(bolt_diameter_m("M8"), 8 * kMm);
}

// The ischial check (ischial_check.h) on a capsule's socket, where every answer is known: the
// cavity closed by the brim's own surface holds the volume below the brim; a point within the wall
// and below the brim is contained, one beside the wall or above the brim is not (a height-only test
// would call the one beside the wall contained); a quadrilateral seat holds a point resting on it.
namespace ischial {
BrimLine wavy(BrimTemplate kind) {
  // High postero-medially (135°), low in front: an ICS-like line.
  return BrimLine(kind, {{"", 0.0, 0.110}, {"", 0.5 * kPi, 0.130}, {"", 0.75 * kPi, 0.150}, {"", kPi, 0.130},
                         {"", -0.5 * kPi, 0.115}});
}
Vec3 at(double theta_deg, double r, double h) {
  const double t = theta_deg * kPi / 180;
  // z_frame(): anterior +y, axis +z, right side: medial = axis × anterior = −x.
  return r * std::cos(t) * Vec3::UnitY() + r * std::sin(t) * (-Vec3::UnitX()) + h * Vec3::UnitZ();
}
}  // namespace ischial

TEST(IschialCheck, the_cavity_closed_by_the_brim_holds_the_volume_below_the_brim) {
  const double R = 0.05, H = 0.2;
  const TriMesh inner = capsule(R, H);
  SocketOptions o;
  o.undeformed_skin = &inner;
  const BrimLine brim = ischial::wavy(BrimTemplate::Ics);
  const SocketResult s = build_socket(inner, z_frame(), brim, o);
  const TriMesh cavity = socket_cavity_surface(s, z_frame());
  // Analytic: the hemisphere and, above it, (R²/2) ∫ (brim(θ) − R) dθ.
  double integral = 0;
  const int n = 3600;
  for (int k = 0; k < n; ++k) integral += (brim.height(-kPi + 2 * kPi * (k + 0.5) / n) - R) * 2 * kPi / n;
  const double expected = 2.0 / 3.0 * kPi * R * R * R + 0.5 * R * R * integral;
  EXPECT_NEAR(geometry::signed_volume(cavity), expected, 0.01 * expected);
  // A level brim: the same as the builder's own cavity measure (a fan to the rim's centroid).
  const SocketResult level = build_socket(inner, z_frame(), flat_brim(0.13), o);
  EXPECT_NEAR(geometry::signed_volume(socket_cavity_surface(level, z_frame())), level.cavity_volume_m3,
              1e-3 * level.cavity_volume_m3);
}

TEST(IschialCheck, containment_is_3d_and_a_seat_holds_a_point_resting_on_it) {
  const double R = 0.05, H = 0.2;
  const TriMesh inner = capsule(R, H);
  SocketOptions o;
  o.undeformed_skin = &inner;
  const BrimLine ics = ischial::wavy(BrimTemplate::Ics);
  const SocketResult s = build_socket(inner, z_frame(), ics, o);
  // Inside: 15 mm from the wall, 30 mm below the brim (150 mm at 135°).
  IschialCheck c = check_ischial_tuberosity(ics, z_frame(), ischial::at(135, 0.035, 0.120), s);
  EXPECT_TRUE(c.applies);
  EXPECT_EQ(c.kind, "containment");
  EXPECT_TRUE(c.inside_cavity) << c.summary;
  EXPECT_TRUE(c.met);
  EXPECT_NEAR(c.cavity_margin_m, 0.015, 0.0005);
  EXPECT_NEAR(c.height_margin_m, 0.030, 1e-6);
  // Beside the wall at the same height: below the brim (a height test would pass) but outside.
  c = check_ischial_tuberosity(ics, z_frame(), ischial::at(135, 0.060, 0.120), s);
  EXPECT_GT(c.height_margin_m, 0.0);
  EXPECT_FALSE(c.inside_cavity);
  EXPECT_FALSE(c.met);
  EXPECT_NEAR(c.cavity_margin_m, -0.010, 0.0005);
  // Above the brim in front (110 mm at 0°), half-way to the axis: outside (a cap fanned from the
  // rim's centroid, ~124 mm high, would pass ~117 mm over this point and call it contained).
  c = check_ischial_tuberosity(ics, z_frame(), ischial::at(0, 0.025, 0.114), s);
  EXPECT_FALSE(c.inside_cavity);
  EXPECT_FALSE(c.met);
  EXPECT_LT(c.height_margin_m, 0.0);
  // Another template: the check does not apply.
  EXPECT_FALSE(check_ischial_tuberosity(flat_brim(0.13), z_frame(), ischial::at(135, 0.03, 0.1),
                                        build_socket(inner, z_frame(), flat_brim(0.13), o))
                   .applies);

  // A level quadrilateral seat at 130 mm: a point 5 mm above it rests on it; one 20 mm below sits
  // inside the socket, one 30 mm above floats over it.
  const BrimLine quad(BrimTemplate::Quad, flat_brim(0.13).key_points());
  const SocketResult q = build_socket(inner, z_frame(), quad, o);
  c = check_ischial_tuberosity(quad, z_frame(), ischial::at(135, 0.035, 0.135), q);
  EXPECT_EQ(c.kind, "seat");
  EXPECT_TRUE(c.met) << c.summary;
  EXPECT_NEAR(c.height_margin_m, 0.005, 1e-6);
  EXPECT_FALSE(c.inside_cavity);
  c = check_ischial_tuberosity(quad, z_frame(), ischial::at(135, 0.035, 0.110), q);
  EXPECT_TRUE(c.inside_cavity);
  EXPECT_FALSE(c.met) << c.summary;
  c = check_ischial_tuberosity(quad, z_frame(), ischial::at(135, 0.035, 0.160), q);
  EXPECT_FALSE(c.met) << c.summary;
}

}  // namespace
}  // namespace socketsmith::design
