#pragma once
/// @file case_file.h
/// The case file: one JSON document describing a whole socket design job (docs/case_file.md).
/// In the file, angles are in degrees, lengths in mm, pressures in kPa, masses in kg; inside
/// socketsmith everything is SI. Relative paths are relative to the case file's folder. Unknown
/// keys are errors (a misspelt key would otherwise be silently ignored).

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "socketsmith/design/brim.h"
#include "socketsmith/design/design_solver.h"
#include "socketsmith/design/optimizer.h"
#include "socketsmith/design/pain_map.h"
#include "socketsmith/design/socket_builder.h"
#include "socketsmith/design/spots.h"

namespace socketsmith::design {

/// Where the limb comes from: a file (with optional bones) or the generator (the sample).
struct CaseLimb {
  std::string file;                        ///< STL/OBJ/PLY/AOP; "" = generate
  std::string bones = "auto";              ///< auto (shells of the file) | estimate | none | a file
  std::string units;                       ///< mm | m | "" (guess from the size)
  /// Multiplies the coordinates after the units (a normalised shape: its reference length in the
  /// units, e.g. 0.45 with units m for an OpenLimb TF shape normalised to a 0.45 m femur), (0, 1e4].
  double scale = 1.0;
  geometry::LimbType type = geometry::LimbType::Transtibial;
  std::optional<geometry::Side> side;
  std::optional<Eigen::Vector3d> anterior; ///< world direction of the front
  std::optional<Eigen::Vector3d> axis;     ///< world direction of the long axis (the femur's or the skin's otherwise)
  std::optional<double> cut_height_m;      ///< proximal cut above the distal end [m]
  /// Accept a limb whose size is outside the anatomical range of its type (volume::check_limb_size).
  bool force_size = false;
  std::uint64_t generate_seed = 1;         ///< when file is empty
};

struct CaseFile {
  std::filesystem::path folder;            ///< relative paths are resolved against this
  CaseLimb limb;
  // Patient
  std::string patient_id;
  std::string patient_note;
  PatientLoad patient;
  ThresholdTable thresholds;               ///< [Pa]; empty = the limb type's defaults
  // Tissue model
  /// neo-hookean (default: measured end to end against CalculiX, docs/design.md "Which tissue
  /// model is the default") | mss-cs | mss-cf | mss | fe
  std::string model = "neo-hookean";
  /// Poisson ratio of the fe model (default 0.45) or MSS-CF's target (default 0.49); not set =
  /// the model's default. MSS and MSS-CS have none of their own (their lattice's is 1/4).
  std::optional<double> poisson_ratio;
  std::string constants = "cube-targets";  ///< cube-targets | recommended | thesis | cube-fit
  /// The hexahedra's integration: c3d8 (CalculiX's C3D8, the default) | fbar (F-bar, neo-hookean
  /// only: no volumetric locking; docs/tissue.md, "Locking").
  tissue::HexFormulation element = tissue::HexFormulation::Full;
  double youngs_modulus_pa = 100e3;
  double density_kg_m3 = 1060.0;
  /// The model's own when the case file does not say (default_solve_mode): nonlinear for
  /// neo-hookean, linear for the lattices and fe, which collapse on the thin tissue over bone.
  DesignSolveMode solve_mode = DesignSolveMode::Nonlinear;
  int target_nodes = 8000;
  // Landmarks moved by the user (world positions [m], projected onto the skin)
  std::map<std::string, Eigen::Vector3d> landmarks;
  // Design
  std::vector<Spot> spots;                 ///< empty = the default layout of the limb type
  bool optimise = true;
  OptimizerOptions::Objective objective = OptimizerOptions::Objective::Pressure;
  double model_pressure_limit = 0.25;      ///< × E (see OptimizerOptions)
  /// Transfemoral: the least share of the axial load on the ischial/gluteal region the optimiser
  /// keeps, [0, 0.9]; not given: the brim template's (default_ischial_share).
  std::optional<double> ischial_share_min;
  /// The optimiser aims at what the brim template means (design/template_regions.h): PTB family —
  /// the tolerant regions' mean pressure ≥ 1.5 × the sensitive ones', the distal fifth ≤ 10 % of
  /// the axial load. false: only the seven constraints and the most even pressure.
  bool follow_template = true;
  double time_limit_s = 0.0;               ///< the optimiser's wall-time bound [s]; 0 = none
  /// Closed-loop design (pipeline/closed_loop.h): don and stand on the socket, correct its wall
  /// until it delivers the designed pressures, write the corrected socket. Not given: on, for both
  /// levels (closes_loop; docs/design.md, "Closed loop").
  std::optional<bool> closed_loop;
  int closed_loop_donnings = 4;            ///< donnings at most, the open-loop socket's included, 1–20
  /// How far the closed loop may raise the socket's brim above the design's where donning drags
  /// skin designed below it out of the socket [m], 0–0.05; 0 (the default): never — the brim is the
  /// prosthetist's line (e.g. low posteriorly for knee flexion). pipeline::ClosedLoopOptions::max_brim_raise_m.
  double closed_loop_max_brim_raise_m = 0.0;
  /// The closed loop's largest node-scale wall correction [m], 0–0.005; 0 (the default): no cap.
  /// pipeline::ClosedLoopOptions::max_roughness_m.
  double closed_loop_max_roughness_m = 0.0;
  /// The longest step of the closed loop's donning path [m], 0.002–0.02; the default is
  /// contact::DonningOptions::step_m's (a test keeps the two equal). docs/design.md, "Closed loop".
  double closed_loop_step_m = 0.006;
  /// A flared brim [m], 0–0.05: the designed pressure eases to nothing over this distance below the
  /// brim (DesignSolver::set_brim_flare); 0: the spots' pressure up to the brim. Not given: the
  /// limb type's (brim_flare_m()).
  std::optional<double> brim_flare_m;
  /// The closed loop's donnings — and the case's other donnings of its socket (`simulate donning
  /// --case`, `validate design`) — against a wall the skin does not penetrate (augmented Lagrangian
  /// contact, ContactOptions::augmented_tol) instead of the penalty's ~60 µm at 15 kPa: the
  /// pressures a rigid socket delivers, ~1.5× the loop's time (docs/contact.md, "Penetration").
  bool closed_loop_rigid_wall = false;
  /// When the closed loop's socket misses the delivery bar and donning dragged skin designed to
  /// bear more than 1 kPa out of it over the brim, design again asking no pressure of a band below
  /// the brim there (DesignSolver::set_brim_band) and keep the design whose socket delivers it
  /// better (pipeline::solve_design). false: the design as asked, whatever donning drags out.
  bool closed_loop_drag_band = true;
  /// The brim template; not given: the limb type's (default_brim: PTB transtibial, ICS transfemoral).
  std::optional<BrimTemplate> brim;
  std::vector<BrimKeyPoint> brim_key_points;  ///< non-empty = the user's brim (overrides the template)
  SocketOptions socket;
};

/// The limb's directions: `limb.axis` (the long axis, distal to proximal) and `limb.anterior`
/// (the front). The case file and the command line's `--axis` / `--anterior` (`design`, `run`,
/// `mesh`) check them with the two functions below, so both refuse the same values in the same words.
enum class LimbDirection { Axis, Anterior };

/// Checks a limb direction: finite, not the zero vector (its length does not matter).
/// @param where names the value at the start of the message: "case file: 'limb.axis'",
///        "design --axis '0,0,0'".
/// @throws InvalidInputError with one line: "<where> is the zero vector (give the long axis, distal
///         to proximal, e.g. 0,0,1)".
Eigen::Vector3d check_limb_direction(const Eigen::Vector3d& v, LimbDirection which, const std::string& where);

/// A limb direction from command-line text "x,y,z" (spaces allowed), then check_limb_direction.
/// @param flag names the flag in the message: "design --axis".
/// @throws InvalidInputError: "design --axis '0,0' is not a direction x,y,z (the long axis, distal
///         to proximal, e.g. 0,0,1)", or the zero-vector line.
Eigen::Vector3d parse_limb_direction(const std::string& text, LimbDirection which, const std::string& flag);

/// Parses a case document. @p folder resolves relative paths.
/// @throws InvalidInputError with one line naming the key and the fix (unknown key, wrong type,
///         negative mass, thickness ≤ 0, ...).
/// The design solve a tissue model gets when the case file names no `tissue.solve`: nonlinear
/// for neo-hookean, linear for the others (docs/design.md, "Design solve").
DesignSolveMode default_solve_mode(const std::string& model);

CaseFile parse_case(const nlohmann::json& doc, const std::filesystem::path& folder = {});

/// Reads and parses a case file. @throws IoError when it cannot be read, InvalidInputError when it
/// is not JSON or not a valid case.
CaseFile read_case(const std::filesystem::path& path);

/// The case as JSON in file units (the inverse of parse_case for every field it holds).
nlohmann::json case_to_json(const CaseFile& c);

/// Writes the case atomically (temporary file + rename).
void write_case(const std::filesystem::path& path, const CaseFile& c);

/// Spot ↔ JSON in file units (degrees, mm, kPa).
nlohmann::json spot_to_json(const Spot& s);
Spot spot_from_json(const nlohmann::json& j, const std::string& where);

/// Absolute path of a file named in the case.
std::filesystem::path resolve(const CaseFile& c, const std::string& file);

/// Whether the design closes the loop (pipeline/closed_loop.h): `design.closed_loop` when the case
/// gives it, else true for a transtibial limb (docs/design.md, "Closed loop": the socket written
/// then delivers its design) and false for a transfemoral one (its donning is not validated).
bool closes_loop(const CaseFile& c);

/// The brim's flare [m]: `design.brim_flare_mm` when the case gives it, else 5 mm for a
/// transtibial limb — a trim line presses nothing at its edge, and the skin that donning drags
/// up to 3–5 mm over the brim then takes the pressure it was designed for (docs/design.md, "Nodes
/// dragged out of the socket") — and 0 for a transfemoral one, whose ischial seat is its brim.
double brim_flare_m(const CaseFile& c);

}  // namespace socketsmith::design
