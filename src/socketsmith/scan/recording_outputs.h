#pragma once
/// @file recording_outputs.h
/// The runs on recordings as `socketsmith scan simulate|reconstruct|calibrate|register` run them
/// (docs/scan.md), each one library call that runs, writes its file and returns the summary the
/// command prints with --json:
///  - simulation: a scene, or a chessboard calibration session, ray-cast from a simulated rig into
///    a recording folder;
///  - reconstruction: a recording folder, or loose depth frames of one camera, into a surface in mm;
///  - calibration: each sensor's learned error compensation from board frames, into one JSON file;
///  - registration: the rig's poses from a recording of the chessboard box, into a rig file.
/// A request holds the run's inputs and options and what its summary repeats as the user gave it
/// (paths, names of choices, the scene's description). The CLI turns flags into requests, adds
/// the wall time and prints.

#include <chrono>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "socketsmith/core/progress.h"
#include "socketsmith/scan/reconstruction.h"
#include "socketsmith/scan/recording.h"
#include "socketsmith/scan/registration.h"
#include "socketsmith/scan/sensor_calibration.h"
#include "socketsmith/scan/simulated_sensor.h"

namespace socketsmith::scan {

/// A simulated rig records a static scene, or a calibration session of the chessboard.
struct SimulationRequest {
  Scene scene;               ///< what a static session's rig looks at (centred on the rig)
  std::string scene_label;   ///< what was recorded: the summary's "scene", the end of the description
  std::vector<SimulatedSensor> sensors;
  double radius_mm = 750.0;  ///< the ring's radius as given, for the recording's description [mm]
  SimulationOptions simulation;
  /// Set: a calibration session (the board in a random pose per frame) instead of the scene; its
  /// simulation is @ref simulation.
  std::optional<CalibrationSessionOptions> board_session;
  ProgressCallback progress;
};

struct SimulationRun {
  Recording recording;     ///< as written, with its description
  nlohmann::json summary;  ///< without the wall time
};

/// Simulates the recording and writes it into @p out (rig.json with a description of the rig and
/// the scene, one folder per sensor).
/// @throws as simulate_recording / simulate_calibration_session; IoError when it cannot be written.
SimulationRun run_simulation(const SimulationRequest& request, const std::filesystem::path& out);

/// Where a reconstruction reads its depth frames: a recording folder, or loose frames of one camera.
struct ReconstructionInput {
  std::string recording;            ///< recording folder; empty: @ref frames
  std::vector<std::string> frames;  ///< 16-bit depth PNGs of one static camera (fused per pixel)
  std::string intrinsics;           ///< the frames' camera, any file read_intrinsics reads
  double depth_scale_m = 1e-3;      ///< metres per raw unit of @ref frames
  std::string rig;                  ///< rig file whose poses replace the recording's, by name; empty: none
  std::string compensation;         ///< learned models applied to every sensor they name; empty: none
};

struct ReconstructionRequest {
  ReconstructionInput input;
  /// Loose frames are a scene, not a limb along the rig's vertical: their proximal cut is off.
  ReconstructionOptions options;
  ProgressCallback progress;
  /// When the run started: the summary's reading and total times count from here.
  std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();
};

struct ReconstructionRun {
  ReconstructionResult result;
  std::size_t sensors = 0;  ///< sensors of the recording read
  nlohmann::json summary;   ///< with the stages' seconds ("timing_s")
};

/// Reads the input (compensation, recording or frames, rig file), reconstructs it and writes the
/// surface to @p out in mm (the format by its extension).
/// @throws IoError for a missing or unwritable file; as read_recording, recording_from_frames,
///         apply_rig_file and reconstruct_recording.
ReconstructionRun run_reconstruction(const ReconstructionRequest& request, const std::filesystem::path& out);

/// Each sensor of a recording of board frames learns its error compensation.
struct CalibrationRequest {
  std::string recording;       ///< the recording's folder as given, for the summary
  ChessboardPattern pattern;   ///< the board of the frames
  SensorCalibrationOptions options;
  std::string truth;           ///< the name of options.truth ("pnp", "kabsch")
  std::string model;           ///< the name of options.form ("linear", "ray-poly")
  ProgressCallback progress;
  /// Called after each sensor with what it learned and its dimension errors on the training poses.
  std::function<void(const SensorRecording&, const SensorCalibrationResult&, const TrainingDimensionErrors&)> on_sensor;
};

struct CalibrationRun {
  std::vector<ErrorCompensation> models;  ///< one a sensor, in the recording's order
  nlohmann::json summary;                 ///< without the wall time
};

/// Calibrates every sensor of @p recording and writes the models to @p out (write_compensation_json).
/// @throws as calibrate_sensor; IoError when the file cannot be written.
CalibrationRun run_calibration(const Recording& recording, const CalibrationRequest& request,
                               const std::filesystem::path& out);

/// The rig's poses registered on the boards of a box recording, from the poses it names.
struct RegistrationRequest {
  std::string recording;  ///< the box recording's folder (IR + depth frames, rig.json with "chessboard")
  BoxDetectionOptions detection;
  bool sequential = false;  ///< chain pairwise fits (the baseline) instead of the multi-set registration
  ProgressCallback progress;
};

struct RegistrationRun {
  ReferenceSet refs;
  RegistrationResult result;
  nlohmann::json summary;  ///< without the wall time
};

/// Reads the recording, finds its reference points, registers the sensors from the recording's
/// poses and writes the rig file @p out (write_rig_file, with the registration's figures).
/// @throws as read_recording and box_reference_points; IoError when the file cannot be written.
RegistrationRun run_registration(const RegistrationRequest& request, const std::filesystem::path& out);

}  // namespace socketsmith::scan
