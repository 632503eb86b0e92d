#pragma once
/// @file calculix_deck.h
/// A flat CalculiX (Abaqus-style) input deck of socketsmith's own hexahedral stump: the same
/// nodes and hexahedra (C3D8 by default), fixed (bone) nodes, a tissue material, and either
/// nodal forces (the designed pressures as loads) or a rigid socket (one layer of solids tied to
/// a reference node) donned under displacement control with surface-to-surface penalty contact,
/// optionally followed by an axial force step. The deck follows ../shared/docs/CALCULIX.md, a deck
/// known to run with ccx 2.20 (what it accepts, what it silently ignores).
///
/// Numbering: stump node i is CalculiX node i + 1, hexahedron e is element e + 1 (same ids, so
/// results map back one to one); socket nodes and elements follow; the rigid body's reference
/// and rotation nodes are kRefNode and kRotNode.

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/volume/hex_mesh.h"

namespace socketsmith::calculix {

using Vec3 = Eigen::Vector3d;

inline constexpr int kRefNode = 900001;  ///< rigid socket's reference node (translation)
inline constexpr int kRotNode = 900002;  ///< rigid socket's rotation node

/// Element formulation of the stump (CALCULIX.md: C3D8 is the safe choice; C3D8R hourglasses
/// under contact; C3D8I is most accurate but ≈ 4× the equations).
enum class ElementType { C3D8, C3D8I, C3D8R };
std::string to_string(ElementType type);
/// "c3d8" | "c3d8i" | "c3d8r" (case-insensitive). @throws InvalidInputError otherwise.
ElementType parse_element_type(const std::string& text);

/// Tissue material of the FE stump.
struct FeMaterial {
  double youngs_modulus_pa = 100e3;  ///< E [Pa], > 0
  double poisson_ratio = 0.45;       ///< ν [-], in (-1, 0.5) (thesis's FE: 0.45)
  double density_kg_m3 = 1060.0;     ///< ρ [kg/m³], > 0
  /// true: *HYPERELASTIC, NEO HOOKE with C10 = E/(4(1+ν)), D1 = 6(1−2ν)/E (like-for-like with
  /// Abaqus at large strain); false: *ELASTIC (St Venant–Kirchhoff under NLGEOM in ccx).
  bool is_neo_hookean = false;
};

/// A face of a hexahedron: element index (0-based in its mesh) and local face (kHexFaces index;
/// CalculiX face label S(local_face + 1)).
struct HexFace {
  int hexahedron = -1;
  int local_face = -1;
};

/// A rigid socket: one layer of hexahedra (C3D8) or of wedges (C3D6, a triangulated wall), its own
/// nodes, and the faces that touch the stump.
struct RigidShell {
  std::vector<Vec3> nodes;                ///< [m]
  std::vector<volume::Hex> hexahedra;     ///< indices into nodes
  /// C3D6 wedges (indices into nodes; 0-1-2 the face on the wall, 3-4-5 behind it), numbered after
  /// the hexahedra.
  std::vector<std::array<int, 6>> wedges;
  /// Faces facing the stump: element index (hexahedra first, then wedges) and local face (0: S1).
  std::vector<HexFace> contact_faces;
  Vec3 reference_point = Vec3::Zero();    ///< reference node position [m]
  std::vector<int> source_points;         ///< extrude_shell: input point of inner node k (outer node = k + #inner)
};

/// Surface-to-surface penalty contact (CALCULIX.md: penetration = p / K).
struct FeContact {
  double penalty_pa_per_m = 2e8;   ///< K [Pa/m], > 0
  double friction = 0.0;           ///< μ [-], ≥ 0; 0 = frictionless (no *FRICTION card)
  double stick_slope_pa_per_m = 5e7;  ///< [Pa/m], > 0 (used when friction > 0)
};

/// The analysis steps. Step 1 always exists.
struct FeSteps {
  bool is_nonlinear_geometry = true;  ///< NLGEOM
  /// Donning: the socket starts displaced by −donning_travel_m and is moved back by it
  /// (displacement control of the reference node) [m]. Ignored without a socket.
  Vec3 donning_travel_m = Vec3::Zero();
  double initial_increment = 0.05;  ///< of the step time 1, in (0, 1]
  double min_increment = 1e-5;      ///< in (0, initial_increment]
  double max_increment = 0.1;       ///< in [initial_increment, 1]
  int max_increments = 1000;        ///< > 0
  /// ≠ 0: a second step (standing) moves the rigid socket's reference node this much further along
  /// load_direction [m] (> 0: further onto the stump), from where step 1 left it, under displacement
  /// control. A push under a force leaves the socket free along the axis, and ccx's contact set then
  /// chatters on a thigh socket whose walls are nearly parallel to the push (docs/VALIDATION.md); the
  /// pose where the reaction equals the standing load is read from the increments (design_check.h).
  double stand_travel_m = 0.0;
  Vec3 load_direction = Vec3::UnitZ();  ///< unit
};

/// Everything a deck holds.
struct DeckSpec {
  std::string title = "socketsmith";
  const volume::HexMesh* stump = nullptr;  ///< not owned, required
  std::vector<int> fixed_nodes;            ///< stump nodes fixed in x, y, z (bones, cut)
  /// (stump node, component 0..2) fixed: rollers, symmetry planes (frictionless supports).
  std::vector<std::array<int, 2>> fixed_components;
  std::vector<HexFace> skin_faces;         ///< stump faces of the contact (slave) surface
  FeMaterial material;
  ElementType element = ElementType::C3D8;
  std::vector<std::pair<int, Vec3>> nodal_forces;  ///< (stump node, force [N]) applied in step 1
  const RigidShell* socket = nullptr;              ///< not owned; null = no contact
  /// Non-empty (one per socket node): the socket is not a rigid body; in step 1 every socket
  /// node is moved by its vector (a prescribed fit: the shell shrinks from a clearance outside
  /// the stump onto the designed socket surface). No axial load step then.
  std::vector<Vec3> socket_node_displacements;
  FeContact contact;
  FeSteps steps;
};

/// The deck as text (SI units). Outputs: U; with a socket also the stump's stress S (*EL FILE, nodal
/// values in the .frd) for the contact pressure −n·σ·n, the integration-point stresses of the
/// elements touching the skin faces (*EL PRINT, ELSET SKINEL, in the .dat) for the nodal-force
/// pressure, contact CDIS/CSTR, the reference node's U and RF and the contact force CF.
/// @throws InvalidInputError naming the field: no stump, a node/element/face index out of range,
///         a non-finite coordinate or force, a material or step value out of range, a socket
///         without contact faces or a stump without skin faces when there is a socket, no load
///         at all (no forces and no socket).
std::string write_deck(const DeckSpec& spec);

/// Faces of @p mesh whose four nodes are the given quads (any order/rotation): maps a surface
/// given by node quads (e.g. volume::SkinSurface::quads) to element faces.
/// @throws InvalidInputError naming the first quad that is not a boundary face of the mesh.
std::vector<HexFace> faces_of_quads(const volume::HexMesh& mesh,
                                    const std::vector<std::array<int, 4>>& quads);

/// A rigid shell from a triangulated wall facing a body — a socket's inner wall as built, brim and
/// lip included, its triangles' normals pointing into the cavity (towards the body): each triangle
/// extruded by @p thickness_m away from the cavity along its own normal, a C3D6 wedge whose face S1
/// is the triangle (the wall's vertices shared, each wedge's back nodes its own: no wedge inverts
/// where the wall curves tighter than the thickness). Only the vertices the triangles use become
/// wall nodes; source_points maps them to @p vertices.
/// @throws InvalidInputError for no triangles, an index out of range, a non-finite vertex or
///         thickness ≤ 0.
RigidShell extrude_wall(const std::vector<Vec3>& vertices, const std::vector<std::array<int, 3>>& triangles,
                        double thickness_m);

/// A surface of quads split @p n × @p n: each quad's points on its bilinear patch, the points on a
/// shared edge (and the corners) shared with the neighbouring quad, the sub-quads ordered as their
/// quad. @p points' first entries are the corners' (the same ids); normals interpolated and
/// normalised. n = 1 returns the surface as given.
/// @throws InvalidInputError when sizes differ, an index is out of range, or n < 1.
struct QuadSurface {
  std::vector<Vec3> points, normals;
  std::vector<std::array<int, 4>> quads;
};
QuadSurface subdivide_quads(const std::vector<Vec3>& points, const std::vector<Vec3>& normals,
                            const std::vector<std::array<int, 4>>& quads, int n);

/// A rigid shell from a surface of quads facing a body: the quads (node ids into @p points,
/// counter-clockwise seen from the side away from the body, i.e. their normal points away from
/// the body) extruded by @p thickness_m along the per-point @p normals (away from the body).
/// The contact faces are the quads themselves (face S1 of each shell element).
/// @throws InvalidInputError when sizes differ, an index is out of range, or thickness ≤ 0.
RigidShell extrude_shell(const std::vector<Vec3>& points, const std::vector<Vec3>& normals,
                         const std::vector<std::array<int, 4>>& quads, double thickness_m);

}  // namespace socketsmith::calculix
