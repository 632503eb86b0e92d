#include "socketsmith/scan/registration.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <random>
#include <limits>
#include <numeric>

#include <Eigen/SVD>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/json_input.h"
#include "socketsmith/core/units.h"
#include "socketsmith/scan/sensor_calibration.h"

namespace socketsmith::scan {
namespace {

using Vec3 = Eigen::Vector3d;

/// observations[sensor] = (point, p) sorted by point.
std::vector<std::vector<std::pair<int, Vec3>>> by_sensor(const ReferenceSet& refs) {
  std::vector<std::vector<std::pair<int, Vec3>>> out(static_cast<size_t>(refs.num_sensors()));
  for (const auto& o : refs.observations) {
    require(o.sensor >= 0 && o.sensor < refs.num_sensors() && o.point >= 0 &&
                o.point < static_cast<int>(refs.point_names.size()),
            "registration: an observation refers to sensor {} / point {} out of range", o.sensor, o.point);
    out[static_cast<size_t>(o.sensor)].emplace_back(o.point, o.p);
  }
  for (auto& v : out) std::sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return out;
}

void check_initial(const ReferenceSet& refs, const std::vector<Eigen::Isometry3d>& initial,
                   const RegistrationOptions& o) {
  require(static_cast<int>(initial.size()) == refs.num_sensors(), "registration: {} starting poses for {} sensors",
          initial.size(), refs.num_sensors());
  require(refs.num_sensors() >= 2, "registration: {} sensor(s); registration needs at least 2", refs.num_sensors());
  require(o.fixed_sensor >= 0 && o.fixed_sensor < refs.num_sensors(), "registration: fixed sensor {} out of range",
          o.fixed_sensor);
  require(o.max_iterations >= 1 && o.min_shared_points >= 3, "registration: max_iterations >= 1 and "
          "min_shared_points >= 3 expected");
}

/// Largest displacement of @p points by going from pose @p a to @p b [m].
double largest_move(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, const std::vector<std::pair<int, Vec3>>& pts) {
  double m = 0.0;
  for (const auto& [id, p] : pts) m = std::max(m, (a * p - b * p).norm());
  return m;
}

}  // namespace

int ReferenceSet::shared(int a, int b) const {
  std::vector<int> pa, pb;
  for (const auto& o : observations) {
    if (o.sensor == a) pa.push_back(o.point);
    if (o.sensor == b) pb.push_back(o.point);
  }
  std::sort(pa.begin(), pa.end());
  std::sort(pb.begin(), pb.end());
  std::vector<int> both;
  std::set_intersection(pa.begin(), pa.end(), pb.begin(), pb.end(), std::back_inserter(both));
  return static_cast<int>(both.size());
}

Eigen::Isometry3d kabsch(const std::vector<Vec3>& src, const std::vector<Vec3>& dst) {
  require(src.size() == dst.size(), "kabsch: {} source but {} destination points", src.size(), dst.size());
  require(src.size() >= 3, "kabsch: {} point pairs (at least 3 non-collinear ones are needed)", src.size());
  Vec3 cs = Vec3::Zero(), cd = Vec3::Zero();
  for (size_t i = 0; i < src.size(); ++i) {
    cs += src[i];
    cd += dst[i];
  }
  cs /= static_cast<double>(src.size());
  cd /= static_cast<double>(src.size());
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < src.size(); ++i) H += (src[i] - cs) * (dst[i] - cd).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d sv = svd.singularValues();
  require(sv(1) > 1e-12 * std::max(1.0, sv(0)),
          "kabsch: the {} reference points are collinear (the rotation about their line is undetermined)", src.size());
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = svd.matrixV() * D * svd.matrixU().transpose();
  T.translation() = cd - T.linear() * cs;
  return T;
}

