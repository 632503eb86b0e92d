// `socketsmith scan simulate` (a simulated Kinect v2 rig writes a recording folder), `scan
// reconstruct` (a recording folder becomes a watertight limb surface in mm), `scan calibrate` (each
// sensor's learned error compensation from chessboard frames) and `scan register` (the rig's poses
// from a recording of the chessboard box): flags into requests and the printed summary; the runs,
// their files and summaries are scan/recording_outputs.h's.
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "cli_common.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/progress.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/scan/recording_outputs.h"

#include "scan_cli.h"

namespace socketsmith::cli::scan_cli {
namespace fs = std::filesystem;

namespace {

/// The scene of `scan simulate` (a mesh, a cylinder, the box or the chessboard session) and its
/// description, into @p q.
void set_simulated_scene(const SimulateFlags& f, scan::SimulationRequest& q) {
  scan::Scene& scene = q.scene;
  std::string& what = q.scene_label;
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
  o.back_projection.max_depth_m = f.max_depth_m;
  return o;
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
  scan::SimulationRequest q;
  q.simulation.error = error_model(f.noise_scale, f.systematic_scale, "scan simulate");
  set_simulated_scene(f, q);
  q.sensors = scan::default_rig(f.sensors, f.radius_mm * units::mm, f.height_mm * units::mm, geometry::Vec3::Zero(),
                                rig_intrinsics(f.calibration, f.sensors));
  q.radius_mm = f.radius_mm;
  q.simulation.seed = f.seed;
  q.simulation.frames = f.frames;
  if (f.chessboard) {
    scan::CalibrationSessionOptions co;
    co.min_distance_m = f.min_distance_mm * units::mm;
    co.max_distance_m = f.max_distance_mm * units::mm;
    co.frames_per_pose = f.frames_per_pose;
    q.board_session = co;
  } else {
    require(f.frames_per_pose == 1, "scan simulate: --frames-per-pose is for --chessboard sessions (a static scene's "
                                    "frames are all of one pose: use --frames)");
  }
  q.progress = f.json ? ProgressCallback{} : console_progress(1.0);
  scan::SimulationRun run = scan::run_simulation(q, f.out);
  if (print_summary_json(run.summary, t0, f.json)) return;
  std::string valid_pixels;
  for (const auto& s : run.summary["sensors"])
    valid_pixels += fmt::format("{}{} {} px", valid_pixels.empty() ? "" : ", ", s["name"].get<std::string>(),
                                s["valid_pixels"].get<int>());
  log::info("simulated {} sensor(s) x {} frame(s) of the {}; valid pixels: {}; wrote recording '{}' in {:.2f} s.",
            f.sensors, f.frames, q.scene_label, valid_pixels, f.out, elapsed_s(t0));
}

void run_reconstruct(const ReconstructFlags& f) {
  scan::ReconstructionRequest q;  // its clock starts here
  const fs::path out(f.out);
  std::string ext = out.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  require(ext == ".stl" || ext == ".obj" || ext == ".ply" || ext == ".aop",
          "scan reconstruct: --out '{}' has extension '{}' (expected .stl, .obj, .ply or .aop)", f.out, ext);
  q.options = reconstruction_options(f);
  require(f.recording.empty() != f.frames.empty(),
          "scan reconstruct: give a recording folder or --frame DEPTH.png --intrinsics FILE (not both, not neither)");
  require(f.frames.empty() || !f.intrinsics.empty(),
          "scan reconstruct: --frame needs --intrinsics (the camera's intrinsics.json, Open3D camera json or "
          "calib_ir.yaml)");
  require(f.intrinsics.empty() || !f.frames.empty(),
          "scan reconstruct: --intrinsics is for --frame (a recording folder names its intrinsics in rig.json)");
  q.input = {f.recording, f.frames, f.intrinsics, f.depth_scale, f.rig, f.compensation};
  q.progress = f.json ? ProgressCallback{} : console_progress(1.0);
  const scan::ReconstructionRun run = scan::run_reconstruction(q, out);
  if (f.json) {
    print_json(run.summary);
    return;
  }
  const scan::ReconstructionResult& r = run.result;
  log::info("reconstructed {} sensor(s): {} points, {} outliers removed, {} for Poisson (spacing {:.2f} mm); surface "
            "{} vertices, {} triangles, {}; wrote {} (mm) in {:.2f} s (reconstruction {:.2f} s).",
            run.sensors, r.input_points, r.outliers_removed, r.poisson_points, r.average_spacing_m / units::mm,
            r.mesh.num_vertices(), r.mesh.num_triangles(),
            r.check.is_valid_closed_surface() ? fmt::format("watertight, {:.1f} ml", r.check.signed_volume_m3 * 1e6)
                                              : fmt::format("open ({} boundary loop(s))", r.check.boundary_loops),
            f.out, run.summary["timing_s"]["total"].get<double>(), r.total_s);
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
  scan::CalibrationRequest q;
  q.recording = f.recording;
  q.pattern = calibration_pattern(f, rec);
  scan::SensorCalibrationOptions& o = q.options;
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
  q.truth = f.truth;
  q.model = f.model;
  q.progress = f.json ? ProgressCallback{} : console_progress(1.0);
  if (!f.json)
    q.on_sensor = [&o](const scan::SensorRecording& s, const scan::SensorCalibrationResult& r,
                       const scan::TrainingDimensionErrors& dim) {
      log::info("{}: board in {}/{} {}, {} corners; corner error to truth {:.2f} -> {:.2f} mm RMS, dimension error "
                "{:.2f} -> {:.2f} mm (training frames); f = {:.1f}, {:.1f} px",
                s.name, r.observations.size(), s.frames.size() / static_cast<size_t>(o.frames_per_pose),
                o.frames_per_pose == 1 ? "frames" : fmt::format("poses of {} frames", o.frames_per_pose),
                r.model.corners, r.rms_before_mm, r.rms_after_mm,
                dim.before.mean_mm, dim.after.mean_mm, r.fx, r.fy);
    };
  scan::CalibrationRun run = scan::run_calibration(rec, q, f.out);
  if (print_summary_json(run.summary, t0, f.json)) return;
  log::info("wrote the error models of {} sensor(s) to '{}' in {:.1f} s (use: scan reconstruct --compensation {}).",
            run.models.size(), f.out, elapsed_s(t0), f.out);
}

void run_register(const RegisterFlags& f) {
  const auto t0 = std::chrono::steady_clock::now();
  scan::RegistrationRequest q;
  q.recording = f.recording;
  q.detection.chessboard.upsample = f.upsample;
  q.detection.chessboard.corner_depth = parse_corner_depth(f.corner_depth, "scan register");
  q.sequential = f.sequential;
  q.progress = f.json ? ProgressCallback{} : console_progress(1.0);
  scan::RegistrationRun run = scan::run_registration(q, f.out);
  if (print_summary_json(run.summary, t0, f.json)) return;
  const scan::RegistrationResult& r = run.result;
  log::info("registered {} sensors ({}) on {} reference points: pair error mean {:.3f} mm, max {:.3f} mm (from {:.2f} / "
            "{:.2f} mm at the rig's poses) after {} iteration(s); wrote {} in {:.1f} s.",
            run.refs.num_sensors(), r.method, run.refs.point_names.size(), r.final.mean_m / units::mm,
            r.final.max_m / units::mm, r.initial.mean_m / units::mm, r.initial.max_m / units::mm, r.iterations, f.out,
            elapsed_s(t0));
}

}  // namespace socketsmith::cli::scan_cli
