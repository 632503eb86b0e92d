#include "socketsmith/geometry/aaop.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/geometry/mesh_repair.h"
#include "test_shapes.h"

namespace socketsmith::geometry {
namespace {

namespace fs = std::filesystem;
using test::error_message;
using test::LogCapture;
using test::TempDir;

const fs::path kAaopDir = fs::path(SOCKETSMITH_SHARED_DATA_DIR) / "aaop";

#define REQUIRE_SHARED_FILE(file)                                                              \
  if (!fs::exists(file)) GTEST_SKIP() << "shared data not found at '" << fs::path(file).string() \
                                      << "' (set SOCKETSMITH_SHARED_DATA_DIR)"

/// A small valid file: 4 spokes 90 deg apart, 3 slices 10 mm apart, the first slice closed.
std::string small_file(const std::string& eol) {
  std::string s;
  for (const char* l : {"AAOP1", "a comment", "END COMMENTS", "CYLINDRICAL", "LEFT", "1", "PT ", "1", "30",
                        "90", "50", "4", "90", "3", "10", "0", "0", "0", "0", "20", "21 7", "22", "23",
                        "30", "31", "32", "33"})
    s += std::string(l) + eol;
  return s;
}

/// The volume below the plane at @p fraction of the axis' length from the distal end, capped.
double volume_below(const TriMesh& mesh, double fraction) {
  const LimbFrame f = estimate_limb_axis(mesh);
  double h_max = 0.0;
  for (const Vec3& p : mesh.vertices) h_max = std::max(h_max, (p - f.origin).dot(f.axis));
  return signed_volume(trim_and_cap(mesh, f.on_axis(fraction * h_max), f.axis).mesh);
}

TEST(Aaop, parses_header_landmarks_grid_and_every_line_ending) {
  for (const std::string eol : {"\n", "\r", "\r\n"}) {
    SCOPED_TRACE(eol == "\n" ? "LF" : eol == "\r" ? "CR" : "CRLF");
    const AaopShape s = parse_aaop(small_file(eol), "small.aop");
    EXPECT_EQ(s.version, "AAOP1");
    ASSERT_EQ(s.comments.size(), 1u);
    EXPECT_EQ(s.side, "LEFT");
    ASSERT_EQ(s.landmarks.size(), 1u);
    EXPECT_EQ(s.landmarks[0].name, "PT");
    ASSERT_EQ(s.landmarks[0].points_mm.size(), 1u);
    EXPECT_EQ(s.landmarks[0].points_mm[0], Vec3(30, 90, 50));
    ASSERT_EQ(s.num_spokes(), 4);
    EXPECT_DOUBLE_EQ(s.spoke_angles_deg[0], -90.0);
    EXPECT_DOUBLE_EQ(s.spoke_angles_deg[3], 180.0);
    ASSERT_EQ(s.num_slices(), 3);
    EXPECT_DOUBLE_EQ(s.slice_heights_mm[2], 20.0);
    EXPECT_DOUBLE_EQ(s.radius_mm(1, 1), 21.0);  // the value after a radius is ignored
    EXPECT_DOUBLE_EQ(s.radius_mm(2, 3), 33.0);
  }
}

TEST(Aaop, grid_surface_is_outward_and_closed_where_a_slice_of_zero_radii_closes_it) {
  bool distal = false, proximal = true;
  const TriMesh m = aaop_surface(parse_aaop(small_file("\n"), "small.aop"), &distal, &proximal);
  EXPECT_TRUE(distal);
  EXPECT_FALSE(proximal);
  const MeshCheckReport r = check_mesh(m);
  EXPECT_EQ(r.num_vertices, 1 + 4 + 4);
  EXPECT_EQ(r.boundary_loops, 1);
  EXPECT_TRUE(r.is_manifold());
  EXPECT_TRUE(r.is_oriented());
  EXPECT_EQ(r.degenerate_triangles, 0);
  // Closed at the top too, the volume is positive (outward normals).
  TriMesh closed = trim_and_cap(m, Vec3(0, 0, 0.015), Vec3::UnitZ()).mesh;
  EXPECT_GT(signed_volume(closed), 0.0);
  // Spoke 1 is at -90 deg: radius 20 mm at z = 10 mm is the point (0, -20, 10) mm; spoke 2 at 0 deg.
  EXPECT_LT((m.vertices[1] - Vec3(0.0, -0.020, 0.010)).norm(), 1e-12);
  EXPECT_LT((m.vertices[2] - Vec3(0.021, 0.0, 0.010)).norm(), 1e-12);
}

TEST(Aaop, malformed_files_give_one_line_errors) {
  const std::string good = small_file("\n");
  auto replaced = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    const auto at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return s.replace(at, from.size(), to);
  };
  struct Case {
    std::string name, text, expected;
  };
  const Case cases[] = {
      {"empty", "\r\n\n", "is empty"},
      {"not aaop", "solid x\n" + good, "not an AAOP version line"},
      {"no end of comments", "AAOP1\ncomment\n", "'END COMMENTS' was expected"},
      {"truncated radii", good.substr(0, good.size() - 6), "ends after line 25 where the radius of slice 3 spoke 3"},
      {"extra radii", good + "34\n35\n", "2 more line(s) after its 3 × 4 radii"},
      {"radius not a number", replaced("\n31\n", "\nabc\n"), "line 25: 'abc' is not a number (expected the radius of slice 3 spoke 2"},
      {"NaN radius", replaced("\n31\n", "\nnan\n"), "the radius of slice 3 spoke 2 [mm] is 'nan' (expected a finite number)"},
      {"negative radius", replaced("\n31\n", "\n-31\n"), "is -31 mm (expected >= 0)"},
      {"spokes not a full turn", replaced("\n4\n90\n", "\n4\n80\n"), "4 spokes 80 deg apart make 320 deg"},
      {"count not a number", replaced("\n3\n10\n", "\nthree\n10\n"), "the slice count is 'three' (expected a whole number >= 2)"},
      {"landmark count", replaced("LEFT\n1\n", "LEFT\n-1\n"), "the landmark count is '-1'"},
      {"coordinate system", replaced("CYLINDRICAL", "CARTESIAN"), "coordinate system 'CARTESIAN' is not supported"},
      {"heights not increasing", replaced("\n3\n10\n", "\n3\n0\n0\n10\n5\n"), "slice height 5 mm does not increase"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string msg = error_message<InvalidInputError>([&] { parse_aaop(c.text, "bad.aop"); });
    EXPECT_NE(msg.find(c.expected), std::string::npos) << msg;
    EXPECT_NE(msg.find("'bad.aop'"), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
  // Through read_mesh, by extension.
  LogCapture quiet;
  TempDir dir;
  test::write_bytes(dir / "bad.AOP", replaced("\n31\n", "\n1e999\n"));
  const std::string msg = error_message<InvalidInputError>([&] { read_mesh(dir / "bad.AOP"); });
  EXPECT_NE(msg.find("expected a finite number"), std::string::npos) << msg;
}

TEST(Aaop, clinical_example_loads_in_mm_with_its_landmarks) {
  const fs::path file = kAaopDir / "example_transtibial.aop";
  REQUIRE_SHARED_FILE(file);
  LogCapture quiet;
  MeshReadInfo info;
  const TriMesh m = read_mesh(file, {}, &info);
  EXPECT_EQ(info.format, "aaop");
  EXPECT_EQ(info.unit, units::LengthUnit::Millimetre);
  EXPECT_FALSE(info.unit_was_guessed);
  EXPECT_TRUE(info.warning.empty()) << info.warning;
  EXPECT_EQ(info.side, "right");  // the header's side, for the limb's frame
  const AaopShape s = read_aaop(file);
  EXPECT_EQ(s.side, "RIGHT");
  EXPECT_EQ(s.num_spokes(), 72);
  EXPECT_EQ(s.num_slices(), 68);
  ASSERT_EQ(info.landmarks.size(), 3u);
  EXPECT_EQ(info.landmarks[0].name, "TIB");
  EXPECT_EQ(info.landmarks[0].points.size(), 2u);
  EXPECT_EQ(info.landmarks[1].name, "MPT");
  EXPECT_EQ(info.landmarks[2].name, "TE");
  // TE: r 54.11751 mm at -15.18 deg, z 14.31 mm.
  const Vec3 te = info.landmarks[2].points[0];
  EXPECT_NEAR(std::hypot(te.x(), te.y()), 0.05411751, 1e-9);
  EXPECT_NEAR(std::atan2(te.y(), te.x()) / units::deg, -15.18, 1e-9);
  EXPECT_NEAR(te.z(), 0.01431, 1e-12);
  // 68 slices 3 mm apart: 201 mm long; radii up to 77.981 mm.
  const Aabb box = bounding_box(m);
  EXPECT_NEAR(box.extent().z(), 0.201, 1e-12);
  const double r_max = *std::max_element(s.radii_mm.begin(), s.radii_mm.end());
  EXPECT_NEAR(r_max, 77.981, 1e-9);
  EXPECT_LE(box.extent().head<2>().maxCoeff(), 2 * r_max * units::mm + 1e-12);
  EXPECT_GT(box.extent().head<2>().minCoeff(), r_max * units::mm);
  // The distal slice is a ring (radii 6-20 mm), not closed: the surface is open at both ends.
  const MeshCheckReport r = check_mesh(m);
  EXPECT_EQ(r.boundary_loops, 2);
  EXPECT_TRUE(r.is_manifold());
  EXPECT_TRUE(r.is_oriented());
  EXPECT_EQ(r.num_vertices, 72 * 68);
}

TEST(Aaop, ampscan_scan_matches_its_stl_twin) {
  const fs::path aop = kAaopDir / "ampscan_limb_scan.aop";
  const fs::path stl = fs::path(SOCKETSMITH_SHARED_DATA_DIR) / "limbs/transtibial/ampscan_limb_scan_mm.stl";
  REQUIRE_SHARED_FILE(aop);
  REQUIRE_SHARED_FILE(stl);
  LogCapture quiet;
  MeshReadInfo info;
  const TriMesh m = read_mesh(aop, {}, &info);
  MeshReadOptions mm;
  mm.unit = units::LengthUnit::Millimetre;
  const TriMesh twin = read_mesh(stl, mm);
  EXPECT_EQ(info.unit, units::LengthUnit::Millimetre);
  EXPECT_TRUE(info.landmarks.empty());
  const AaopShape a = read_aaop(aop);
  ASSERT_EQ(a.num_spokes(), 72);
  ASSERT_EQ(a.num_slices(), 100);
  // Its first slice is a ring a little above the tip, not closed: open at both ends.
  const MeshCheckReport r = check_mesh(m);
  EXPECT_EQ(r.boundary_loops, 2);
  EXPECT_TRUE(r.is_manifold());
  EXPECT_TRUE(r.is_oriented());

  // Extents (the README: ~115 x 127 x 260 mm; measured 112 x 127 x 254 against 115 x 127 x 260):
  // the grid runs from the first to the last complete section, a few mm short of either end.
  const Vec3 e = bounding_box(m).extent();
  const Vec3 et = bounding_box(twin).extent();
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(e[k] / et[k], 1.0, 0.03) << "axis " << k << ": " << e.transpose() << " vs " << et.transpose();

  // Orientation and shape: the twin sampled about the same axis (z, through the centre of its
  // distal 5 %, where ampscan centres its export) at the file's slice heights, over a few mm of
  // the file's unknown start above the tip. The radii agree spoke by spoke; mirrored they do not.
  const Aabb b = bounding_box(twin);
  Vec3 c = Vec3::Zero();
  int n = 0;
  for (const Vec3& p : twin.vertices)
    if (p.z() < b.min.z() + 0.05 * b.extent().z()) c += p, ++n;
  c /= n;
  LimbFrame f;
  f.origin = Vec3(c.x(), c.y(), b.min.z());
  f.axis = Vec3::UnitZ();
  f.anterior = Vec3::UnitX();
  double best = 1e9, best_mirrored = 1e9, best_dz = 0.0;
  for (double dz = 0.0; dz <= 6.0; dz += 0.5) {
    AaopSampleOptions o;
    o.close_distal = false;
    for (int i = 5; i < 95; ++i) o.heights_mm.push_back(a.slice_heights_mm[i] + dz);
    const AaopShape s = sample_aaop(twin, f, o);
    double err = 0.0, err_mirrored = 0.0;
    for (int i = 5; i < 95; ++i)
      for (int j = 0; j < 72; ++j) {
        err += std::abs(a.radius_mm(i, j) - s.radius_mm(i - 5, j));
        err_mirrored += std::abs(a.radius_mm(i, j) - s.radius_mm(i - 5, (72 - j) % 72));  // x -> -x
      }
    if (err < best) best = err, best_dz = dz;
    best_mirrored = std::min(best_mirrored, err_mirrored);
  }
  best /= 90 * 72;
  best_mirrored /= 90 * 72;
  // (measured: 0.63 mm at 2.5 mm above the tip; mirrored 8.9 mm)
  EXPECT_LT(best, 1.0) << "mean radius difference [mm] at " << best_dz << " mm above the tip";
  EXPECT_GT(best_mirrored, 5.0 * best);

  // Volume between 10 % and 90 % of the file's length, capped on both (measured 1314.4 ml against
  // 1314.6 ml).
  const double l = a.slice_heights_mm.back() * units::mm;
  auto between = [](const TriMesh& mesh, double z0, double z1) {
    const TriMesh below = trim_and_cap(mesh, Vec3(0, 0, z1), Vec3::UnitZ()).mesh;
    return signed_volume(trim_and_cap(below, Vec3(0, 0, z0), -Vec3::UnitZ()).mesh);
  };
  const double v = between(m, 0.1 * l, 0.9 * l);
  const double z0 = b.min.z() + best_dz * units::mm;
  const double vt = between(twin, z0 + 0.1 * l, z0 + 0.9 * l);
  EXPECT_NEAR(v / vt, 1.0, 0.03) << v * 1e6 << " vs " << vt * 1e6 << " ml";
}

TEST(Aaop, a_closed_shape_round_trips_through_the_file) {
  LogCapture quiet;
  TempDir dir;
  // An elongated closed shape (ellipsoid, semi-axes 40 x 50 x 150 mm), tilted and moved.
  TriMesh shape = test::make_icosphere(1.0, 4);
  for (Vec3& p : shape.vertices) p = Vec3(0.040 * p.x(), 0.050 * p.y(), 0.150 * p.z());
  shape = test::transformed(shape, test::random_rigid_motion(7));
  AaopSampleOptions opt;
  opt.spokes = 36;
  opt.slices = 40;
  opt.comments = {"round trip"};
  const LimbFrame frame = estimate_limb_axis(shape);
  const AaopShape sampled = sample_aaop(shape, frame, opt);
  ASSERT_EQ(sampled.num_spokes(), 36);
  ASSERT_EQ(sampled.num_slices(), 40);
  // Every sampled point lies on the (faceted) ellipsoid: back in its own frame, its implicit
  // function is 1 on the true surface and a little less on the facets.
  const Eigen::Isometry3d to_own = test::random_rigid_motion(7).inverse();
  const Vec3 x = frame.anterior.normalized(), z = frame.axis.normalized(), y = z.cross(x);
  double h_min = 1e9;
  for (const Vec3& p : shape.vertices) h_min = std::min(h_min, (p - frame.origin).dot(z));
  for (int i = 1; i < sampled.num_slices(); ++i)
    for (int j = 0; j < sampled.num_spokes(); ++j) {
      const Vec3 q = aaop_point_m(Vec3(sampled.radius_mm(i, j), sampled.spoke_angles_deg[j], sampled.slice_heights_mm[i]));
      const Vec3 p = to_own * (frame.origin + (h_min + q.z()) * z + q.x() * x + q.y() * y);
      const double f = std::pow(p.x() / 0.040, 2) + std::pow(p.y() / 0.050, 2) + std::pow(p.z() / 0.150, 2);
      ASSERT_GT(f, 0.97) << "slice " << i << " spoke " << j;
      ASSERT_LT(f, 1.0 + 1e-9) << "slice " << i << " spoke " << j;
    }
  const fs::path file = dir / "shape.aop";
  write_aaop(file, sampled);
  const AaopShape back = read_aaop(file);
  ASSERT_EQ(back.num_spokes(), sampled.num_spokes());
  ASSERT_EQ(back.num_slices(), sampled.num_slices());
  EXPECT_EQ(back.comments, sampled.comments);
  for (int j = 0; j < 36; ++j) EXPECT_NEAR(back.spoke_angles_deg[j], sampled.spoke_angles_deg[j], 1e-9);
  for (int i = 0; i < 40; ++i) EXPECT_NEAR(back.slice_heights_mm[i], sampled.slice_heights_mm[i], 1e-6);
  double worst = 0.0;
  for (std::size_t k = 0; k < sampled.radii_mm.size(); ++k)
    worst = std::max(worst, std::abs(back.radii_mm[k] - sampled.radii_mm[k]) / std::max(1.0, sampled.radii_mm[k]));
  EXPECT_LT(worst, 1e-6);

  // Through write_mesh / read_mesh by extension: about the shape's own axis, distal end closed,
  // and the volume below 90 % of the length that of the shape within 2 %.
  const fs::path file2 = dir / "shape2.aop";
  write_mesh(file2, shape);
  const TriMesh m = read_mesh(file2);
  const MeshCheckReport r = check_mesh(m);
  EXPECT_EQ(r.boundary_loops, 1);
  EXPECT_TRUE(r.is_oriented());
  EXPECT_NEAR(volume_below(m, 0.9) / volume_below(shape, 0.9), 1.0, 0.02);
  EXPECT_NE(error_message<InvalidInputError>([&] { write_mesh(dir / "m.aop", shape, units::LengthUnit::Metre); })
                .find("AAOP files are in millimetres"),
            std::string::npos);
}

}  // namespace
}  // namespace socketsmith::geometry

namespace socketsmith::geometry {
namespace {

// Both shared samples written back and read again: every header field, landmark, spoke angle,
// slice height and radius comes back exactly, and so does the surface built from them.
TEST(Aaop, the_shared_samples_round_trip_exactly) {
  LogCapture quiet;
  TempDir dir;
  for (const char* name : {"ampscan_limb_scan.aop", "example_transtibial.aop"}) {
    SCOPED_TRACE(name);
    const fs::path file = kAaopDir / name;
    REQUIRE_SHARED_FILE(file);
    const AaopShape a = read_aaop(file);
    ASSERT_GT(a.num_spokes(), 0);
    ASSERT_GT(a.num_slices(), 0);
    const fs::path copy = dir / name;
    write_aaop(copy, a);
    const AaopShape b = read_aaop(copy);
    EXPECT_EQ(b.version, a.version);
    EXPECT_EQ(b.comments, a.comments);
    EXPECT_EQ(b.side, a.side);
    ASSERT_EQ(b.landmarks.size(), a.landmarks.size());
    for (std::size_t k = 0; k < a.landmarks.size(); ++k) {
      EXPECT_EQ(b.landmarks[k].name, a.landmarks[k].name);
      ASSERT_EQ(b.landmarks[k].points_mm.size(), a.landmarks[k].points_mm.size());
      for (std::size_t i = 0; i < a.landmarks[k].points_mm.size(); ++i)
        EXPECT_EQ(b.landmarks[k].points_mm[i], a.landmarks[k].points_mm[i]) << a.landmarks[k].name << " point " << i;
    }
    EXPECT_EQ(b.spoke_angles_deg, a.spoke_angles_deg);
    EXPECT_EQ(b.slice_heights_mm, a.slice_heights_mm);
    EXPECT_EQ(b.radii_mm, a.radii_mm);
    // The surfaces read through read_mesh: the same vertices and triangles.
    const TriMesh m = read_mesh(file);
    const TriMesh n = read_mesh(copy);
    ASSERT_EQ(n.vertices.size(), m.vertices.size());
    ASSERT_EQ(n.triangles, m.triangles);
    double worst = 0.0;
    for (std::size_t i = 0; i < m.vertices.size(); ++i) worst = std::max(worst, (n.vertices[i] - m.vertices[i]).norm());
    EXPECT_EQ(worst, 0.0);
    // And a second round trip writes the same bytes as the first.
    const fs::path again = dir / (std::string("again_") + name);
    write_aaop(again, b);
    EXPECT_EQ(format_aaop(read_aaop(again)), format_aaop(b));
  }
}

}  // namespace
}  // namespace socketsmith::geometry
