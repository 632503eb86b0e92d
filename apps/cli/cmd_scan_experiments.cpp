// `socketsmith scan experiment limb|registration|chessboard|cylinders`: the thesis's scan
// experiments (Tables 3-4 and the limb scans) on simulated recordings — flags into requests and
// the printed summary; the runs, their files and reports are scan/experiment_outputs.h's.
#include <string>

#include "cli_common.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/progress.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/scan/experiment_outputs.h"
#include "socketsmith/volume/limb_generator.h"

#include "scan_cli.h"

namespace socketsmith::cli::scan_cli {
namespace {

/// Runs an experiment with a console progress line, or quietly and then prints its JSON report
/// (--json).
template <class Request, class RunFn>
auto run_and_report(Request& q, bool json, RunFn&& run) {
  q.progress = json ? ProgressCallback{} : console_progress(1.0);
  auto result = run(q);
  if (json) print_json(result.report);
  return result;
}

}  // namespace

/// The limb experiment's rig, simulation, reconstruction and measure from its flags.
scan::LimbScanOptions limb_scan_options(const LimbExperimentFlags& f, const scan::SensorErrorModel& error) {
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
  return o;
}

void run_limb_experiment(const LimbExperimentFlags& f) {
  scan::LimbExperimentRequest q;  // its clock starts here, before the limb is read
  require(f.mesh.empty() != f.generated.empty(),
          "scan experiment limb: give exactly one limb: --mesh FILE or --generated transtibial|transfemoral");
  const scan::SensorErrorModel error = error_model(f.noise_scale, f.systematic_scale, "scan experiment limb");
  if (!f.mesh.empty()) {
    geometry::MeshReadOptions ro;
    if (!f.units.empty()) ro.unit = units::parse_length_unit(f.units);
    q.limb = geometry::read_mesh(f.mesh, ro);
    q.limb_label = fmt::format("mesh '{}'", f.mesh);
  } else {
    q.limb = volume::generate_limb(volume::default_params(geometry::parse_limb_type(f.generated), f.limb_seed)).skin;
    q.limb_label = fmt::format("generated {} limb (seed {}), skin only", f.generated, f.limb_seed);
  }
  q.options = limb_scan_options(f, error);
  q.sources = {f.calibration, f.compensation};
  const scan::LimbExperimentRun run =
      run_and_report(q, f.json, [&](const auto& request) { return scan::run_limb_experiment(request, f.out); });
  if (f.json) return;
  const scan::LimbScanResult& r = run.result;
  const scan::ScanAccuracy& a = r.accuracy;
  const bool watertight = r.reconstruction.check.is_valid_closed_surface();
  log::info("limb scan of the {}: {}, {} triangles; symmetric surface distance RMS {:.3f} mm (max {:.2f} mm); "
            "reconstruction->original RMS {:.3f} mm, seen original->reconstruction RMS {:.3f} mm ({:.1f} % of the "
            "area seen; unseen part RMS {:.3f} mm); wrote {} in {:.1f} s.",
            q.limb_label, watertight ? "watertight" : fmt::format("NOT watertight ({} boundary loops)", r.reconstruction.check.boundary_loops),
            r.reconstruction.mesh.num_triangles(), a.symmetric.rms_m / units::mm, a.symmetric.max_m / units::mm,
            a.reconstructed_to_original.rms_m / units::mm, a.seen_original_to_reconstructed.rms_m / units::mm,
            100.0 * a.seen_area_fraction, a.unseen_original_to_reconstructed.rms_m / units::mm, f.out, elapsed_s(q.started));
}

/// The registration experiment's options from its flags (checked in the flags' order).
scan::RegistrationExperimentOptions registration_experiment_options(const RegistrationExperimentFlags& f) {
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
  return o;
}

void run_registration_experiment(const RegistrationExperimentFlags& f) {
  scan::RegistrationExperimentRequest q;
  q.options = registration_experiment_options(f);
  q.sources = {f.calibration, f.compensation};
  q.corner_depth = f.corner_depth;
  q.pose_error_mm = f.pose_error_mm;
  const scan::RegistrationExperimentRun run =
      run_and_report(q, f.json, [&](const auto& r) { return scan::run_registration_experiment(r, f.out); });
  if (f.json) return;
  const scan::RegistrationExperimentResult& r = run.result;
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
            r.truth_errors.mean_m / units::mm, r.truth_errors.max_m / units::mm, f.out, elapsed_s(q.started));
}