PairErrors pair_errors(const ReferenceSet& refs, const std::vector<Eigen::Isometry3d>& pose) {
  require(static_cast<int>(pose.size()) == refs.num_sensors(), "pair_errors: {} poses for {} sensors", pose.size(),
          refs.num_sensors());
  std::vector<std::vector<std::pair<int, Vec3>>> per_point(refs.point_names.size());
  for (const auto& o : refs.observations)
    per_point[static_cast<size_t>(o.point)].emplace_back(o.sensor, pose[static_cast<size_t>(o.sensor)] * o.p);
  PairErrors e;
  e.min_m = std::numeric_limits<double>::infinity();
  double sum = 0.0, sum2 = 0.0;
  for (const auto& seen : per_point)
    for (size_t a = 0; a < seen.size(); ++a)
      for (size_t b = a + 1; b < seen.size(); ++b) {
        const double d = (seen[a].second - seen[b].second).norm();
        sum += d;
        sum2 += d * d;
        e.min_m = std::min(e.min_m, d);
        e.max_m = std::max(e.max_m, d);
        ++e.pairs;
      }
  if (e.pairs == 0) {
    e.min_m = 0.0;
    return e;
  }
  e.mean_m = sum / e.pairs;
  e.rms_m = std::sqrt(sum2 / e.pairs);
  return e;
}

nlohmann::json pair_errors_json(const PairErrors& e) {
  return {{"mean_mm", e.mean_m / units::mm}, {"rms_mm", e.rms_m / units::mm}, {"min_mm", e.min_m / units::mm},
          {"max_mm", e.max_m / units::mm}, {"pairs", e.pairs}};
}

nlohmann::json registration_json(const RegistrationResult& r) {
  return {{"method", r.method}, {"iterations", r.iterations}, {"converged", r.converged},
          {"initial", pair_errors_json(r.initial)}, {"final", pair_errors_json(r.final)}};
}

namespace {

/// The result a registration @p method starts from: @p initial (checked) and its errors.
RegistrationResult start_registration(const ReferenceSet& refs, const std::vector<Eigen::Isometry3d>& initial,
                                      const RegistrationOptions& o, const char* method) {
  check_initial(refs, initial, o);
  RegistrationResult r;
  r.method = method;
  r.world_from_sensor = initial;
  r.initial = pair_errors(refs, initial);
  return r;
}

}  // namespace

RegistrationResult register_multiset(const ReferenceSet& refs, const std::vector<Eigen::Isometry3d>& initial,
                                     const RegistrationOptions& o) {
  RegistrationResult r = start_registration(refs, initial, o, "multi-set");
  const auto obs = by_sensor(refs);
  const int n = refs.num_sensors();
  // who[point] = sensors that saw it.
  std::vector<std::vector<std::pair<int, Vec3>>> who(refs.point_names.size());
  for (const auto& ob : refs.observations) who[static_cast<size_t>(ob.point)].emplace_back(ob.sensor, ob.p);
  for (int s = 0; s < n; ++s) {
    int shared = 0;
    for (const auto& [id, p] : obs[static_cast<size_t>(s)]) shared += who[static_cast<size_t>(id)].size() > 1 ? 1 : 0;
    require(shared >= o.min_shared_points,
            "scan register: sensor '{}' shares {} reference point(s) with the other sensors (expected at least {}): the "
            "sensors do not overlap on the box; turn the box so each chessboard faces two neighbouring sensors, or check "
            "that '{}' sees its boards",
            refs.sensor_names[static_cast<size_t>(s)], shared, o.min_shared_points,
            refs.sensor_names[static_cast<size_t>(s)]);
  }
  for (int it = 1; it <= o.max_iterations; ++it) {
    double moved = 0.0;
    for (int s = 0; s < n; ++s) {
      if (s == o.fixed_sensor) continue;
      // PS1: every point of s shared with another sensor (in s's frame); PS2: its counterparts in
      // the world by the other sensors' current poses (one pair per other sensor).
      std::vector<Vec3> src, dst;
      for (const auto& [id, p] : obs[static_cast<size_t>(s)])
        for (const auto& [other, q] : who[static_cast<size_t>(id)]) {
          if (other == s) continue;
          src.push_back(p);
          dst.push_back(r.world_from_sensor[static_cast<size_t>(other)] * q);
        }
      const Eigen::Isometry3d next = kabsch(src, dst);
      moved = std::max(moved, largest_move(r.world_from_sensor[static_cast<size_t>(s)], next, obs[static_cast<size_t>(s)]));
      r.world_from_sensor[static_cast<size_t>(s)] = next;
    }
    r.iterations = it;
    if (moved < o.tolerance_m) {
      r.converged = true;
      break;
    }
  }
  r.final = pair_errors(refs, r.world_from_sensor);
  return r;
}

