#include "socketsmith/scan/recording.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/json_input.h"

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

void validate_pattern(const ChessboardPattern& p, const std::string& what) {
  require(p.inner_cols >= 2 && p.inner_rows >= 2 && p.inner_cols <= 100 && p.inner_rows <= 100,
          "{}: chessboard of {}x{} inner corners (expected 2 to 100 each way)", what, p.inner_cols, p.inner_rows);
  require(std::isfinite(p.square_m) && p.square_m > 0.0 && p.square_m < 1.0,
          "{}: chessboard square {} m is not valid (expected metres, e.g. 0.06)", what, p.square_m);
}

namespace {

/// Files of @p sub whose names start with @p prefix and end in .png, sorted.
std::vector<fs::path> list_frames(const fs::path& sub, const std::string& prefix) {
  std::vector<fs::path> files;
  if (!fs::is_directory(sub)) return files;
  for (const auto& e : fs::directory_iterator(sub)) {
    const std::string n = e.path().filename().string();
    if (n.rfind(prefix, 0) == 0 && e.path().extension() == ".png") files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}


/// Parses rig.json from @p in (opened by the caller on @p rig_path) and checks its "sensors" array.
nlohmann::json read_rig_json(std::ifstream& in, const fs::path& rig_path) {
  if (!in) fail<IoError>("read_recording: '{}' is missing (a recording needs rig.json, see docs/scan.md)", rig_path.string());
  nlohmann::json rig = parse_json_stream(in, rig_path.string(), "read_recording");
  require(rig.is_object() && rig.contains("sensors") && rig["sensors"].is_array() && !rig["sensors"].empty(),
          "read_recording: '{}' has no \"sensors\" array (expected one entry per depth sensor)", rig_path.string());
  return rig;
}

/// rig.json's optional "chessboard" {inner_cols, inner_rows, square_mm} and "frames_per_pose".
void read_board_settings(const nlohmann::json& rig, const fs::path& rig_path, Recording& rec) {
  if (rig.contains("chessboard")) {
    const auto& c = rig["chessboard"];
    const std::string what = fmt::format("read_recording: \"chessboard\" in '{}'", rig_path.string());
    require(c.is_object() && c.contains("inner_cols") && c.contains("inner_rows") && c.contains("square_mm"),
            "{}: expected {{\"inner_cols\", \"inner_rows\", \"square_mm\"}}", what);
    try {
      ChessboardPattern p;
      p.inner_cols = c["inner_cols"].get<int>();
      p.inner_rows = c["inner_rows"].get<int>();
      p.square_m = c["square_mm"].get<double>() * 1e-3;
      validate_pattern(p, what);
      rec.chessboard = p;
    } catch (const nlohmann::json::exception&) {
      fail("{}: inner_cols, inner_rows must be integers and square_mm a number", what);
    }
  }
  if (rig.contains("frames_per_pose")) {
    const auto& n = rig["frames_per_pose"];
    require(n.is_number_integer() && n.get<int>() >= 1 && n.get<int>() <= 1000,
            "read_recording: \"frames_per_pose\" in '{}' must be an integer from 1 to 1000 (consecutive frames of one "
            "board pose)",
            rig_path.string());
    rec.frames_per_pose = n.get<int>();
  }
}

void check_sensor_keys(const nlohmann::json& s, const std::string& what) {
  static const std::set<std::string> known = {"name", "intrinsics", "pose_world_from_sensor", "depth_scale_m",
                                              "frames", "ir_frames", "folder", "compensation"};
  for (const auto& [key, value] : s.items())
    require(known.count(key) > 0,
            "{}: unknown key '{}' (expected name, intrinsics, pose_world_from_sensor, depth_scale_m, frames, ir_frames, "
            "folder, compensation)",
            what, key);
}

/// The sensor's intrinsics file: "intrinsics", a path relative to the recording; default
/// <sensor>/intrinsics.json.
fs::path sensor_intrinsics_path(const nlohmann::json& s, const fs::path& folder, const fs::path& sub) {
  return s.contains("intrinsics") ? folder / s["intrinsics"].get<std::string>() : sub / "intrinsics.json";
}

/// The sensor's intrinsics (from @p intr), pose and depth scale (metres per raw unit).
void read_sensor_geometry(const nlohmann::json& s, const fs::path& intr, const std::string& what,
                          SensorRecording& sr) {
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
}

/// The files listed under @p key, else the folder's <prefix>*.png.
std::vector<fs::path> sensor_frame_files(const nlohmann::json& s, const char* key, const fs::path& sub,
                                         const std::string& prefix) {
  std::vector<fs::path> files;
  if (s.contains(key)) {
    for (const auto& f : s[key]) files.push_back(sub / f.get<std::string>());
  } else {
    files = list_frames(sub, prefix);
  }
  return files;
}

/// The depth frames, each the intrinsics' size.
void read_depth_frames(const std::vector<fs::path>& files, const fs::path& sub, const std::string& what,
                       SensorRecording& sr) {
  require(!files.empty(), "{}: no depth frames (expected {}/depth_0000.png ...)", what, sub.string());
  for (const fs::path& f : files) {
    DepthImage d = read_depth_png(f, sr.depth_scale_m);
    require(d.width == sr.intrinsics.width && d.height == sr.intrinsics.height,
            "{}: frame '{}' is {}x{} px but its intrinsics are for {}x{} (wrong intrinsics file?)", what,
            f.string(), d.width, d.height, sr.intrinsics.width, sr.intrinsics.height);
    sr.frames.push_back(std::move(d));
    sr.frame_files.push_back(f.filename().string());
  }
}

/// The IR frames: none, or one per depth frame, pixel-aligned with them.
void read_ir_frames(const std::vector<fs::path>& ir_files, std::size_t depth_frames, const std::string& what,
                    SensorRecording& sr) {
  require(ir_files.empty() || ir_files.size() == depth_frames,
          "{}: {} IR frames for {} depth frames (expected none or one ir_XXXX.png per depth_XXXX.png)", what,
          ir_files.size(), depth_frames);
  for (const fs::path& f : ir_files) {
    IrImage ir = read_ir_png(f);
    require(ir.width == sr.intrinsics.width && ir.height == sr.intrinsics.height,
            "{}: IR frame '{}' is {}x{} px but the depth frames are {}x{} (IR must be pixel-aligned with depth)",
            what, f.string(), ir.width, ir.height, sr.intrinsics.width, sr.intrinsics.height);
    sr.ir_frames.push_back(std::move(ir));
  }
}

/// One entry of rig.json's "sensors"; @p names collects the names seen, which must be unique.
SensorRecording read_sensor(const nlohmann::json& s, const fs::path& folder, const fs::path& rig_path,
                            std::set<std::string>& names) {
  require(s.is_object() && s.contains("name") && s["name"].is_string(),
          "read_recording: '{}': a sensor has no \"name\"", rig_path.string());
  SensorRecording sr;
  sr.name = s["name"].get<std::string>();
  const std::string what = fmt::format("read_recording: sensor '{}' in '{}'", sr.name, rig_path.string());
  require(names.insert(sr.name).second, "{}: the name is used twice", what);
  check_sensor_keys(s, what);
  const fs::path sub = folder / s.value("folder", sr.name);
  const fs::path intr = sensor_intrinsics_path(s, folder, sub);
  read_sensor_geometry(s, intr, what, sr);
  const std::vector<fs::path> files = sensor_frame_files(s, "frames", sub, "depth_");
  read_depth_frames(files, sub, what, sr);
  const std::vector<fs::path> ir_files = sensor_frame_files(s, "ir_frames", sub, "ir_");
  read_ir_frames(ir_files, files.size(), what, sr);
  if (s.contains("compensation")) {
    const fs::path model = folder / s["compensation"].get<std::string>();
    sr.compensation = compensation_for(read_compensation_json(model), sr.name, sr.intrinsics.width,
                                       sr.intrinsics.height, model.string());
  }
  return sr;
}

}  // namespace

Recording read_recording(const fs::path& folder) {
  if (!fs::is_directory(folder))
    fail<IoError>("read_recording: recording folder '{}' not found", folder.string());
  const fs::path rig_path = folder / "rig.json";
  // Opened here and kept open to the end, as the paths and file lists of read_sensor live to its
  // end: scan reconstruct's surface depends on the heap's state (reconstruction.cpp), so the
  // order of allocations and frees here is part of its output.
  std::ifstream in(rig_path);
  const nlohmann::json rig = read_rig_json(in, rig_path);
  Recording rec;
  rec.description = rig.value("description", std::string());
  read_board_settings(rig, rig_path, rec);
  std::set<std::string> names;
  for (const auto& s : rig["sensors"]) rec.sensors.push_back(read_sensor(s, folder, rig_path, names));
  return rec;
}

Recording recording_from_frames(const std::vector<fs::path>& frames, const fs::path& intrinsics,
                                double depth_scale_m) {
  require(!frames.empty(), "recording_from_frames: no depth frames given");
  require(std::isfinite(depth_scale_m) && depth_scale_m > 0.0 && depth_scale_m < 1.0,
          "recording_from_frames: depth scale {} is not valid (expected metres per raw unit, e.g. 0.001 for mm, "
          "0.0002 for TUM)",
          depth_scale_m);
  if (intrinsics.empty())
    fail("recording_from_frames: no intrinsics given for the depth frames (pass the camera's intrinsics: the "
         "project's intrinsics.json, an Open3D camera json or an iai_kinect2 calib_ir.yaml)");
  if (!fs::exists(intrinsics))
    fail<IoError>("recording_from_frames: intrinsics '{}' not found (expected the project's intrinsics.json, an Open3D "
                  "camera json or an iai_kinect2 calib_ir.yaml)",
                  intrinsics.string());
  SensorRecording sr;
  sr.name = "frame";
  sr.intrinsics = read_intrinsics(intrinsics);
  sr.depth_scale_m = depth_scale_m;
  for (const fs::path& f : frames) {
    DepthImage d = read_depth_png(f, depth_scale_m);
    require(d.width == sr.intrinsics.width && d.height == sr.intrinsics.height,
            "recording_from_frames: frame '{}' is {}x{} px but the intrinsics '{}' are for {}x{} (wrong intrinsics "
            "file?)",
            f.string(), d.width, d.height, intrinsics.string(), sr.intrinsics.width, sr.intrinsics.height);
    sr.frames.push_back(std::move(d));
    sr.frame_files.push_back(f.filename().string());
  }
  Recording rec;
  rec.description = fmt::format("{} loose depth frame(s) of one camera", frames.size());
  rec.sensors.push_back(std::move(sr));
  return rec;
}

void write_recording(const fs::path& folder, const Recording& rec) {
  require(!rec.sensors.empty(), "write_recording: no sensors to write");
  ensure_directory(folder);
  nlohmann::ordered_json rig;
  rig["format"] = "socketsmith-scan-recording";
  rig["version"] = 1;
  if (!rec.description.empty()) rig["description"] = rec.description;
  if (rec.chessboard) {
    validate_pattern(*rec.chessboard, "write_recording");
    rig["chessboard"] = {{"inner_cols", rec.chessboard->inner_cols},
                         {"inner_rows", rec.chessboard->inner_rows},
                         {"square_mm", rec.chessboard->square_m * 1e3}};
  }
  if (rec.frames_per_pose != 1) {
    require(rec.frames_per_pose >= 1, "write_recording: frames_per_pose {} must be at least 1", rec.frames_per_pose);
    rig["frames_per_pose"] = rec.frames_per_pose;
  }
  rig["sensors"] = nlohmann::ordered_json::array();
  for (const SensorRecording& s : rec.sensors) {
    require(!s.name.empty() && s.name.find_first_of("/\\") == std::string::npos,
            "write_recording: sensor name '{}' is not a valid folder name", s.name);
    require(!s.frames.empty(), "write_recording: sensor '{}' has no frames", s.name);
    require(s.ir_frames.empty() || s.ir_frames.size() == s.frames.size(),
            "write_recording: sensor '{}' has {} IR frames for {} depth frames (expected none or one each)", s.name,
            s.ir_frames.size(), s.frames.size());
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
    if (s.compensation) {
      write_compensation_json(sub / "compensation.json", {*s.compensation});
      j["compensation"] = s.name + "/compensation.json";
    }
    for (size_t f = 0; f < s.frames.size(); ++f) write_depth_png(sub / fmt::format("depth_{:04d}.png", f), s.frames[f]);
    for (size_t f = 0; f < s.ir_frames.size(); ++f) write_ir_png(sub / fmt::format("ir_{:04d}.png", f), s.ir_frames[f]);
    rig["sensors"].push_back(j);
  }
  write_text_atomically(folder / "rig.json", rig.dump(2) + "\n");
}

}  // namespace socketsmith::scan
