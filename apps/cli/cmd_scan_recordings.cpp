// `socketsmith scan simulate` (a simulated Kinect v2 rig writes a recording folder), `scan
// reconstruct` (a recording folder becomes a watertight limb surface in mm), `scan calibrate` (each
// sensor's learned error compensation from chessboard frames) and `scan register` (the rig's poses
// from a recording of the chessboard box): the runs on recordings, apart from the experiments.
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
#include "socketsmith/scan/sensor_calibration.h"
#include "socketsmith/scan/experiments.h"
#include "socketsmith/scan/reconstruction.h"
#include "socketsmith/scan/registration.h"
#include "socketsmith/scan/simulated_sensor.h"
#include "socketsmith/volume/limb_generator.h"

#include "scan_cli.h"

namespace socketsmith::cli::scan_cli {
namespace fs = std::filesystem;

namespace {

/// The scene of `scan simulate` (a mesh, a cylinder, the box or the chessboard session) and its description.
struct SimulatedScene {
  scan::Scene scene;
  std::string what;
};

SimulatedScene simulated_scene(const SimulateFlags& f) {
  SimulatedScene out;
  scan::Scene& scene = out.scene;
  std::string& what = out.what;
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
  return out;
}

/// The reconstruction options of `scan reconstruct`'s flags.
scan::ReconstructionOptions reconstruction_options(const ReconstructFlags& f) {
  scan::ReconstructionOptions o;
  o.back_projection.upsample = f.upsample;
  o.back_projection.fusion = scan::parse_frame_fusion(f.fusion, "scan reconstruct: --fusion");
  o.grid_cell_m = f.grid_mm * units::mm;
  o.smoothing_iterations = f.smooth;
  o.max_facet_m = f.facet_mm * units::mm;
  o.open_proximal = f.open;
  o.cut_proximal = !f.no_cut;
  return o;
}

/// The seconds of each stage of a reconstruction, with the reading and writing around it.
nlohmann::json reconstruction_timing_json(const scan::ReconstructionResult& r, double read_s, double write_s,
                                          double wall_s) {
  return {{"read", read_s},
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
}

}  // namespace

void run_simulate(const SimulateFlags& f) {
  const auto t0 = std::chrono::steady_clock::now();
  const int scenes = (f.mesh.empty() ? 0 : 1) + (f.cylinder_mm > 0 ? 1 : 0) + (f.box ? 1 : 0) + (f.chessboard ? 1 : 0);
  require(scenes == 1,
          "scan simulate: give exactly one scene: --mesh FILE, --cylinder-mm D, --box or --chessboard ({} given)",
          scenes);
  require(f.sensors >= 1 && f.sensors <= 32, "scan simulate: --sensors {} is out of range (expected 1 to 32)",
          f.sensors);
  const scan::SensorErrorModel error = error_model(f.noise_scale, f.systematic_scale, "scan simulate");
  const auto [scene, what] = simulated_scene(f);
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
  if (print_summary_json(j, t0, f.json)) return;
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
  scan::ReconstructionOptions o = reconstruction_options(f);
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
  j["timing_s"] = reconstruction_timing_json(r, read_s, write_s, wall_s);
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

namespace {

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

}  // namespace

void run_calibrate(const CalibrateFlags& f) {
  const auto t0 = std::chrono::steady_clock::now();
  const scan::Recording rec = scan::read_recording(f.recording);
  const scan::ChessboardPattern pattern = calibration_pattern(f, rec);
  scan::SensorCalibrationOptions o;
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
    const scan::SensorCalibrationResult r = scan::calibrate_sensor(s, pattern, o, progress);
    models.push_back(r.model);
    const scan::TrainingDimensionErrors dim = scan::training_dimension_errors(r);
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
    e["dimension_error_mm"] = {{"before", dim.before.mean_mm}, {"after", dim.after.mean_mm}};
    e["model"] = f.model;
    js.push_back(e);
    if (!f.json)
      log::info("{}: board in {}/{} {}, {} corners; corner error to truth {:.2f} -> {:.2f} mm RMS, dimension error "
                "{:.2f} -> {:.2f} mm (training frames); f = {:.1f}, {:.1f} px",
                s.name, r.observations.size(), s.frames.size() / static_cast<size_t>(o.frames_per_pose),
                o.frames_per_pose == 1 ? "frames" : fmt::format("poses of {} frames", o.frames_per_pose),
                r.model.corners, r.rms_before_mm, r.rms_after_mm,
                dim.before.mean_mm, dim.after.mean_mm, r.fx, r.fy);
  }
  scan::write_compensation_json(f.out, models);
  nlohmann::json j;
  j["command"] = "socketsmith scan calibrate";
  j["recording"] = f.recording;
  j["output"] = f.out;
  j["truth"] = f.truth;
  j["pattern"] = {{"inner_cols", pattern.inner_cols}, {"inner_rows", pattern.inner_rows}, {"square_mm", pattern.square_m * 1e3}};
  j["sensors"] = js;
  if (print_summary_json(j, t0, f.json)) return;
  log::info("wrote the error models of {} sensor(s) to '{}' in {:.1f} s (use: scan reconstruct --compensation {}).",
            models.size(), f.out, elapsed_s(t0), f.out);
}

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
  j["registration"] = scan::registration_json(r);
  nlohmann::json moved = nlohmann::json::array();
  for (size_t s = 0; s < start.size(); ++s) {
    const scan::PoseError e = scan::pose_error(r.world_from_sensor[s], start[s]);
    moved.push_back({{"name", refs.sensor_names[s]}, {"moved_mm", e.translation_m / units::mm},
                     {"turned_deg", e.rotation_rad * 180.0 / M_PI}});
  }
  j["pose_changes"] = moved;
  scan::write_rig_file(f.out, refs.sensor_names, r.world_from_sensor, scan::registration_json(r).dump());
  if (print_summary_json(j, t0, f.json)) return;
  log::info("registered {} sensors ({}) on {} reference points: pair error mean {:.3f} mm, max {:.3f} mm (from {:.2f} / "
            "{:.2f} mm at the rig's poses) after {} iteration(s); wrote {} in {:.1f} s.",
            refs.num_sensors(), r.method, refs.point_names.size(), r.final.mean_m / units::mm, r.final.max_m / units::mm,
            r.initial.mean_m / units::mm, r.initial.max_m / units::mm, r.iterations, f.out, elapsed_s(t0));
}

}  // namespace socketsmith::cli::scan_cli
