// Limb frame: cylindrical coordinates, slices, axis and distal-end estimation.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/mesh_io.h"
#include "test_shapes.h"

namespace socketsmith::geometry {
namespace {

/// Open-topped tapered limb along @p axis: radius R at the top, a rounded distal end.
TriMesh tapered_limb(const Vec3& origin, const Vec3& axis, double length, double R, int rings = 60, int seg = 64) {
  const Vec3 a = axis.normalized();
  const Vec3 u = (std::abs(a.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(a).normalized();
  const Vec3 v = a.cross(u);
  auto radius = [&](double h) {
    const double taper = 0.7 + 0.3 * h / length;  // conical
    const double cap = std::sqrt(std::max(0.0, 1.0 - std::pow(std::max(0.0, 0.04 - h) / 0.04, 2)));
    return R * taper * cap;
  };
  TriMesh m;
  m.vertices.push_back(origin);
  for (int r = 1; r <= rings; ++r) {
    const double s = static_cast<double>(r) / rings;
    const double h = length * (s < 0.25 ? 0.16 * (1 - std::cos(M_PI * 2 * s)) / 2 * 2.0 : 0.16 + (s - 0.25) / 0.75 * 0.84);
    for (int k = 0; k < seg; ++k) {
      const double th = 2 * M_PI * k / seg;
      m.vertices.push_back(origin + h * a + radius(h) * (std::cos(th) * u + std::sin(th) * v));
    }
  }
  auto id = [&](int r, int k) { return 1 + (r - 1) * seg + (k % seg); };
  for (int k = 0; k < seg; ++k) m.triangles.push_back({0, id(1, k + 1), id(1, k)});
  for (int r = 1; r < rings; ++r)
    for (int k = 0; k < seg; ++k) {
      m.triangles.push_back({id(r, k), id(r, k + 1), id(r + 1, k + 1)});
      m.triangles.push_back({id(r, k), id(r + 1, k + 1), id(r + 1, k)});
    }
  return m;
}

TEST(LimbFrame, CylindricalRoundTripAndConventions) {
  LimbFrame f;
  f.origin = Vec3(0.1, -0.2, 0.3);
  f.axis = Vec3(0, 0, 1);
  f.anterior = Vec3(0, 1, 0);
  f.side = Side::Right;
  // Right limb: medial is the patient's left = −x when facing +y with +z up.
  EXPECT_NEAR((f.medial() - Vec3(-1, 0, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(f.to_cylindrical(f.origin + Vec3(-0.05, 0, 0.1)).theta, M_PI / 2, 1e-12);
  f.side = Side::Left;
  EXPECT_NEAR((f.medial() - Vec3(1, 0, 0)).norm(), 0.0, 1e-12);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 100; ++i) {
    const Vec3 p(u(rng), u(rng), u(rng));
    const Cylindrical c = f.to_cylindrical(p);
    EXPECT_GE(c.rho, 0.0);
    EXPECT_NEAR((f.from_cylindrical(c) - p).norm(), 0.0, 1e-12);
  }
  EXPECT_EQ(parse_side("LEFT"), Side::Left);
  EXPECT_EQ(parse_limb_type("tf"), LimbType::Transfemoral);
  EXPECT_THROW(parse_side("up"), InvalidInputError);
  EXPECT_THROW(parse_limb_type("arm"), InvalidInputError);
}

TEST(LimbFrame, SliceOfASphereHasTheAnalyticAreaAndCentroid) {
  const TriMesh s = test::make_icosphere(1.0, 5, Vec3(0.5, 0, 0));
  const Slice sl = slice_surface(s, Vec3(0, 0, 0.6), Vec3::UnitZ());
  const double r2 = 1.0 - 0.36;
  EXPECT_NEAR(sl.area, M_PI * r2, 0.01 * M_PI * r2);
  EXPECT_NEAR((sl.centroid - Vec3(0.5, 0, 0.6)).norm(), 0.0, 1e-3);
  EXPECT_NEAR(sl.perimeter, 2 * M_PI * std::sqrt(r2), 0.01 * 2 * M_PI);
  EXPECT_EQ(slice_surface(s, Vec3(0, 0, 2), Vec3::UnitZ()).segments.size(), 0u);
}

TEST(LimbFrame, AxisAndDistalEndOfATiltedOpenLimb) {
  const Vec3 axis = Vec3(0.3, -0.2, 1.0).normalized();
  const Vec3 origin(0.01, 0.02, -0.03);
  const TriMesh m = tapered_limb(origin, axis, 0.25, 0.05);
  const LimbFrame f = estimate_limb_axis(m);
  EXPECT_GT(f.axis.dot(axis), std::cos(1.0 * units::deg));  // right direction: distal -> open end
  EXPECT_NEAR((f.origin - origin).norm(), 0.0, 2e-3);
  EXPECT_NEAR(f.anterior.dot(f.axis), 0.0, 1e-12);
  EXPECT_NEAR(lowest_open_boundary_height(m, f), 0.25, 1e-3);
  // The same limb turned upside down (a rotation of 180 degrees about x): the axis follows.
  TriMesh turned = m;
  for (auto& v : turned.vertices) v = Vec3(v.x(), -v.y(), -v.z());
  const LimbFrame g = estimate_limb_axis(turned);
  EXPECT_GT(g.axis.dot(Vec3(axis.x(), -axis.y(), -axis.z())), std::cos(1.0 * units::deg));
}

TEST(LimbFrame, RejectsASphereAndABox) {
  EXPECT_THROW(estimate_limb_axis(test::make_icosphere(0.1, 3)), InvalidInputError);
  TriMesh box = test::make_cube(0.1);
  for (auto& v : box.vertices) v.z() *= 3.0;  // elongated but it does not taper
  EXPECT_THROW(estimate_limb_axis(box), InvalidInputError);
  LimbFrame f;
  EXPECT_THROW(set_anterior(f, Vec3(0, 0, 2)), InvalidInputError);
}

TEST(LimbFrame, RealTranstibialScansAreLongAlongTheirLargestExtent) {
  const std::filesystem::path dir = SOCKETSMITH_SHARED_DATA_DIR "/limbs/transtibial";
  for (const char* name : {"ampscan_limb_scan_mm.stl", "openlimb_tt_mean_skin_mm.stl"}) {
    if (!std::filesystem::exists(dir / name)) GTEST_SKIP() << "shared data absent: " << (dir / name);
    MeshReadOptions ro;
    ro.unit = units::LengthUnit::Millimetre;
    const TriMesh m = read_mesh(dir / name, ro);
    const LimbFrame f = estimate_limb_axis(m);
    const Vec3 ext = bounding_box(m).extent();
    int longest = 0;
    ext.maxCoeff(&longest);
    EXPECT_GT(std::abs(f.axis[longest]), 0.9) << name;
    const double top = lowest_open_boundary_height(m, f);
    EXPECT_GT(top, 0.15) << name;
    EXPECT_LT(top, 0.30) << name;
  }
}

}  // namespace
}  // namespace socketsmith::geometry
