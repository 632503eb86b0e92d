#include "socketsmith/scan/recording.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"

namespace socketsmith::scan {
namespace fs = std::filesystem;

Eigen::Isometry3d pose_from_rows(const std::vector<std::vector<double>>& rows, const std::string& what) {
  require(rows.size() == 4 && std::all_of(rows.begin(), rows.end(), [](const auto& r) { return r.size() == 4; }),
          "{}: pose is not a 4x4 matrix (expected 4 rows of 4 numbers, world<-sensor, metres)", what);
  Eigen::Matrix4d m;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      m(i, j) = rows[static_cast<size_t>(i)][static_cast<size_t>(j)];
      require(std::isfinite(m(i, j)), "{}: pose has a non-finite entry", what);
    }
  require(std::abs(m(3, 0)) + std::abs(m(3, 1)) + std::abs(m(3, 2)) + std::abs(m(3, 3) - 1.0) < 1e-9,
          "{}: pose's last row is not 0 0 0 1", what);
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  require((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-4 && R.determinant() > 0.0,
          "{}: pose's 3x3 block is not a rotation (expected orthonormal with det +1)", what);
  require(m.topRightCorner<3, 1>().norm() < 100.0,
          "{}: pose translation {:.1f} m is implausible (expected metres, not mm)", what,
          m.topRightCorner<3, 1>().norm());
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = R;
  pose.translation() = m.topRightCorner<3, 1>();
  return pose;
}

Recording read_recording(const fs::path& folder) {
  if (!fs::is_directory(folder))
    fail<IoError>("read_recording: recording folder '{}' not found", folder.string());
  const fs::path rig_path = folder / "rig.json";
  std::ifstream in(rig_path);
  if (!in) fail<IoError>("read_recording: '{}' is missing (a recording needs rig.json, see docs/scan.md)", rig_path.string());
  nlohmann::json rig;
  try {
    rig = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    fail("read_recording: '{}' is not valid JSON ({})", rig_path.string(), e.what());
  }
  require(rig.is_object() && rig.contains("sensors") && rig["sensors"].is_array() && !rig["sensors"].empty(),
          "read_recording: '{}' has no \"sensors\" array (expected one entry per depth sensor)", rig_path.string());
  Recording rec;
  rec.description = rig.value("description", std::string());
  std::set<std::string> names;
  for (const auto& s : rig["sensors"]) {
    require(s.is_object() && s.contains("name") && s["name"].is_string(),
            "read_recording: '{}': a sensor has no \"name\"", rig_path.string());
    SensorRecording sr;
    sr.name = s["name"].get<std::string>();
    const std::string what = fmt::format("read_recording: sensor '{}' in '{}'", sr.name, rig_path.string());
    require(names.insert(sr.name).second, "{}: the name is used twice", what);
    static const std::set<std::string> known = {"name", "intrinsics", "pose_world_from_sensor", "depth_scale_m",
                                                "frames", "folder"};
    for (const auto& [key, value] : s.items())
      require(known.count(key) > 0,
              "{}: unknown key '{}' (expected name, intrinsics, pose_world_from_sensor, depth_scale_m, frames, folder)",
              what, key);
    const fs::path sub = folder / s.value("folder", sr.name);
    // Intrinsics: a path relative to the recording; default <sensor>/intrinsics.json.
    const fs::path intr = s.contains("intrinsics") ? folder / s["intrinsics"].get<std::string>() : sub / "intrinsics.json";
    if (!fs::exists(intr))
      fail<IoError>("{}: intrinsics '{}' are missing (write intrinsics.json with fx, fy, cx, cy, width, height, or "
                    "point \"intrinsics\" to a calib_ir.yaml folder)",
                    what, intr.string());
    sr.intrinsics = read_intrinsics(intr);
    require(s.contains("pose_world_from_sensor"), "{}: \"pose_world_from_sensor\" (4x4, metres) is missing", what);
    try {
      sr.world_from_sensor =
          pose_from_rows(s["pose_world_from_sensor"].get<std::vector<std::vector<double>>>(), what);
    } catch (const nlohmann::json::exception&) {
      fail("{}: \"pose_world_from_sensor\" is not a 4x4 array of numbers", what);
    }
    sr.depth_scale_m = s.value("depth_scale_m", 1e-3);
    require(std::isfinite(sr.depth_scale_m) && sr.depth_scale_m > 0.0 && sr.depth_scale_m < 1.0,
            "{}: depth_scale_m = {} is not valid (expected metres per raw unit, e.g. 0.001 for mm)", what,
            sr.depth_scale_m);
    std::vector<fs::path> files;
    if (s.contains("frames")) {
      for (const auto& f : s["frames"]) files.push_back(sub / f.get<std::string>());
    } else if (fs::is_directory(sub)) {
      for (const auto& e : fs::directory_iterator(sub)) {
        const std::string n = e.path().filename().string();
        if (n.rfind("depth_", 0) == 0 && e.path().extension() == ".png") files.push_back(e.path());
      }
      std::sort(files.begin(), files.end());
    }
    require(!files.empty(), "{}: no depth frames (expected {}/depth_0000.png ...)", what, sub.string());
    for (const fs::path& f : files) {
      DepthImage d = read_depth_png(f, sr.depth_scale_m);
      require(d.width == sr.intrinsics.width && d.height == sr.intrinsics.height,
              "{}: frame '{}' is {}x{} px but its intrinsics are for {}x{} (wrong intrinsics file?)", what,
              f.string(), d.width, d.height, sr.intrinsics.width, sr.intrinsics.height);
      sr.frames.push_back(std::move(d));
      sr.frame_files.push_back(f.filename().string());
    }
    rec.sensors.push_back(std::move(sr));
  }
  return rec;
}

void write_recording(const fs::path& folder, const Recording& rec) {
  require(!rec.sensors.empty(), "write_recording: no sensors to write");
  ensure_directory(folder);
  nlohmann::ordered_json rig;
  rig["format"] = "socketsmith-scan-recording";
  rig["version"] = 1;
  if (!rec.description.empty()) rig["description"] = rec.description;
  rig["sensors"] = nlohmann::ordered_json::array();
  for (const SensorRecording& s : rec.sensors) {
    require(!s.name.empty() && s.name.find_first_of("/\\") == std::string::npos,
            "write_recording: sensor name '{}' is not a valid folder name", s.name);
    require(!s.frames.empty(), "write_recording: sensor '{}' has no frames", s.name);
    const fs::path sub = folder / s.name;
    ensure_directory(sub);
    write_intrinsics_json(sub / "intrinsics.json", s.intrinsics);
    nlohmann::ordered_json j;
    j["name"] = s.name;
    j["intrinsics"] = s.name + "/intrinsics.json";
    const Eigen::Matrix4d m = s.world_from_sensor.matrix();
    nlohmann::ordered_json rows = nlohmann::ordered_json::array();
    for (int i = 0; i < 4; ++i) rows.push_back({m(i, 0), m(i, 1), m(i, 2), m(i, 3)});
    j["pose_world_from_sensor"] = rows;
    j["depth_scale_m"] = s.depth_scale_m;
    for (size_t f = 0; f < s.frames.size(); ++f) {
      DepthImage d = s.frames[f];
      write_depth_png(sub / fmt::format("depth_{:04d}.png", f), d);
    }
    rig["sensors"].push_back(j);
  }
  write_text_atomically(folder / "rig.json", rig.dump(2) + "\n");
}

}  // namespace socketsmith::scan