RegistrationResult register_sequential(const ReferenceSet& refs, const std::vector<Eigen::Isometry3d>& initial,
                                       const RegistrationOptions& o) {
  RegistrationResult r = start_registration(refs, initial, o, "sequential");
  const auto obs = by_sensor(refs);
  const int n = refs.num_sensors();
  for (int k = 1; k < n; ++k) {
    const int prev = (o.fixed_sensor + k - 1) % n, s = (o.fixed_sensor + k) % n;
    std::vector<Vec3> src, dst;
    const auto& a = obs[static_cast<size_t>(s)];
    const auto& b = obs[static_cast<size_t>(prev)];
    size_t j = 0;
    for (const auto& [id, p] : a) {
      while (j < b.size() && b[j].first < id) ++j;
      if (j < b.size() && b[j].first == id) {
        src.push_back(p);
        dst.push_back(r.world_from_sensor[static_cast<size_t>(prev)] * b[j].second);
      }
    }
    require(static_cast<int>(src.size()) >= o.min_shared_points,
            "scan register: sensor '{}' shares {} reference point(s) with '{}' (expected at least {}): sequential "
            "registration needs each sensor to see a board with the previous one; the sensors do not overlap",
            refs.sensor_names[static_cast<size_t>(s)], src.size(), refs.sensor_names[static_cast<size_t>(prev)],
            o.min_shared_points);
    r.world_from_sensor[static_cast<size_t>(s)] = kabsch(src, dst);
  }
  r.iterations = 1;
  r.converged = true;
  r.final = pair_errors(refs, r.world_from_sensor);
  return r;
}

namespace {

/// One chessboard found by one sensor: its corners (compensated when the sensor has a model) and
/// their centroid in the world by the approximate pose [m].
struct BoxBoardDetection {
  int sensor;
  ChessboardDetection det;
  Vec3 centroid_world;
};

/// The boards sensor @p s sees on the static box (in the depth frames' median and the IR frames'
/// mean), those with at least 3 corners with depth appended to @p dets.
void detect_box_boards(const SensorRecording& sr, int s, const Eigen::Isometry3d& approx,
                       const ChessboardPattern& pattern, const BoxDetectionOptions& o,
                       std::vector<BoxBoardDetection>& dets) {
  require(!sr.ir_frames.empty(),
          "scan register: sensor '{}' has no IR frames (ir_0000.png …): the chessboard corners are found in the IR "
          "image",
          sr.name);
  // The box is static: the depth frames' median and the IR frames' mean (less IR noise).
  const DepthImage depth = fuse_frames(sr.frames, FrameFusion::Median);
  const auto boards = find_all_chessboard_corners(mean_of_ir_frames(sr.ir_frames), pattern, o.chessboard.upsample,
                                                  o.max_boards_per_sensor);
  require(!boards.empty(),
          "chessboard not found in {}/{}{} (expected {}x{} inner corners on the box: check that the boards are in view "
          "and rig.json's \"chessboard\")",
          sr.name, "ir_0000.png",
          sr.ir_frames.size() > 1 ? fmt::format(" and the mean of its {} IR frames", sr.ir_frames.size()) : "",
          pattern.inner_cols, pattern.inner_rows);
  for (const auto& uv : boards) {
    BoxBoardDetection d{s, corners_to_3d(uv, depth, sr.intrinsics, pattern, o.chessboard), Vec3::Zero()};
    // The sensor's learned error compensation, when it has one: (I − ε(u, v, d)) P per corner.
    if (sr.compensation) {
      const std::vector<Vec3> fixed = compensated_corners(d.det, &*sr.compensation);
      for (size_t c = 0; c < fixed.size(); ++c) d.det.corners[c].point = fixed[c];
    }
    int count = 0;
    for (const auto& c : d.det.corners)
      if (c.has_depth()) {
        d.centroid_world += approx * c.point;
        ++count;
      }
    if (count < 3) continue;
    d.centroid_world /= count;
    dets.push_back(std::move(d));
  }
}

/// Physical boards: union of detections of different sensors whose world centroids are closer
/// than same_board_distance_m. Returns each detection's board, numbered 0.. in order of first
/// detection; @p boards is their count.
std::vector<int> physical_boards(const std::vector<BoxBoardDetection>& dets, const BoxDetectionOptions& o,
                                 int& boards) {
  std::vector<int> board(dets.size());
  std::iota(board.begin(), board.end(), 0);
  std::function<int(int)> root = [&](int x) { return board[static_cast<size_t>(x)] == x ? x : board[static_cast<size_t>(x)] = root(board[static_cast<size_t>(x)]); };
  for (size_t a = 0; a < dets.size(); ++a)
    for (size_t b = a + 1; b < dets.size(); ++b)
      if (dets[a].sensor != dets[b].sensor &&
          (dets[a].centroid_world - dets[b].centroid_world).norm() < o.same_board_distance_m)
        board[static_cast<size_t>(root(static_cast<int>(a)))] = root(static_cast<int>(b));
  std::vector<int> board_id(dets.size(), -1);
  boards = 0;
  for (size_t a = 0; a < dets.size(); ++a) {
    const int rt = root(static_cast<int>(a));
    if (board_id[static_cast<size_t>(rt)] < 0) board_id[static_cast<size_t>(rt)] = boards++;
  }
  std::vector<int> of_detection(dets.size());
  for (size_t a = 0; a < dets.size(); ++a) of_detection[a] = board_id[static_cast<size_t>(root(static_cast<int>(a)))];
  return of_detection;
}

}  // namespace

