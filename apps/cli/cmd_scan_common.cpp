// The `socketsmith scan` commands' shared checks and readers of flags (declared in scan_cli.h).
#include <algorithm>
#include <cmath>
#include <filesystem>

#include "cli_common.h"
#include "scan_cli.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"

namespace socketsmith::cli::scan_cli {
namespace fs = std::filesystem;

scan::SensorErrorModel error_model(double noise_scale, double systematic_scale, const char* cmd) {
  require(std::isfinite(noise_scale) && noise_scale >= 0.0,
          "{}: --noise-scale {} must be >= 0 (0: noise free, 1: default Kinect v2 errors)", cmd, noise_scale);
  require(std::isfinite(systematic_scale) && systematic_scale >= 0.0,
          "{}: --systematic-scale {} must be >= 0 (0: random errors only)", cmd, systematic_scale);
  scan::SensorErrorModel m = scan::scale_systematic_errors(scan::SensorErrorModel{}, systematic_scale);
  m.scale = noise_scale;
  return m;
}

void add_simulated_error_flags(CLI::App& cmd, std::uint64_t& seed, double& noise_scale, double& systematic_scale,
                               int& frames) {
  cmd.add_option("--seed", seed, "seed of the error model (default 1)");
  cmd.add_option("--noise-scale", noise_scale, "scale of every error term (0: noise free; default 1)");
  cmd.add_option("--systematic-scale", systematic_scale, kSystematicScaleHelp);
  cmd.add_option("--frames", frames, "frames per sensor (default 1)");
}

void add_session_flags(CLI::App& cmd, SessionFlags& f, const std::string& compensation_help) {
  cmd.add_option("--sensors", f.sensors, "number of sensors on the ring (default 4)");
  add_simulated_error_flags(cmd, f.seed, f.noise_scale, f.systematic_scale, f.frames);
  cmd.add_option("--calibration", f.calibration, "iai_kinect2 calibration folder(s), as for scan simulate");
  cmd.add_option("--compensation", f.compensation, compensation_help);
}

void add_compensation_form_flags(CLI::App& cmd, std::string& model, int& depth_degree, bool& refine_distortion) {
  cmd.add_option("--model", model, kModelHelp);
  cmd.add_option("--depth-degree", depth_degree, kDepthDegreeHelp);
  cmd.add_flag("--refine-distortion", refine_distortion, kRefineDistortionHelp);
}

void add_surface_flags(CLI::App& cmd, double& grid_mm, double& facet_mm, int& smooth) {
  cmd.add_option("--grid-mm", grid_mm, "voxel-grid simplification before Poisson [mm] (default 2.5; 0: off)");
  cmd.add_option("--facet-mm", facet_mm, "largest facet of the reconstructed surface [mm] (default 8)");
  cmd.add_option("--smooth", smooth, "Taubin smoothing iterations (default 0)");
}

double elapsed_s(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

bool print_summary_json(nlohmann::json& j, std::chrono::steady_clock::time_point t0, bool as_json) {
  j["wall_s"] = elapsed_s(t0);
  if (as_json) print_json(j);
  return as_json;
}

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

scan::CompensationForm parse_model(const std::string& name, const char* cmd) {
  if (name == "linear") return scan::CompensationForm::LinearUvd;
  if (name == "ray-poly") return scan::CompensationForm::RayPolynomial;
  fail("{}: --model '{}' is not known (expected linear or ray-poly)", cmd, name);
}

scan::CornerDepth parse_corner_depth(const std::string& name, const char* cmd) {
  if (name == "plane") return scan::CornerDepth::LocalPlane;
  if (name == "bilinear") return scan::CornerDepth::Bilinear;
  fail("{}: --corner-depth '{}' is not known (expected plane or bilinear)", cmd, name);
}

scan::TruthEstimate parse_truth(const std::string& t, const char* cmd) {
  if (t == "pnp") return scan::TruthEstimate::Pnp;
  if (t == "kabsch") return scan::TruthEstimate::Kabsch;
  fail("{}: --truth '{}' is not known (expected pnp or kabsch)", cmd, t);
}

}  // namespace socketsmith::cli::scan_cli
