#include "socketsmith/volume/limb_generator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "brute_force.h"

namespace socketsmith::volume {
namespace {

using geometry::LimbType;
using geometry::Side;
using geometry::TriMesh;
using geometry::Vec3;
using namespace test;

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

/// Perimeter of the plane section z = h (sum of the segment lengths).
double section_perimeter(const TriMesh& m, double h) {
  double perimeter = 0.0;
  for (const auto& t : m.triangles) {
    std::vector<Vec3> pts;
    for (int e = 0; e < 3; ++e) {
      const Vec3 &a = m.vertices[t[e]], &b = m.vertices[t[(e + 1) % 3]];
      if ((a.z() - h) * (b.z() - h) < 0) pts.push_back(a + (h - a.z()) / (b.z() - a.z()) * (b - a));
    }
    if (pts.size() == 2) perimeter += (pts[1] - pts[0]).norm();
  }
  return perimeter;
}

/// Distance from the axis (x = y = 0) to the skin along the ray at angle theta in the plane z = h.
double section_radius(const GeneratedLimb& limb, double theta, double h) {
  const Vec3 dir = limb.frame.radial(theta);
  double best = std::numeric_limits<double>::infinity();
  for (const auto& t : limb.skin.triangles) {
    std::vector<Vec3> pts;
    for (int e = 0; e < 3; ++e) {
      const Vec3 &a = limb.skin.vertices[t[e]], &b = limb.skin.vertices[t[(e + 1) % 3]];
      if ((a.z() - h) * (b.z() - h) < 0) pts.push_back(a + (h - a.z()) / (b.z() - a.z()) * (b - a));
    }
    if (pts.size() != 2) continue;
    // Solve s * dir = p0 + u (p1 - p0) in the xy plane.
    const Vec3 e = pts[1] - pts[0];
    const double den = dir.x() * e.y() - dir.y() * e.x();
    if (std::abs(den) < 1e-20) continue;
    const double s = (pts[0].x() * e.y() - pts[0].y() * e.x()) / den;
    const double u = (pts[0].x() * dir.y() - pts[0].y() * dir.x()) / den;
    if (s > 0 && u >= 0 && u <= 1) best = std::min(best, s);
  }
  return best;
}

GeneratedLimb make(LimbType type, std::uint64_t seed, bool open = true, Side side = Side::Right) {
  LimbShapeParams p = default_params(type, seed);
  p.open_proximal = open;
  p.side = side;
  return generate_limb(p);
}

const NamedMesh& bone(const GeneratedLimb& limb, const std::string& name) {
  for (const auto& b : limb.bones)
    if (b.name == name) return b;
  throw std::runtime_error("no bone " + name);
}

const Landmark& landmark(const GeneratedLimb& limb, const std::string& code) {
  for (const auto& l : limb.landmarks)
    if (l.code == code) return l;
  throw std::runtime_error("no landmark " + code);
}

// --- Tests --------------------------------------------------------------------------------------

TEST(LimbGenerator, transtibial_skin_and_bones_are_valid_closed_surfaces) {
  for (const std::uint64_t seed : {0u, 1u, 2u}) {
    const GeneratedLimb limb = make(LimbType::Transtibial, seed, /*open=*/false);
    const auto rep = geometry::check_mesh(limb.skin);
    std::string problems;
    for (const auto& line : rep.problems()) problems += line + "; ";
    EXPECT_TRUE(rep.is_valid_closed_surface()) << "seed " << seed << ": " << problems;
    EXPECT_EQ(rep.connected_components, 1);
    EXPECT_GT(rep.signed_volume_m3, 0.0);
    EXPECT_GE(limb.skin.num_vertices(), 5000);
    EXPECT_LE(limb.skin.num_vertices(), 10000);
    std::set<std::string> names;
    for (const auto& b : limb.bones) {
      names.insert(b.name);
      const auto r = geometry::check_mesh(b.mesh);
      EXPECT_TRUE(r.is_valid_closed_surface()) << b.name;
      EXPECT_EQ(r.connected_components, 1) << b.name;
      EXPECT_GT(r.signed_volume_m3, 0.0) << b.name;
      EXPECT_GE(b.mesh.num_vertices(), 1000) << b.name;
      EXPECT_LE(b.mesh.num_vertices(), 3000) << b.name;
    }
    EXPECT_EQ(names, (std::set<std::string>{"tibia", "fibula", "femur", "patella"})) << "seed " << seed;
    // The cap triangles lie in the cut plane.
    ASSERT_GE(limb.first_cap_triangle, 0);
    for (int t = limb.first_cap_triangle; t < limb.skin.num_triangles(); ++t)
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(limb.skin.vertices[limb.skin.triangles[t][k]].z(), limb.cut_height_m, 1e-12);
  }
}

TEST(LimbGenerator, transfemoral_skin_and_femur_are_valid_closed_surfaces) {
  for (const std::uint64_t seed : {0u, 3u}) {
    const GeneratedLimb limb = make(LimbType::Transfemoral, seed, /*open=*/false);
    EXPECT_TRUE(geometry::check_mesh(limb.skin).is_valid_closed_surface());
    EXPECT_GE(limb.skin.num_vertices(), 5000);
    EXPECT_LE(limb.skin.num_vertices(), 10000);
    // The femur and, like a CT scan's, a whole hemipelvis (the limb model clips it to the stump).
    ASSERT_EQ(limb.bones.size(), 2u);
    EXPECT_EQ(limb.bones[0].name, "femur");
    EXPECT_EQ(limb.bones[1].name, "hemipelvis");
    for (const auto& b : limb.bones) {
      const auto r = geometry::check_mesh(b.mesh);
      EXPECT_TRUE(r.is_valid_closed_surface()) << b.name;
      EXPECT_GT(r.signed_volume_m3, 0.0) << b.name;
    }
  }
}

TEST(LimbGenerator, open_skin_has_exactly_one_boundary_loop_at_the_proximal_cut) {
  for (const LimbType type : {LimbType::Transtibial, LimbType::Transfemoral}) {
    const GeneratedLimb open = make(type, 4, /*open=*/true);
    const GeneratedLimb closed = make(type, 4, /*open=*/false);
    const auto rep = geometry::check_mesh(open.skin);
    EXPECT_EQ(rep.boundary_loops, 1);
    EXPECT_EQ(rep.non_manifold_edges, 0);
    EXPECT_EQ(rep.inconsistently_oriented_edges, 0);
    EXPECT_EQ(rep.degenerate_triangles, 0);
    EXPECT_EQ(rep.connected_components, 1);
    EXPECT_EQ(open.first_cap_triangle, -1);
    // Boundary edges (used once) all lie in the cut plane.
    std::map<std::pair<int, int>, int> uses;
    for (const auto& t : open.skin.triangles)
      for (int e = 0; e < 3; ++e) ++uses[std::minmax(t[e], t[(e + 1) % 3])];
    int boundary = 0;
    for (const auto& [edge, n] : uses)
      if (n == 1) {
        ++boundary;
        EXPECT_NEAR(open.skin.vertices[edge.first].z(), open.cut_height_m, 1e-12);
        EXPECT_NEAR(open.skin.vertices[edge.second].z(), open.cut_height_m, 1e-12);
      }
    EXPECT_GT(boundary, 0);
    // The open skin is the closed one without its cap; the bones are the same.
    ASSERT_EQ(open.skin.num_triangles(), closed.first_cap_triangle);
    for (int t = 0; t < open.skin.num_triangles(); ++t)
      for (int k = 0; k < 3; ++k)
        EXPECT_EQ(open.skin.vertices[open.skin.triangles[t][k]], closed.skin.vertices[closed.skin.triangles[t][k]]);
    ASSERT_EQ(open.bones.size(), closed.bones.size());
    for (std::size_t b = 0; b < open.bones.size(); ++b) EXPECT_EQ(open.bones[b].mesh.vertices, closed.bones[b].mesh.vertices);
    EXPECT_DOUBLE_EQ(open.skin_volume_m3, closed.skin_volume_m3);
  }
}

TEST(LimbGenerator, bones_lie_inside_the_skin_with_at_least_3mm_of_tissue) {
  for (const auto& [type, seed] : std::vector<std::pair<LimbType, std::uint64_t>>{
           {LimbType::Transtibial, 1}, {LimbType::Transtibial, 7}, {LimbType::Transfemoral, 3}}) {
    const GeneratedLimb limb = make(type, seed, /*open=*/true);
    for (const auto& b : limb.bones) {
      if (b.name == "hemipelvis") continue;  // whole, as in a CT scan: it leaves the skin; its gap to the femur is checked below
      EXPECT_GE(min_vertex_distance(b.mesh, limb.skin), kMinBoneClearance_m) << b.name << " seed " << seed;
      EXPECT_GE(min_vertex_distance(limb.skin, b.mesh), kMinBoneClearance_m) << b.name << " seed " << seed;
      for (std::size_t v = 0; v < b.mesh.vertices.size(); v += 97)
        EXPECT_TRUE(inside_by_parity(b.mesh.vertices[v], limb.skin)) << b.name << " vertex " << v;
      EXPECT_LT(b.mesh.vertices.front().z(), limb.cut_height_m - kMinBoneClearance_m);
    }
    for (std::size_t i = 0; i < limb.bones.size(); ++i)
      for (std::size_t j = 0; j < limb.bones.size(); ++j)
        if (i != j) {
          EXPECT_GE(min_vertex_distance(limb.bones[i].mesh, limb.bones[j].mesh, 2), kMinBoneGap_m)
              << limb.bones[i].name << " vs " << limb.bones[j].name;
          EXPECT_FALSE(inside_by_parity(limb.bones[i].mesh.vertices[0], limb.bones[j].mesh));
        }
  }
}

TEST(LimbGenerator, volumes_are_plausible) {
  for (std::uint64_t seed = 0; seed < 5; ++seed) {
    const GeneratedLimb tt = make(LimbType::Transtibial, seed, /*open=*/false);
    const double v = geometry::signed_volume(tt.skin);
    EXPECT_NEAR(tt.skin_volume_m3, v, 1e-15);
    EXPECT_GT(v, 1.0e-3) << "seed " << seed;  // 1–3 litres (OpenLimb mean transtibial limb: 1.75 l)
    EXPECT_LT(v, 3.0e-3) << "seed " << seed;
    const std::map<std::string, std::pair<double, double>> range_cm3 = {
        {"tibia", {80, 300}}, {"fibula", {5, 40}}, {"patella", {8, 40}}, {"femur", {60, 300}}};
    for (const auto& b : tt.bones) {
      const double cm3 = geometry::signed_volume(b.mesh) * 1e6;
      EXPECT_GT(cm3, range_cm3.at(b.name).first) << b.name;
      EXPECT_LT(cm3, range_cm3.at(b.name).second) << b.name;
    }
    const GeneratedLimb tf = make(LimbType::Transfemoral, seed, /*open=*/false);
    EXPECT_GT(geometry::signed_volume(tf.skin), 2.0e-3);
    EXPECT_LT(geometry::signed_volume(tf.skin), 7.0e-3);
    const double femur_cm3 = geometry::signed_volume(tf.bones[0].mesh) * 1e6;
    EXPECT_GT(femur_cm3, 60);
    EXPECT_LT(femur_cm3, 300);
  }
}

TEST(LimbGenerator, circumferences_match_the_parameters) {
  for (const LimbType type : {LimbType::Transtibial, LimbType::Transfemoral}) {
    const GeneratedLimb limb = make(type, 2);
    const auto& p = limb.params;
    // Polygon sections are a little shorter than the smooth curve they sample.
    EXPECT_NEAR(section_perimeter(limb.skin, p.distal_cap_height_m), p.distal_circumference_m, 0.01 * p.distal_circumference_m);
    const double h_prox = type == LimbType::Transtibial ? p.residual_length_m : p.residual_length_m - 1e-4;
    EXPECT_NEAR(section_perimeter(limb.skin, h_prox), p.proximal_circumference_m, 0.01 * p.proximal_circumference_m);
  }
}

TEST(LimbGenerator, frame_is_the_truth_with_the_distal_end_at_the_origin) {
  for (const Side side : {Side::Right, Side::Left}) {
    const GeneratedLimb limb = make(LimbType::Transtibial, 3, true, side);
    EXPECT_EQ(limb.frame.origin, Vec3::Zero());
    EXPECT_EQ(limb.frame.axis, Vec3::UnitZ());
    EXPECT_EQ(limb.frame.anterior, Vec3::UnitY());
    EXPECT_EQ(limb.frame.side, side);
    EXPECT_FALSE(limb.frame.anterior_estimated);
    EXPECT_FALSE(limb.frame.side_estimated);
    EXPECT_TRUE(limb.frame.medial().isApprox(side == Side::Right ? Vec3(-1, 0, 0) : Vec3(1, 0, 0)));
    const auto box = geometry::bounding_box(limb.skin);
    EXPECT_EQ(box.min.z(), 0.0);
    EXPECT_DOUBLE_EQ(box.max.z(), limb.cut_height_m);
    EXPECT_NEAR(limb.cut_height_m, limb.params.residual_length_m + limb.params.proximal_extension_m, 1e-12);
    EXPECT_EQ(limb.skin.vertices.front(), Vec3::Zero());  // the distal pole, on the axis
  }
}

TEST(LimbGenerator, same_seed_gives_the_same_limb_and_other_seeds_differ) {
  const GeneratedLimb a = make(LimbType::Transtibial, 5), b = make(LimbType::Transtibial, 5);
  EXPECT_EQ(a.skin.vertices, b.skin.vertices);
  EXPECT_EQ(a.skin.triangles, b.skin.triangles);
  ASSERT_EQ(a.bones.size(), b.bones.size());
  for (std::size_t i = 0; i < a.bones.size(); ++i) EXPECT_EQ(a.bones[i].mesh.vertices, b.bones[i].mesh.vertices);
  for (std::size_t i = 0; i < a.landmarks.size(); ++i) EXPECT_EQ(a.landmarks[i].position, b.landmarks[i].position);
  const GeneratedLimb c = make(LimbType::Transtibial, 6);
  EXPECT_NE(a.params.residual_length_m, c.params.residual_length_m);
  EXPECT_NE(a.params.proximal_circumference_m, c.params.proximal_circumference_m);
  EXPECT_NE(a.skin.vertices, c.skin.vertices);
  // Seed 0 is the nominal limb.
  const LimbShapeParams nominal = default_params(LimbType::Transtibial, 0);
  const LimbShapeParams defaults;
  EXPECT_EQ(nominal.residual_length_m, defaults.residual_length_m);
  EXPECT_EQ(nominal.proximal_circumference_m, defaults.proximal_circumference_m);
  EXPECT_EQ(nominal.bones.tibia_plateau_width_m, defaults.bones.tibia_plateau_width_m);
}

TEST(LimbGenerator, left_and_right_limbs_are_mirror_images) {
  for (const LimbType type : {LimbType::Transtibial, LimbType::Transfemoral}) {
    const GeneratedLimb r = make(type, 8, true, Side::Right), l = make(type, 8, true, Side::Left);
    ASSERT_EQ(r.skin.num_vertices(), l.skin.num_vertices());
    for (int v = 0; v < r.skin.num_vertices(); ++v) {
      const Vec3 m(-r.skin.vertices[v].x(), r.skin.vertices[v].y(), r.skin.vertices[v].z());
      ASSERT_LT((l.skin.vertices[v] - m).norm(), 1e-9) << "vertex " << v;
    }
    EXPECT_TRUE(geometry::check_mesh(l.skin).is_oriented());
    ASSERT_EQ(r.bones.size(), l.bones.size());
    for (std::size_t b = 0; b < r.bones.size(); ++b) {
      // The hemipelvis is a boolean union of two tubes: its vertices are rounded, not mirrored exactly.
      const bool rounded = r.bones[b].name == "hemipelvis";
      EXPECT_NEAR(geometry::signed_volume(l.bones[b].mesh), geometry::signed_volume(r.bones[b].mesh),
                  rounded ? 1e-9 : 1e-12);
      EXPECT_GT(geometry::signed_volume(l.bones[b].mesh), 0.0);
      const Vec3 cr = volume_centroid(r.bones[b].mesh), cl = volume_centroid(l.bones[b].mesh);
      EXPECT_LT((cl - Vec3(-cr.x(), cr.y(), cr.z())).norm(), rounded ? 1e-6 : 1e-9)
          << r.bones[b].name;
    }
    ASSERT_EQ(r.landmarks.size(), l.landmarks.size());
    for (std::size_t i = 0; i < r.landmarks.size(); ++i) {
      EXPECT_EQ(r.landmarks[i].code, l.landmarks[i].code);
      EXPECT_NEAR(r.landmarks[i].cylindrical.theta, l.landmarks[i].cylindrical.theta, 1e-9) << r.landmarks[i].code;
      EXPECT_NEAR(r.landmarks[i].position.x(), -l.landmarks[i].position.x(), 1e-9);
    }
  }
  // The medial flare is medial on both sides: -x on a right limb, +x on a left one.
  const GeneratedLimb r = make(LimbType::Transtibial, 8, true, Side::Right), l = make(LimbType::Transtibial, 8, true, Side::Left);
  EXPECT_GT(landmark(r, "MF").cylindrical.theta, 0.0);
  EXPECT_GT(landmark(l, "MF").cylindrical.theta, 0.0);
  EXPECT_LT(landmark(r, "MF").position.x(), 0.0);
  EXPECT_GT(landmark(l, "MF").position.x(), 0.0);
}

TEST(LimbGenerator, landmarks_lie_on_the_skin_on_their_anatomical_side) {
  for (const auto& [seed, side] : std::vector<std::pair<std::uint64_t, Side>>{
           {0, Side::Right}, {1, Side::Right}, {2, Side::Left}, {3, Side::Right}}) {
    const GeneratedLimb limb = make(LimbType::Transtibial, seed, true, side);
    const double knee = limb.params.residual_length_m;
    std::set<std::string> codes;
    for (const auto& lm : limb.landmarks) {
      codes.insert(lm.code);
      TriMesh point;
      point.vertices = {lm.position};
      EXPECT_LT(min_vertex_distance(point, limb.skin), 0.5e-3) << lm.code;
      const auto cyl = limb.frame.to_cylindrical(lm.position);
      EXPECT_NEAR(std::remainder(cyl.theta - lm.cylindrical.theta, 2 * kPi), 0.0, 1e-12);
      EXPECT_GT(lm.cylindrical.theta, -kPi);  // theta in (-pi, pi]
      EXPECT_LE(lm.cylindrical.theta, kPi);
      EXPECT_NEAR(cyl.h, lm.cylindrical.h, 1e-12);
      EXPECT_NEAR(cyl.rho, lm.cylindrical.rho, 1e-12);
      EXPECT_FALSE(lm.estimated);
      EXPECT_GT(lm.radius_m, 0.0);
      EXPECT_FALSE(lm.name.empty());
    }
    EXPECT_EQ(codes, (std::set<std::string>{"PT", "MF", "LF", "FH", "POP", "AD", "TC", "DT"})) << "seed " << seed;
    EXPECT_LT(std::abs(landmark(limb, "PT").cylindrical.theta), 30 * kDeg);
    EXPECT_GT(std::abs(landmark(limb, "POP").cylindrical.theta), 150 * kDeg);
    EXPECT_GT(landmark(limb, "MF").cylindrical.theta, 0.0);
    EXPECT_LT(landmark(limb, "LF").cylindrical.theta, 0.0);
    EXPECT_LT(landmark(limb, "FH").cylindrical.theta, -90 * kDeg);  // postero-lateral
    EXPECT_LT(std::abs(landmark(limb, "TC").cylindrical.theta), 30 * kDeg);
    EXPECT_LT(std::abs(landmark(limb, "AD").cylindrical.theta), 45 * kDeg);
    for (const char* code : {"PT", "MF", "LF", "FH", "POP"})
      EXPECT_NEAR(landmark(limb, code).cylindrical.h, knee, 0.05) << code;
    EXPECT_LT(landmark(limb, "AD").cylindrical.h, 0.4 * knee);
    EXPECT_LT(landmark(limb, "DT").cylindrical.h, 0.03);
    // The patellar tendon lies between the patella and the tibial tuberosity.
    EXPECT_LT(landmark(limb, "PT").cylindrical.h, geometry::bounding_box(bone(limb, "patella").mesh).min.z());
  }
  const GeneratedLimb tf = make(LimbType::Transfemoral, 1);
  const double cut = tf.cut_height_m;
  const double tuberosity = tf.params.residual_length_m;
  EXPECT_GT(landmark(tf, "IS").cylindrical.theta, 60 * kDeg);  // medial to postero-medial
  EXPECT_LT(landmark(tf, "IS").cylindrical.theta, 150 * kDeg);
  EXPECT_NEAR(landmark(tf, "IS").cylindrical.h, tuberosity, 0.02);
  EXPECT_LT(landmark(tf, "IS").cylindrical.h, cut - 0.05);  // the skin reaches above it (buttock, groin)
  EXPECT_GT(landmark(tf, "IR").cylindrical.theta, 0.0);  // medial
  EXPECT_LT(landmark(tf, "IR").cylindrical.theta, landmark(tf, "IS").cylindrical.theta);  // in front of IS
  EXPECT_GT(landmark(tf, "AL").cylindrical.theta, 25 * kDeg);  // antero-medial
  EXPECT_LT(landmark(tf, "AL").cylindrical.theta, 80 * kDeg);
  EXPECT_LT(std::abs(landmark(tf, "ST").cylindrical.theta), landmark(tf, "AL").cylindrical.theta);  // anterior of AL
  EXPECT_NEAR(landmark(tf, "GT").cylindrical.theta, -90 * kDeg, 30 * kDeg);  // lateral
  EXPECT_GT(landmark(tf, "GT").cylindrical.h, tuberosity);
  EXPECT_LT(landmark(tf, "DF").cylindrical.h, 0.05);
  for (const auto& lm : tf.landmarks) {
    TriMesh point;
    point.vertices = {lm.position};
    EXPECT_LT(min_vertex_distance(point, tf.skin), 0.5e-3) << lm.code;
  }
}

TEST(LimbGenerator, bones_are_placed_anatomically) {
  for (const std::uint64_t seed : {0u, 9u}) {
    const GeneratedLimb limb = make(LimbType::Transtibial, seed);
    const double knee = limb.params.residual_length_m;
    const auto& f = limb.frame;
    const auto tib = f.to_cylindrical(volume_centroid(bone(limb, "tibia").mesh));
    const auto fib = f.to_cylindrical(volume_centroid(bone(limb, "fibula").mesh));
    const auto pat = f.to_cylindrical(volume_centroid(bone(limb, "patella").mesh));
    EXPECT_GT((volume_centroid(bone(limb, "tibia").mesh) - f.origin).dot(f.anterior), 0.0);  // tibia anterior
    EXPECT_LT(fib.theta, -90 * kDeg);                                                       // fibula postero-lateral
    EXPECT_LT(std::abs(pat.theta), 20 * kDeg);                                               // patella in front
    EXPECT_GT(pat.rho, tib.rho);
    const auto tib_box = geometry::bounding_box(bone(limb, "tibia").mesh);
    const auto fib_box = geometry::bounding_box(bone(limb, "fibula").mesh);
    EXPECT_LE(tib_box.max.z(), knee + 1e-9);
    EXPECT_GT(tib_box.max.z(), knee - 0.01);
    EXPECT_GT(geometry::bounding_box(bone(limb, "femur").mesh).min.z(), knee);
    EXPECT_GT(tib_box.extent().x(), 0.06);  // the plateau is 70-80 mm wide
    EXPECT_LT(tib_box.extent().x(), 0.09);
    const double tib_end = tib_box.min.z(), fib_end = fib_box.min.z();
    EXPECT_GT(tib_end, 0.010);
    EXPECT_LT(tib_end, 0.040);
    EXPECT_GT(fib_end - tib_end, 0.010);
    EXPECT_LT(fib_end - tib_end, 0.065);
  }
  const GeneratedLimb tf = make(LimbType::Transfemoral, 2);
  const Vec3 c = volume_centroid(tf.bones[0].mesh);
  const auto cyl = tf.frame.to_cylindrical(c);
  EXPECT_LT(cyl.theta, 0.0);  // lateral ...
  EXPECT_GT(cyl.theta, -90 * kDeg);  // ... and anterior
  const double end = geometry::bounding_box(tf.bones[0].mesh).min.z();
  EXPECT_GT(end, 0.02);
  EXPECT_LT(end, 0.07);
}

TEST(LimbGenerator, shank_has_a_crest_ridge_a_flat_anteromedial_face_and_a_calf) {
  // Measured on the OpenLimb mean transtibial limb about its section centroid, 80 mm below the
  // knee: r(0) 46.5, r(30°) 42.8, r(60°) 44.2, r(135°) 52.9, r(180°) 40.5 mm.
  for (const std::uint64_t seed : {0u, 4u}) {
    const GeneratedLimb limb = make(LimbType::Transtibial, seed);
    const double h = 0.5 * (limb.params.distal_cap_height_m + limb.params.residual_length_m);
    auto r = [&](double deg) { return section_radius(limb, deg * kDeg, h); };
    // The crest: the sharpest convex corner of r(theta) is at theta = 0 (anterior).
    auto kink = [&](double deg) { return r(deg + 7.5) + r(deg - 7.5) - 2 * r(deg); };
    const double crest = kink(0);
    EXPECT_LT(crest, -0.0005) << "seed " << seed;
    for (double deg = -90; deg <= 90; deg += 15) {
      if (deg == 0) continue;
      EXPECT_LT(crest, kink(deg)) << "seed " << seed << " at " << deg << "°";
    }
    // The flat antero-medial face dips below the crest and the medial side.
    EXPECT_LT(r(30), r(0) - 0.002);
    EXPECT_LT(r(30), r(60));
    // The calf bulges postero-medially, with a flatter midline between its heads.
    EXPECT_GT(r(135), r(180) + 0.005);
    EXPECT_GT(r(135), r(-135));
  }
}

TEST(LimbGenerator, rejects_out_of_range_parameters) {
  auto expect_invalid = [](const LimbShapeParams& p, const std::string& field) {
    try {
      generate_limb(p);
      ADD_FAILURE() << "no error for " << field;
    } catch (const InvalidInputError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  LimbShapeParams p = default_params(LimbType::Transtibial, 0);
  p.residual_length_m = -0.005;
  expect_invalid(p, "residual_length_m");
  p = default_params(LimbType::Transtibial, 0);
  p.bulbousness = 2.0;
  expect_invalid(p, "bulbousness");
  p = default_params(LimbType::Transfemoral, 0);
  p.proximal_extension_m = 0.16;  // above the tuberosity: at most 0.15 m
  expect_invalid(p, "proximal_extension_m");
  p = default_params(LimbType::Transtibial, 0);
  p.ring_vertices = 10;
  expect_invalid(p, "ring_vertices");
  p = default_params(LimbType::Transtibial, 0);
  p.bones.crest_tissue_m = 0.0;
  expect_invalid(p, "crest_tissue_m");
  p = default_params(LimbType::Transtibial, 0);
  p.distal_circumference_m = std::nan("");
  expect_invalid(p, "distal_circumference_m");
}

TEST(LimbGenerator, default_params_stay_in_range_and_every_seed_generates) {
  for (std::uint64_t seed = 1; seed <= 300; ++seed)
    for (const LimbType type : {LimbType::Transtibial, LimbType::Transfemoral}) {
      const LimbShapeParams p = default_params(type, seed);
      EXPECT_NO_THROW(validate(p)) << "seed " << seed;
      EXPECT_EQ(p.seed, seed);
      EXPECT_EQ(p.type, type);
      if (type == LimbType::Transtibial) {
        EXPECT_NEAR(p.residual_length_m, 0.15, 0.02 + 1e-12);
        EXPECT_NEAR(p.proximal_extension_m, 0.07, 0.01 + 1e-12);
      } else {
        EXPECT_NEAR(p.residual_length_m, 0.27, 0.03 + 1e-12);
        EXPECT_NEAR(p.proximal_extension_m, 0.09, 0.01 + 1e-12);
      }
    }
  for (std::uint64_t seed = 10; seed < 20; ++seed)
    for (const LimbType type : {LimbType::Transtibial, LimbType::Transfemoral})
      EXPECT_NO_THROW(make(type, seed)) << geometry::to_string(type) << " seed " << seed;
}

TEST(LimbGenerator, extreme_parameters_still_give_valid_limbs) {
  std::vector<LimbShapeParams> cases;
  LimbShapeParams p = default_params(LimbType::Transtibial, 0);
  p.residual_length_m = 0.06;
  p.distal_cap_height_m = 0.03;
  cases.push_back(p);  // very short stump: no fibula
  p = default_params(LimbType::Transtibial, 0);
  p.proximal_extension_m = 0.0;
  p.bulbousness = 1.0;
  cases.push_back(p);  // cut at the joint line: no femur, no patella
  p = default_params(LimbType::Transtibial, 0);
  p.proximal_circumference_m = 0.26;
  p.distal_circumference_m = 0.13;
  p.bulbousness = 0.0;
  cases.push_back(p);  // thin conical stump
  p = default_params(LimbType::Transfemoral, 0);
  p.residual_length_m = 0.10;
  cases.push_back(p);
  for (const auto& q : cases) {
    const GeneratedLimb limb = generate_limb(q);
    EXPECT_EQ(geometry::check_mesh(limb.skin).boundary_loops, 1);
    ASSERT_FALSE(limb.bones.empty());
    for (const auto& b : limb.bones) {
      EXPECT_TRUE(geometry::check_mesh(b.mesh).is_valid_closed_surface()) << b.name;
      if (b.name == "hemipelvis") continue;  // leaves the skin by design (clipped by the limb model)
      EXPECT_GE(min_vertex_distance(b.mesh, limb.skin, 3), kMinBoneClearance_m) << b.name;
    }
  }
}

TEST(LimbGenerator, merge_shells_keeps_every_shell) {
  const GeneratedLimb limb = make(LimbType::Transtibial, 1, /*open=*/false);
  const TriMesh merged = merge_shells(limb);
  int nv = limb.skin.num_vertices(), nt = limb.skin.num_triangles();
  double volume = geometry::signed_volume(limb.skin);
  for (const auto& b : limb.bones) {
    nv += b.mesh.num_vertices();
    nt += b.mesh.num_triangles();
    volume += geometry::signed_volume(b.mesh);
  }
  EXPECT_EQ(merged.num_vertices(), nv);
  EXPECT_EQ(merged.num_triangles(), nt);
  EXPECT_NEAR(geometry::signed_volume(merged), volume, 1e-12);
  const auto parts = geometry::split_components(merged);
  EXPECT_EQ(parts.size(), 1 + limb.bones.size());
  EXPECT_TRUE(geometry::check_mesh(merged).is_valid_closed_surface());
}

TEST(LimbGenerator, sidecar_has_params_frame_and_landmarks_in_mm_and_degrees) {
  const GeneratedLimb limb = make(LimbType::Transtibial, 1, true, Side::Left);
  const auto dir = std::filesystem::path(testing::TempDir()) / "socketsmith_limb_sidecar";
  std::filesystem::create_directories(dir);
  const auto path = dir / "limb.json";
  write_limb_sidecar(path, limb);
  std::ifstream in(path);
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["type"], "transtibial");
  EXPECT_EQ(j["side"], "left");
  EXPECT_EQ(j["seed"], 1);
  EXPECT_DOUBLE_EQ(j["params"]["residual_length_m"].get<double>(), limb.params.residual_length_m);
  EXPECT_EQ(j["frame"]["anterior_estimated"], false);
  EXPECT_EQ(j["frame"]["medial"][0].get<double>(), 1.0);
  ASSERT_EQ(j["landmarks"].size(), limb.landmarks.size());
  for (std::size_t i = 0; i < limb.landmarks.size(); ++i) {
    const auto& l = limb.landmarks[i];
    const auto& jl = j["landmarks"][i];
    EXPECT_EQ(jl["code"], l.code);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(jl["position_mm"][k].get<double>(), 1e3 * l.position[k], 1e-9);
    EXPECT_NEAR(jl["theta_deg"].get<double>(), l.cylindrical.theta / kDeg, 1e-9);
    EXPECT_NEAR(jl["h_mm"].get<double>(), 1e3 * l.cylindrical.h, 1e-9);
  }
  std::vector<std::string> names;
  for (const auto& b : limb.bones) names.push_back(b.name);
  EXPECT_EQ(j["bones"].get<std::vector<std::string>>(), names);
  EXPECT_EQ(j["shells"].size(), 1 + limb.bones.size());
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace socketsmith::volume
