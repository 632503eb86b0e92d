#pragma once
/// @file experiment_outputs.h
/// The thesis's scan experiments as `socketsmith scan experiment` runs them (docs/scan.md), each
/// one library call that runs the experiment and writes its files and report:
///  - limb: the simulated recording, the reconstruction and the centred original as STL (mm), and
///    report.json with the surface distances (run_limb_scan_experiment, accuracy.h);
///  - registration: the box recording (rig.json with the hand-measured poses), the true,
///    multi-set and sequential rig files and report.json (Table 4; run_registration_experiment,
///    registration.h);
///  - chessboard and cylinders: compensation.json (the models learned) and chessboard.json or
///    cylinders.json (Table 3, the cylinders' errors; experiments.h).
/// A request holds the experiment's options and what its report repeats as the user gave it (the
/// calibration and compensation files, names of choices, the command line). The CLI turns flags
/// into requests and prints the summary.

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "socketsmith/core/progress.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/scan/accuracy.h"
#include "socketsmith/scan/experiments.h"
#include "socketsmith/scan/registration.h"

namespace socketsmith::scan {

/// The rig's intrinsics and the applied compensation as the report names them.
struct ExperimentSources {
  std::string calibration;   ///< the iai_kinect2 calibration given; empty: typical Kinect v2 intrinsics
  std::string compensation;  ///< the learned models' file; empty: none (options.compensation empty too)
};

/// A limb scanned by a simulated ring rig, reconstructed and measured.
struct LimbExperimentRequest {
  geometry::TriMesh limb;  ///< [m], long axis along +z, proximal end up
  std::string limb_label;  ///< what the limb is, for the report and the recording's description
  LimbScanOptions options;
  ExperimentSources sources;
  ProgressCallback progress;
  /// When the run started: the report's total time counts from here (reading the limb included).
  std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();
};

struct LimbExperimentRun {
  LimbScanResult result;
  nlohmann::json report;  ///< report.json
};

/// Runs run_limb_scan_experiment and writes into @p out (created): recording/ (with a description
/// of the run), reconstruction.stl and original_centred.stl in mm, report.json.
/// @throws as run_limb_scan_experiment; IoError when a file cannot be written.
LimbExperimentRun run_limb_experiment(const LimbExperimentRequest& request, const std::filesystem::path& out);

/// Table 4 on a simulated registration box.
struct RegistrationExperimentRequest {
  RegistrationExperimentOptions options;
  ExperimentSources sources;
  std::string corner_depth;  ///< the name of options.detection.chessboard.corner_depth ("plane", "bilinear")
  double pose_error_mm = 20.0;  ///< options.pose_error_m as given [mm]
  ProgressCallback progress;
  std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();  ///< the report's wall time counts from here
};

struct RegistrationExperimentRun {
  RegistrationExperimentResult result;
  nlohmann::json report;  ///< report.json
};

/// Runs run_registration_experiment and writes into @p out (created): box_recording/ (its rig.json
/// with the hand-measured poses), rig_true.json, rig_multiset.json, rig_sequential.json and
/// report.json (with the compensated rows when the request has a compensation).
/// @throws as run_registration_experiment; IoError when a file cannot be written.
RegistrationExperimentRun run_registration_experiment(const RegistrationExperimentRequest& request,
                                                      const std::filesystem::path& out);

/// The chessboard experiment, and with @ref cylinders the cylinder experiment after it.
struct BoardExperimentRequest {
  ExperimentOptions options;
  bool cylinders = false;          ///< also scan the 10, 16 and 21 cm cylinders
  bool reconstruct_meshes = true;  ///< cylinders: reconstruct and measure the meshes too
  std::string command;             ///< the command line the report repeats
  std::string truth;               ///< the name of options.truth ("pnp", "kabsch")
  ExperimentSources sources;       ///< the calibration (the board experiments apply no compensation)
  ProgressCallback progress;
  std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();  ///< the report's wall time counts from here
};

struct BoardExperimentRun {
  ChessboardExperiment chessboard;
  std::optional<CylinderExperiment> cylinders;
  nlohmann::json report;  ///< chessboard.json or cylinders.json
};

/// Creates @p out, runs run_chessboard_experiment and writes compensation.json (each sensor's
/// learned model), then with request.cylinders runs run_cylinder_experiment, and writes the report
/// as chessboard.json or cylinders.json.
/// @throws as the experiments; IoError when a file cannot be written.
BoardExperimentRun run_board_experiment(const BoardExperimentRequest& request, const std::filesystem::path& out);

}  // namespace socketsmith::scan
