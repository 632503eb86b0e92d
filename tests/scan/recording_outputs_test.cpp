// The runs on recordings as `scan simulate|reconstruct|calibrate|register` run them: each run
// writes its file, and its summary holds the keys and values the CLI prints — the inputs as given,
// the results, the output's name.
#include "socketsmith/scan/recording_outputs.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "scan_fixtures.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/scan/error_compensation.h"

namespace socketsmith::scan {
namespace {

namespace fs = std::filesystem;

nlohmann::json read_json(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

/// A noise-free recording of a 120 mm cylinder by a ring of four sensors.
SimulationRun simulate_cylinder(const fs::path& out) {
  SimulationRequest q;
  q.scene.mesh = make_cylinder(0.12, 0.30);
  q.scene_label = "test cylinder";
  q.sensors = default_rig(4);
  q.simulation.error.scale = 0.0;
  q.simulation.seed = 3;
  return run_simulation(q, out);
}

TEST(RecordingOutputs, a_simulation_writes_the_recording_with_a_description_of_the_rig_and_the_scene) {
  const fs::path out = test::temp_dir("recording_outputs_simulation") / "recording";
  const SimulationRun run = simulate_cylinder(out);
  const Recording written = read_recording(out);
  ASSERT_EQ(written.sensors.size(), 4u);
  EXPECT_EQ(written.description, run.recording.description);
  EXPECT_EQ(written.description, "simulated Kinect v2 rig (4 sensors, radius 750 mm, seed 3, noise scale 0): test cylinder");

  const nlohmann::json& j = run.summary;
  EXPECT_EQ(j["command"], "socketsmith scan simulate");
  EXPECT_EQ(j["recording"], out.string());
  EXPECT_EQ(j["scene"], "test cylinder");
  EXPECT_EQ(j["seed"], 3);
  EXPECT_EQ(j["noise_scale"], 0.0);
  ASSERT_EQ(j["sensors"].size(), 4u);
  EXPECT_EQ(j["sensors"][0]["name"], written.sensors[0].name);
  EXPECT_EQ(j["sensors"][0]["valid_pixels"], written.sensors[0].frames.front().count_valid());
  EXPECT_GT(j["sensors"][0]["valid_pixels"].get<int>(), 0);
  EXPECT_EQ(j["sensors"][0]["frames"], 1);
  EXPECT_FALSE(j.contains("wall_s")) << "the CLI adds its own wall time";
}

TEST(RecordingOutputs, a_reconstruction_writes_the_surface_in_mm_and_a_summary_with_its_timings) {
  const fs::path dir = test::temp_dir("recording_outputs_reconstruction");
  simulate_cylinder(dir / "recording");
  ReconstructionRequest q;
  q.input.recording = (dir / "recording").string();
  const ReconstructionRun run = run_reconstruction(q, dir / "surface.stl");
  EXPECT_EQ(run.sensors, 4u);

  geometry::MeshReadOptions ro;
  ro.unit = units::LengthUnit::Millimetre;
  const geometry::TriMesh surface = geometry::read_mesh(dir / "surface.stl", ro);
  EXPECT_EQ(surface.num_triangles(), run.result.mesh.num_triangles());
  const geometry::Vec3 size = geometry::bounding_box(surface).extent();
  EXPECT_NEAR(size.x(), 0.12, 0.02) << "the 120 mm cylinder, read back as mm";

  const nlohmann::json& j = run.summary;
  EXPECT_EQ(j["command"], "socketsmith scan reconstruct");
  EXPECT_EQ(j["recording"], q.input.recording);
  EXPECT_EQ(j["output"], (dir / "surface.stl").string());
  EXPECT_EQ(j["sensors"], 4);
  EXPECT_EQ(j["compensated_sensors"], 0);
  EXPECT_EQ(j["input_points"], run.result.input_points);
  EXPECT_EQ(j["triangles"], run.result.mesh.num_triangles());
  EXPECT_EQ(j["points_per_sensor"].size(), 4u);
  for (const char* t : {"read", "poisson", "reconstruct", "write", "total"}) EXPECT_TRUE(j["timing_s"].contains(t)) << t;
  EXPECT_GE(j["timing_s"]["total"].get<double>(), j["timing_s"]["reconstruct"].get<double>());
}

TEST(RecordingOutputs, loose_frames_reconstruct_without_a_proximal_cut_and_the_summary_lists_them) {
  const fs::path dir = test::temp_dir("recording_outputs_frames");
  const SimulationRun sim = simulate_cylinder(dir / "recording");
  ReconstructionRequest q;
  q.input.frames = {(dir / "recording" / sim.recording.sensors[0].name / "depth_0000.png").string()};
  q.input.intrinsics = (dir / "recording" / sim.recording.sensors[0].name / "intrinsics.json").string();
  ASSERT_TRUE(fs::exists(q.input.frames[0]));
  ASSERT_TRUE(fs::exists(q.input.intrinsics));
  q.options.open_proximal = true;
  const ReconstructionRun run = run_reconstruction(q, dir / "scene.ply");
  EXPECT_EQ(run.sensors, 1u);
  EXPECT_EQ(run.summary["recording"], nlohmann::json(q.input.frames)) << "the frames as given";
  EXPECT_TRUE(std::isnan(run.result.cut_height_m)) << "a scene of one camera is not cut";
}

TEST(RecordingOutputs, a_calibration_writes_one_model_a_sensor_and_reports_each_sensor_once) {
  const fs::path dir = test::temp_dir("recording_outputs_calibration");
  SimulationRequest sq;
  sq.sensors = default_rig(1);
  sq.scene_label = "board";
  sq.simulation.frames = 6;
  sq.board_session = CalibrationSessionOptions{};
  const SimulationRun board = run_simulation(sq, dir / "board");
  ASSERT_TRUE(board.recording.chessboard.has_value());

  CalibrationRequest q;
  q.recording = "the board recording";
  q.pattern = *board.recording.chessboard;
  q.options.min_frames = 3;
  q.truth = "pnp";
  q.model = "linear";
  int reported = 0;
  q.on_sensor = [&](const SensorRecording& s, const SensorCalibrationResult& r, const TrainingDimensionErrors&) {
    ++reported;
    EXPECT_EQ(r.model.sensor, s.name);
  };
  const CalibrationRun run = run_calibration(board.recording, q, dir / "models.json");
  EXPECT_EQ(reported, 1);
  const auto models = read_compensation_json(dir / "models.json");
  ASSERT_EQ(models.size(), 1u);
  EXPECT_EQ(models[0].sensor, "K1");

  const nlohmann::json& j = run.summary;
  EXPECT_EQ(j["command"], "socketsmith scan calibrate");
  EXPECT_EQ(j["recording"], "the board recording");
  EXPECT_EQ(j["truth"], "pnp");
  EXPECT_EQ(j["pattern"]["inner_cols"], q.pattern.inner_cols);
  EXPECT_NEAR(j["pattern"]["square_mm"].get<double>(), q.pattern.square_m * 1e3, 1e-12);
  ASSERT_EQ(j["sensors"].size(), 1u);
  EXPECT_EQ(j["sensors"][0]["name"], "K1");
  EXPECT_EQ(j["sensors"][0]["frames"], 6);
  EXPECT_EQ(j["sensors"][0]["model"], "linear");
  EXPECT_EQ(j["sensors"][0]["corners"], models[0].corners);
  EXPECT_EQ(j["sensors"][0]["dimension_error_mm"].size(), 2u);
}

TEST(RecordingOutputs, a_registration_writes_the_rig_file_with_its_figures_and_the_pose_changes) {
  const fs::path dir = test::temp_dir("recording_outputs_registration");
  SimulationRequest sq;
  // Turned 45 degrees, so that each board faces two neighbouring sensors of the ring.
  sq.scene = make_box_scene(Vec3(0.30, 0.30, 0.70), Eigen::Isometry3d(Eigen::AngleAxisd(M_PI / 4, Vec3::UnitZ())));
  sq.scene_label = "box";
  sq.sensors = default_rig(4);
  sq.simulation.error.scale = 0.0;
  run_simulation(sq, dir / "box");

  RegistrationRequest q;
  q.recording = (dir / "box").string();
  const RegistrationRun run = run_registration(q, dir / "rig.json");
  const nlohmann::json rig = read_json(dir / "rig.json");
  EXPECT_EQ(rig["registration"], registration_json(run.result));
  ASSERT_EQ(rig["sensors"].size(), 4u);

  const nlohmann::json& j = run.summary;
  EXPECT_EQ(j["command"], "socketsmith scan register");
  EXPECT_EQ(j["recording"], q.recording);
  EXPECT_EQ(j["output"], (dir / "rig.json").string());
  EXPECT_EQ(j["reference_points"], run.refs.point_names.size());
  EXPECT_EQ(j["registration"]["method"], "multi-set");
  EXPECT_FALSE(j["shared_points"].empty());
  ASSERT_EQ(j["pose_changes"].size(), 4u);
  // Noise free and rendered at the recording's own poses: the registration hardly moves them.
  EXPECT_LT(j["pose_changes"][0]["moved_mm"].get<double>(), 5.0);
}

}  // namespace
}  // namespace socketsmith::scan
