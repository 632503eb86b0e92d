// `socketsmith scan simulate` (a simulated Kinect v2 rig writes a recording folder) and
// `socketsmith scan reconstruct` (a recording folder becomes a watertight limb surface in mm).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <memory>

#include "cli_common.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/progress.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/core/atomic_file.h"
#include "socketsmith/scan/accuracy.h"
#include "socketsmith/scan/calibration.h"
#include "socketsmith/scan/experiments.h"
#include "socketsmith/scan/reconstruction.h"
#include "socketsmith/scan/registration.h"
#include "socketsmith/scan/simulated_sensor.h"
#include "socketsmith/volume/limb_generator.h"

namespace socketsmith::cli {
namespace {
namespace fs = std::filesystem;

struct SimulateFlags {
  std::string mesh;
  std::string units;
  double cylinder_mm = -1;
  double cylinder_height_mm = 400;
  bool box = false;
  double box_yaw_deg = 45.0;
  bool chessboard = false;
  int sensors = 4;
  double radius_mm = 750;
  double height_mm = 0;
  std::uint64_t seed = 1;
  double noise_scale = 1.0;
  double systematic_scale = 1.0;
  int frames = 1;
  int frames_per_pose = 1;
  double min_distance_mm = 550;
  double max_distance_mm = 1000;
  std::string calibration;
  std::string out;
  bool json = false;
};

struct CalibrateFlags {
  std::string recording;
  std::string out;
  std::string pattern;
  double square_mm = -1;
  std::string truth = "pnp";
  int upsample = 2;
  int min_frames = 5;
  std::string corner_depth = "bilinear";
  std::string model = "linear";
  int depth_degree = 3;
  bool refine_distortion = false;
  int frames_per_pose = 0;
  std::string fusion = "trimmed-mean";
  bool json = false;
};

struct ExperimentFlags {
  std::string which;
  std::string out;
  std::uint64_t seed = 1;
  int sensors = 4;
  int frames = 50;
  int test_frames = 5;
  double noise_scale = 1.0;
  double systematic_scale = 1.0;
  std::string calibration;
  std::string corner_depth = "bilinear";
  std::string model = "linear";
  int depth_degree = 3;
  bool refine_distortion = false;
  int scan_frames = 1;
  std::string fusion = "median";
  int board_frames_per_pose = 1;
  std::string truth = "pnp";
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

/// The simulated session of an experiment: the ring's sensors and their error model.
struct SessionFlags {
  int sensors = 4;
  std::uint64_t seed = 1;
  double noise_scale = 1.0;
  double systematic_scale = 1.0;
  int frames = 1;
  std::string calibration;
  std::string compensation;
};

constexpr const char* kSystematicScaleHelp =
    "scale of the systematic error terms only (bias, unit offsets, wiggling, radial bias, lateral scale errors), on top "
    "of --noise-scale (default 1; 0: random errors only)";

/// The simulated units' error model of --noise-scale and --systematic-scale.
scan::SensorErrorModel error_model(double noise_scale, double systematic_scale, const char* cmd) {
  require(std::isfinite(noise_scale) && noise_scale >= 0.0,
          "{}: --noise-scale {} must be >= 0 (0: noise free, 1: default Kinect v2 errors)", cmd, noise_scale);
  require(std::isfinite(systematic_scale) && systematic_scale >= 0.0,
          "{}: --systematic-scale {} must be >= 0 (0: random errors only)", cmd, systematic_scale);
  scan::SensorErrorModel m = scan::scale_systematic_errors(scan::SensorErrorModel{}, systematic_scale);
  m.scale = noise_scale;
  return m;
}

void add_session_flags(CLI::App& cmd, SessionFlags& f, const std::string& compensation_help) {
  cmd.add_option("--sensors", f.sensors, "number of sensors on the ring (default 4)");
  cmd.add_option("--seed", f.seed, "seed of the error model (default 1)");
  cmd.add_option("--noise-scale", f.noise_scale, "scale of every error term (0: noise free; default 1)");
  cmd.add_option("--systematic-scale", f.systematic_scale, kSystematicScaleHelp);
  cmd.add_option("--frames", f.frames, "frames per sensor (default 1)");
  cmd.add_option("--calibration", f.calibration, "iai_kinect2 calibration folder(s), as for scan simulate");
  cmd.add_option("--compensation", f.compensation, compensation_help);
}

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

double elapsed_s(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Intrinsics for the simulated rig: --calibration is an iai_kinect2 root (one serial folder per
/// sensor, in name order, reused cyclically), a serial folder, or a calib_ir.yaml.
std::vector<scan::CameraIntrinsics> rig_intrinsics(const std::string& calibration, int sensors) {
  if (calibration.empty()) return {};
  const fs::path p(calibration);
  if (!fs::exists(p))
    fail<IoError>("scan simulate: --calibration '{}' not found (expected an iai_kinect2 folder with calib_ir.yaml, or "
                  "a folder of such folders)",
                  calibration);
  if (!fs::is_directory(p) || fs::exists(p / "calib_ir.yaml")) return {scan::read_kinect2_calibration(p)};
  std::vector<fs::path> serials;
  for (const auto& e : fs::directory_iterator(p))
    if (e.is_directory() && fs::exists(e.path() / "calib_ir.yaml")) serials.push_back(e.path());
  std::sort(serials.begin(), serials.end());
  require(!serials.empty(), "scan simulate: --calibration '{}' holds no calib_ir.yaml (expected iai_kinect2 folders)",
          calibration);
  std::vector<scan::CameraIntrinsics> out;
  for (int i = 0; i < sensors; ++i) out.push_back(scan::read_kinect2_calibration(serials[static_cast<size_t>(i) % serials.size()]));
  return out;
}

void run_simulate(const SimulateFlags& f) {
  const auto t0 = std::chrono::steady_clock::now();
  const int scenes = (f.mesh.empty() ? 0 : 1) + (f.cylinder_mm > 0 ? 1 : 0) + (f.box ? 1 : 0) + (f.chessboard ? 1 : 0);
  require(scenes == 1,
          "scan simulate: give exactly one scene: --mesh FILE, --cylinder-mm D, --box or --chessboard ({} given)",
          scenes);
  require(f.sensors >= 1 && f.sensors <= 32, "scan simulate: --sensors {} is out of range (expected 1 to 32)",
          f.sensors);
  const scan::SensorErrorModel error = error_model(f.noise_scale, f.systematic_scale, "scan simulate");
  scan::Scene scene;
  std::string what;
  if (!f.mesh.empty()) {
    geometry::MeshReadOptions ro;
    if (!f.units.empty()) ro.unit = units::parse_length_unit(f.units);
    scene.mesh = geometry::read_mesh(f.mesh, ro);
    const geometry::Vec3 c = geometry::bounding_box(scene.mesh).center();
    for (auto& v : scene.mesh.vertices) v -= c;  // the rig looks at the origin
    what = fmt::format("mesh '{}' centred at the rig's centre", f.mesh);
  } else if (f.cylinder_mm > 0) {
    require(std::isfinite(f.cylinder_mm) && f.cylinder_mm <= 1000 && f.cylinder_height_mm > 0,
            "scan simulate: --cylinder-mm {} is not a plausible diameter (expected 10 to 1000 mm)", f.cylinder_mm);
    scene.mesh = scan::make_cylinder(f.cylinder_mm * units::mm, f.cylinder_height_mm * units::mm);
    what = fmt::format("cylinder of diameter {:g} mm, height {:g} mm, axis z", f.cylinder_mm, f.cylinder_height_mm);
  } else if (f.box) {
    require(std::isfinite(f.box_yaw_deg), "scan simulate: --box-yaw-deg must be a number");
    scene = scan::make_box_scene(geometry::Vec3(0.30, 0.30, 0.70),
                                 Eigen::Isometry3d(Eigen::AngleAxisd(f.box_yaw_deg * M_PI / 180.0, geometry::Vec3::UnitZ())));
    what = fmt::format("box 300 x 300 x 700 mm turned {:g} deg about the vertical, with a 4 x 11 inner-corner "
                       "chessboard of 50 mm squares on each side",
                       f.box_yaw_deg);
  } else {
    what = fmt::format("calibration chessboard (9 x 6 inner corners, 60 mm squares) in a random pose per frame at "
                       "{:g}-{:g} mm from each sensor",
                       f.min_distance_mm, f.max_distance_mm);
  }
  const auto sensors = scan::default_rig(f.sensors, f.radius_mm * units::mm, f.height_mm * units::mm,
                                         geometry::Vec3::Zero(), rig_intrinsics(f.calibration, f.sensors));
  scan::SimulationOptions so;
  so.seed = f.seed;
  so.frames = f.frames;
  so.error = error;
  const auto progress = f.json ? ProgressCallback{} : console_progress(1.0);
  scan::Recording rec;
  if (f.chessboard) {
    scan::CalibrationSessionOptions co;
    co.simulation = so;
    co.min_distance_m = f.min_distance_mm * units::mm;
    co.max_distance_m = f.max_distance_mm * units::mm;
    co.frames_per_pose = f.frames_per_pose;
    rec = scan::simulate_calibration_session(sensors, co, progress);
  } else {
    require(f.frames_per_pose == 1, "scan simulate: --frames-per-pose is for --chessboard sessions (a static scene's "
                                    "frames are all of one pose: use --frames)");
    rec = scan::simulate_recording(scene, sensors, so, progress);
  }
  scan::Recording named = rec;
  named.description = fmt::format("simulated Kinect v2 rig ({} sensors, radius {:g} mm, seed {}, noise scale {:g}): {}",
                                  f.sensors, f.radius_mm, f.seed, f.noise_scale, what);
  scan::write_recording(f.out, named);
  nlohmann::json j;
  j["command"] = "socketsmith scan simulate";
  j["recording"] = f.out;
  j["scene"] = what;
  j["seed"] = f.seed;
  j["noise_scale"] = f.noise_scale;
  nlohmann::json js = nlohmann::json::array();
  std::string summary;
  for (const auto& s : rec.sensors) {
    const int valid = s.frames.front().count_valid();
    js.push_back({{"name", s.name}, {"valid_pixels", valid}, {"frames", s.frames.size()}});
    summary += fmt::format("{}{} {} px", summary.empty() ? "" : ", ", s.name, valid);
  }
  j["sensors"] = js;
  j["wall_s"] = elapsed_s(t0);
  if (f.json) {
    print_json(j);
    return;
  }
  log::info("simulated {} sensor(s) x {} frame(s) of the {}; valid pixels: {}; wrote recording '{}' in {:.2f} s.",
            f.sensors, f.frames, what, summary, f.out, elapsed_s(t0));
}

void run_reconstruct(const ReconstructFlags& f) {
  const auto t0 = std::chrono::steady_clock::now();
  const fs::path out(f.out);
  std::string ext = out.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  require(ext == ".stl" || ext == ".obj" || ext == ".ply" || ext == ".aop",
          "scan reconstruct: --out '{}' has extension '{}' (expected .stl, .obj, .ply or .aop)", f.out, ext);
  scan::ReconstructionOptions o;
  o.back_projection.upsample = f.upsample;
  o.back_projection.fusion = scan::parse_frame_fusion(f.fusion, "scan reconstruct: --fusion");
  o.grid_cell_m = f.grid_mm * units::mm;
  o.smoothing_iterations = f.smooth;
  o.max_facet_m = f.facet_mm * units::mm;
  o.open_proximal = f.open;
  o.cut_proximal = !f.no_cut;
  const auto progress = f.json ? ProgressCallback{} : console_progress(1.0);
  report_progress(progress, 0.0, "reading the recording");
  require(f.recording.empty() != f.frames.empty(),
          "scan reconstruct: give a recording folder or --frame DEPTH.png --intrinsics FILE (not both, not neither)");
  require(f.frames.empty() || !f.intrinsics.empty(),
          "scan reconstruct: --frame needs --intrinsics (the camera's intrinsics.json, Open3D camera json or "
          "calib_ir.yaml)");
  require(f.intrinsics.empty() || !f.frames.empty(),
          "scan reconstruct: --intrinsics is for --frame (a recording folder names its intrinsics in rig.json)");
  std::vector<fs::path> frame_paths(f.frames.begin(), f.frames.end());
  std::vector<scan::ErrorCompensation> models;
  if (!f.compensation.empty()) models = scan::read_compensation_json(f.compensation);
  scan::Recording rec = f.frames.empty() ? scan::read_recording(f.recording)
                                               : scan::recording_from_frames(frame_paths, f.intrinsics, f.depth_scale);
  if (!f.rig.empty()) scan::apply_rig_file(rec, f.rig);
  for (auto& s : rec.sensors)
    if (!models.empty())
      s.compensation = scan::compensation_for(models, s.name, s.intrinsics.width, s.intrinsics.height, f.compensation);
  // Loose frames of one camera are a scene, not a limb hanging along the rig's vertical: no cut.
  if (!f.frames.empty()) o.cut_proximal = false;
  o.back_projection.max_depth_m = f.max_depth_m;
  const double read_s = elapsed_s(t0);
  const scan::ReconstructionResult r = scan::reconstruct_recording(rec, o, progress);
  const auto t_write = std::chrono::steady_clock::now();
  geometry::write_mesh(out, r.mesh, units::LengthUnit::Millimetre);
  const double write_s = elapsed_s(t_write);
  const double wall_s = elapsed_s(t0);
  const bool watertight = r.check.is_valid_closed_surface();
  nlohmann::json j;
  j["command"] = "socketsmith scan reconstruct";
  j["recording"] = f.frames.empty() ? nlohmann::json(f.recording) : nlohmann::json(f.frames);
  j["output"] = f.out;
  j["sensors"] = rec.sensors.size();
  j["compensated_sensors"] = std::count_if(rec.sensors.begin(), rec.sensors.end(), [](const auto& s) { return s.compensation.has_value(); });
  j["input_points"] = r.input_points;
  j["outliers_removed"] = r.outliers_removed;
  j["poisson_points"] = r.poisson_points;
  j["average_spacing_mm"] = r.average_spacing_m / units::mm;
  j["points_per_sensor"] = r.points_per_sensor;
  j["overlap_per_sensor"] = r.overlap_per_sensor;
  j["vertices"] = r.mesh.num_vertices();
  j["triangles"] = r.mesh.num_triangles();
  j["boundary_loops"] = r.check.boundary_loops;
  j["watertight"] = watertight;
  j["volume_ml"] = watertight ? r.check.signed_volume_m3 * 1e6 : 0.0;
  j["timing_s"] = {{"read", read_s},
                   {"back_projection", r.back_projection_s},
                   {"overlap_check", r.overlap_s},
                   {"outliers", r.outliers_s},
                   {"simplification", r.simplify_s},
                   {"spacing", r.spacing_s},
                   {"poisson", r.poisson_s},
                   {"poisson_implicit_function", r.poisson_implicit_s},
                   {"poisson_surface_mesher", r.poisson_mesher_s},
                   {"component_and_cut", r.cut_s},
                   {"smoothing", r.smoothing_s},
                   {"mesh_check", r.check_s},
                   {"reconstruct", r.total_s},
                   {"write", write_s},
                   {"total", wall_s}};
  if (f.json) {
    print_json(j);
    return;
  }
  log::info("reconstructed {} sensor(s): {} points, {} outliers removed, {} for Poisson (spacing {:.2f} mm); surface "
            "{} vertices, {} triangles, {}; wrote {} (mm) in {:.2f} s (reconstruction {:.2f} s).",
            rec.sensors.size(), r.input_points, r.outliers_removed, r.poisson_points, r.average_spacing_m / units::mm,
            r.mesh.num_vertices(), r.mesh.num_triangles(),
            watertight ? fmt::format("watertight, {:.1f} ml", r.check.signed_volume_m3 * 1e6)
                       : fmt::format("open ({} boundary loop(s))", r.check.boundary_loops),
            f.out, wall_s, r.total_s);
}


/// The learned models of sensors K1…Kn of a simulated ring rig (scan calibrate / scan experiment
/// chessboard output), or none when @p path is empty.
std::vector<scan::ErrorCompensation> ring_compensation(const std::string& path, int sensors,
                                                       const std::vector<scan::CameraIntrinsics>& intrinsics) {
  std::vector<scan::ErrorCompensation> out;
  if (path.empty()) return out;
  const std::vector<scan::ErrorCompensation> models = scan::read_compensation_json(path);
  for (int i = 0; i < sensors; ++i) {
    const scan::CameraIntrinsics k = intrinsics.empty() ? scan::kinect_v2_typical_intrinsics()
                                                        : intrinsics[intrinsics.size() == 1 ? 0 : static_cast<size_t>(i)];
    out.push_back(scan::compensation_for(models, fmt::format("K{}", i + 1), k.width, k.height, path));
  }
  return out;
}

nlohmann::json deviation_json(const scan::Deviation& d) {
  return {{"rms_mm", d.rms_m / units::mm}, {"mean_mm", d.mean_m / units::mm},
          {"signed_mean_mm", d.signed_mean_m / units::mm}, {"p95_mm", d.p95_m / units::mm},
          {"max_mm", d.max_m / units::mm}, {"area_cm2", d.area_m2 * 1e4}, {"samples", d.samples}};
}

void run_limb_experiment(const LimbExperimentFlags& f) {
  const auto t0 = std::chrono::steady_clock::now();
  require(f.mesh.empty() != f.generated.empty(),
          "scan experiment limb: give exactly one limb: --mesh FILE or --generated transtibial|transfemoral");
  const scan::SensorErrorModel error = error_model(f.noise_scale, f.systematic_scale, "scan experiment limb");
  geometry::TriMesh limb;
  std::string what;
  if (!f.mesh.empty()) {
    geometry::MeshReadOptions ro;
    if (!f.units.empty()) ro.unit = units::parse_length_unit(f.units);
    limb = geometry::read_mesh(f.mesh, ro);
    what = fmt::format("mesh '{}'", f.mesh);
  } else {
    const volume::GeneratedLimb g =
        volume::generate_limb(volume::default_params(geometry::parse_limb_type(f.generated), f.limb_seed));
    limb = g.skin;
    what = fmt::format("generated {} limb (seed {}), skin only", f.generated, f.limb_seed);
  }
  scan::LimbScanOptions o;
  o.sensors = f.sensors;
  o.radius_m = f.radius_mm * units::mm;
  o.height_m = f.height_mm * units::mm;
  o.intrinsics = rig_intrinsics(f.calibration, f.sensors);
  o.simulation.seed = f.seed;
  o.simulation.frames = f.frames;
  o.simulation.error = error;
  o.reconstruction.grid_cell_m = f.grid_mm * units::mm;
  o.reconstruction.max_facet_m = f.facet_mm * units::mm;
  o.reconstruction.smoothing_iterations = f.smooth;
  o.reconstruction.back_projection.fusion = scan::parse_frame_fusion(f.fusion, "scan experiment limb: --fusion");
  o.accuracy.sample_spacing_m = f.spacing_mm * units::mm;
  o.compensation = ring_compensation(f.compensation, f.sensors, o.intrinsics);
  const scan::LimbScanResult r =
      scan::run_limb_scan_experiment(limb, o, f.json ? ProgressCallback{} : console_progress(1.0));

  const fs::path dir(f.out);
  ensure_directory(dir);
  scan::Recording rec = r.recording;
  rec.description = fmt::format("scan experiment limb: {} sensors around the {} (seed {}, noise scale {:g})",
                                f.sensors, what, f.seed, f.noise_scale);
  scan::write_recording(dir / "recording", rec);
  geometry::write_mesh(dir / "reconstruction.stl", r.reconstruction.mesh, units::LengthUnit::Millimetre);
  geometry::write_mesh(dir / "original_centred.stl", r.original, units::LengthUnit::Millimetre);
  const scan::ScanAccuracy& a = r.accuracy;
  const bool watertight = r.reconstruction.check.is_valid_closed_surface();
  nlohmann::json j;
  j["command"] = "socketsmith scan experiment limb";
  j["limb"] = what;
  j["offset_mm"] = {r.offset.x() / units::mm, r.offset.y() / units::mm, r.offset.z() / units::mm};
  j["sensors"] = f.sensors;
  j["calibration"] = f.calibration.empty() ? std::string("typical Kinect v2 intrinsics") : f.calibration;
  j["seed"] = f.seed;
  j["noise_scale"] = f.noise_scale;
  j["watertight"] = watertight;
  j["boundary_loops"] = r.reconstruction.check.boundary_loops;
  j["triangles"] = r.reconstruction.mesh.num_triangles();
  j["cut_height_mm"] = r.reconstruction.cut_height_m / units::mm;
  j["measured"] =
      "area-weighted samples every " + fmt::format("{:g}", f.spacing_mm) +
      " mm below the reconstruction's proximal cut: reconstruction (cap excluded) -> original surface, and the "
      "original's samples seen by a sensor -> reconstruction; 'symmetric' pools both";
  j["symmetric"] = deviation_json(a.symmetric);
  j["reconstructed_to_original"] = deviation_json(a.reconstructed_to_original);
  j["seen_original_to_reconstructed"] = deviation_json(a.seen_original_to_reconstructed);
  j["unseen_original_to_reconstructed"] = deviation_json(a.unseen_original_to_reconstructed);
  j["seen_area_fraction"] = a.seen_area_fraction;
  j["compensation"] = f.compensation.empty() ? std::string("none") : f.compensation;
  j["outputs"] = {(dir / "recording").string(), (dir / "reconstruction.stl").string(),
                  (dir / "original_centred.stl").string(), (dir / "report.json").string()};
  j["timing_s"] = {{"simulate", r.simulate_s}, {"reconstruct", r.reconstruction.total_s}, {"total", elapsed_s(t0)}};
  write_text_atomically(dir / "report.json", j.dump(2) + "\n");
  if (f.json) {
    print_json(j);
    return;
  }
  log::info("limb scan of the {}: {}, {} triangles; symmetric surface distance RMS {:.3f} mm (max {:.2f} mm); "
            "reconstruction->original RMS {:.3f} mm, seen original->reconstruction RMS {:.3f} mm ({:.1f} % of the "
            "area seen; unseen part RMS {:.3f} mm); wrote {} in {:.1f} s.",
            what, watertight ? "watertight" : fmt::format("NOT watertight ({} boundary loops)", r.reconstruction.check.boundary_loops),
            r.reconstruction.mesh.num_triangles(), a.symmetric.rms_m / units::mm, a.symmetric.max_m / units::mm,
            a.reconstructed_to_original.rms_m / units::mm, a.seen_original_to_reconstructed.rms_m / units::mm,
            100.0 * a.seen_area_fraction, a.unseen_original_to_reconstructed.rms_m / units::mm, f.out, elapsed_s(t0));
}


nlohmann::json pair_errors_json(const scan::PairErrors& e) {
  return {{"mean_mm", e.mean_m / units::mm}, {"rms_mm", e.rms_m / units::mm}, {"min_mm", e.min_m / units::mm},
          {"max_mm", e.max_m / units::mm}, {"pairs", e.pairs}};
}

nlohmann::json registration_json(const scan::RegistrationResult& r) {
  return {{"method", r.method}, {"iterations", r.iterations}, {"converged", r.converged},
          {"initial", pair_errors_json(r.initial)}, {"final", pair_errors_json(r.final)}};
}

scan::CompensationForm parse_model(const std::string& name, const char* cmd) {
  if (name == "linear") return scan::CompensationForm::LinearUvd;
  if (name == "ray-poly") return scan::CompensationForm::RayPolynomial;
  fail("{}: --model '{}' is not known (expected linear or ray-poly)", cmd, name);
}

constexpr const char* kModelHelp =
    "error model learned: linear (the thesis: rates linear in u, v, d, default) | ray-poly (depth along the ray "
    "corrected by a polynomial in the ray's x, y and d, lateral rates linear in x, y, d)";

constexpr const char* kRefineDistortionHelp =
    "--truth pnp: refine the radial distortion k1, k2 with the focal lengths over the session's board frames (default: "
    "focal lengths only)";

constexpr const char* kDepthDegreeHelp =
    "ray-poly: highest power of d in the depth correction, 1 to 9 (default 3; 7 follows the periodic 'wiggling' error "
    "over a 0.4-1.2 m board session)";

scan::CornerDepth parse_corner_depth(const std::string& name, const char* cmd) {
  if (name == "plane") return scan::CornerDepth::LocalPlane;
  if (name == "bilinear") return scan::CornerDepth::Bilinear;
  fail("{}: --corner-depth '{}' is not known (expected plane or bilinear)", cmd, name);
}

constexpr const char* kCornerDepthHelp =
    "depth at each chessboard corner: plane (a robust local plane fit of the pixels within 6 px, default) | bilinear "
    "(the thesis: its 4 neighbouring pixels)";

void run_register(const RegisterFlags& f) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto progress = f.json ? ProgressCallback{} : console_progress(1.0);
  report_progress(progress, 0.0, "reading the box recording");
  const scan::Recording rec = scan::read_recording(f.recording);
  std::vector<Eigen::Isometry3d> start;
  for (const auto& s : rec.sensors) start.push_back(s.world_from_sensor);
  report_progress(progress, 0.2, "finding the chessboard corners");
  scan::BoxDetectionOptions bo;
  bo.chessboard.upsample = f.upsample;
  bo.chessboard.corner_depth = parse_corner_depth(f.corner_depth, "scan register");
  const scan::ReferenceSet refs = scan::box_reference_points(rec, start, bo);
  report_progress(progress, 0.8, "registering");
  const scan::RegistrationResult r =
      f.sequential ? scan::register_sequential(refs, start) : scan::register_multiset(refs, start);
  nlohmann::json j;
  j["command"] = "socketsmith scan register";
  j["recording"] = f.recording;
  j["output"] = f.out;
  j["reference_points"] = refs.point_names.size();
  j["observations"] = refs.observations.size();
  nlohmann::json shared = nlohmann::json::object();
  for (int a = 0; a < refs.num_sensors(); ++a)
    for (int b = a + 1; b < refs.num_sensors(); ++b)
      if (const int n = refs.shared(a, b); n > 0) shared[refs.sensor_names[static_cast<size_t>(a)] + "-" + refs.sensor_names[static_cast<size_t>(b)]] = n;
  j["shared_points"] = shared;
  j["registration"] = registration_json(r);
  nlohmann::json moved = nlohmann::json::array();
  for (size_t s = 0; s < start.size(); ++s) {
    const scan::PoseError e = scan::pose_error(r.world_from_sensor[s], start[s]);
    moved.push_back({{"name", refs.sensor_names[s]}, {"moved_mm", e.translation_m / units::mm},
                     {"turned_deg", e.rotation_rad * 180.0 / M_PI}});
  }
  j["pose_changes"] = moved;
  scan::write_rig_file(f.out, refs.sensor_names, r.world_from_sensor, registration_json(r).dump());
  j["wall_s"] = elapsed_s(t0);
  if (f.json) {
    print_json(j);
    return;
  }
  log::info("registered {} sensors ({}) on {} reference points: pair error mean {:.3f} mm, max {:.3f} mm (from {:.2f} / "
            "{:.2f} mm at the rig's poses) after {} iteration(s); wrote {} in {:.1f} s.",
            refs.num_sensors(), r.method, refs.point_names.size(), r.final.mean_m / units::mm, r.final.max_m / units::mm,
            r.initial.mean_m / units::mm, r.initial.max_m / units::mm, r.iterations, f.out, elapsed_s(t0));
}

void run_registration_experiment(const RegistrationExperimentFlags& f) {
  const auto t0 = std::chrono::steady_clock::now();
  scan::RegistrationExperimentOptions o;
  o.simulation.error = error_model(f.noise_scale, f.systematic_scale, "scan experiment registration");
  o.sensors = f.sensors;
  o.intrinsics = rig_intrinsics(f.calibration, f.sensors);
  o.simulation.seed = f.seed;
  o.simulation.frames = f.frames;
  o.box_yaw_deg = f.box_yaw_deg;
  o.pose_error_deg = f.pose_error_deg;
  o.pose_error_m = f.pose_error_mm * units::mm;
  o.pose_seed = f.pose_seed;
  o.detection.chessboard.corner_depth = parse_corner_depth(f.corner_depth, "scan experiment registration");
  o.compensation = ring_compensation(f.compensation, f.sensors, o.intrinsics);
  const scan::RegistrationExperimentResult r =
      scan::run_registration_experiment(o, f.json ? ProgressCallback{} : console_progress(1.0));
  const fs::path dir(f.out);
  ensure_directory(dir);
  scan::Recording rec = r.recording;
  for (size_t s = 0; s < rec.sensors.size(); ++s) rec.sensors[s].world_from_sensor = r.measured[s];
  rec.description = fmt::format("scan experiment registration: the box turned {:g} deg, seed {}, noise scale {:g}; "
                                "poses in rig.json are the perturbed (hand-measured) ones",
                                f.box_yaw_deg, f.seed, f.noise_scale);
  scan::write_recording(dir / "box_recording", rec);
  std::vector<std::string> names;
  for (const auto& s : r.rig) names.push_back(s.name);
  scan::write_rig_file(dir / "rig_true.json", names, r.truth);
  scan::write_rig_file(dir / "rig_multiset.json", names, r.multiset.world_from_sensor, registration_json(r.multiset).dump());
  scan::write_rig_file(dir / "rig_sequential.json", names, r.sequential.world_from_sensor,
                       registration_json(r.sequential).dump());
  auto poses_json = [&](const std::vector<scan::PoseError>& e) {
    nlohmann::json a = nlohmann::json::array();
    for (size_t s = 0; s < e.size(); ++s)
      a.push_back({{"name", names[s]}, {"translation_mm", e[s].translation_m / units::mm},
                   {"rotation_deg", e[s].rotation_rad * 180.0 / M_PI}});
    return a;
  };
  nlohmann::json j;
  j["command"] = "socketsmith scan experiment registration";
  j["seed"] = f.seed;
  j["noise_scale"] = f.noise_scale;
  j["calibration"] = f.calibration.empty() ? std::string("typical Kinect v2 intrinsics") : f.calibration;
  j["box_yaw_deg"] = f.box_yaw_deg;
  j["start_pose_error"] = {{"deg", f.pose_error_deg}, {"mm", f.pose_error_mm}, {"seed", f.pose_seed}};
  j["reference_points"] = r.refs.point_names.size();
  j["observations"] = r.refs.observations.size();
  j["measured"] = "Table 4: distances between the world positions two sensors give one chessboard corner, over every "
                  "pair of sensors sharing a corner; pose errors against the poses the frames were rendered with";
  j["corner_depth"] = f.corner_depth;
  auto accuracy_json = [](const std::vector<scan::ReferenceAccuracy>& acc) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& e : acc)
      a.push_back({{"name", e.sensor}, {"points", e.points}, {"along_ray_mean_mm", e.along_mean_m / units::mm},
                   {"along_ray_rms_mm", e.along_rms_m / units::mm}, {"across_ray_rms_mm", e.across_rms_m / units::mm},
                   {"rms_mm", e.rms_m / units::mm}});
    return a;
  };
  j["reference_point_errors"] = accuracy_json(r.accuracy);
  j["at_hand_measured_poses"] = pair_errors_json(r.sequential.initial);
  j["at_true_poses"] = pair_errors_json(r.truth_errors);
  j["sequential"] = registration_json(r.sequential);
  j["multiset"] = registration_json(r.multiset);
  j["pose_errors"] = {{"hand_measured", poses_json(r.measured_pose_errors)},
                      {"sequential", poses_json(r.sequential_pose_errors)},
                      {"multiset", poses_json(r.multiset_pose_errors)}};
  if (f.compensation.empty()) {
    j["compensation"] = "none (pass --compensation from 'scan experiment chessboard' with the same --seed and --calibration)";
  } else {
    j["compensation"] = f.compensation;
    j["multiset_compensated"] = registration_json(r.multiset_compensated);
    j["at_true_poses_compensated"] = pair_errors_json(r.truth_errors_compensated);
    j["reference_point_errors_compensated"] = accuracy_json(r.accuracy_compensated);
    j["pose_errors"]["multiset_compensated"] = poses_json(r.multiset_compensated_pose_errors);
  }
  j["wall_s"] = elapsed_s(t0);
  write_text_atomically(dir / "report.json", j.dump(2) + "\n");
  if (f.json) {
    print_json(j);
    return;
  }
  const std::string compensated =
      f.compensation.empty() ? std::string()
                             : fmt::format("; multi-set + compensation {:.3f}/{:.3f} mm",
                                           r.multiset_compensated.final.mean_m / units::mm,
                                           r.multiset_compensated.final.max_m / units::mm);
  log::info("registration on the box ({} reference points): pair error mean/max at the hand-measured poses {:.2f}/{:.2f} "
            "mm; sequential {:.3f}/{:.3f} mm; multi-set {:.3f}/{:.3f} mm ({} iterations){}; at the true poses "
            "{:.3f}/{:.3f} mm; wrote {} in {:.1f} s.",
            r.refs.point_names.size(), r.sequential.initial.mean_m / units::mm, r.sequential.initial.max_m / units::mm,
            r.sequential.final.mean_m / units::mm, r.sequential.final.max_m / units::mm,
            r.multiset.final.mean_m / units::mm, r.multiset.final.max_m / units::mm, r.multiset.iterations, compensated,
            r.truth_errors.mean_m / units::mm, r.truth_errors.max_m / units::mm, f.out, elapsed_s(t0));
}

scan::TruthEstimate parse_truth(const std::string& t, const char* cmd) {
  if (t == "pnp") return scan::TruthEstimate::Pnp;
  if (t == "kabsch") return scan::TruthEstimate::Kabsch;
  fail("{}: --truth '{}' is not known (expected pnp or kabsch)", cmd, t);
}

scan::ChessboardPattern calibration_pattern(const CalibrateFlags& f, const scan::Recording& rec) {
  if (f.pattern.empty() && f.square_mm <= 0) {
    require(rec.chessboard.has_value(),
            "scan calibrate: the recording names no chessboard (rig.json \"chessboard\"): give --pattern COLSxROWS "
            "(inner corners, e.g. 9x6) and --square-mm");
    return *rec.chessboard;
  }
  scan::ChessboardPattern p = rec.chessboard.value_or(scan::ChessboardPattern{});
  if (!f.pattern.empty()) {
    int c = 0, r = 0;
    char x = 0;
    require(std::sscanf(f.pattern.c_str(), "%d%c%d", &c, &x, &r) == 3 && (x == 'x' || x == 'X'),
            "scan calibrate: --pattern '{}' is not COLSxROWS (inner corners, e.g. 9x6)", f.pattern);
    p.inner_cols = c;
    p.inner_rows = r;
  }
  if (f.square_mm > 0) p.square_m = f.square_mm * units::mm;
  scan::validate_pattern(p, "scan calibrate");
  return p;
}

void run_calibrate(const CalibrateFlags& f) {
  const auto t0 = std::chrono::steady_clock::now();
  const scan::Recording rec = scan::read_recording(f.recording);
  const scan::ChessboardPattern pattern = calibration_pattern(f, rec);
  scan::CalibrationOptions o;
  o.truth = parse_truth(f.truth, "scan calibrate");
  o.chessboard.upsample = f.upsample;
  o.chessboard.corner_depth = parse_corner_depth(f.corner_depth, "scan calibrate");
  o.form = parse_model(f.model, "scan calibrate");
  o.depth_degree = f.depth_degree;
  o.refine_distortion = f.refine_distortion;
  o.min_frames = f.min_frames;
  require(f.frames_per_pose >= 0, "scan calibrate: --frames-per-pose {} must be at least 1", f.frames_per_pose);
  o.frames_per_pose = f.frames_per_pose > 0 ? f.frames_per_pose : rec.frames_per_pose;
  o.fusion = scan::parse_frame_fusion(f.fusion, "scan calibrate: --fusion");
  const auto progress = f.json ? ProgressCallback{} : console_progress(1.0);
  std::vector<scan::ErrorCompensation> models;
  nlohmann::json js = nlohmann::json::array();
  for (const auto& s : rec.sensors) {
    const scan::CalibrationResult r = scan::calibrate_sensor(s, pattern, o, progress);
    models.push_back(r.model);
    scan::EdgeErrors before, after;
    for (const auto& ob : r.observations) {
      before.add(ob.detection, scan::compensated_corners(ob.detection, nullptr));
      after.add(ob.detection, scan::compensated_corners(ob.detection, &r.model));
    }
    nlohmann::json e;
    e["name"] = s.name;
    e["frames"] = s.frames.size();
    e["frames_per_pose"] = o.frames_per_pose;
    e["poses_used"] = r.observations.size();
    e["skipped"] = r.skipped;
    e["corners"] = r.model.corners;
    e["fx_px"] = r.fx;
    e["fy_px"] = r.fy;
    e["corner_rms_mm"] = {{"before", r.rms_before_mm}, {"after", r.rms_after_mm}};
    e["dimension_error_mm"] = {{"before", before.stats().mean_mm}, {"after", after.stats().mean_mm}};
    e["model"] = f.model;
    js.push_back(e);
    if (!f.json)
      log::info("{}: board in {}/{} {}, {} corners; corner error to truth {:.2f} -> {:.2f} mm RMS, dimension error "
                "{:.2f} -> {:.2f} mm (training frames); f = {:.1f}, {:.1f} px",
                s.name, r.observations.size(), s.frames.size() / static_cast<size_t>(o.frames_per_pose),
                o.frames_per_pose == 1 ? "frames" : fmt::format("poses of {} frames", o.frames_per_pose),
                r.model.corners, r.rms_before_mm, r.rms_after_mm,
                before.stats().mean_mm, after.stats().mean_mm, r.fx, r.fy);
  }
  scan::write_compensation_json(f.out, models);
  nlohmann::json j;
  j["command"] = "socketsmith scan calibrate";
  j["recording"] = f.recording;
  j["output"] = f.out;
  j["truth"] = f.truth;
  j["pattern"] = {{"inner_cols", pattern.inner_cols}, {"inner_rows", pattern.inner_rows}, {"square_mm", pattern.square_m * 1e3}};
  j["sensors"] = js;
  j["wall_s"] = elapsed_s(t0);
  if (f.json) {
    print_json(j);
    return;
  }
  log::info("wrote the error models of {} sensor(s) to '{}' in {:.1f} s (use: scan reconstruct --compensation {}).",
            models.size(), f.out, elapsed_s(t0), f.out);
}

nlohmann::json stats_json(const scan::DimensionStats& s) {
  return {{"mean_mm", s.mean_mm}, {"sd_mm", s.sd_mm}, {"border_mean_mm", s.border_mean_mm}, {"edges", s.count}};
}

nlohmann::json error_json(const scan::SurfaceError& e) {
  return {{"rmse_mm", e.rmse_mm}, {"max_mm", e.max_mm}, {"mean_mm", e.mean_mm}, {"samples", e.count}};
}

void run_experiment(const ExperimentFlags& f) {
  const auto t0 = std::chrono::steady_clock::now();
  scan::ExperimentOptions o;
  o.seed = f.seed;
  o.sensors = f.sensors;
  o.training_frames = f.frames;
  o.test_frames_per_distance = f.test_frames;
  o.noise_scale = f.noise_scale;
  o.systematic_scale = f.systematic_scale;
  error_model(f.noise_scale, f.systematic_scale, "scan experiment");  // checks the scales
  o.intrinsics = rig_intrinsics(f.calibration, f.sensors);
  o.truth = parse_truth(f.truth, "scan experiment");
  o.training_corner_depth = parse_corner_depth(f.corner_depth, "scan experiment");
  o.form = parse_model(f.model, "scan experiment");
  o.depth_degree = f.depth_degree;
  o.refine_distortion = f.refine_distortion;
  o.scan_frames = f.scan_frames;
  o.scan_fusion = scan::parse_frame_fusion(f.fusion, "scan experiment: --fusion");
  o.board_frames_per_pose = f.board_frames_per_pose;
  const auto progress = f.json ? ProgressCallback{} : console_progress(1.0);
  ensure_directory(f.out);
  const scan::ChessboardExperiment cb = scan::run_chessboard_experiment(o, progress);
  std::vector<scan::ErrorCompensation> models;
  for (const auto& c : cb.calibrations) models.push_back(c.model);
  scan::write_compensation_json(fs::path(f.out) / "compensation.json", models);
  nlohmann::json j;
  j["command"] = fmt::format("socketsmith scan experiment {} --seed {} --sensors {} --frames {} --board-frames-per-pose "
                             "{} --test-frames {} --noise-scale {:g} --systematic-scale {:g} --truth {} --corner-depth "
                             "{} --model {} --depth-degree {}{}{}{}{}",
                             f.which, f.seed, f.sensors, f.frames, f.board_frames_per_pose, f.test_frames,
                             f.noise_scale, f.systematic_scale, f.truth, f.corner_depth, f.model, f.depth_degree,
                             f.refine_distortion ? " --refine-distortion" : "",
                             f.which == "cylinders"
                                 ? fmt::format(" --scan-frames {} --fusion {}", f.scan_frames, f.fusion)
                                 : "",
                             f.calibration.empty() ? "" : " --calibration " + f.calibration, f.no_mesh ? " --no-mesh" : "");
  j["seed"] = f.seed;
  j["truth"] = f.truth;
  j["noise_scale"] = f.noise_scale;
  j["systematic_scale"] = f.systematic_scale;
  j["intrinsics"] = f.calibration.empty() ? std::string("typical Kinect v2 intrinsics") : f.calibration;
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& r : cb.rows)
    rows.push_back({{"sensor", r.sensor}, {"distance_m", r.distance_m}, {"raw", stats_json(r.raw)},
                    {"compensated", stats_json(r.compensated)}});
  j["chessboard"] = rows;
  j["test_frames_missed"] = cb.test_frames_missed;
  nlohmann::json cal = nlohmann::json::array();
  for (const auto& c : cb.calibrations)
    cal.push_back({{"sensor", c.model.sensor}, {"poses_used", c.observations.size()}, {"skipped", c.skipped.size()},
                   {"corners", c.model.corners},
                   {"fx_px", c.fx}, {"fy_px", c.fy}, {"corner_rms_mm", {c.rms_before_mm, c.rms_after_mm}}});
  j["calibration"] = cal;
  std::string table;
  for (const auto& r : cb.rows)
    if (r.distance_m == 0.0)
      table += fmt::format("\n  {}: {:.2f} ± {:.2f} mm -> {:.2f} ± {:.2f} mm (border {:.2f} -> {:.2f} mm)", r.sensor,
                           r.raw.mean_mm, r.raw.sd_mm, r.compensated.mean_mm, r.compensated.sd_mm, r.raw.border_mean_mm,
                           r.compensated.border_mean_mm);
  if (f.which == "cylinders") {
    const scan::CylinderExperiment cy =
        scan::run_cylinder_experiment(cb, o, {0.10, 0.16, 0.21}, !f.no_mesh, 0.3, progress);
    nlohmann::json cr = nlohmann::json::array();
    table += "\n  cylinders (RMSE / max, raw -> compensated):";
    for (const auto& r : cy.rows) {
      nlohmann::json e = {{"diameter_mm", r.diameter_m * 1e3},
                          {"cloud_raw", error_json(r.cloud_raw)},
                          {"cloud_compensated", error_json(r.cloud_compensated)}};
      table += fmt::format("\n  {:.0f} mm: cloud {:.2f} / {:.2f} -> {:.2f} / {:.2f} mm", r.diameter_m * 1e3,
                           r.cloud_raw.rmse_mm, r.cloud_raw.max_mm, r.cloud_compensated.rmse_mm,
                           r.cloud_compensated.max_mm);
      if (r.mesh_done) {
        e["mesh_raw"] = error_json(r.mesh_raw);
        e["mesh_compensated"] = error_json(r.mesh_compensated);
        table += fmt::format("; mesh {:.2f} / {:.2f} -> {:.2f} / {:.2f} mm", r.mesh_raw.rmse_mm, r.mesh_raw.max_mm,
                             r.mesh_compensated.rmse_mm, r.mesh_compensated.max_mm);
      }
      cr.push_back(e);
    }
    j["cylinders"] = cr;
  }
  j["wall_s"] = elapsed_s(t0);
  write_text_atomically(fs::path(f.out) / (f.which + ".json"), j.dump(2) + "\n");
  if (f.json) {
    print_json(j);
    return;
  }
  log::info("scan experiment {} (seed {}, {} sensors, {} training frames, noise scale {:g}, truth {}): chessboard "
            "dimension errors on held-out frames, raw -> compensated:{}\nwrote {}/{}.json and {}/compensation.json in "
            "{:.1f} s.",
            f.which, f.seed, f.sensors, f.frames, f.noise_scale, f.truth, table, f.out, f.which, f.out, elapsed_s(t0));
}

}  // namespace

