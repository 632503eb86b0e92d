#pragma once
/// @file design_check.h
/// The thesis's ch. 5 FE check of a designed socket, with CalculiX: the stump (same hexahedra,
/// same ids, bones fixed) is put into the designed socket and CalculiX's contact pressure is
/// compared with the pressure socketsmith designed, node by node, on regions (whole socket, away
/// from the brim) and along the thesis's paths (front line through the patellar tendon, back
/// line, mid-stump circumference).
///
/// Two modes:
/// - Contact (the thesis's check): the socket is the designed (deformed) skin below the brim,
///   one layer of C3D8; each socket node starts `clearance_m` outside the rest skin along its
///   normal and is moved onto its designed position (a prescribed fit, step 1, NLGEOM), with
///   surface-to-surface penalty contact and friction μ. Compared: −n·σ·n of the stump's stress (or nodal CPRESS) vs designed p.
/// - Donning (the thesis's procedure, step 1 only): the designed socket as a rigid body (the
///   printed socket's inner wall when given, else one layer of C3D8 outside the designed skin;
///   tied to a reference node) starts
///   `donning_travel_m` distally along the limb axis and is pushed up by that travel under
///   displacement control. Compared as Contact.
/// - Load: the designed pressures as nodal forces p A (−n) at the designed geometry (what the
///   design solve applied), no socket. Compared: FE displacement vs socketsmith's displacement,
///   total applied force vs the bones' reaction.

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "socketsmith/calculix/calculix_deck.h"
#include "socketsmith/calculix/ccx_runner.h"
#include "socketsmith/calculix/dat_reader.h"
#include "socketsmith/calculix/standing_pose.h"
#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/report/field_comparison.h"
#include "socketsmith/volume/hex_mesher.h"

