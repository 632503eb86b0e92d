#include "socketsmith/scan/recording_outputs.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/scan/error_compensation.h"

namespace socketsmith::scan {
namespace {

namespace fs = std::filesystem;

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// The summary of a simulation: the recording, the scene and each sensor's valid pixels.
nlohmann::json simulation_summary(const SimulationRequest& q, const Recording& rec, const fs::path& out) {
  nlohmann::json j;
  j["command"] = "socketsmith scan simulate";
  j["recording"] = out.string();
  j["scene"] = q.scene_label;
  j["seed"] = q.simulation.seed;
  j["noise_scale"] = q.simulation.error.scale;
  nlohmann::json sensors = nlohmann::json::array();
  for (const auto& s : rec.sensors)
    sensors.push_back({{"name", s.name}, {"valid_pixels", s.frames.front().count_valid()}, {"frames", s.frames.size()}});
  j["sensors"] = sensors;
  return j;
}

/// Reads the compensation, the recording or the loose frames and the rig file of @p in.
Recording read_reconstruction_input(const ReconstructionInput& in) {
  const std::vector<fs::path> frame_paths(in.frames.begin(), in.frames.end());
  std::vector<ErrorCompensation> models;
  if (!in.compensation.empty()) models = read_compensation_json(in.compensation);
  Recording rec = in.frames.empty() ? read_recording(in.recording)
                                    : recording_from_frames(frame_paths, in.intrinsics, in.depth_scale_m);
  if (!in.rig.empty()) apply_rig_file(rec, in.rig);
  for (auto& s : rec.sensors)
    if (!models.empty())
      s.compensation = compensation_for(models, s.name, s.intrinsics.width, s.intrinsics.height, in.compensation);
  return rec;
}

/// The seconds of each stage of a reconstruction, with the reading and writing around it.
nlohmann::json reconstruction_timing_json(const ReconstructionResult& r, double read_s, double write_s,
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

/// The summary of a reconstruction: the input, the point counts, the surface and its timings.
nlohmann::json reconstruction_summary(const ReconstructionInput& in, const Recording& rec,
                                      const ReconstructionResult& r, const fs::path& out) {
  const bool watertight = r.check.is_valid_closed_surface();
  nlohmann::json j;
  j["command"] = "socketsmith scan reconstruct";
  j["recording"] = in.frames.empty() ? nlohmann::json(in.recording) : nlohmann::json(in.frames);
  j["output"] = out.string();
  j["sensors"] = rec.sensors.size();
  j["compensated_sensors"] = std::count_if(rec.sensors.begin(), rec.sensors.end(),
                                           [](const auto& s) { return s.compensation.has_value(); });
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
  return j;
}

/// One sensor's entry in the calibration summary: its frames, what it learned and how well.
nlohmann::json sensor_calibration_json(const CalibrationRequest& q, const SensorRecording& s,
                                       const SensorCalibrationResult& r, const TrainingDimensionErrors& dim) {
  nlohmann::json e;
  e["name"] = s.name;
  e["frames"] = s.frames.size();
  e["frames_per_pose"] = q.options.frames_per_pose;
  e["poses_used"] = r.observations.size();
  e["skipped"] = r.skipped;
  e["corners"] = r.model.corners;
  e["fx_px"] = r.fx;
  e["fy_px"] = r.fy;
  e["corner_rms_mm"] = {{"before", r.rms_before_mm}, {"after", r.rms_after_mm}};
  e["dimension_error_mm"] = {{"before", dim.before.mean_mm}, {"after", dim.after.mean_mm}};
  e["model"] = q.model;
  return e;
}

/// The summary of a registration: the reference points, the pairs of sensors sharing them, the
/// registration's figures and how far it moved each sensor from the recording's pose.
nlohmann::json registration_summary(const RegistrationRequest& q, const RegistrationRun& run,
                                    const std::vector<Eigen::Isometry3d>& start, const fs::path& out) {
  const ReferenceSet& refs = run.refs;
  nlohmann::json j;
  j["command"] = "socketsmith scan register";
  j["recording"] = q.recording;
  j["output"] = out.string();
  j["reference_points"] = refs.point_names.size();
  j["observations"] = refs.observations.size();
  nlohmann::json shared = nlohmann::json::object();
  for (int a = 0; a < refs.num_sensors(); ++a)
    for (int b = a + 1; b < refs.num_sensors(); ++b)
      if (const int n = refs.shared(a, b); n > 0)
        shared[refs.sensor_names[static_cast<size_t>(a)] + "-" + refs.sensor_names[static_cast<size_t>(b)]] = n;
  j["shared_points"] = shared;
  j["registration"] = registration_json(run.result);
  nlohmann::json moved = nlohmann::json::array();
  for (size_t s = 0; s < start.size(); ++s) {
    const PoseError e = pose_error(run.result.world_from_sensor[s], start[s]);
    moved.push_back({{"name", refs.sensor_names[s]}, {"moved_mm", e.translation_m / units::mm},
                     {"turned_deg", e.rotation_rad * 180.0 / M_PI}});
  }
  j["pose_changes"] = moved;
  return j;
}

}  // namespace

SimulationRun run_simulation(const SimulationRequest& q, const fs::path& out) {
  SimulationRun run;
  if (q.board_session) {
    CalibrationSessionOptions session = *q.board_session;
    session.simulation = q.simulation;
    run.recording = simulate_calibration_session(q.sensors, session, q.progress);
  } else {
    run.recording = simulate_recording(q.scene, q.sensors, q.simulation, q.progress);
  }
  run.recording.description =
      fmt::format("simulated Kinect v2 rig ({} sensors, radius {:g} mm, seed {}, noise scale {:g}): {}",
                  q.sensors.size(), q.radius_mm, q.simulation.seed, q.simulation.error.scale, q.scene_label);
  write_recording(out, run.recording);
  run.summary = simulation_summary(q, run.recording, out);
  return run;
}

ReconstructionRun run_reconstruction(const ReconstructionRequest& q, const fs::path& out) {
  report_progress(q.progress, 0.0, "reading the recording");
  const Recording rec = read_reconstruction_input(q.input);
  ReconstructionOptions options = q.options;
  if (!q.input.frames.empty()) options.cut_proximal = false;
  const double read_s = seconds_since(q.started);
  ReconstructionRun run;
  run.result = reconstruct_recording(rec, options, q.progress);
  run.sensors = rec.sensors.size();
  const auto write_start = std::chrono::steady_clock::now();
  geometry::write_mesh(out, run.result.mesh, units::LengthUnit::Millimetre);
  const double write_s = seconds_since(write_start);
  run.summary = reconstruction_summary(q.input, rec, run.result, out);
  run.summary["timing_s"] = reconstruction_timing_json(run.result, read_s, write_s, seconds_since(q.started));
  return run;
}

CalibrationRun run_calibration(const Recording& recording, const CalibrationRequest& q, const fs::path& out) {
  CalibrationRun run;
  nlohmann::json sensors = nlohmann::json::array();
  for (const auto& s : recording.sensors) {
    const SensorCalibrationResult r = calibrate_sensor(s, q.pattern, q.options, q.progress);
    run.models.push_back(r.model);
    const TrainingDimensionErrors dim = training_dimension_errors(r);
    sensors.push_back(sensor_calibration_json(q, s, r, dim));
    if (q.on_sensor) q.on_sensor(s, r, dim);
  }
  write_compensation_json(out, run.models);
  nlohmann::json& j = run.summary;
  j["command"] = "socketsmith scan calibrate";
  j["recording"] = q.recording;
  j["output"] = out.string();
  j["truth"] = q.truth;
  j["pattern"] = {{"inner_cols", q.pattern.inner_cols},
                  {"inner_rows", q.pattern.inner_rows},
                  {"square_mm", q.pattern.square_m * 1e3}};
  j["sensors"] = sensors;
  return run;
}

RegistrationRun run_registration(const RegistrationRequest& q, const fs::path& out) {
  report_progress(q.progress, 0.0, "reading the box recording");
  const Recording rec = read_recording(q.recording);
  std::vector<Eigen::Isometry3d> start;
  for (const auto& s : rec.sensors) start.push_back(s.world_from_sensor);
  report_progress(q.progress, 0.2, "finding the chessboard corners");
  RegistrationRun run;
  run.refs = box_reference_points(rec, start, q.detection);
  report_progress(q.progress, 0.8, "registering");
  run.result = q.sequential ? register_sequential(run.refs, start) : register_multiset(run.refs, start);
  run.summary = registration_summary(q, run, start, out);
  write_rig_file(out, run.refs.sensor_names, run.result.world_from_sensor, registration_json(run.result).dump());
  return run;
}

}  // namespace socketsmith::scan
