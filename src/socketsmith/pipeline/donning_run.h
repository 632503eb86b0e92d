#pragma once
/// @file donning_run.h
/// A whole donning run as one library call (`socketsmith simulate donning`, docs/contact.md): the
/// stump and the socket — a case designed into OUT/design with its own socket, or a limb meshed as
/// a case with default settings and a given closed socket —, socketsmith's donning with friction and
/// then the standing load, and its outputs: donning.csv, contact.csv, stump.vtu, contact_map.png
/// (and designed_map.png), donning_force.svg and donning.json with the agreement with the design.
/// And the sock-ply study of a case (`socketsmith simulate sockply`): the design, then
/// run_sock_ply_study (sock_ply.h), with the design's outputs. The CLI only turns flags into these
/// requests and prints the results.

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "socketsmith/contact/donning.h"
#include "socketsmith/core/progress.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/pipeline/sock_ply.h"

namespace socketsmith::pipeline {

/// The donned stump's tissue model.
enum class DonnedBody {
  Design,      ///< as the design solved it: linearised when its solve was linear, else nonlinear
  Linearised,  ///< linearised at rest
  Nonlinear,   ///< the nonlinear model (MSS-CS: the lattice's own Newton)
};

/// What to don and how (the flags of `simulate donning`, in SI units). Either case_file, or limb
/// and socket. The caller validates the combination and the start offset (the CLI with its flags'
/// names); run_donning refuses an inconsistent request too.
struct DonningRequest {
  std::filesystem::path case_file;  ///< design this case into OUT/design and don its socket
  std::filesystem::path limb;       ///< or mesh this limb scan as the stump ...
  std::filesystem::path socket;     ///< ... and don this closed socket solid onto it
  std::string units;                ///< of limb and socket: "mm" | "m" | "" (guessed from the size)
  int target_nodes = 0;             ///< stump size; 0: the case's
  double start_offset_m = 0.0;      ///< start this far below the designed pose [m], ≥ 0; 0: automatic
  int steps = 0;                    ///< equal displacement steps; 0: adaptive
  double max_step_m = 0.0;          ///< longest adaptive step [m]; 0: the case's (design.closed_loop_step_mm)
  double stick_stiffness_ratio = contact::DonningOptions{}.contact.stick_stiffness_ratio;
  double friction = -1.0;           ///< Coulomb μ; < 0: the case's
  double penalty_factor = 20.0;     ///< contact penalty k = factor · E / h
  int reuse_cg = -1;                ///< CG iterations before refactorising; < 0: the donning's default
  std::optional<bool> smooth_wall;  ///< the socket wall for contact; unset: DonningOptions' default
  /// No penetration of the wall (augmented Lagrangian, contact::kRigidWallAugmentedTol); also on
  /// when the case file asks it of its closed loop (design.closed_loop_rigid_wall).
  bool rigid_wall = false;
  DonnedBody body = DonnedBody::Design;
  bool stand = true;                ///< then stand with half the body weight
  ProgressCallback progress;        ///< 0–0.3 the stump (and design), 0.3–0.95 the donning, 1 done
};

/// A donning run and what it wrote.
struct DonningRun {
  contact::DonningResult donning;
  contact::DonningOptions options;  ///< as run (friction, standing force, body)
  bool has_design = false;          ///< the socket was the case's design (agreement, designed_map.png)
  nlohmann::json agreement;         ///< contact vs designed pressure (null without a design)
  nlohmann::json summary;           ///< donning.json
};

/// Runs the donning of @p request and writes its outputs into @p out (each file atomically; the
/// design, with a case, into @p out / "design"). Logs the run's settings in one line first.
/// @throws InvalidInputError for an inconsistent request or a design without a socket;
///         TopologyError for a given socket that is not closed; SolverError when the donning does
///         not complete (after the converged part is written).
DonningRun run_donning(const DonningRequest& request, const std::filesystem::path& out);

/// The last accepted step of a donning (all zero when there was none).
contact::DonningSample last_sample(const contact::DonningResult& r);

/// What to study (the flags of `simulate sockply`): a case file or the embedded demo case.
struct SockPlyRequest {
  std::filesystem::path case_file;  ///< the case to design and study; or
  bool demo = false;                ///< the embedded sample case (written as OUT/case.json)
  int target_nodes = 0;             ///< stump size; 0: the case's
  SockPlyOptions study;             ///< the volume changes etc.; its progress is set from @ref progress
  ProgressCallback progress;        ///< 0–0.15 the design, 0.15–0.98 the donnings, 1 done
};

/// A sock-ply study and its design.
struct SockPlyRun {
  std::unique_ptr<DesignSetup> setup;
  DesignResult result;    ///< result.sock_ply: the study
  nlohmann::json summary; ///< design.json (its "sock_ply" the study's)
  double seconds = 0.0;   ///< the whole run
};

/// Designs the case, runs the study and writes the design's outputs with it into @p out.
/// @throws InvalidInputError when the design has no socket (its outputs are written first) and as
///         run_sock_ply_study; SolverError as run_sock_ply_study.
SockPlyRun run_sock_ply_case(const SockPlyRequest& request, const std::filesystem::path& out);

}  // namespace socketsmith::pipeline