void register_scan(CLI::App& app) {
  auto* scan_cmd = app.add_subcommand("scan", "multi-sensor depth scans: simulate a Kinect v2 rig, reconstruct a limb");
  scan_cmd->require_subcommand(1);

  auto sf = std::make_shared<SimulateFlags>();
  auto* sim = scan_cmd->add_subcommand("simulate", "ray-cast a scene from a simulated Kinect v2 rig into a recording folder");
  sim->add_option("--mesh", sf->mesh, "scene mesh (STL/OBJ/PLY/AOP), centred on the rig");
  sim->add_option("--units", sf->units, "units of --mesh: mm | m (default: guessed)");
  sim->add_option("--cylinder-mm", sf->cylinder_mm, "scene: a cylinder of this diameter [mm] (thesis: 100, 160, 210)");
  sim->add_option("--cylinder-height-mm", sf->cylinder_height_mm, "height of the cylinder [mm] (default 400)");
  sim->add_flag("--box", sf->box, "scene: the 300 x 300 x 700 mm calibration box with a chessboard on each side");
  sim->add_option("--box-yaw-deg", sf->box_yaw_deg,
                  "turn of the box about the vertical [deg] (default 45: each board faces two neighbouring sensors, "
                  "as registration needs)");
  sim->add_flag("--chessboard", sf->chessboard,
                "a calibration session: each sensor sees the chessboard (9 x 6 inner corners, 60 mm) in a random pose "
                "per frame (use --frames, thesis ~50)");
  sim->add_option("--frames-per-pose", sf->frames_per_pose,
                  "--chessboard: frames recorded of each board pose (independent noise; --frames poses x this many "
                  "frames, 1 to 30, default 1); scan calibrate fuses them");
  sim->add_option("--min-distance-mm", sf->min_distance_mm, "--chessboard: nearest board distance [mm] (default 550)");
  sim->add_option("--max-distance-mm", sf->max_distance_mm, "--chessboard: farthest board distance [mm] (default 1000)");
  sim->add_option("--sensors", sf->sensors, "number of sensors on the ring (default 4)");
  sim->add_option("--radius-mm", sf->radius_mm, "ring radius [mm] (default 750, as the thesis)");
  sim->add_option("--height-mm", sf->height_mm, "sensor height above the scene centre [mm] (default 0)");
  sim->add_option("--seed", sf->seed, "seed of the error model (default 1)");
  sim->add_option("--noise-scale", sf->noise_scale, "scale of every error term (0: noise free; default 1)");
  sim->add_option("--systematic-scale", sf->systematic_scale, kSystematicScaleHelp);
  sim->add_option("--frames", sf->frames, "frames per sensor (default 1)");
  sim->add_option("--calibration", sf->calibration,
                  "iai_kinect2 calibration: a folder of <serial> folders (one per sensor), a <serial> folder or a "
                  "calib_ir.yaml (default: typical Kinect v2 intrinsics)");
  sim->add_option("--out", sf->out, "recording folder to write")->required();
  sim->add_flag("--json", sf->json, "print a JSON summary on stdout");
  sim->callback([sf] { run_simulate(*sf); });

  auto rf = std::make_shared<ReconstructFlags>();
  auto* rec = scan_cmd->add_subcommand("reconstruct", "reconstruct a watertight limb surface from a recording folder");
  rec->add_option("recording", rf->recording, "recording folder (rig.json + one folder per sensor)");
  rec->add_option("--frame", rf->frames,
                  "instead of a recording: a 16-bit depth PNG of one static camera (repeat for a temporal median); "
                  "needs --intrinsics");
  rec->add_option("--intrinsics", rf->intrinsics,
                  "intrinsics of --frame: intrinsics.json, an Open3D camera json or an iai_kinect2 calib_ir.yaml");
  rec->add_option("--depth-scale", rf->depth_scale,
                  "metres per raw unit of --frame (default 0.001 = mm; TUM: 0.0002)");
  rec->add_option("--max-depth-m", rf->max_depth_m, "readings farther than this are ignored [m] (default 4.5)");
  rec->add_option("--rig", rf->rig, "rig file of 'scan register': replaces the sensor poses of rig.json (by name)");
  rec->add_option("--out", rf->out, "output surface: .stl, .obj, .ply or .aop, in mm")->required();
  auto* open = rec->add_flag("--open", rf->open, "leave the proximal cut open (one boundary loop)");
  auto* closed = rec->add_flag("--closed", rf->closed, "cap the proximal cut with a plane (default)");
  open->excludes(closed);
  rec->add_flag("--no-cut", rf->no_cut, "keep the whole Poisson surface (no proximal cut)");
  rec->add_option("--compensation", rf->compensation,
                  "learned error model (scan calibrate --out): applied to every sensor it names (overrides rig.json)");
  rec->add_option("--fusion", rf->fusion,
                  "per-pixel fusion of a sensor's several frames: median (default) | trimmed-mean (mean of the middle "
                  "half, kept at 0.1 mm)");
  rec->add_option("--upsample", rf->upsample, "bilinear up-sampling of the depth frames, 1 to 8 (default 1)");
  rec->add_option("--grid-mm", rf->grid_mm, "voxel-grid simplification before Poisson [mm] (default 2.5; 0: off)");
  rec->add_option("--facet-mm", rf->facet_mm, "largest facet of the output surface [mm] (default 8)");
  rec->add_option("--smooth", rf->smooth, "Taubin smoothing iterations (default 0)");
  rec->add_flag("--json", rf->json, "print a JSON summary on stdout");
  rec->callback([rf] { run_reconstruct(*rf); });

  auto* exp = scan_cmd->add_subcommand("experiment", "the thesis's scan experiments on simulated recordings");
  exp->require_subcommand(1);
  auto lf = std::make_shared<LimbExperimentFlags>();
  auto* limb = exp->add_subcommand(
      "limb", "simulate a rig around a limb, reconstruct it and measure the surface distance to the original");
  limb->add_option("--mesh", lf->mesh, "limb surface (STL/OBJ/PLY/AOP), long axis along z, proximal end up");
  limb->add_option("--units", lf->units, "units of --mesh: mm | m (default: guessed)");
  limb->add_option("--generated", lf->generated, "use the generated limb's skin: transtibial | transfemoral");
  limb->add_option("--limb-seed", lf->limb_seed, "seed of the generated limb (default 1)");
  add_session_flags(*limb, *lf,
                    "learned models of K1..Kn (from 'scan experiment chessboard' or 'scan calibrate' with the same "
                    "--seed and --calibration), applied by the back-projection");
  limb->add_option("--radius-mm", lf->radius_mm, "ring radius [mm] (default 750)");
  limb->add_option("--height-mm", lf->height_mm, "sensor height above the limb's centre [mm] (default 0)");
  limb->add_option("--grid-mm", lf->grid_mm, "voxel-grid simplification before Poisson [mm] (default 2.5)");
  limb->add_option("--facet-mm", lf->facet_mm, "largest facet of the surface [mm] (default 8)");
  limb->add_option("--smooth", lf->smooth, "Taubin smoothing iterations (default 0)");
  limb->add_option("--fusion", lf->fusion,
                   "per-pixel fusion of each sensor's --frames: median (default) | trimmed-mean");
  limb->add_option("--spacing-mm", lf->spacing_mm, "sample spacing of the distance measure [mm] (default 2)");
  limb->add_option("--out", lf->out, "folder for the recording, the surfaces and report.json")->required();
  limb->add_flag("--json", lf->json, "print the report on stdout");
  limb->callback([lf] { run_limb_experiment(*lf); });

  auto gf = std::make_shared<RegisterFlags>();
  auto* regc = scan_cmd->add_subcommand(
      "register", "register the sensors of a rig from a recording of the chessboard box (multi-set, thesis Table 2)");
  regc->add_option("recording", gf->recording, "recording of the registration box (IR + depth frames, rig.json with "
                                               "the hand-measured poses and \"chessboard\")")->required();
  regc->add_option("--out", gf->out, "rig file to write (use it with 'scan reconstruct --rig')")->required();
  regc->add_flag("--sequential", gf->sequential, "chain pairwise fits K1 <- K2 <- K3 <- ... instead (the baseline)");
  regc->add_option("--upsample", gf->upsample, "up-sampling of the IR frames for corner detection (default 2)");
  regc->add_option("--corner-depth", gf->corner_depth, kCornerDepthHelp);
  regc->add_flag("--json", gf->json, "print a JSON summary on stdout");
  regc->callback([gf] { run_register(*gf); });

  auto xf = std::make_shared<RegistrationExperimentFlags>();
  auto* xreg = exp->add_subcommand(
      "registration", "Table 4: sequential vs multi-set registration on a simulated box session from perturbed poses");
  add_session_flags(*xreg, *xf,
                    "learned models of K1..Kn (compensation.json of 'scan experiment chessboard' or 'scan calibrate' "
                    "with the same --seed and --calibration): adds the multi-set + compensation row");
  xreg->add_option("--corner-depth", xf->corner_depth, kCornerDepthHelp);
  xreg->add_option("--box-yaw-deg", xf->box_yaw_deg, "turn of the box about the vertical [deg] (default 45)");
  xreg->add_option("--pose-error-deg", xf->pose_error_deg, "rotation error of the starting poses [deg] (default 3)");
  xreg->add_option("--pose-error-mm", xf->pose_error_mm, "translation error of the starting poses [mm] (default 20)");
  xreg->add_option("--pose-seed", xf->pose_seed, "seed of the starting pose errors (default 7)");
  xreg->add_option("--out", xf->out, "folder for the box recording, the rig files and report.json")->required();
  xreg->add_flag("--json", xf->json, "print the report on stdout");
  xreg->callback([xf] { run_registration_experiment(*xf); });

  auto cf = std::make_shared<CalibrateFlags>();
  auto* cal = scan_cmd->add_subcommand(
      "calibrate", "learn each sensor's error compensation (linear regression on u, v, d) from chessboard frames");
  cal->add_option("recording", cf->recording, "recording of board frames (IR + depth), e.g. scan simulate --chessboard")
      ->required();
  cal->add_option("--out", cf->out, "model file to write (JSON, one entry per sensor)")->required();
  cal->add_option("--pattern", cf->pattern, "inner corners COLSxROWS (default: rig.json \"chessboard\")");
  cal->add_option("--square-mm", cf->square_mm, "square side [mm] (default: rig.json \"chessboard\")");
  cal->add_option("--truth", cf->truth,
                  "true corners from: pnp (board pose from the IR image, default) | kabsch (thesis: rigid fit to the "
                  "measured corners)");
  cal->add_option("--upsample", cf->upsample, "IR up-sampling for corner detection, 1 to 8 (default 2)");
  cal->add_option("--model", cf->model, kModelHelp);
  cal->add_option("--depth-degree", cf->depth_degree, kDepthDegreeHelp);
  cal->add_flag("--refine-distortion", cf->refine_distortion, kRefineDistortionHelp);
  cal->add_option("--corner-depth", cf->corner_depth,
                  "depth at each corner of the training frames: bilinear (the thesis, default) | plane (a robust local "
                  "plane fit of the pixels within 6 px)");
  cal->add_option("--min-frames", cf->min_frames, "fewest usable board frames (poses) per sensor (default 5)");
  cal->add_option("--frames-per-pose", cf->frames_per_pose,
                  "consecutive frames of one board pose, fused into one observation (default: rig.json "
                  "\"frames_per_pose\", else 1)");
  cal->add_option("--fusion", cf->fusion,
                  "depth fusion of a pose's frames: trimmed-mean (default) | median; IR frames are averaged");
  cal->add_flag("--json", cf->json, "print a JSON summary on stdout");
  cal->callback([cf] { run_calibrate(*cf); });

  for (const char* which : {"chessboard", "cylinders"}) {
    auto ef = std::make_shared<ExperimentFlags>();
    ef->which = which;
    auto* x = exp->add_subcommand(
        which, std::string(which) == "chessboard"
                   ? "Table 3: chessboard dimension errors on held-out frames without/with the learned compensation"
                   : "cylinders of 10, 16, 21 cm: RMSE and max error without/with the learned compensation");
    x->add_option("--out", ef->out, "folder for <which>.json and the learned compensation.json")->required();
    x->add_option("--seed", ef->seed, "seed of the units' errors, poses and noise (default 1)");
    x->add_option("--sensors", ef->sensors, "sensors K1..Kn (default 4)");
    x->add_option("--frames", ef->frames, "training board poses per sensor (default 50, as the thesis)");
    x->add_option("--board-frames-per-pose", ef->board_frames_per_pose,
                  "frames recorded of each training board pose and fused (IR mean, depth trimmed mean; default 1); "
                  "the held-out frames stay single frames");
    x->add_option("--test-frames", ef->test_frames, "held-out frames per sensor at each of 60, 75, 90 cm (default 5)");
    x->add_option("--noise-scale", ef->noise_scale, "scale of every simulated error term (default 1)");
    x->add_option("--systematic-scale", ef->systematic_scale, kSystematicScaleHelp);
    x->add_option("--calibration", ef->calibration,
                  "iai_kinect2 calibration folder(s) for the simulated units' intrinsics and distortion, as for scan "
                  "simulate (default: typical Kinect v2 intrinsics)");
    x->add_option("--truth", ef->truth, "pnp (default) | kabsch (thesis eqs. 31-35)");
    x->add_option("--model", ef->model, kModelHelp);
    x->add_option("--depth-degree", ef->depth_degree, kDepthDegreeHelp);
    x->add_flag("--refine-distortion", ef->refine_distortion, kRefineDistortionHelp);
    x->add_option("--corner-depth", ef->corner_depth,
                  "depth at the corners of the training frames: bilinear (the thesis, default) | plane (local plane "
                  "fit); the held-out frames are always measured the thesis's way (bilinear)");
    if (std::string(which) == "cylinders") {
      x->add_flag("--no-mesh", ef->no_mesh, "point-cloud errors only (skip the reconstructions)");
      x->add_option("--scan-frames", ef->scan_frames,
                    "frames per sensor of each cylinder scan, fused per pixel (default 1)");
      x->add_option("--fusion", ef->fusion,
                    "per-pixel fusion of the --scan-frames: median (default) | trimmed-mean");
    }
    x->add_flag("--json", ef->json, "print the results as JSON on stdout");
    x->callback([ef] { run_experiment(*ef); });
  }
}

}  // namespace socketsmith::cli