/// The chessboard and cylinder experiments' options from their flags (checked in the flags' order).
scan::ExperimentOptions board_experiment_options(const ExperimentFlags& f) {
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
  return o;
}

/// The command line the report repeats: every setting of the run, the defaults too.
std::string board_command(const ExperimentFlags& f) {
  return fmt::format("socketsmith scan experiment {} --seed {} --sensors {} --frames {} --board-frames-per-pose {} "
                     "--test-frames {} --noise-scale {:g} --systematic-scale {:g} --truth {} --corner-depth {} --model "
                     "{} --depth-degree {}{}{}{}{}",
                     f.which, f.seed, f.sensors, f.frames, f.board_frames_per_pose, f.test_frames, f.noise_scale,
                     f.systematic_scale, f.truth, f.corner_depth, f.model, f.depth_degree,
                     f.refine_distortion ? " --refine-distortion" : "",
                     f.which == "cylinders" ? fmt::format(" --scan-frames {} --fusion {}", f.scan_frames, f.fusion) : "",
                     f.calibration.empty() ? "" : " --calibration " + f.calibration, f.no_mesh ? " --no-mesh" : "");
}

/// Table 3 (all held-out frames of each sensor) and the cylinders' errors, one line each.
std::string board_table(const scan::BoardExperimentRun& run) {
  std::string table;
  for (const auto& r : run.chessboard.rows)
    if (r.distance_m == 0.0)
      table += fmt::format("\n  {}: {:.2f} ± {:.2f} mm -> {:.2f} ± {:.2f} mm (border {:.2f} -> {:.2f} mm)", r.sensor,
                           r.raw.mean_mm, r.raw.sd_mm, r.compensated.mean_mm, r.compensated.sd_mm, r.raw.border_mean_mm,
                           r.compensated.border_mean_mm);
  if (!run.cylinders) return table;
  table += "\n  cylinders (RMSE / max, raw -> compensated):";
  for (const auto& r : run.cylinders->rows) {
    table += fmt::format("\n  {:.0f} mm: cloud {:.2f} / {:.2f} -> {:.2f} / {:.2f} mm", r.diameter_m * 1e3,
                         r.cloud_raw.rmse_mm, r.cloud_raw.max_mm, r.cloud_compensated.rmse_mm, r.cloud_compensated.max_mm);
    if (r.mesh_done)
      table += fmt::format("; mesh {:.2f} / {:.2f} -> {:.2f} / {:.2f} mm", r.mesh_raw.rmse_mm, r.mesh_raw.max_mm,
                           r.mesh_compensated.rmse_mm, r.mesh_compensated.max_mm);
  }
  return table;
}

void run_experiment(const ExperimentFlags& f) {
  scan::BoardExperimentRequest q;
  q.options = board_experiment_options(f);
  q.cylinders = f.which == "cylinders";
  q.reconstruct_meshes = !f.no_mesh;
  q.command = board_command(f);
  q.truth = f.truth;
  q.sources.calibration = f.calibration;
  const scan::BoardExperimentRun run =
      run_and_report(q, f.json, [&](const auto& request) { return scan::run_board_experiment(request, f.out); });
  if (f.json) return;
  log::info("scan experiment {} (seed {}, {} sensors, {} training frames, noise scale {:g}, truth {}): chessboard "
            "dimension errors on held-out frames, raw -> compensated:{}\nwrote {}/{}.json and {}/compensation.json in "
            "{:.1f} s.",
            f.which, f.seed, f.sensors, f.frames, f.noise_scale, f.truth, board_table(run), f.out, f.which, f.out,
            elapsed_s(q.started));
}

}  // namespace socketsmith::cli::scan_cli
