#include "socketsmith/scan/experiment_outputs.h"

#include <cmath>

#include <fmt/format.h>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/scan/error_compensation.h"
#include "socketsmith/scan/recording.h"

namespace socketsmith::scan {
namespace {

namespace fs = std::filesystem;

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// The rig's intrinsics as the reports name them.
std::string intrinsics_label(const ExperimentSources& s) {
  return s.calibration.empty() ? std::string("typical Kinect v2 intrinsics") : s.calibration;
}

nlohmann::json deviation_json(const Deviation& d) {
  return {{"rms_mm", d.rms_m / units::mm}, {"mean_mm", d.mean_m / units::mm},
          {"signed_mean_mm", d.signed_mean_m / units::mm}, {"p95_mm", d.p95_m / units::mm},
          {"max_mm", d.max_m / units::mm}, {"area_cm2", d.area_m2 * 1e4}, {"samples", d.samples}};
}

nlohmann::json stats_json(const DimensionStats& s) {
  return {{"mean_mm", s.mean_mm}, {"sd_mm", s.sd_mm}, {"border_mean_mm", s.border_mean_mm}, {"edges", s.count}};
}

nlohmann::json error_json(const SurfaceError& e) {
  return {{"rmse_mm", e.rmse_mm}, {"max_mm", e.max_mm}, {"mean_mm", e.mean_mm}, {"samples", e.count}};
}

/// Each sensor's pose error against the pose its frames were rendered with.
nlohmann::json pose_errors_json(const std::vector<std::string>& names, const std::vector<PoseError>& e) {
  nlohmann::json a = nlohmann::json::array();
  for (size_t s = 0; s < e.size(); ++s)
    a.push_back({{"name", names[s]}, {"translation_mm", e[s].translation_m / units::mm},
                 {"rotation_deg", e[s].rotation_rad * 180.0 / M_PI}});
  return a;
}

/// Each sensor's error on the box's reference points, along and across its rays.
nlohmann::json reference_accuracy_json(const std::vector<ReferenceAccuracy>& acc) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& e : acc)
    a.push_back({{"name", e.sensor}, {"points", e.points}, {"along_ray_mean_mm", e.along_mean_m / units::mm},
                 {"along_ray_rms_mm", e.along_rms_m / units::mm}, {"across_ray_rms_mm", e.across_rms_m / units::mm},
                 {"rms_mm", e.rms_m / units::mm}});
  return a;
}

/// report.json of the limb experiment (without its timings).
nlohmann::json limb_report(const LimbExperimentRequest& q, const LimbScanResult& r, const fs::path& out) {
  const ScanAccuracy& a = r.accuracy;
  nlohmann::json j;
  j["command"] = "socketsmith scan experiment limb";
  j["limb"] = q.limb_label;
  j["offset_mm"] = {r.offset.x() / units::mm, r.offset.y() / units::mm, r.offset.z() / units::mm};
  j["sensors"] = q.options.sensors;
  j["calibration"] = intrinsics_label(q.sources);
  j["seed"] = q.options.simulation.seed;
  j["noise_scale"] = q.options.simulation.error.scale;
  j["watertight"] = r.reconstruction.check.is_valid_closed_surface();
  j["boundary_loops"] = r.reconstruction.check.boundary_loops;
  j["triangles"] = r.reconstruction.mesh.num_triangles();
  j["cut_height_mm"] = r.reconstruction.cut_height_m / units::mm;
  j["measured"] =
      "area-weighted samples every " + fmt::format("{:g}", q.options.accuracy.sample_spacing_m / units::mm) +
      " mm below the reconstruction's proximal cut: reconstruction (cap excluded) -> original surface, and the "
      "original's samples seen by a sensor -> reconstruction; 'symmetric' pools both";
  j["symmetric"] = deviation_json(a.symmetric);
  j["reconstructed_to_original"] = deviation_json(a.reconstructed_to_original);
  j["seen_original_to_reconstructed"] = deviation_json(a.seen_original_to_reconstructed);
  j["unseen_original_to_reconstructed"] = deviation_json(a.unseen_original_to_reconstructed);
  j["seen_area_fraction"] = a.seen_area_fraction;
  j["compensation"] = q.sources.compensation.empty() ? std::string("none") : q.sources.compensation;
  j["outputs"] = {(out / "recording").string(), (out / "reconstruction.stl").string(),
                  (out / "original_centred.stl").string(), (out / "report.json").string()};
  return j;
}

/// report.json of the registration experiment (without its wall time).
nlohmann::json registration_report(const RegistrationExperimentRequest& q, const RegistrationExperimentResult& r,
                                   const std::vector<std::string>& names) {
  const RegistrationExperimentOptions& o = q.options;
  const auto poses_json = [&](const std::vector<PoseError>& e) { return pose_errors_json(names, e); };
  nlohmann::json j;
  j["command"] = "socketsmith scan experiment registration";
  j["seed"] = o.simulation.seed;
  j["noise_scale"] = o.simulation.error.scale;
  j["calibration"] = intrinsics_label(q.sources);
  j["box_yaw_deg"] = o.box_yaw_deg;
  j["start_pose_error"] = {{"deg", o.pose_error_deg}, {"mm", q.pose_error_mm}, {"seed", o.pose_seed}};
  j["reference_points"] = r.refs.point_names.size();
  j["observations"] = r.refs.observations.size();
  j["measured"] = "Table 4: distances between the world positions two sensors give one chessboard corner, over every "
                  "pair of sensors sharing a corner; pose errors against the poses the frames were rendered with";
  j["corner_depth"] = q.corner_depth;
  j["reference_point_errors"] = reference_accuracy_json(r.accuracy);
  j["at_hand_measured_poses"] = pair_errors_json(r.sequential.initial);
  j["at_true_poses"] = pair_errors_json(r.truth_errors);
  j["sequential"] = registration_json(r.sequential);
  j["multiset"] = registration_json(r.multiset);
  j["pose_errors"] = {{"hand_measured", poses_json(r.measured_pose_errors)},
                      {"sequential", poses_json(r.sequential_pose_errors)},
                      {"multiset", poses_json(r.multiset_pose_errors)}};
  if (q.sources.compensation.empty()) {
    j["compensation"] = "none (pass --compensation from 'scan experiment chessboard' with the same --seed and --calibration)";
  } else {
    j["compensation"] = q.sources.compensation;
    j["multiset_compensated"] = registration_json(r.multiset_compensated);
    j["at_true_poses_compensated"] = pair_errors_json(r.truth_errors_compensated);
    j["reference_point_errors_compensated"] = reference_accuracy_json(r.accuracy_compensated);
    j["pose_errors"]["multiset_compensated"] = poses_json(r.multiset_compensated_pose_errors);
  }
  return j;
}