ReferenceSet box_reference_points(const Recording& rec, const std::vector<Eigen::Isometry3d>& approx,
                                  const BoxDetectionOptions& o) {
  require(rec.chessboard.has_value(),
          "scan register: the recording has no chessboard pattern (rig.json \"chessboard\": inner_cols, inner_rows, "
          "square_mm); record the registration box with its boards");
  require(approx.size() == rec.sensors.size(), "box_reference_points: {} poses for {} sensors", approx.size(),
          rec.sensors.size());
  const ChessboardPattern& pattern = *rec.chessboard;
  std::vector<BoxBoardDetection> dets;
  ReferenceSet refs;
  for (size_t s = 0; s < rec.sensors.size(); ++s) {
    refs.sensor_names.push_back(rec.sensors[s].name);
    detect_box_boards(rec.sensors[s], static_cast<int>(s), approx[s], pattern, o, dets);
  }
  int boards = 0;
  const std::vector<int> board_of = physical_boards(dets, o, boards);
  // Reference points: every inner corner of every physical board, "board<n>:i<i>j<j>".
  const int per_board = pattern.inner_cols * pattern.inner_rows;
  refs.point_names.resize(static_cast<size_t>(boards * per_board));
  for (int b = 0; b < boards; ++b)
    for (int j = 0; j < pattern.inner_rows; ++j)
      for (int i = 0; i < pattern.inner_cols; ++i)
        refs.point_names[static_cast<size_t>(b * per_board + j * pattern.inner_cols + i)] =
            fmt::format("board{}:i{}j{}", b + 1, i, j);
  for (size_t a = 0; a < dets.size(); ++a) {
    const int b = board_of[a];
    for (const auto& c : dets[a].det.corners)
      if (c.has_depth())
        refs.observations.push_back({dets[a].sensor, b * per_board + c.j * pattern.inner_cols + c.i, c.point});
  }
  return refs;
}

PoseError pose_error(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  const Eigen::Isometry3d d = truth.inverse() * estimate;
  return {(estimate.translation() - truth.translation()).norm(), Eigen::AngleAxisd(d.linear()).angle()};
}

