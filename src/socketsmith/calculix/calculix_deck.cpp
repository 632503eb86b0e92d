#include "socketsmith/calculix/calculix_deck.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>

#include <fmt/format.h>

#include "socketsmith/core/enum_names.h"
#include "socketsmith/core/errors.h"

namespace socketsmith::calculix {
namespace {

bool finite(const Vec3& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

/// Writes ids in lines of at most 16 (ccx reads at most 16 entries per data line).
void write_id_lines(std::string& out, const std::vector<int>& ids) {
  for (size_t k = 0; k < ids.size(); ++k) {
    out += fmt::format("{}", ids[k]);
    out += (k + 1 == ids.size() || k % 16 == 15) ? "\n" : ", ";
  }
}

void check_spec(const DeckSpec& s) {
  require(s.stump != nullptr, "write_deck: no stump mesh (DeckSpec::stump is null)");
  const auto& m = *s.stump;
  require(m.num_nodes() > 0 && m.num_hexahedra() > 0, "write_deck: the stump has {} nodes and {} hexahedra (expected a volume mesh)",
          m.num_nodes(), m.num_hexahedra());
  for (int i = 0; i < m.num_nodes(); ++i)
    require(finite(m.nodes[i]), "write_deck: stump node {} has a non-finite coordinate", i);
  for (int e = 0; e < m.num_hexahedra(); ++e)
    for (int v : m.hexahedra[e])
      require(v >= 0 && v < m.num_nodes(), "write_deck: hexahedron {} uses node {} (mesh has {} nodes)", e, v, m.num_nodes());
  for (int v : s.fixed_nodes)
    require(v >= 0 && v < m.num_nodes(), "write_deck: fixed node {} is out of range (mesh has {} nodes)", v, m.num_nodes());
  for (const auto& [v, c] : s.fixed_components)
    require(v >= 0 && v < m.num_nodes() && c >= 0 && c < 3, "write_deck: fixed component ({}, {}) is out of range", v, c);
  for (const auto& [v, f] : s.nodal_forces) {
    require(v >= 0 && v < m.num_nodes(), "write_deck: force on node {} is out of range (mesh has {} nodes)", v, m.num_nodes());
    require(finite(f), "write_deck: the force on node {} is not finite", v);
  }
  for (const auto& f : s.skin_faces)
    require(f.hexahedron >= 0 && f.hexahedron < m.num_hexahedra() && f.local_face >= 0 && f.local_face < 6,
            "write_deck: skin face ({}, {}) is out of range", f.hexahedron, f.local_face);
  const auto& mat = s.material;
  require(mat.youngs_modulus_pa > 0 && std::isfinite(mat.youngs_modulus_pa),
          "write_deck: Young's modulus {} Pa (expected > 0)", mat.youngs_modulus_pa);
  require(mat.poisson_ratio > -1 && mat.poisson_ratio < 0.5, "write_deck: Poisson ratio {} (expected in (-1, 0.5))",
          mat.poisson_ratio);
  require(mat.density_kg_m3 > 0, "write_deck: density {} kg/m^3 (expected > 0)", mat.density_kg_m3);
  const auto& st = s.steps;
  require(st.initial_increment > 0 && st.initial_increment <= 1, "write_deck: initial increment {} (expected in (0, 1])",
          st.initial_increment);
  require(st.min_increment > 0 && st.min_increment <= st.initial_increment,
          "write_deck: minimum increment {} (expected in (0, initial increment {}])", st.min_increment, st.initial_increment);
  require(st.max_increment >= st.initial_increment && st.max_increment <= 1,
          "write_deck: maximum increment {} (expected in [initial increment {}, 1])", st.max_increment, st.initial_increment);
  require(st.max_increments > 0, "write_deck: max_increments {} (expected > 0)", st.max_increments);
  require(finite(st.donning_travel_m), "write_deck: the donning travel is not finite");
  require(std::isfinite(st.stand_travel_m), "write_deck: standing travel {} m (expected finite)", st.stand_travel_m);
  require(finite(st.load_direction) && st.load_direction.norm() > 0, "write_deck: the load direction is not a direction");
  if (s.socket) {
    const auto& sh = *s.socket;
    const int nh = static_cast<int>(sh.hexahedra.size()), nel = nh + static_cast<int>(sh.wedges.size());
    require(nel > 0 && !sh.contact_faces.empty(),
            "write_deck: the socket has {} elements and {} contact faces (expected a shell facing the stump)", nel,
            sh.contact_faces.size());
    require(!s.skin_faces.empty(), "write_deck: a socket needs the stump's skin faces (DeckSpec::skin_faces is empty)");
    for (const auto& p : sh.nodes) require(finite(p), "write_deck: a socket node has a non-finite coordinate");
    std::vector<int> used;
    for (const auto& h : sh.hexahedra) used.insert(used.end(), h.begin(), h.end());
    for (const auto& w : sh.wedges) used.insert(used.end(), w.begin(), w.end());
    for (int v : used)
      require(v >= 0 && v < static_cast<int>(sh.nodes.size()), "write_deck: a socket element uses node {} (socket has {})",
              v, sh.nodes.size());
    for (const auto& f : sh.contact_faces)  // a hexahedron has 6 faces, a wedge 5
      require(f.hexahedron >= 0 && f.hexahedron < nel && f.local_face >= 0 && f.local_face < (f.hexahedron < nh ? 6 : 5),
              "write_deck: socket contact face ({}, {}) is out of range", f.hexahedron, f.local_face);
    require(s.socket_node_displacements.empty() || s.socket_node_displacements.size() == sh.nodes.size(),
            "write_deck: {} socket node displacements for {} socket nodes", s.socket_node_displacements.size(),
            sh.nodes.size());
    for (const auto& d : s.socket_node_displacements) require(finite(d), "write_deck: a socket node displacement is not finite");
    require(s.socket_node_displacements.empty() || st.stand_travel_m == 0,
            "write_deck: a standing step needs a rigid socket (no prescribed node displacements)");
    require(s.contact.penalty_pa_per_m > 0, "write_deck: contact penalty {} Pa/m (expected > 0)", s.contact.penalty_pa_per_m);
    require(s.contact.friction >= 0, "write_deck: friction {} (expected ≥ 0)", s.contact.friction);
    require(s.contact.stick_slope_pa_per_m > 0, "write_deck: stick slope {} Pa/m (expected > 0)",
            s.contact.stick_slope_pa_per_m);
  } else {
    require(!s.nodal_forces.empty(), "write_deck: nothing loads the stump (no nodal forces and no socket)");
    require(st.stand_travel_m == 0, "write_deck: a standing step needs a socket");
  }
}

std::string static_card(const FeSteps& st) {
  return fmt::format("*STEP{}, INC={}\n*STATIC\n{:.9g}, 1., {:.9g}, {:.9g}\n", st.is_nonlinear_geometry ? ", NLGEOM" : "",
                     st.max_increments, st.initial_increment, st.min_increment, st.max_increment);
}

}  // namespace

constexpr EnumName<ElementType> kElementTypes[] = {
    {ElementType::C3D8, "C3D8"}, {ElementType::C3D8I, "C3D8I"}, {ElementType::C3D8R, "C3D8R"}};

std::string to_string(ElementType type) { return name_of(kElementTypes, type, "C3D8"); }

ElementType parse_element_type(const std::string& text) {
  std::string t = text;
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  if (const auto type = find_named(kElementTypes, t)) return *type;
  fail("element type '{}' is not known (expected c3d8, c3d8i or c3d8r)", text);
}

namespace {

/// Numbering and frames shared by the deck's parts.
struct DeckLayout {
  int nn = 0, ne = 0;                ///< stump nodes and elements
  int sock_node0 = 0, sock_elem0 = 0;  ///< first socket node and element id (1-based)
  bool rigid = false;                ///< the socket is a rigid body on a reference node
};

DeckLayout layout_of(const DeckSpec& s) {
  DeckLayout L;
  L.nn = s.stump->num_nodes();
  L.ne = s.stump->num_hexahedra();
  L.sock_node0 = L.nn + 1;
  L.sock_elem0 = L.ne + 1;
  L.rigid = s.socket && s.socket_node_displacements.empty();
  return L;
}

/// The stump's and the socket's nodes and the rigid body's reference nodes.
void write_nodes(std::string& out, const DeckSpec& s, const DeckLayout& L) {
  const auto& m = *s.stump;
  out += "*NODE, NSET=NLIMB\n";
  for (int i = 0; i < L.nn; ++i)
    out += fmt::format("{}, {:.12g}, {:.12g}, {:.12g}\n", i + 1, m.nodes[i].x(), m.nodes[i].y(), m.nodes[i].z());
  if (!s.socket) return;
  out += "*NODE, NSET=NSOCK\n";
  for (size_t i = 0; i < s.socket->nodes.size(); ++i) {
    const auto& p = s.socket->nodes[i];
    out += fmt::format("{}, {:.12g}, {:.12g}, {:.12g}\n", L.sock_node0 + static_cast<int>(i), p.x(), p.y(), p.z());
  }
  if (!L.rigid) return;
  const auto& r = s.socket->reference_point;
  out += fmt::format("*NODE, NSET=REF\n{}, {:.12g}, {:.12g}, {:.12g}\n", kRefNode, r.x(), r.y(), r.z());
  out += fmt::format("*NODE, NSET=ROT\n{}, {:.12g}, {:.12g}, {:.12g}\n", kRotNode, r.x(), r.y(), r.z());
}

/// The elements, the bone's node set, the skin's element set and the contact surfaces.
void write_elements_and_sets(std::string& out, const DeckSpec& s, const DeckLayout& L) {
  const auto& m = *s.stump;
  out += fmt::format("*ELEMENT, TYPE={}, ELSET=LIMB\n", to_string(s.element));
  for (int e = 0; e < L.ne; ++e) {
    const auto& h = m.hexahedra[e];
    out += fmt::format("{}, {}, {}, {}, {}, {}, {}, {}, {}\n", e + 1, h[0] + 1, h[1] + 1, h[2] + 1, h[3] + 1, h[4] + 1,
                       h[5] + 1, h[6] + 1, h[7] + 1);
  }
  if (s.socket) {
    const auto& sh = *s.socket;
    // One card per element type (a set named on two *ELEMENT cards gathers both).
    if (!sh.hexahedra.empty()) out += "*ELEMENT, TYPE=C3D8, ELSET=SOCKET\n";
    for (size_t e = 0; e < sh.hexahedra.size(); ++e) {
      out += fmt::format("{}", L.sock_elem0 + static_cast<int>(e));
      for (int v : sh.hexahedra[e]) out += fmt::format(", {}", L.sock_node0 + v);
      out += "\n";
    }
    if (!sh.wedges.empty()) out += "*ELEMENT, TYPE=C3D6, ELSET=SOCKET\n";
    for (size_t e = 0; e < sh.wedges.size(); ++e) {
      out += fmt::format("{}", L.sock_elem0 + static_cast<int>(sh.hexahedra.size() + e));
      for (int v : sh.wedges[e]) out += fmt::format(", {}", L.sock_node0 + v);
      out += "\n";
    }
  }
  if (!s.fixed_nodes.empty()) {
    out += "*NSET, NSET=BONE\n";
    std::vector<int> ids;
    for (int v : s.fixed_nodes) ids.push_back(v + 1);
    write_id_lines(out, ids);
  }
  if (s.socket && !s.skin_faces.empty()) {
    // Every element with a node on the skin: their stresses give the skin nodes' forces.
    std::vector<char> on_skin(m.nodes.size(), 0);
    for (const auto& f : s.skin_faces)
      for (int k = 0; k < 4; ++k) on_skin[m.hexahedra[f.hexahedron][volume::kHexFaces[f.local_face][k]]] = 1;
    std::vector<int> ids;
    for (int e = 0; e < L.ne; ++e)
      if (std::any_of(m.hexahedra[e].begin(), m.hexahedra[e].end(), [&](int v) { return on_skin[v] != 0; }))
        ids.push_back(e + 1);
    out += "*ELSET, ELSET=SKINEL\n";
    write_id_lines(out, ids);
  }
  if (!s.skin_faces.empty()) {
    out += "*SURFACE, NAME=SLIMB, TYPE=ELEMENT\n";
    for (const auto& f : s.skin_faces) out += fmt::format("{}, S{}\n", f.hexahedron + 1, f.local_face + 1);
  }
  if (s.socket) {
    out += "*SURFACE, NAME=SSOCK, TYPE=ELEMENT\n";
    for (const auto& f : s.socket->contact_faces)
      out += fmt::format("{}, S{}\n", L.sock_elem0 + f.hexahedron, f.local_face + 1);
  }
}

/// The tissue's material (its twin of the tissue model), the rigid socket and the contact pair.
void write_materials_and_contact(std::string& out, const DeckSpec& s, const DeckLayout& L) {
  const auto& mat = s.material;
  out += "*MATERIAL, NAME=TISSUE\n";
  if (mat.is_neo_hookean) {
    const double c10 = mat.youngs_modulus_pa / (4 * (1 + mat.poisson_ratio));
    const double d1 = 6 * (1 - 2 * mat.poisson_ratio) / mat.youngs_modulus_pa;
    out += fmt::format("*HYPERELASTIC, NEO HOOKE\n{:.9g}, {:.9g}\n", c10, d1);
  } else {
    out += fmt::format("*ELASTIC\n{:.9g}, {:.9g}\n", mat.youngs_modulus_pa, mat.poisson_ratio);
  }
  out += fmt::format("*DENSITY\n{:.9g}\n", mat.density_kg_m3);
  out += "*SOLID SECTION, ELSET=LIMB, MATERIAL=TISSUE\n";
  if (!s.socket) return;
  out += "*MATERIAL, NAME=RIGIDMAT\n*ELASTIC\n2e11, 0.3\n*SOLID SECTION, ELSET=SOCKET, MATERIAL=RIGIDMAT\n";
  if (L.rigid) out += fmt::format("*RIGID BODY, NSET=NSOCK, REF NODE={}, ROT NODE={}\n", kRefNode, kRotNode);
  out += "*SURFACE INTERACTION, NAME=SI\n*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR\n";
  out += fmt::format("{:.9g}, 0.1\n", s.contact.penalty_pa_per_m);
  if (s.contact.friction > 0)
    out += fmt::format("*FRICTION\n{:.9g}, {:.9g}\n", s.contact.friction, s.contact.stick_slope_pa_per_m);
  out += "*CONTACT PAIR, INTERACTION=SI, TYPE=SURFACE TO SURFACE\nSLIMB, SSOCK\n";
}

/// What every step writes: displacements, the tissue's stress, contact, reactions.
std::string step_outputs(const DeckSpec& s, const DeckLayout& L) {
  std::string o = "*NODE FILE\nU\n";
  if (s.socket) {
    // The tissue's stress: the contact pressure is read as −n·σ·n at the skin (surface_pressure.h),
    // not from CPRESS, which follows where a node sits on the socket's facets.
    o += "*EL FILE\nS\n";
    if (!s.skin_faces.empty()) o += "*EL PRINT, ELSET=SKINEL\nS\n";
    o += "*CONTACT FILE\nCDIS, CSTR\n";
    if (L.rigid) o += "*NODE PRINT, NSET=REF\nU, RF\n";
    o += "*CONTACT PRINT, SLAVE=SLIMB, MASTER=SSOCK\nCF\n";
  }
  if (!s.fixed_nodes.empty()) o += "*NODE PRINT, NSET=BONE, TOTALS=ONLY\nRF\n";
  o += "*END STEP\n";
  return o;
}

/// The rigid socket's reference node at @p displacement from its start [m] (round-off across the
/// axis written as 0), its rotation held.
void write_reference_pose(std::string& out, const Vec3& displacement) {
  for (int c = 0; c < 3; ++c) {
    const double u = std::abs(displacement[c]) < 1e-12 * displacement.norm() ? 0.0 : displacement[c];
    out += fmt::format("{}, {}, {}, {:.12g}\n", kRefNode, c + 1, c + 1, u);
  }
  out += fmt::format("{}, 1, 3\n", kRotNode);
}

/// Step 1: nodal forces, or donning under displacement control.
void write_first_step(std::string& out, const DeckSpec& s, const DeckLayout& L) {
  const auto& st = s.steps;
  out += static_card(st);
  out += "*BOUNDARY\n";
  if (!s.fixed_nodes.empty()) out += "BONE, 1, 3\n";
  for (const auto& [v, c] : s.fixed_components) out += fmt::format("{}, {}, {}\n", v + 1, c + 1, c + 1);
  if (L.rigid) write_reference_pose(out, st.donning_travel_m);
  for (size_t i = 0; i < s.socket_node_displacements.size(); ++i)
    for (int c = 0; c < 3; ++c)
      out += fmt::format("{}, {}, {}, {:.12g}\n", L.sock_node0 + static_cast<int>(i), c + 1, c + 1,
                         s.socket_node_displacements[i][c]);
  if (!s.nodal_forces.empty()) {
    out += "*CLOAD\n";
    for (const auto& [v, f] : s.nodal_forces)
      for (int c = 0; c < 3; ++c)
        if (f[c] != 0) out += fmt::format("{}, {}, {:.12g}\n", v + 1, c + 1, f[c]);
  }
  out += step_outputs(s, L);
}

/// Step 2 (standing): the reference node moved on by the standing travel along the load
/// direction; ccx's *BOUNDARY values are totals from the start, so the donning travel is in them.
void write_load_step(std::string& out, const DeckSpec& s, const DeckLayout& L) {
  const auto& st = s.steps;
  FeSteps st2 = st;
  // Displacement control is well posed: increments of a tenth or a fifth of the push (the 2k thigh
  // socket: 6 increments, 6–10 iterations each), fine enough to interpolate the standing pose.
  st2.initial_increment = 0.1;
  st2.max_increment = 0.2;
  st2.min_increment = std::min(std::max(st.min_increment, 1e-3), st2.initial_increment);
  out += static_card(st2);
  out += "*BOUNDARY, OP=NEW\n";
  if (!s.fixed_nodes.empty()) out += "BONE, 1, 3\n";
  for (const auto& [v, c] : s.fixed_components) out += fmt::format("{}, {}, {}\n", v + 1, c + 1, c + 1);
  write_reference_pose(out, st.donning_travel_m + st.stand_travel_m * st.load_direction.normalized());
  out += step_outputs(s, L);
}

}  // namespace

std::string write_deck(const DeckSpec& s) {
  check_spec(s);
  const DeckLayout L = layout_of(s);
  std::string out;
  out.reserve(static_cast<size_t>(L.nn) * 60 + static_cast<size_t>(L.ne) * 70 + 4096);
  out += fmt::format("** {}\n** written by socketsmith (calculix/calculix_deck); SI units (m, N, Pa)\n", s.title);
  write_nodes(out, s, L);
  write_elements_and_sets(out, s, L);
  write_materials_and_contact(out, s, L);
  const bool load_step = s.socket && s.steps.stand_travel_m != 0;
  write_first_step(out, s, L);
  if (load_step) write_load_step(out, s, L);
  return out;
}

std::vector<HexFace> faces_of_quads(const volume::HexMesh& mesh, const std::vector<std::array<int, 4>>& quads) {
  std::map<std::array<int, 4>, HexFace> by_nodes;
  for (const auto& b : volume::boundary_quads(mesh)) {
    auto key = b.nodes;
    std::sort(key.begin(), key.end());
    by_nodes[key] = {b.hexahedron, b.local_face};
  }
  std::vector<HexFace> faces;
  faces.reserve(quads.size());
  for (size_t k = 0; k < quads.size(); ++k) {
    auto key = quads[k];
    std::sort(key.begin(), key.end());
    const auto it = by_nodes.find(key);
    require(it != by_nodes.end(), "faces_of_quads: quad {} (nodes {}, {}, {}, {}) is not a boundary face of the mesh", k,
            quads[k][0], quads[k][1], quads[k][2], quads[k][3]);
    faces.push_back(it->second);
  }
  return faces;
}

RigidShell extrude_wall(const std::vector<Vec3>& vertices, const std::vector<std::array<int, 3>>& triangles,
                        double thickness_m) {
  require(thickness_m > 0 && std::isfinite(thickness_m), "extrude_wall: thickness {} m (expected > 0)", thickness_m);
  require(!triangles.empty(), "extrude_wall: no triangles");
  const int nv = static_cast<int>(vertices.size());
  std::vector<int> node(nv, -1);
  RigidShell sh;
  for (const auto& t : triangles)
    for (int v : t) {
      require(v >= 0 && v < nv, "extrude_wall: triangle uses vertex {} ({} vertices)", v, nv);
      require(finite(vertices[v]), "extrude_wall: vertex {} is not finite", v);
      if (node[v] < 0) {
        node[v] = static_cast<int>(sh.nodes.size());
        sh.nodes.push_back(vertices[v]);
        sh.source_points.push_back(v);
      }
    }
  Vec3 centre = Vec3::Zero();
  for (const auto& p : sh.nodes) centre += p;
  sh.reference_point = centre / static_cast<double>(sh.nodes.size());
  for (size_t k = 0; k < triangles.size(); ++k) {
    const auto& t = triangles[k];
    const Vec3 n = (vertices[t[1]] - vertices[t[0]]).cross(vertices[t[2]] - vertices[t[0]]);  // into the cavity
    require(n.norm() > 0, "extrude_wall: triangle {} has no area", k);
    // Each wedge behind its own triangle, along the triangle's normal: a right prism, never
    // inverted where the wall curves tighter than the thickness (the lip); the rigid body ties them.
    const int o = static_cast<int>(sh.nodes.size());
    for (int v : {t[0], t[2], t[1]}) sh.nodes.push_back(vertices[v] - thickness_m * n.normalized());
    // C3D6 wants 0-1-2 counter-clockwise seen from 3-4-5 (behind the wall): the triangle reversed.
    // Its face S1 then faces the cavity.
    sh.contact_faces.push_back({static_cast<int>(sh.wedges.size()), 0});
    sh.wedges.push_back({node[t[0]], node[t[2]], node[t[1]], o, o + 1, o + 2});
  }
  return sh;
}

QuadSurface subdivide_quads(const std::vector<Vec3>& points, const std::vector<Vec3>& normals,
                            const std::vector<std::array<int, 4>>& quads, int n) {
  require(points.size() == normals.size(), "subdivide_quads: {} points but {} normals", points.size(), normals.size());
  require(n >= 1, "subdivide_quads: {} divisions (expected ≥ 1)", n);
  const int np = static_cast<int>(points.size());
  QuadSurface s{points, normals, {}};
  s.quads.reserve(quads.size() * n * n);
  // A point on the edge a→b at k/n from a, keyed from the edge's lower id so both quads find it.
  std::map<std::array<int, 3>, int> on_edge;
  const auto add = [&s](const Vec3& p, const Vec3& nrm) {
    s.points.push_back(p);
    s.normals.push_back(nrm.normalized());
    return static_cast<int>(s.points.size()) - 1;
  };
  std::vector<int> id((n + 1) * (n + 1));
  for (const auto& q : quads) {
    for (int v : q) require(v >= 0 && v < np, "subdivide_quads: quad uses point {} ({} points)", v, np);
    const auto edge_point = [&](int a, int b, int k) -> int {
      if (k == 0) return a;
      if (k == n) return b;
      const std::array<int, 3> key = a < b ? std::array<int, 3>{a, b, k} : std::array<int, 3>{b, a, n - k};
      const auto it = on_edge.find(key);
      if (it != on_edge.end()) return it->second;
      const double t = static_cast<double>(k) / n;
      const int i = add((1 - t) * points[a] + t * points[b], (1 - t) * normals[a] + t * normals[b]);
      on_edge.emplace(key, i);
      return i;
    };
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        int& at = id[j * (n + 1) + i];
        if (j == 0) at = edge_point(q[0], q[1], i);
        else if (j == n) at = edge_point(q[3], q[2], i);
        else if (i == 0) at = edge_point(q[0], q[3], j);
        else if (i == n) at = edge_point(q[1], q[2], j);
        else {
          const double u = static_cast<double>(i) / n, v = static_cast<double>(j) / n;
          const double w[4] = {(1 - u) * (1 - v), u * (1 - v), u * v, (1 - u) * v};
          Vec3 p = Vec3::Zero(), nrm = Vec3::Zero();
          for (int c = 0; c < 4; ++c) {
            p += w[c] * points[q[c]];
            nrm += w[c] * normals[q[c]];
          }
          at = add(p, nrm);
        }
      }
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        s.quads.push_back({id[j * (n + 1) + i], id[j * (n + 1) + i + 1], id[(j + 1) * (n + 1) + i + 1], id[(j + 1) * (n + 1) + i]});
  }
  return s;
}

RigidShell extrude_shell(const std::vector<Vec3>& points, const std::vector<Vec3>& normals,
                         const std::vector<std::array<int, 4>>& quads, double thickness_m) {
  require(points.size() == normals.size(), "extrude_shell: {} points but {} normals", points.size(), normals.size());
  require(thickness_m > 0 && std::isfinite(thickness_m), "extrude_shell: thickness {} m (expected > 0)", thickness_m);
  require(!quads.empty(), "extrude_shell: no quads");
  const int np = static_cast<int>(points.size());
  // Only the points used by the quads become shell nodes.
  std::vector<int> inner(np, -1), source;
  RigidShell sh;
  for (const auto& q : quads)
    for (int v : q) {
      require(v >= 0 && v < np, "extrude_shell: quad uses point {} ({} points)", v, np);
      if (inner[v] < 0) {
        inner[v] = static_cast<int>(sh.nodes.size());
        sh.nodes.push_back(points[v]);
        source.push_back(v);
      }
    }
  const int ni = static_cast<int>(sh.nodes.size());
  for (int v : source) sh.nodes.push_back(points[v] + thickness_m * normals[v].normalized());
  sh.source_points = source;
  Vec3 centre = Vec3::Zero();
  for (int k = 0; k < ni; ++k) centre += sh.nodes[k];
  sh.reference_point = centre / ni;
  for (const auto& q : quads) {
    // Bottom face 0-1-2-3 counter-clockwise seen from the top (away from the body), top above it.
    volume::Hex h{inner[q[0]], inner[q[1]], inner[q[2]], inner[q[3]],
                  ni + inner[q[0]], ni + inner[q[1]], ni + inner[q[2]], ni + inner[q[3]]};
    sh.contact_faces.push_back({static_cast<int>(sh.hexahedra.size()), 0});
    sh.hexahedra.push_back(h);
  }
  return sh;
}

}  // namespace socketsmith::calculix
