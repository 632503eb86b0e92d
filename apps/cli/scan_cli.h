#pragma once
/// The `socketsmith scan` commands' shared pieces (apps/cli only): the flags of each subcommand,
/// their help texts, the checks and readers of flags more than one subcommand takes, and the runs.
/// Why a header: the subcommands are registered in cmd_scan.cpp, the runs that work on recordings
/// (simulate, reconstruct, calibrate, register) live in cmd_scan_recordings.cpp and the thesis's
/// experiments (limb, registration, chessboard, cylinders) in cmd_scan_experiments.cpp.

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "socketsmith/scan/sensor_calibration.h"
#include "socketsmith/scan/reconstruction.h"
#include "socketsmith/scan/registration.h"
#include "socketsmith/scan/simulated_sensor.h"

namespace socketsmith::cli::scan_cli {

/// A simulated ring rig: its sensors, their intrinsics and their error model (scan simulate, the
/// experiments).
struct RigFlags {
  int sensors = 4;
  std::uint64_t seed = 1;
  double noise_scale = 1.0;
  double systematic_scale = 1.0;
  int frames = 1;
  std::string calibration;
};

struct SimulateFlags : RigFlags {
  std::string mesh;
  std::string units;
  double cylinder_mm = -1;
  double cylinder_height_mm = 400;
  bool box = false;
  double box_yaw_deg = 45.0;
  bool chessboard = false;
  double radius_mm = 750;
  double height_mm = 0;
  int frames_per_pose = 1;
  double min_distance_mm = 550;
  double max_distance_mm = 1000;
  std::string out;
  bool json = false;
};

/// How a compensation is trained from board frames: `scan calibrate` and the experiments that
/// train one (their help texts differ, so each command registers these itself).
struct TrainingFlags {
  std::string truth = "pnp";
  std::string corner_depth = "bilinear";
  std::string model = "linear";
  int depth_degree = 3;
  bool refine_distortion = false;
};

struct CalibrateFlags : TrainingFlags {
  std::string recording;
  std::string out;
  std::string pattern;
  double square_mm = -1;
  int upsample = 2;
  int min_frames = 5;
  int frames_per_pose = 0;
  std::string fusion = "trimmed-mean";
  bool json = false;
};

/// The chessboard and cylinder experiments; their --frames are the training board poses.
struct ExperimentFlags : RigFlags, TrainingFlags {
  ExperimentFlags() { frames = 50; }
  std::string which;
  std::string out;
  int test_frames = 5;
  int scan_frames = 1;
  std::string fusion = "median";
  int board_frames_per_pose = 1;
  bool no_mesh = false;
  bool json = false;
};

struct ReconstructFlags {
  std::string recording;
  std::vector<std::string> frames;
  std::string intrinsics;
  double depth_scale = 1e-3;
  double max_depth_m = 4.5;
  std::string rig;
  std::string compensation;
  std::string out;
  bool open = false;
  bool closed = false;
  bool no_cut = false;
  int upsample = 1;
  double grid_mm = 2.5;
  int smooth = 0;
  double facet_mm = 8.0;
  std::string fusion = "median";
  bool json = false;
};

/// The simulated session of an experiment on a ring rig, with the learned models it applies.
struct SessionFlags : RigFlags {
  std::string compensation;
};

struct LimbExperimentFlags : SessionFlags {
  std::string mesh;
  std::string units;
  std::string generated;
  std::uint64_t limb_seed = 1;
  double radius_mm = 750;
  double height_mm = 0;
  double grid_mm = 2.5;
  double facet_mm = 8.0;
  int smooth = 0;
  double spacing_mm = 2.0;
  std::string fusion = "median";
  std::string out;
  bool json = false;
};

struct RegisterFlags {
  std::string recording;
  std::string out;
  bool sequential = false;
  int upsample = 2;
  std::string corner_depth = "plane";
  bool json = false;
};

struct RegistrationExperimentFlags : SessionFlags {
  std::string corner_depth = "plane";
  double box_yaw_deg = 45.0;
  double pose_error_deg = 3.0;
  double pose_error_mm = 20.0;
  std::uint64_t pose_seed = 7;
  std::string out;
  bool json = false;
};

inline constexpr const char* kSystematicScaleHelp =
    "scale of the systematic error terms only (bias, unit offsets, wiggling, radial bias, lateral scale errors), on top "
    "of --noise-scale (default 1; 0: random errors only)";

inline constexpr const char* kModelHelp =
    "error model learned: linear (the thesis: rates linear in u, v, d, default) | ray-poly (depth along the ray "
    "corrected by a polynomial in the ray's x, y and d, lateral rates linear in x, y, d)";

inline constexpr const char* kRefineDistortionHelp =
    "--truth pnp: refine the radial distortion k1, k2 with the focal lengths over the session's board frames (default: "
    "focal lengths only)";

inline constexpr const char* kDepthDegreeHelp =
    "ray-poly: highest power of d in the depth correction, 1 to 9 (default 3; 7 follows the periodic 'wiggling' error "
    "over a 0.4-1.2 m board session)";

inline constexpr const char* kCornerDepthHelp =
    "depth at each chessboard corner: plane (a robust local plane fit of the pixels within 6 px, default) | bilinear "
    "(the thesis: its 4 neighbouring pixels)";

// Shared checks and readers (cmd_scan_common.cpp).

/// The simulated units' error model of --noise-scale and --systematic-scale.
scan::SensorErrorModel error_model(double noise_scale, double systematic_scale, const char* cmd);
/// The --seed, --noise-scale, --systematic-scale and --frames flags of a simulated rig (scan
/// simulate and the experiments' sessions).
void add_simulated_error_flags(CLI::App& cmd, std::uint64_t& seed, double& noise_scale, double& systematic_scale,
                               int& frames);
/// The --sensors, --seed, --noise-scale, --systematic-scale, --frames, --calibration and
/// --compensation flags of an experiment's simulated session.
void add_session_flags(CLI::App& cmd, SessionFlags& f, const std::string& compensation_help);
/// The --model, --depth-degree and --refine-distortion flags of a learned error compensation
/// (scan calibrate and the board experiments).
void add_compensation_form_flags(CLI::App& cmd, std::string& model, int& depth_degree, bool& refine_distortion);
/// The --grid-mm, --facet-mm and --smooth flags of a Poisson reconstruction (scan reconstruct and
/// the limb experiment).
void add_surface_flags(CLI::App& cmd, double& grid_mm, double& facet_mm, int& smooth);
/// Seconds since @p t0.
double elapsed_s(std::chrono::steady_clock::time_point t0);
/// A scan command's summary @p j gets its wall time since @p t0 ("wall_s") and, with --json
/// (@p as_json), is printed on stdout. True when printed: the command then logs nothing.
bool print_summary_json(nlohmann::json& j, std::chrono::steady_clock::time_point t0, bool as_json);
/// Intrinsics for the simulated rig: --calibration is an iai_kinect2 root (one serial folder per
/// sensor, in name order, reused cyclically), a serial folder, or a calib_ir.yaml.
std::vector<scan::CameraIntrinsics> rig_intrinsics(const std::string& calibration, int sensors);
/// The learned models of sensors K1…Kn of a simulated ring rig (scan calibrate / scan experiment
/// chessboard output), or none when @p path is empty.
std::vector<scan::ErrorCompensation> ring_compensation(const std::string& path, int sensors,
                                                       const std::vector<scan::CameraIntrinsics>& intrinsics);
scan::CompensationForm parse_model(const std::string& name, const char* cmd);
scan::CornerDepth parse_corner_depth(const std::string& name, const char* cmd);
scan::TruthEstimate parse_truth(const std::string& t, const char* cmd);

// The runs on recordings (cmd_scan_recordings.cpp).
void run_simulate(const SimulateFlags& f);
void run_reconstruct(const ReconstructFlags& f);
void run_calibrate(const CalibrateFlags& f);
void run_register(const RegisterFlags& f);

// The thesis's experiments (cmd_scan_experiments.cpp).
void run_limb_experiment(const LimbExperimentFlags& f);
void run_registration_experiment(const RegistrationExperimentFlags& f);
void run_experiment(const ExperimentFlags& f);

}  // namespace socketsmith::cli::scan_cli