namespace socketsmith::calculix {

/// The designed state, as plain data (from the design pipeline).
struct DesignedStump {
  const volume::HexMesh* mesh = nullptr;       ///< rest stump, not owned
  const volume::SkinSurface* skin = nullptr;   ///< rest skin (node ids, quads, normals), not owned
  std::vector<int> fixed_nodes;                ///< bones and cut (mesh ids)
  geometry::LimbFrame frame;
  std::vector<Vec3> designed_positions;        ///< deformed position of every mesh node [m]
  std::vector<double> pressure_pa;             ///< designed (applied) pressure per skin node [Pa]
  std::vector<Vec3> skin_normals;              ///< deformed outward normals per skin node
  std::vector<double> skin_areas_m2;           ///< deformed nodal areas per skin node [m²]
  std::vector<char> above_brim;                ///< per skin node: above the design's brim (not compared)
  /// Per skin node: above the socket's brim (no socket there), where it differs from the design's
  /// (the closed loop raised it: pipeline::ClosedLoopOptions::max_brim_raise_m); empty: above_brim.
  std::vector<char> above_socket_brim;
  /// The socket's inner wall at each skin node [m] when it is not the designed skin (the closed
  /// loop moved it by δ along the designed normals); empty: the designed skin is the wall. The
  /// donning check's rigid socket is built on it.
  std::vector<Vec3> wall_positions;
  /// socketsmith's own contact surface, when it has one: a point near the socket's inner wall (at
  /// its designed pose) projected onto the wall socketsmith's donning and standing touch (its
  /// smoothed wall) and the outward normal there (away from the stump); nothing where the point
  /// does not face that wall. The donning check's shell is laid on it
  /// (DesignCheckOptions::shell_subdivision). Empty: the shell's quads through wall_positions are the wall.
  std::function<std::optional<std::pair<Vec3, Vec3>>(const Vec3&)> wall_surface;
  /// The printed socket's inner wall as built (cavity, brim and lip; triangles facing the cavity)
  /// at its designed pose [m]. With DesignCheckOptions::printed_wall the donning check dons this
  /// wall (C3D6 wedges on its triangles: extrude_wall) — the socket that is written — instead of a
  /// shell of C3D8 on the skin quads below the brim at wall_positions, whose rim is the quads'
  /// staircase with a sharp edge. Empty unless pipeline::designed_stump was asked for it.
  geometry::TriMesh socket_wall;
  double front_theta_rad = 0;                  ///< angle of the front line (through PT)
  double stump_length_m = 0;                   ///< for the mid-stump circumference
};

enum class DesignCheckMode { Contact, Load, Donning };

/// Which FE quantity is the contact pressure (Contact and Donning modes).
/// - NodalForce: the stump's internal force at each skin node from CalculiX's integration-point
///   stresses, over the node's area (surface_pressure.h): the same quantity as a designed pressure
///   (nodal force / nodal area), no stress extrapolation. The default: on the fe-model
///   design of OpenLimb (60 kg, 100 kPa, 3k nodes) it and the design agree with R 0.999 over the
///   socket, where −n·σ·n scatters by ±1 kPa node to node (R 0.92).
/// - SurfaceStress: −n·σ·n of the stump's nodal (extrapolated) stress on the deformed skin; the
///   donning's answer does not depend on where it started (demo, 1.8k nodes, frictionless, 30 vs
///   60 mm: R 0.997, means 9.03 / 9.06 kPa), but it extrapolates the stress to the skin.
/// - Cpress: CalculiX's nodal CPRESS (K × extrapolated penetration): follows where a skin node sits
///   on the socket's facets (the same two donnings: R 0.68, means 11.7 / 16.0 kPa; docs/validation_fe.md).
/// All three are written to comparison.csv and summarised in summary.json.
enum class FePressure { NodalForce, SurfaceStress, Cpress };
std::string to_string(FePressure what);
/// "force" | "stress" | "cpress". @throws InvalidInputError otherwise.
FePressure parse_fe_pressure(const std::string& text);
std::string to_string(DesignCheckMode mode);
/// "contact" | "load" | "donning". @throws InvalidInputError otherwise.
DesignCheckMode parse_design_check_mode(const std::string& text);

struct DesignCheckOptions {
  DesignCheckMode mode = DesignCheckMode::Contact;
  FeMaterial material;                 ///< E from the case; ν = 0.45 (thesis)
  ElementType element = ElementType::C3D8;
  FeContact contact{1e9, 0.5, 5e7};    ///< penalty 1e9 Pa/m: 20 kPa penetrates 0.02 mm
  double clearance_m = 1e-3;           ///< start of the fit outside the rest skin [m], > 0
  double socket_thickness_m = 3e-3;    ///< the rigid layer [m], > 0
  double donning_travel_m = 0.03;      ///< Donning: start this far distally along the axis [m], > 0
  /// Donning: > 0 adds the thesis's second step, standing with this force on the socket [N] (half
  /// the body weight): the socket is moved on by stand_travel_m along the axis under displacement
  /// control, and CalculiX's standing state is the one interpolated between the two increments whose
  /// reactions bracket this force (StandingPose).
  double stand_force_n = 0.0;
  /// The standing step's push past the donned pose [m], signed (> 0: further onto the stump; < 0: a
  /// socket that carries more than the load when donned comes back down), ≠ 0 with a standing force.
  /// Estimate it beyond the pose of the load (the validation: twice socketsmith's own standing travel):
  /// a push that ends short of the load, or goes the wrong way, is run once more with a travel
  /// from CalculiX's own reactions (standing_retry_travel_m).
  double stand_travel_m = 0.0;
  double initial_increment = 0.05;
  double max_increment = 0.1;
  /// A run whose compared pressure alternates node by node (alternating_skin_nodes) at this many
  /// skin nodes or more is run once more with increments half as long; 0: never. The AAOP example's
  /// closed-loop socket, in one try with 5 % increments, lost contact on some nodes of the anterior
  /// crest and put 25–32 kPa on the next where the design put a smooth 11–18 (9 such nodes), and went
  /// smooth with 2.5 %; the sample's MSS-CS design against CalculiX's continuum, where the two models
  /// part at its sharpest features, has 3 such nodes with either increment (docs/VALIDATION.md).
  int alternation_rerun_nodes = 5;
  double alternation_margin_pa = 5e3;  ///< how far a node stands out of its neighbours to count [Pa]
  FePressure fe_pressure = FePressure::NodalForce;
  /// NLGEOM (large displacements; St Venant–Kirchhoff for the linear elastic material). false: a
  /// small-strain step, the same problem as socketsmith's linear design solve.
  bool nonlinear_geometry = true;
  /// Donning: don the printed socket's inner wall (DesignedStump::socket_wall, C3D6 wedges) instead
  /// of the C3D8 shell on the skin quads below the brim. Not the default: ccx stands the 1.8k
  /// demo's socket with it, but stops in the 3k demo's donning (SPOOLES, 100k contact springs) and
  /// diverges early in OpenLimb's mean limb's (docs/VALIDATION.md, issue 20).
  bool printed_wall = false;
  /// Donning, the shell on the skin quads: each quad split n × n (calculix::subdivide_quads).
  int shell_subdivision = 1;
  /// Donning: every shell point laid on socketsmith's own contact surface (DesignedStump::wall_surface,
  /// its smoothed wall) instead of the bilinear quads through wall_positions. Not the default: on
  /// the demo's 3k closed-loop socket (with n = 2) it took CalculiX vs socketsmith from p99 6.75 to
  /// 4.53 kPa and POP from +12 to +10 %, but the distal tip from −9 to −35 % (docs/VALIDATION.md).
  bool shell_on_wall = false;
  /// Donning: also the skin quads across the brim, their points past the rim on socketsmith's lip
  /// (a rounded rim instead of the shell's sharp edge at the brim). Without shell_on_wall only the
  /// points no quad below the brim shares move; the shell below the brim keeps the skin's facets.
  bool shell_lip = false;
  CcxOptions ccx;
};

/// Per-path comparison.
struct PathComparison {
  std::string name;           ///< "front", "back", "mid"
  std::string label;          ///< "front line (through the patellar tendon)", ...
  bool is_vertical = true;
  std::vector<int> skin_index;  ///< skin nodes along the path, in order
  std::vector<double> s;        ///< path coordinate: mm (vertical) or degrees (circumference)
  report::ErrorStats stats;             ///< FE vs socketsmith on the path (Pa or m)
  report::ErrorStats smoothed;          ///< the same on the one-ring smoothed fields
};

struct DesignCheckResult {
  DesignCheckMode mode = DesignCheckMode::Contact;
  /// Compared field per skin node: pressure [Pa] (Contact) or displacement magnitude [m] (Load).
  std::vector<double> socketsmith_value, fe_value;
  std::vector<double> fe_penetration_m;   ///< −COPEN where > 0 (Contact), per skin node
  /// Contact and Donning: the three FE pressures per skin node [Pa]; fe_value is one of them (fe_pressure).
  std::vector<double> fe_cpress_pa, fe_stress_pressure_pa, fe_force_pressure_pa;
  FePressure fe_pressure = FePressure::NodalForce;  ///< the one compared
  /// Socket nodes, each FE pressure against socketsmith (whichever is compared).
  report::ErrorStats all_cpress, all_stress, all_force;
  std::vector<Vec3> fe_displacement_m;    ///< per mesh node (the compared state)
  std::vector<int> brim_ring;             ///< per skin node: rings of quads from the brim (0 = above)
  report::ErrorStats all;                         ///< socket nodes (ring ≥ 1)
  report::ErrorStats one_ring_away;               ///< ring ≥ 2
  report::ErrorStats away_from_brim;              ///< ring ≥ 4
  /// Both fields averaged over each node's one ring (area-weighted): separates the pattern from
  /// node-level scatter of nodal CPRESS (CALCULIX.md: ±40 % between formulations).
  std::vector<double> socketsmith_value_smoothed, fe_value_smoothed;
  report::ErrorStats all_smoothed, away_from_brim_smoothed;
  std::vector<PathComparison> paths;      ///< front, back, mid
  double designed_force_n = 0;            ///< |Σ p A n| of the design [N]
  double fe_force_n = 0;                  ///< |contact force| (Contact) or |bone reaction| (Load) [N]
  double mean_designed_pa = 0, mean_fe_pa = 0;  ///< over the socket nodes (Contact)
  double max_penetration_m = 0;
  int nodes = 0, elements = 0, socket_elements = 0;
  CcxRun ccx;
  std::filesystem::path deck;
  bool converged = false;
  std::string message;                    ///< ccx's message (partial results when not converged)
  // The standing step (DesignCheckOptions::stand_force_n > 0):
  bool stood = false;                     ///< CalculiX's reaction reached the standing load: compared there
  double donned_force_n = 0;              ///< CalculiX's axial reaction at the end of donning [N]
  double stand_travel_m = 0;              ///< the push of the (last) run's step 2 past the donned pose [m]
  /// CalculiX's pose at the standing load, along the axis past the designed pose [m]; when not stood,
  /// its furthest pose, where it carried stand_reached_force_n.
  double stand_offset_m = 0;
  double stand_reached_force_n = 0;       ///< the axial reaction compared [N]: the load when stood
  /// Of the socket's push on the skin along the axis (Σ f·axis over the skin nodes, f the nodal-force
  /// measure's force), the part its tangential tractions carry: friction [N] (Contact modes with the
  /// nodal-force measure; 0 without it).
  double fe_axial_force_n = 0, fe_axial_friction_n = 0;
  /// ccx runs: one more when step 1 stopped on its way (again with increments half as long), up to
  /// two more when step 2 ended short of the load (again with a travel from CalculiX's reactions).
  int ccx_runs = 0;
  /// Wall-clock seconds of every ccx run together (ccx.wall_s: the last run's alone).
  double ccx_total_wall_s = 0;
  /// Skin nodes where the compared pressure alternates node by node (alternating_skin_nodes) in the
  /// run compared, and in the first try when that asked for a rerun with shorter increments (−1: no
  /// such rerun).
  int fe_alternating_nodes = 0, fe_alternating_nodes_first_try = -1;
  std::vector<char> fe_alternating;       ///< per skin node: 1 where it alternates (Contact modes)
};

/// Skin nodes, two rings or more below the brim, where @p fe stands out of the mean of its edge
/// neighbours in @p adj (those two rings or more below the brim) by more than @p margin_pa beyond
/// what @p design does there: the node-by-node alternation of a contact solution caught between
/// two states (contact lost on some nodes of a loaded patch, a spike on the next), which no smooth
/// pressure field has. 1 for such a node, else 0.
std::vector<char> alternating_skin_nodes(const std::vector<double>& fe, const std::vector<double>& design,
                                         const std::vector<std::vector<int>>& adj, const std::vector<int>& brim_ring,
                                         double margin_pa);

/// Writes <dir>/<job>.inp, runs ccx, reads and compares. When ccx fails after some increments,
/// the last converged increment is compared and the result says so (converged = false).
/// @throws InvalidInputError for inconsistent input or a missing ccx; SolverError when ccx
///         produced no usable increment (deck and log kept in @p dir).
DesignCheckResult check_design(const DesignedStump& stump, const DesignCheckOptions& options,
                               const std::filesystem::path& dir, const std::string& job = "design");

}  // namespace socketsmith::calculix