/// The chessboard experiment's part of its report: the settings, Table 3's rows, the calibrations.
nlohmann::json chessboard_report(const BoardExperimentRequest& q, const ChessboardExperiment& cb) {
  nlohmann::json j;
  j["command"] = q.command;
  j["seed"] = q.options.seed;
  j["truth"] = q.truth;
  j["noise_scale"] = q.options.noise_scale;
  j["systematic_scale"] = q.options.systematic_scale;
  j["intrinsics"] = intrinsics_label(q.sources);
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
  return j;
}

/// The cylinders' rows of the report: the point clouds' errors, and the meshes' where reconstructed.
nlohmann::json cylinders_json(const CylinderExperiment& cy) {
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& r : cy.rows) {
    nlohmann::json e = {{"diameter_mm", r.diameter_m * 1e3},
                        {"cloud_raw", error_json(r.cloud_raw)},
                        {"cloud_compensated", error_json(r.cloud_compensated)}};
    if (r.mesh_done) {
      e["mesh_raw"] = error_json(r.mesh_raw);
      e["mesh_compensated"] = error_json(r.mesh_compensated);
    }
    rows.push_back(e);
  }
  return rows;
}

}  // namespace

LimbExperimentRun run_limb_experiment(const LimbExperimentRequest& q, const fs::path& out) {
  LimbExperimentRun run;
  run.result = run_limb_scan_experiment(q.limb, q.options, q.progress);
  const LimbScanResult& r = run.result;
  ensure_directory(out);
  Recording rec = r.recording;
  rec.description = fmt::format("scan experiment limb: {} sensors around the {} (seed {}, noise scale {:g})",
                                q.options.sensors, q.limb_label, q.options.simulation.seed,
                                q.options.simulation.error.scale);
  write_recording(out / "recording", rec);
  geometry::write_mesh(out / "reconstruction.stl", r.reconstruction.mesh, units::LengthUnit::Millimetre);
  geometry::write_mesh(out / "original_centred.stl", r.original, units::LengthUnit::Millimetre);
  run.report = limb_report(q, r, out);
  run.report["timing_s"] = {
      {"simulate", r.simulate_s}, {"reconstruct", r.reconstruction.total_s}, {"total", seconds_since(q.started)}};
  write_text_atomically(out / "report.json", run.report.dump(2) + "\n");
  return run;
}

RegistrationExperimentRun run_registration_experiment(const RegistrationExperimentRequest& q, const fs::path& out) {
  RegistrationExperimentRun run;
  run.result = run_registration_experiment(q.options, q.progress);
  const RegistrationExperimentResult& r = run.result;
  ensure_directory(out);
  Recording rec = r.recording;
  for (size_t s = 0; s < rec.sensors.size(); ++s) rec.sensors[s].world_from_sensor = r.measured[s];
  rec.description = fmt::format("scan experiment registration: the box turned {:g} deg, seed {}, noise scale {:g}; "
                                "poses in rig.json are the perturbed (hand-measured) ones",
                                q.options.box_yaw_deg, q.options.simulation.seed, q.options.simulation.error.scale);
  write_recording(out / "box_recording", rec);
  std::vector<std::string> names;
  for (const auto& s : r.rig) names.push_back(s.name);
  write_rig_file(out / "rig_true.json", names, r.truth);
  write_rig_file(out / "rig_multiset.json", names, r.multiset.world_from_sensor, registration_json(r.multiset).dump());
  write_rig_file(out / "rig_sequential.json", names, r.sequential.world_from_sensor,
                 registration_json(r.sequential).dump());
  run.report = registration_report(q, r, names);
  run.report["wall_s"] = seconds_since(q.started);
  write_text_atomically(out / "report.json", run.report.dump(2) + "\n");
  return run;
}

BoardExperimentRun run_board_experiment(const BoardExperimentRequest& q, const fs::path& out) {
  ensure_directory(out);
  BoardExperimentRun run;
  run.chessboard = run_chessboard_experiment(q.options, q.progress);
  std::vector<ErrorCompensation> models;
  for (const auto& c : run.chessboard.calibrations) models.push_back(c.model);
  write_compensation_json(out / "compensation.json", models);
  run.report = chessboard_report(q, run.chessboard);
  if (q.cylinders) {
    run.cylinders =
        run_cylinder_experiment(run.chessboard, q.options, {0.10, 0.16, 0.21}, q.reconstruct_meshes, 0.3, q.progress);
    run.report["cylinders"] = cylinders_json(*run.cylinders);
  }
  run.report["wall_s"] = seconds_since(q.started);
  write_text_atomically(out / (q.cylinders ? "cylinders.json" : "chessboard.json"), run.report.dump(2) + "\n");
  return run;
}

}  // namespace socketsmith::scan
