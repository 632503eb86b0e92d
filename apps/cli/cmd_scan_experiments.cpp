// `socketsmith scan experiment limb|registration|chessboard|cylinders`: the thesis's scan
// experiments (Tables 3-4 and the limb scans) on simulated recordings, their reports and files.
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

nlohmann::json deviation_json(const scan::Deviation& d) {
  return {{"rms_mm", d.rms_m / units::mm}, {"mean_mm", d.mean_m / units::mm},
          {"signed_mean_mm", d.signed_mean_m / units::mm}, {"p95_mm", d.p95_m / units::mm},
          {"max_mm", d.max_m / units::mm}, {"area_cm2", d.area_m2 * 1e4}, {"samples", d.samples}};
}

nlohmann::json stats_json(const scan::DimensionStats& s) {
  return {{"mean_mm", s.mean_mm}, {"sd_mm", s.sd_mm}, {"border_mean_mm", s.border_mean_mm}, {"edges", s.count}};
}

nlohmann::json error_json(const scan::SurfaceError& e) {
  return {{"rmse_mm", e.rmse_mm}, {"max_mm", e.max_mm}, {"mean_mm", e.mean_mm}, {"samples", e.count}};
}

/// Each sensor's pose error against the pose its frames were rendered with.
nlohmann::json pose_errors_json(const std::vector<std::string>& names, const std::vector<scan::PoseError>& e) {
  nlohmann::json a = nlohmann::json::array();
  for (size_t s = 0; s < e.size(); ++s)
    a.push_back({{"name", names[s]}, {"translation_mm", e[s].translation_m / units::mm},
                 {"rotation_deg", e[s].rotation_rad * 180.0 / M_PI}});
  return a;
}

/// Each sensor's error on the box's reference points, along and across its rays.
nlohmann::json reference_accuracy_json(const std::vector<scan::ReferenceAccuracy>& acc) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& e : acc)
    a.push_back({{"name", e.sensor}, {"points", e.points}, {"along_ray_mean_mm", e.along_mean_m / units::mm},
                 {"along_ray_rms_mm", e.along_rms_m / units::mm}, {"across_ray_rms_mm", e.across_rms_m / units::mm},
                 {"rms_mm", e.rms_m / units::mm}});
  return a;
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
  const scan::LimbScanOptions o = limb_scan_options(f, error);
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
  const auto t0 = std::chrono::steady_clock::now();
  const scan::RegistrationExperimentOptions o = registration_experiment_options(f);
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
  const auto poses_json = [&](const std::vector<scan::PoseError>& e) { return pose_errors_json(names, e); };
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
  j["reference_point_errors"] = reference_accuracy_json(r.accuracy);
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
    j["reference_point_errors_compensated"] = reference_accuracy_json(r.accuracy_compensated);
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

void run_experiment(const ExperimentFlags& f) {
  const auto t0 = std::chrono::steady_clock::now();
  const scan::ExperimentOptions o = board_experiment_options(f);
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

}  // namespace socketsmith::cli::scan_cli