void write_rig_file(const std::filesystem::path& path, const std::vector<std::string>& names,
                    const std::vector<Eigen::Isometry3d>& pose, const std::string& info_json) {
  require(names.size() == pose.size(), "write_rig_file: {} names for {} poses", names.size(), pose.size());
  nlohmann::ordered_json j;
  j["format"] = "socketsmith-scan-rig";
  j["version"] = 1;
  j["sensors"] = nlohmann::ordered_json::array();
  for (size_t s = 0; s < names.size(); ++s) {
    const Eigen::Matrix4d m = pose[s].matrix();
    nlohmann::ordered_json rows = nlohmann::ordered_json::array();
    for (int i = 0; i < 4; ++i) rows.push_back({m(i, 0), m(i, 1), m(i, 2), m(i, 3)});
    j["sensors"].push_back({{"name", names[s]}, {"pose_world_from_sensor", rows}});
  }
  j["registration"] = nlohmann::ordered_json::parse(info_json);
  write_text_atomically(path, j.dump(2) + "\n");
}

void apply_rig_file(Recording& rec, const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) fail<IoError>("--rig: cannot open '{}' (expected a rig file written by 'scan register')", path.string());
  nlohmann::json j = parse_json_stream(in, path.string(), "--rig");
  require(j.is_object() && j.contains("sensors") && j["sensors"].is_array(),
          "--rig: '{}' has no \"sensors\" array (expected a rig file written by 'scan register')", path.string());
  for (SensorRecording& s : rec.sensors) {
    bool found = false;
    for (const auto& e : j["sensors"]) {
      if (!e.is_object() || e.value("name", std::string()) != s.name) continue;
      require(e.contains("pose_world_from_sensor"), "--rig: '{}': sensor '{}' has no pose_world_from_sensor",
              path.string(), s.name);
      try {
        s.world_from_sensor = pose_from_rows(e["pose_world_from_sensor"].get<std::vector<std::vector<double>>>(),
                                             fmt::format("--rig '{}': sensor '{}'", path.string(), s.name));
      } catch (const nlohmann::json::exception&) {
        fail("--rig: '{}': sensor '{}': pose_world_from_sensor is not a 4x4 array of numbers", path.string(), s.name);
      }
      found = true;
    }
    require(found, "--rig: '{}' has no sensor named '{}' (the rig file must come from a registration of the same rig)",
            path.string(), s.name);
  }
}

}  // namespace socketsmith::scan

