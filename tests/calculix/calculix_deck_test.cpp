#include "socketsmith/calculix/calculix_deck.h"
#include "socketsmith/calculix/design_check.h"

#include <limits>
#include <map>
#include <numbers>
#include <sstream>

#include <gtest/gtest.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/pipeline/validation_inputs.h"
#include "socketsmith/tissue/hyperelastic_hex.h"
#include "socketsmith/volume/box_mesher.h"
#include "box_with_top.h"

namespace socketsmith::calculix {
namespace {

/// The deck's keyword blocks: keyword line → data lines.
std::multimap<std::string, std::vector<std::string>> parse_blocks(const std::string& deck) {
  std::multimap<std::string, std::vector<std::string>> out;
  std::istringstream in(deck);
  std::string line;
  std::vector<std::string>* cur = nullptr;
  while (std::getline(in, line)) {
    if (line.starts_with("**")) continue;
    if (line.starts_with("*")) {
      cur = &out.emplace(line, std::vector<std::string>{})->second;
    } else if (cur) {
      cur->push_back(line);
    }
  }
  return out;
}

std::vector<double> numbers(const std::string& line) {
  std::vector<double> v;
  std::string s = line;
  for (auto& c : s)
    if (c == ',') c = ' ';
  std::istringstream in(s);
  double x;
  while (in >> x) v.push_back(x);
  return v;
}

using Box = testing::BoxWithTop;

/// A plate (one shell element) over the box's top at height @p z, and a deck with the box and it.
struct BoxAndPlate {
  Box b;
  RigidShell plate;
  DeckSpec spec;
  explicit BoxAndPlate(double z) {
    const std::vector<Vec3> pts{{-0.01, -0.01, z}, {0.03, -0.01, z}, {0.03, 0.03, z}, {-0.01, 0.03, z}};
    plate = extrude_shell(pts, std::vector<Vec3>(4, Vec3::UnitZ()), {{0, 1, 2, 3}}, 0.002);
    spec.stump = &b.mesh;
    spec.fixed_nodes = {0};
    spec.skin_faces = b.top;
    spec.socket = &plate;
  }
};

/// The box with three fixed nodes and one nodal force (no socket).
DeckSpec loaded_box(const Box& b) {
  DeckSpec s;
  s.stump = &b.mesh;
  s.fixed_nodes = {0, 1, 2};
  s.nodal_forces = {{26, Vec3(0, 0, -1.5)}};
  return s;
}

TEST(CalculixDeck, nodes_elements_sets_and_loads_read_back) {
  Box b;
  DeckSpec s = loaded_box(b);
  s.material.youngs_modulus_pa = 100e3;
  s.material.poisson_ratio = 0.45;
  const auto blocks = parse_blocks(write_deck(s));
  const auto& nodes = blocks.find("*NODE, NSET=NLIMB")->second;
  ASSERT_EQ(nodes.size(), 27u);
  for (int i = 0; i < 27; ++i) {
    const auto v = numbers(nodes[i]);
    ASSERT_EQ(v.size(), 4u);
    EXPECT_EQ(v[0], i + 1);
    EXPECT_NEAR(v[1], b.mesh.nodes[i].x(), 1e-12);
    EXPECT_NEAR(v[3], b.mesh.nodes[i].z(), 1e-12);
  }
  const auto& elems = blocks.find("*ELEMENT, TYPE=C3D8, ELSET=LIMB")->second;
  ASSERT_EQ(elems.size(), 8u);
  for (int e = 0; e < 8; ++e) {
    const auto v = numbers(elems[e]);
    ASSERT_EQ(v.size(), 9u);
    for (int k = 0; k < 8; ++k) EXPECT_EQ(v[k + 1], b.mesh.hexahedra[e][k] + 1);
  }
  EXPECT_EQ(numbers(blocks.find("*NSET, NSET=BONE")->second.at(0)), (std::vector<double>{1, 2, 3}));
  const auto& el = blocks.find("*ELASTIC")->second;
  EXPECT_EQ(numbers(el.at(0)), (std::vector<double>{100e3, 0.45}));
  const auto& cl = blocks.find("*CLOAD")->second;
  ASSERT_EQ(cl.size(), 1u);
  EXPECT_EQ(numbers(cl[0]), (std::vector<double>{27, 3, -1.5}));
  EXPECT_EQ(blocks.count("*CONTACT PAIR, INTERACTION=SI, TYPE=SURFACE TO SURFACE"), 0u);
  EXPECT_EQ(blocks.count("*STEP, NLGEOM, INC=1000"), 1u);
}

TEST(CalculixDeck, the_cases_tissue_model_picks_calculixs_material) {
  // neo-hookean: *HYPERELASTIC, NEO HOOKE with the C10 and D1 of socketsmith's own elements;
  // fe: *ELASTIC with its ν; a lattice: *ELASTIC with the thesis's ν 0.45.
  Box b;
  DeckSpec s = loaded_box(b);
  auto c = design::parse_case(nlohmann::json::parse(R"({"tissue": {"model": "neo-hookean", "poisson": 0.47, "youngs_kpa": 80}})"));
  s.material = pipeline::fe_material(c);
  EXPECT_TRUE(s.material.is_neo_hookean);
  auto blocks = parse_blocks(write_deck(s));
  ASSERT_EQ(blocks.count("*HYPERELASTIC, NEO HOOKE"), 1u);
  EXPECT_EQ(blocks.count("*ELASTIC"), 0u);
  const tissue::HyperelasticMaterial nh(tissue::HyperelasticLaw::NeoHookean, 80e3, 0.47);
  const auto v = numbers(blocks.find("*HYPERELASTIC, NEO HOOKE")->second.at(0));
  ASSERT_EQ(v.size(), 2u);
  EXPECT_NEAR(v[0], nh.c10(), 1e-8 * nh.c10());
  EXPECT_NEAR(v[1], nh.d1(), 1e-8 * nh.d1());
  c = design::parse_case(nlohmann::json::parse(R"({"tissue": {"model": "fe", "poisson": 0.47, "youngs_kpa": 80}})"));
  s.material = pipeline::fe_material(c);
  blocks = parse_blocks(write_deck(s));
  EXPECT_EQ(numbers(blocks.find("*ELASTIC")->second.at(0)), (std::vector<double>{80e3, 0.47}));
  c = design::parse_case(nlohmann::json::parse(R"({"tissue": {"model": "mss-cs", "youngs_kpa": 80}})"));
  s.material = pipeline::fe_material(c);
  EXPECT_FALSE(s.material.is_neo_hookean);
  EXPECT_DOUBLE_EQ(s.material.poisson_ratio, 0.45);
}

TEST(CalculixDeck, socket_contact_and_the_two_steps_follow_calculix_md) {
  BoxAndPlate bp(0.02);
  DeckSpec& s = bp.spec;
  s.contact.friction = 0.5;
  s.steps.donning_travel_m = Vec3(0, 0, 0.03);
  s.steps.stand_travel_m = 0.004;
  const std::string deck = write_deck(s);
  const auto blocks = parse_blocks(deck);
  // Each top face is face S2 (+z, local face 1) of a top-layer element.
  const auto& slimb = blocks.find("*SURFACE, NAME=SLIMB, TYPE=ELEMENT")->second;
  ASSERT_EQ(slimb.size(), 4u);
  for (const auto& l : slimb) EXPECT_NE(l.find(", S2"), std::string::npos) << l;
  // Socket nodes and element follow the stump's ids; its contact face is S1, facing the stump.
  EXPECT_EQ(blocks.find("*NODE, NSET=NSOCK")->second.size(), 8u);
  EXPECT_EQ(blocks.find("*SURFACE, NAME=SSOCK, TYPE=ELEMENT")->second.at(0), "9, S1");
  EXPECT_EQ(numbers(blocks.find("*FRICTION")->second.at(0)), (std::vector<double>{0.5, 5e7}));
  EXPECT_EQ(blocks.count("*STEP, NLGEOM, INC=1000"), 2u);
  // Step 1 moves the socket 30 mm up; step 2 (standing) 4 mm further, under displacement control:
  // ccx's values are totals from the start, the rotation held, no force and no amplitude.
  EXPECT_NE(deck.find("900001, 1, 1, 0\n900001, 2, 2, 0\n900001, 3, 3, 0.03\n900002, 1, 3\n"), std::string::npos);
  EXPECT_NE(deck.find("*BOUNDARY, OP=NEW\nBONE, 1, 3\n900001, 1, 1, 0\n900001, 2, 2, 0\n900001, 3, 3, 0.034\n900002, 1, 3\n"),
            std::string::npos);
  EXPECT_EQ(deck.find("*CLOAD"), std::string::npos);
  EXPECT_EQ(deck.find("*AMPLITUDE"), std::string::npos);
  EXPECT_NE(deck.find("*RIGID BODY, NSET=NSOCK, REF NODE=900001, ROT NODE=900002"), std::string::npos);
  EXPECT_EQ(deck.find("ENCASTRE"), std::string::npos);  // CALCULIX.md: fails in ccx
  // Every step writes the stump's stress: the contact pressure is −n·σ·n (surface_pressure.h), since
  // nodal CPRESS depended on where the donning started (30 vs 60 mm: R 0.68 between the two).
  const auto el_file = blocks.equal_range("*EL FILE");
  ASSERT_EQ(std::distance(el_file.first, el_file.second), 2);
  for (auto it = el_file.first; it != el_file.second; ++it) EXPECT_EQ(it->second, std::vector<std::string>{"S"});
  // ... and prints the integration-point stresses of the elements touching the skin (the top
  // layer of the 2×2×2 box, elements 5–8) for the nodal-force pressure.
  EXPECT_EQ(numbers(blocks.find("*ELSET, ELSET=SKINEL")->second.at(0)), (std::vector<double>{5, 6, 7, 8}));
  const auto el_print = blocks.equal_range("*EL PRINT, ELSET=SKINEL");
  ASSERT_EQ(std::distance(el_print.first, el_print.second), 2);
  for (auto it = el_print.first; it != el_print.second; ++it) EXPECT_EQ(it->second, std::vector<std::string>{"S"});
}

TEST(CalculixDeck, a_standing_step_along_a_slanted_axis_moves_the_socket_along_it) {
  BoxAndPlate bp(0.02);
  DeckSpec& s = bp.spec;
  const Vec3 axis = Vec3(0.1, -0.2, 1.0).normalized();
  s.steps.donning_travel_m = 0.03 * axis;
  s.steps.stand_travel_m = -0.002;  // a socket carrying more than the load when donned comes back down
  s.steps.load_direction = axis;
  const std::string deck = write_deck(s);
  EXPECT_EQ(deck.find("*TRANSFORM"), std::string::npos);  // every component prescribed: no local frame
  const auto step2 = deck.substr(deck.find("*BOUNDARY, OP=NEW"));
  const auto blocks = parse_blocks(step2);
  const auto& bc = blocks.find("*BOUNDARY, OP=NEW")->second;
  Vec3 u = Vec3::Zero();
  for (const auto& line : bc) {
    const auto v = numbers(line);
    if (v.size() == 4 && v[0] == 900001) u[static_cast<int>(v[1]) - 1] = v[3];
  }
  EXPECT_LT((u - 0.028 * axis).norm(), 1e-12);
  s.steps.load_direction = Vec3::Zero();
  EXPECT_THROW(write_deck(s), InvalidInputError);
  s.steps.load_direction = axis;
  s.steps.stand_travel_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(write_deck(s), InvalidInputError);
}

TEST(CalculixDeck, a_shell_with_prescribed_node_displacements_is_not_a_rigid_body) {
  BoxAndPlate bp(0.021);
  DeckSpec& s = bp.spec;
  s.socket_node_displacements.assign(8, Vec3(0, 0, -0.002));
  const std::string deck = write_deck(s);
  EXPECT_EQ(deck.find("*RIGID BODY"), std::string::npos);
  EXPECT_EQ(deck.find("900001"), std::string::npos);
  // Socket nodes 28..35, each moved in x, y, z.
  EXPECT_NE(deck.find("28, 3, 3, -0.002\n"), std::string::npos);
  EXPECT_NE(deck.find("35, 1, 1, 0\n"), std::string::npos);
  s.socket_node_displacements.resize(3);
  EXPECT_THROW(write_deck(s), InvalidInputError);
  s.socket_node_displacements.assign(8, Vec3::Zero());
  s.steps.stand_travel_m = 0.002;
  EXPECT_THROW(write_deck(s), InvalidInputError);  // a standing step needs a rigid socket
}

TEST(CalculixDeck, extruded_shell_elements_are_not_inverted_and_face_the_body) {
  // A quad facing +z (counter-clockwise seen from above) over a body below it.
  const std::vector<Vec3> pts{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  const auto sh = extrude_shell(pts, std::vector<Vec3>(4, Vec3::UnitZ()), {{0, 1, 2, 3}}, 0.1);
  volume::HexMesh m;
  m.nodes = sh.nodes;
  m.hexahedra = sh.hexahedra;
  m.node_tags.assign(m.nodes.size(), 0);
  EXPECT_NO_THROW(volume::validate(m));
  EXPECT_NEAR(volume::total_volume(m), 0.1, 1e-12);
  // The contact face S1 = local face 0 lies on the quad (z = 0), its outward normal is −z (towards the body).
  ASSERT_EQ(sh.contact_faces.size(), 1u);
  const auto& f = volume::kHexFaces[sh.contact_faces[0].local_face];
  const Vec3 a = m.nodes[sh.hexahedra[0][f[0]]], b = m.nodes[sh.hexahedra[0][f[1]]], c = m.nodes[sh.hexahedra[0][f[2]]];
  EXPECT_LT((b - a).cross(c - a).z(), 0);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(m.nodes[sh.hexahedra[0][f[k]]].z(), 0.0);
}

TEST(CalculixDeck, subdivided_quads_share_their_edges_keep_their_orientation_and_lie_on_the_patches) {
  // Two quads side by side on a saddle-free bent strip (x from 0 to 2, z up at x = 2), facing +z-ish.
  const std::vector<Vec3> pts{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {2, 0, 0.5}, {2, 1, 0.5}};
  const std::vector<Vec3> nrm(6, Vec3::UnitZ());
  const std::vector<std::array<int, 4>> quads{{0, 1, 2, 3}, {1, 4, 5, 2}};
  for (const int n : {1, 2, 3}) {
    SCOPED_TRACE(n);
    const auto s = subdivide_quads(pts, nrm, quads, n);
    // (n+1)² points per quad, the shared edge's n+1 once: 2(n+1)² − (n+1) in all.
    EXPECT_EQ(s.points.size(), static_cast<size_t>(2 * (n + 1) * (n + 1) - (n + 1)));
    ASSERT_EQ(s.quads.size(), static_cast<size_t>(2 * n * n));
    for (int k = 0; k < 6; ++k) EXPECT_EQ(s.points[k], pts[k]);  // the corners keep their ids
    // Every edge of the refined surface is used by one or two sub-quads, in opposite directions
    // when shared (one consistent orientation, no crack along the old shared edge).
    std::map<std::pair<int, int>, int> used;
    double area = 0;
    for (const auto& q : s.quads) {
      for (int k = 0; k < 4; ++k) ++used[{q[k], q[(k + 1) % 4]}];
      const Vec3 a = (s.points[q[2]] - s.points[q[0]]).cross(s.points[q[3]] - s.points[q[1]]);
      EXPECT_GT(a.z(), 0);  // the parents' orientation
      area += 0.5 * a.norm();
    }
    int interior = 0;
    for (const auto& [e, count] : used) {
      EXPECT_EQ(count, 1);
      if (used.count({e.second, e.first})) ++interior;
    }
    EXPECT_EQ(interior, 2 * (4 * n * n - 3 * n));  // each interior edge of the 2n × n grid seen from both sides
    EXPECT_NEAR(area, 1.0 + std::hypot(1.0, 0.5), 1e-12);  // planar patches: the area is kept
  }
  EXPECT_THROW(subdivide_quads(pts, nrm, quads, 0), InvalidInputError);
  EXPECT_THROW(subdivide_quads(pts, nrm, {{0, 1, 2, 7}}, 2), InvalidInputError);
}

/// Signed volume of a C3D6 wedge (three tetrahedra; > 0 when 0-1-2 turns counter-clockwise seen
/// from 3-4-5, CalculiX's positive orientation).
double wedge_volume(const RigidShell& sh, const std::array<int, 6>& w) {
  const auto tet = [&](int a, int b, int c, int d) {
    const Vec3 &p = sh.nodes[w[a]], &q = sh.nodes[w[b]], &r = sh.nodes[w[c]], &t = sh.nodes[w[d]];
    return (q - p).cross(r - p).dot(t - p) / 6.0;
  };
  return tet(0, 1, 2, 3) + tet(1, 2, 3, 4) + tet(2, 3, 4, 5);
}

TEST(CalculixDeck, a_triangulated_wall_becomes_wedges_that_are_not_inverted_and_face_the_body) {
  // A square wall over a body below it, its two triangles facing the body (−z): a socket's inner
  // wall facing its cavity.
  const std::vector<Vec3> v{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {5, 5, 5}};  // the last one unused
  const RigidShell sh = extrude_wall(v, {{0, 2, 1}, {0, 3, 2}}, 0.1);
  ASSERT_EQ(sh.wedges.size(), 2u);
  EXPECT_TRUE(sh.hexahedra.empty());
  EXPECT_EQ(sh.nodes.size(), 10u);  // four wall vertices and three behind each triangle
  double volume = 0;
  for (const auto& w : sh.wedges) {
    EXPECT_GT(wedge_volume(sh, w), 0);
    volume += wedge_volume(sh, w);
    // Face S1 (nodes 0-1-2) lies on the wall; its outward normal, against 0-1-2's turn, faces the body.
    for (int k = 0; k < 3; ++k) EXPECT_EQ(sh.nodes[w[k]].z(), 0.0);
    for (int k = 3; k < 6; ++k) EXPECT_NEAR(sh.nodes[w[k]].z(), 0.1, 1e-12);
    const Vec3 outward = -(sh.nodes[w[1]] - sh.nodes[w[0]]).cross(sh.nodes[w[2]] - sh.nodes[w[0]]);
    EXPECT_LT(outward.z(), 0);
  }
  EXPECT_NEAR(volume, 0.1, 1e-12);
  ASSERT_EQ(sh.contact_faces.size(), 2u);
  EXPECT_EQ(sh.contact_faces[1].hexahedron, 1);
  EXPECT_EQ(sh.contact_faces[1].local_face, 0);
  // A wall curving tighter than the thickness (the lip: a tube of 1 mm radius facing out, 3 mm
  // thick behind it): every wedge still has the volume of its triangle times the thickness.
  std::vector<Vec3> tube;
  std::vector<std::array<int, 3>> tris;
  for (int k = 0; k < 8; ++k) {
    const double a = k * std::numbers::pi / 4;
    tube.push_back(Vec3(1e-3 * std::cos(a), 1e-3 * std::sin(a), 0));
    tube.push_back(Vec3(1e-3 * std::cos(a), 1e-3 * std::sin(a), 1e-3));
  }
  for (int k = 0; k < 8; ++k) {
    const int a = 2 * k, b = 2 * ((k + 1) % 8);
    tris.push_back({a, b, b + 1});
    tris.push_back({a, b + 1, a + 1});
  }
  const RigidShell lip = extrude_wall(tube, tris, 3e-3);
  for (size_t k = 0; k < lip.wedges.size(); ++k) {
    const auto& t = tris[k];
    const double area = 0.5 * (tube[t[1]] - tube[t[0]]).cross(tube[t[2]] - tube[t[0]]).norm();
    EXPECT_NEAR(wedge_volume(lip, lip.wedges[k]), area * 3e-3, 1e-6 * area * 3e-3);
  }
  EXPECT_THROW(extrude_wall(v, {{0, 2, 9}}, 0.1), InvalidInputError);
  EXPECT_THROW(extrude_wall(v, {{0, 2, 1}}, 0.0), InvalidInputError);
  EXPECT_THROW(extrude_wall(v, {}, 0.1), InvalidInputError);
}

TEST(CalculixDeck, a_wedge_socket_is_written_as_c3d6_with_its_contact_faces) {
  BoxAndPlate bp(0.02);
  const std::vector<Vec3> v{{-0.01, -0.01, 0.02}, {0.03, -0.01, 0.02}, {0.03, 0.03, 0.02}, {-0.01, 0.03, 0.02}};
  const RigidShell wall = extrude_wall(v, {{0, 2, 1}, {0, 3, 2}}, 0.002);
  bp.spec.socket = &wall;
  bp.spec.steps.donning_travel_m = Vec3(0, 0, 0.03);
  const auto blocks = parse_blocks(write_deck(bp.spec));
  EXPECT_EQ(blocks.count("*ELEMENT, TYPE=C3D8, ELSET=SOCKET"), 0u);
  const auto& wedges = blocks.find("*ELEMENT, TYPE=C3D6, ELSET=SOCKET")->second;
  ASSERT_EQ(wedges.size(), 2u);
  EXPECT_EQ(numbers(wedges[0]).size(), 7u);  // id and six nodes
  EXPECT_EQ(numbers(wedges[0])[0], 9);       // after the box's 8 elements
  EXPECT_EQ(blocks.find("*SURFACE, NAME=SSOCK, TYPE=ELEMENT")->second, (std::vector<std::string>{"9, S1", "10, S1"}));
  EXPECT_EQ(blocks.find("*NODE, NSET=NSOCK")->second.size(), 10u);
}

TEST(CalculixDeck, bad_input_names_the_field) {
  Box b;
  DeckSpec s;
  EXPECT_THROW(write_deck(s), InvalidInputError);
  s.stump = &b.mesh;
  try {
    write_deck(s);
    FAIL();
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("nothing loads the stump"), std::string::npos);
  }
  s.nodal_forces = {{99, Vec3(1, 0, 0)}};
  EXPECT_THROW(write_deck(s), InvalidInputError);
  s.nodal_forces = {{3, Vec3(1, 0, 0)}};
  s.material.poisson_ratio = 0.5;
  try {
    write_deck(s);
    FAIL();
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("Poisson ratio 0.5"), std::string::npos);
  }
  EXPECT_THROW(faces_of_quads(b.mesh, {{0, 1, 2, 3}}), InvalidInputError);  // an interior quad
  EXPECT_THROW(parse_element_type("C3D20"), InvalidInputError);
  EXPECT_EQ(parse_element_type("c3d8i"), ElementType::C3D8I);
  EXPECT_EQ(parse_design_check_mode("donning"), DesignCheckMode::Donning);
  EXPECT_EQ(to_string(DesignCheckMode::Load), "load");
  EXPECT_THROW(parse_design_check_mode("abaqus"), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::calculix
