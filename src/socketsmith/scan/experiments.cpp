#include "socketsmith/scan/experiments.h"

#include <chrono>
#include <cmath>

#include <fmt/format.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/scan/reconstruction.h"

namespace socketsmith::scan {
namespace {

using Clock = std::chrono::steady_clock;

SensorErrorModel base_model(const ExperimentOptions& o) {
  SensorErrorModel m = scale_systematic_errors(SensorErrorModel{}, o.systematic_scale);
  m.scale = o.noise_scale;
  return m;
}

}  // namespace

SurfaceError cylinder_error(const std::vector<Eigen::Vector3d>& points, double radius_m, double half_band_m) {
  SurfaceError e;
  double sum2 = 0.0, sum = 0.0;
  for (const Eigen::Vector3d& p : points) {
    if (std::abs(p.z()) > half_band_m) continue;
    const double d = (std::hypot(p.x(), p.y()) - radius_m) * 1e3;
    sum2 += d * d;
    sum += d;
    e.max_mm = std::max(e.max_mm, std::abs(d));
    ++e.count;
  }
  if (e.count > 0) {
    e.rmse_mm = std::sqrt(sum2 / e.count);
    e.mean_mm = sum / e.count;
  }
  return e;
}

SurfaceError cylinder_error(const geometry::TriMesh& mesh, double radius_m, double half_band_m) {
  std::vector<Eigen::Vector3d> samples = mesh.vertices;
  for (const auto& t : mesh.triangles)
    samples.push_back((mesh.vertices[static_cast<size_t>(t[0])] + mesh.vertices[static_cast<size_t>(t[1])] +
                       mesh.vertices[static_cast<size_t>(t[2])]) / 3.0);
  return cylinder_error(samples, radius_m, half_band_m);
}

ChessboardExperiment run_chessboard_experiment(const ExperimentOptions& o, const ProgressCallback& progress) {
  require(o.sensors >= 1 && o.sensors <= 8, "chessboard experiment: {} sensors (expected 1 to 8)", o.sensors);
  require(o.test_frames_per_distance >= 1 && o.test_frames_per_distance <= 30,
          "chessboard experiment: {} test frames per distance (expected 1 to 30)", o.test_frames_per_distance);
  const auto t0 = Clock::now();
  ChessboardExperiment x;
  x.rig = default_rig(o.sensors, 0.75, 0.0, Vec3::Zero(), o.intrinsics);
  x.base_error = base_model(o);
  CalibrationSessionOptions train;
  train.simulation.seed = o.seed;
  train.simulation.frames = o.training_frames;
  train.simulation.error = x.base_error;
  train.frames_per_pose = o.board_frames_per_pose;
  const ProgressCallback simulating = [&progress](double f, std::string_view what) {
    return report_progress(progress, 0.35 * f, what);
  };
  const Recording training = simulate_calibration_session(x.rig, train, simulating);
  SensorCalibrationOptions co;
  co.truth = o.truth;
  co.chessboard.corner_depth = o.training_corner_depth;
  co.form = o.form;
  co.frames_per_pose = o.board_frames_per_pose;
  co.depth_degree = o.depth_degree;
  co.refine_distortion = o.refine_distortion;
  for (size_t s = 0; s < training.sensors.size(); ++s) {
    x.calibrations.push_back(calibrate_sensor(training.sensors[s], *training.chessboard, co));
    report_progress(progress, 0.35 + 0.3 * (s + 1) / training.sensors.size(), "learning the error models");
  }
  // Held-out frames: the same units (seed), other poses and noise, at the thesis's distances.
  const double distances[3] = {0.60, 0.75, 0.90};
  std::vector<EdgeErrors> raw_all(x.rig.size()), comp_all(x.rig.size());
  std::vector<ChessboardRow> per_distance;
  for (int q = 0; q < 3; ++q) {
    CalibrationSessionOptions test = train;
    test.simulation.frames = o.test_frames_per_distance;
    test.frames_per_pose = 1;
    test.min_distance_m = test.max_distance_m = distances[q];
    test.frame_seed = o.seed * 7919 + 101 + static_cast<std::uint64_t>(q);
    const Recording held = simulate_calibration_session(x.rig, test);
    for (size_t s = 0; s < held.sensors.size(); ++s) {
      const SensorRecording& sr = held.sensors[s];
      EdgeErrors raw, comp;
      for (size_t f = 0; f < sr.frames.size(); ++f) {
        const auto uv = find_chessboard_corners(sr.ir_frames[f], *held.chessboard);
        if (!uv) {
          ++x.test_frames_missed;
          continue;
        }
        const ChessboardDetection det = corners_to_3d(*uv, sr.frames[f], sr.intrinsics, *held.chessboard);
        const auto p_raw = compensated_corners(det, nullptr);
        const auto p_comp = compensated_corners(det, &x.calibrations[s].model);
        raw.add(det, p_raw);
        comp.add(det, p_comp);
        raw_all[s].add(det, p_raw);
        comp_all[s].add(det, p_comp);
      }
      per_distance.push_back({sr.name, distances[q], raw.stats(), comp.stats()});
    }
    report_progress(progress, 0.65 + 0.35 * (q + 1) / 3.0, "measuring held-out frames");
  }
  for (size_t s = 0; s < x.rig.size(); ++s) {
    x.rows.push_back({x.rig[s].name, 0.0, raw_all[s].stats(), comp_all[s].stats()});
    for (const ChessboardRow& r : per_distance)
      if (r.sensor == x.rig[s].name) x.rows.push_back(r);
  }
  x.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return x;
}

CylinderExperiment run_cylinder_experiment(const ChessboardExperiment& cb, const ExperimentOptions& o,
                                           const std::vector<double>& diameters, bool meshes, double band_m,
                                           const ProgressCallback& progress) {
  require(!cb.calibrations.empty() && cb.calibrations.size() == cb.rig.size(),
          "cylinder experiment: needs the chessboard experiment's learned models (one per sensor)");
  const auto t0 = Clock::now();
  CylinderExperiment x;
  SimulationOptions so;
  so.seed = o.seed;  // the same units as the calibration session
  so.frames = o.scan_frames;
  so.error = cb.base_error;
  int step = 0;
  const int steps = static_cast<int>(diameters.size()) * (meshes ? 3 : 1);
  for (double dia : diameters) {
    CylinderRow row;
    row.diameter_m = dia;
    const Recording plain = simulate_recording(make_cylinder(dia, 0.4), cb.rig, so);
    Recording compensated = plain;
    for (size_t s = 0; s < compensated.sensors.size(); ++s) compensated.sensors[s].compensation = cb.calibrations[s].model;
    report_progress(progress, double(++step) / steps, fmt::format("cylinder {:.0f} mm: simulated", dia * 1e3));
    ReconstructionOptions ro;
    ro.back_projection.fusion = o.scan_fusion;
    for (int c = 0; c < 2; ++c) {
      const Recording& rec = c == 0 ? plain : compensated;
      PointCloud cloud = recording_point_cloud(rec, ro.back_projection);
      remove_statistical_outliers(cloud, ro.outliers);
      (c == 0 ? row.cloud_raw : row.cloud_compensated) = cylinder_error(cloud.points, dia / 2, band_m / 2);
      if (meshes) {
        const ReconstructionResult r = reconstruct_recording(rec, ro);
        (c == 0 ? row.mesh_raw : row.mesh_compensated) = cylinder_error(r.mesh, dia / 2, band_m / 2);
        report_progress(progress, double(++step) / steps,
                        fmt::format("cylinder {:.0f} mm: reconstructed {}", dia * 1e3, c == 0 ? "raw" : "compensated"));
      }
    }
    row.mesh_done = meshes;
    x.rows.push_back(row);
  }
  x.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return x;
}

}  // namespace socketsmith::scan