namespace socketsmith::scan {

std::vector<ReferenceAccuracy> reference_accuracy(const ReferenceSet& refs, const Scene& scene,
                                                  const std::vector<Eigen::Isometry3d>& truth) {
  require(static_cast<int>(truth.size()) == refs.num_sensors(), "reference_accuracy: {} poses for {} sensors",
          truth.size(), refs.num_sensors());
  std::vector<Vec3> corners;
  for (const ChessboardPatch& b : scene.chessboards)
    for (int j = 0; j < b.pattern.inner_rows; ++j)
      for (int i = 0; i < b.pattern.inner_cols; ++i) corners.push_back(b.corner(i, j));
  std::vector<ReferenceAccuracy> out(static_cast<size_t>(refs.num_sensors()));
  for (int s = 0; s < refs.num_sensors(); ++s) out[static_cast<size_t>(s)].sensor = refs.sensor_names[static_cast<size_t>(s)];
  for (const ReferenceObservation& o : refs.observations) {
    const Eigen::Isometry3d& pose = truth[static_cast<size_t>(o.sensor)];
    const Vec3 world = pose * o.p;
    double best = 0.03;
    const Vec3* nearest = nullptr;
    for (const Vec3& c : corners)
      if ((c - world).norm() < best) {
        best = (c - world).norm();
        nearest = &c;
      }
    if (nearest == nullptr) continue;
    const Vec3 err = o.p - pose.inverse() * *nearest;
    const Vec3 ray = o.p.normalized();
    const double along = err.dot(ray);
    ReferenceAccuracy& a = out[static_cast<size_t>(o.sensor)];
    a.along_mean_m += along;
    a.along_rms_m += along * along;
    a.across_rms_m += (err - along * ray).squaredNorm();
    a.rms_m += err.squaredNorm();
    ++a.points;
  }
  for (ReferenceAccuracy& a : out) {
    if (a.points == 0) continue;
    a.along_mean_m /= a.points;
    a.along_rms_m = std::sqrt(a.along_rms_m / a.points);
    a.across_rms_m = std::sqrt(a.across_rms_m / a.points);
    a.rms_m = std::sqrt(a.rms_m / a.points);
  }
  return out;
}

RegistrationExperimentResult run_registration_experiment(const RegistrationExperimentOptions& o,
                                                         const ProgressCallback& progress) {
  require(o.sensors >= 2 && o.sensors <= 8, "registration experiment: {} sensors (expected 2 to 8)", o.sensors);
  require(std::isfinite(o.pose_error_deg) && o.pose_error_deg >= 0.0 && o.pose_error_deg <= 20.0 &&
              std::isfinite(o.pose_error_m) && o.pose_error_m >= 0.0 && o.pose_error_m <= 0.2,
          "registration experiment: pose errors {} deg / {} mm out of range (expected 0-20 deg, 0-200 mm)",
          o.pose_error_deg, o.pose_error_m * 1e3);
  RegistrationExperimentResult r;
  const Eigen::Isometry3d box_pose(Eigen::AngleAxisd(o.box_yaw_deg * M_PI / 180.0, Vec3::UnitZ()));
  const Scene scene = make_box_scene(Vec3(0.30, 0.30, 0.70), box_pose);
  r.rig = default_rig(o.sensors, o.radius_m, 0.0, Vec3::Zero(), o.intrinsics);
  r.recording = simulate_recording(scene, r.rig, o.simulation, progress);
  // Hand-measured poses: each sensor but the fixed one turned by pose_error_deg about a random axis
  // through its centre and moved by pose_error_m in a random direction.
  std::mt19937_64 rng(o.pose_seed);
  std::normal_distribution<double> g(0.0, 1.0);
  auto random_unit = [&] {
    Vec3 v(g(rng), g(rng), g(rng));
    return Vec3(v.normalized());
  };
  for (size_t s = 0; s < r.rig.size(); ++s) {
    r.truth.push_back(r.rig[s].world_from_sensor);
    Eigen::Isometry3d p = r.rig[s].world_from_sensor;
    const Vec3 axis = random_unit(), shift = random_unit();
    if (static_cast<int>(s) != o.registration.fixed_sensor) {
      p.linear() = Eigen::AngleAxisd(o.pose_error_deg * M_PI / 180.0, axis).toRotationMatrix() * p.linear();
      p.translation() += o.pose_error_m * shift;
    }
    r.measured.push_back(p);
  }
  r.refs = box_reference_points(r.recording, r.measured, o.detection);
  r.sequential = register_sequential(r.refs, r.measured, o.registration);
  r.multiset = register_multiset(r.refs, r.measured, o.registration);
  if (!o.compensation.empty()) {
    require(o.compensation.size() == r.recording.sensors.size(),
            "registration experiment: {} compensation models for {} sensors", o.compensation.size(),
            r.recording.sensors.size());
    Recording compensated = r.recording;
    for (size_t s = 0; s < compensated.sensors.size(); ++s) compensated.sensors[s].compensation = o.compensation[s];
    r.refs_compensated = box_reference_points(compensated, r.measured, o.detection);
    r.multiset_compensated = register_multiset(r.refs_compensated, r.measured, o.registration);
    r.truth_errors_compensated = pair_errors(r.refs_compensated, r.truth);
    r.accuracy_compensated = reference_accuracy(r.refs_compensated, scene, r.truth);
    for (size_t s = 0; s < r.rig.size(); ++s)
      r.multiset_compensated_pose_errors.push_back(pose_error(r.multiset_compensated.world_from_sensor[s], r.truth[s]));
  }
  for (size_t s = 0; s < r.rig.size(); ++s) {
    r.measured_pose_errors.push_back(pose_error(r.measured[s], r.truth[s]));
    r.sequential_pose_errors.push_back(pose_error(r.sequential.world_from_sensor[s], r.truth[s]));
    r.multiset_pose_errors.push_back(pose_error(r.multiset.world_from_sensor[s], r.truth[s]));
  }
  r.truth_errors = pair_errors(r.refs, r.truth);
  r.accuracy = reference_accuracy(r.refs, scene, r.truth);
  return r;
}

}  // namespace socketsmith::scan
