#include "socketsmith/scan/simulated_sensor.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <random>

#include <fmt/format.h>

#include "socketsmith/core/errors.h"

namespace socketsmith::scan {
namespace {

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

void validate_model(const SensorErrorModel& m) {
  const double values[] = {m.scale, m.bias_m, m.bias_slope, m.sensor_offset_m, m.sensor_offset_sd_m, m.wiggle_amplitude_m, m.wiggle_period_m,
                           m.radial_bias_m, m.noise_sigma0_m, m.noise_sigma2_per_m, m.flying_pixel_probability,
                           m.edge_jump_m, m.flying_background_m, m.random_invalid_probability,
                           m.grazing_limit_rad, m.min_range_m, m.max_range_m, m.dark_noise_factor, m.ray_scale_x,
                           m.ray_scale_y, m.ray_scale_sd, m.ir_counts_at_1m, m.ir_noise_relative, m.ir_noise_floor};
  for (double v : values) require(std::isfinite(v), "SensorErrorModel: a parameter is not finite");
  require(m.scale >= 0.0, "SensorErrorModel: scale {} must be >= 0 (0: noise free)", m.scale);
  require(m.sensor_offset_sd_m >= 0.0, "SensorErrorModel: sensor_offset_sd_m {} must be >= 0", m.sensor_offset_sd_m);
  require(m.wiggle_period_m > 0.0, "SensorErrorModel: wiggle_period_m {} must be positive", m.wiggle_period_m);
  require(m.noise_sigma0_m >= 0.0 && m.noise_sigma2_per_m >= 0.0, "SensorErrorModel: noise sigmas must be >= 0");
  require(m.flying_pixel_probability >= 0.0 && m.flying_pixel_probability <= 1.0 &&
              m.random_invalid_probability >= 0.0 && m.random_invalid_probability <= 1.0,
          "SensorErrorModel: probabilities must lie in [0, 1]");
  require(m.dark_noise_factor >= 1.0, "SensorErrorModel: dark_noise_factor {} must be >= 1", m.dark_noise_factor);
  require(m.ray_scale_sd >= 0.0 && std::abs(m.ray_scale_x) < 0.5 && std::abs(m.ray_scale_y) < 0.5,
          "SensorErrorModel: ray scale errors must be small relative values (|e| < 0.5, sd >= 0)");
  require(m.ir_counts_at_1m > 0.0 && m.ir_noise_relative >= 0.0 && m.ir_noise_floor >= 0.0,
          "SensorErrorModel: IR gain must be positive and IR noise >= 0");
  require(m.edge_jump_m > 0.0, "SensorErrorModel: edge_jump_m {} must be positive", m.edge_jump_m);
  require(m.min_range_m >= 0.0 && m.max_range_m > m.min_range_m, "SensorErrorModel: range [{}, {}] m is empty",
          m.min_range_m, m.max_range_m);
}

/// Slab test: does the ray origin + t dir (t > 0) meet the box?
bool ray_meets_box(const Vec3& o, const Vec3& d, const geometry::Aabb& box) {
  double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-300) {
      if (o[a] < box.min[a] || o[a] > box.max[a]) return false;
      continue;
    }
    double ta = (box.min[a] - o[a]) / d[a], tb = (box.max[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

}  // namespace

Eigen::Isometry3d look_at(const Vec3& eye, const Vec3& target, const Vec3& up) {
  const Vec3 z = target - eye;
  require(z.norm() > 1e-9, "look_at: the eye and the target coincide");
  const Vec3 zn = z.normalized();
  const Vec3 x = zn.cross(up);
  require(x.norm() > 1e-6, "look_at: the view direction is parallel to 'up'");
  const Vec3 xn = x.normalized();
  const Vec3 yn = zn.cross(xn);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear().col(0) = xn;
  pose.linear().col(1) = yn;
  pose.linear().col(2) = zn;
  pose.translation() = eye;
  return pose;
}

std::vector<SimulatedSensor> default_rig(int n, double radius_m, double height_m, const Vec3& target,
                                         const std::vector<CameraIntrinsics>& intrinsics) {
  require(n >= 1 && n <= 32, "default_rig: {} sensors (expected 1 to 32; the thesis used 4)", n);
  require(std::isfinite(radius_m) && radius_m > 0.1 && radius_m < 10.0,
          "default_rig: radius {} m is not plausible (expected 0.1 to 10 m; the thesis used 0.75 m)", radius_m);
  require(std::isfinite(height_m) && std::abs(height_m) < 10.0, "default_rig: height {} m is not plausible", height_m);
  require(intrinsics.empty() || intrinsics.size() == 1 || intrinsics.size() == static_cast<size_t>(n),
          "default_rig: {} intrinsics for {} sensors (expected 0, 1 or one per sensor)", intrinsics.size(), n);
  std::vector<SimulatedSensor> rig;
  for (int i = 0; i < n; ++i) {
    const double a = -M_PI / 2 + 2.0 * M_PI * i / n;  // K1 on the −y side (in front)
    SimulatedSensor s;
    s.name = fmt::format("K{}", i + 1);
    if (!intrinsics.empty()) s.intrinsics = intrinsics[intrinsics.size() == 1 ? 0 : static_cast<size_t>(i)];
    const Vec3 eye = target + Vec3(radius_m * std::cos(a), radius_m * std::sin(a), height_m);
    s.world_from_sensor = look_at(eye, target);
    rig.push_back(s);
  }
  return rig;
}

Vec3 ChessboardPatch::corner_in_board(int i, int j) const {
  const double s = pattern.square_m;
  return {(i + 1) * s - 0.5 * (pattern.inner_cols + 1) * s, (j + 1) * s - 0.5 * (pattern.inner_rows + 1) * s, 0.0};
}

Eigen::Vector2d ChessboardPatch::half_size() const {
  return {0.5 * (pattern.inner_cols + 1) * pattern.square_m + margin_m,
          0.5 * (pattern.inner_rows + 1) * pattern.square_m + margin_m};
}

double ChessboardPatch::albedo_at(double x, double y) const {
  constexpr double kBlack = 0.05, kWhite = 0.9;
  const Eigen::Vector2d h = half_size();
  if (std::abs(x) > h.x() || std::abs(y) > h.y()) return -1.0;
  const double s = pattern.square_m;
  const double a = (x + 0.5 * (pattern.inner_cols + 1) * s) / s, b = (y + 0.5 * (pattern.inner_rows + 1) * s) / s;
  if (a < 0.0 || b < 0.0 || a >= pattern.inner_cols + 1 || b >= pattern.inner_rows + 1) return kWhite;  // margin
  return (static_cast<int>(a) + static_cast<int>(b)) % 2 == 0 ? kBlack : kWhite;
}

namespace {

/// A sensor's rays in the world: the calibration's ray table as the unit sees it.
struct SensorRays {
  const RayTable& table;
  int w, h;
  Eigen::Matrix3d R;  ///< world from sensor
  Vec3 origin;        ///< the sensor's centre in the world [m]
  // The unit's true rays (lateral scale error): the calibration's (x, y) divided by 1 + s·e.
  double gx, gy;
  Vec3 world(const Eigen::Vector2d& xy) const { return R * Vec3(xy.x() * gx, xy.y() * gy, 1.0); }
  // Bilinear interpolation of the ray table at a sub-pixel position (distortion is smooth).
  Eigen::Vector2d at(double uf, double vf) const {
    const int u0 = std::clamp(static_cast<int>(std::floor(uf)), 0, w - 2), v0 = std::clamp(static_cast<int>(std::floor(vf)), 0, h - 2);
    const double fu = uf - u0, fv = vf - v0;
    return (1 - fv) * ((1 - fu) * table.at(u0, v0) + fu * table.at(u0 + 1, v0)) +
           fv * ((1 - fu) * table.at(u0, v0 + 1) + fu * table.at(u0 + 1, v0 + 1));
  }
};

/// What every frame of a sensor sees alike, per pixel: the exact depth along the optical axis
/// (0: no surface; negative: a grazing return), the cosine of incidence and the IR albedo.
struct PixelTruth {
  std::vector<double> truth, cosine, albedo;
};

/// The albedo of board b seen by pixel (u, v) (its centre's ray hits the board face): inside a
/// square (the four pixel corners agree) one value, on an edge the mean of 8×8 sub-pixel rays;
/// none when no sub-pixel ray sees anything.
std::optional<double> board_albedo(const SensorRays& rays, const ChessboardPatch& b, const Eigen::Isometry3d& to_board,
                                   double scene_albedo, int u, int v) {
  const Vec3 bn = b.world_from_board.linear().col(2);  // into the board
  // Albedo seen along a sub-pixel ray (the scene's outside the board).
  auto albedo_along = [&](double uf, double vf) {
    const Eigen::Vector2d sxy = rays.at(uf, vf);
    if (!std::isfinite(sxy.x())) return -1.0;
    const Vec3 sd = rays.world(sxy);
    const double denom = bn.dot(sd);
    if (std::abs(denom) < 1e-12) return -1.0;
    const Vec3 q = to_board * (rays.origin + sd * (bn.dot(b.world_from_board.translation() - rays.origin) / denom));
    const double a = b.albedo_at(q.x(), q.y());
    return a < 0.0 ? scene_albedo : a;
  };
  const double a00 = albedo_along(u - 0.5, v - 0.5), a10 = albedo_along(u + 0.5, v - 0.5),
               a01 = albedo_along(u - 0.5, v + 0.5), a11 = albedo_along(u + 0.5, v + 0.5);
  if (a00 >= 0.0 && a00 == a10 && a00 == a01 && a00 == a11) return a00;
  double sum = 0.0;
  int count = 0;
  constexpr int kSub = 8;
  for (int sv = 0; sv < kSub; ++sv)
    for (int su = 0; su < kSub; ++su) {
      const double a = albedo_along(u + (su + 0.5) / kSub - 0.5, v + (sv + 0.5) / kSub - 0.5);
      if (a < 0.0) continue;
      sum += a;
      ++count;
    }
  if (count == 0) return std::nullopt;
  return sum / count;
}

/// Step 1: traces every pixel's ray into the scene (chessboard squares antialiased).
PixelTruth trace_pixels(const geometry::SurfaceQuery& query, const Scene& scene, const SensorRays& rays,
                        double cos_grazing) {
  const int w = rays.w, h = rays.h;
  const size_t n = static_cast<size_t>(w) * h;
  const geometry::TriMesh& mesh = query.mesh();
  const geometry::Aabb box = geometry::bounding_box(mesh);
  PixelTruth p{std::vector<double>(n, 0.0), std::vector<double>(n, 0.0), std::vector<double>(n, scene.albedo)};
  std::vector<Eigen::Isometry3d> board_from_world;
  for (const ChessboardPatch& b : scene.chessboards) board_from_world.push_back(b.world_from_board.inverse());
#pragma omp parallel for schedule(dynamic, 4)
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector2d& xy = rays.table.at(u, v);
      if (!std::isfinite(xy.x())) continue;  // outside the lens model's valid range
      const Vec3 dir = rays.world(xy);
      if (!ray_meets_box(rays.origin, dir, box)) continue;
      const auto hit = query.first_hit(rays.origin, dir);
      if (!hit) continue;
      const size_t i = static_cast<size_t>(v) * w + u;
      const double d = (rays.R.transpose() * (hit->point - rays.origin)).z();
      const Vec3 normal = geometry::triangle_normal(mesh, hit->triangle);
      const double c = std::abs(normal.dot(dir.normalized()));
      p.truth[i] = c < cos_grazing ? -d : d;
      p.cosine[i] = c;
      for (size_t bi = 0; bi < scene.chessboards.size(); ++bi) {
        const ChessboardPatch& b = scene.chessboards[bi];
        const Vec3 bn = b.world_from_board.linear().col(2);  // into the board
        const Vec3 local = board_from_world[bi] * hit->point;
        if (normal.dot(-bn) < 0.99 || std::abs(local.z()) > 1e-3 || b.albedo_at(local.x(), local.y()) < 0.0) continue;
        if (const auto a = board_albedo(rays, b, board_from_world[bi], scene.albedo, u, v)) p.albedo[i] = *a;
        break;
      }
    }
  return p;
}

/// The largest depth step [m] from pixel (u, v) at depth t to a 4-neighbour beyond the edge jump
/// (the background's distance where a neighbour sees nothing); 0 when there is none.
double far_depth_step(const std::vector<double>& truth, int w, int h, int u, int v, double t,
                      const SensorErrorModel& model) {
  double far_step = 0.0;
  const int du[4] = {1, -1, 0, 0}, dv[4] = {0, 0, 1, -1};
  for (int q = 0; q < 4; ++q) {
    const int un = u + du[q], vn = v + dv[q];
    if (un < 0 || un >= w || vn < 0 || vn >= h) continue;
    const double tn = std::abs(truth[static_cast<size_t>(vn) * w + un]);
    const double step = tn == 0.0 ? model.flying_background_m : tn - t;
    if (std::abs(step) > model.edge_jump_m && std::abs(step) > std::abs(far_step)) far_step = step;
  }
  return far_step;
}

/// Step 2: depth errors, flying pixels, losses; one random stream per row (deterministic under
/// OpenMP).
DepthImage depth_frame(const PixelTruth& p, const CameraIntrinsics& k, const SensorErrorModel& model,
                       std::uint64_t seed, double depth_scale_m) {
  const int w = k.width, h = k.height;
  const double s = model.scale;
  DepthImage img;
  img.width = w;
  img.height = h;
  img.scale_m = depth_scale_m;
  img.raw.assign(static_cast<size_t>(w) * h, 0);
  const double half_diag = std::hypot(w / 2.0, h / 2.0);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < h; ++v) {
    std::mt19937_64 rng(splitmix64(seed ^ splitmix64(static_cast<std::uint64_t>(v) + 0x51ed27ULL)));
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    std::normal_distribution<double> gauss(0.0, 1.0);
    for (int u = 0; u < w; ++u) {
      const size_t i = static_cast<size_t>(v) * w + u;
      const double t = p.truth[i];
      // Draw every random number for every pixel so the stream does not depend on the scene.
      const double r_fly = uni(rng), r_mix = uni(rng), r_lost = uni(rng), r_noise = gauss(rng);
      if (t <= 0.0) continue;
      double d = t;
      // Flying pixels: mix with the neighbour across the strongest depth edge.
      const double far_step = far_depth_step(p.truth, w, h, u, v, t, model);
      if (far_step != 0.0 && r_fly < s * model.flying_pixel_probability) d += (0.1 + 0.8 * r_mix) * far_step;
      if (r_lost < s * model.random_invalid_probability) continue;
      const double rho = std::hypot(u - k.cx, v - k.cy) / half_diag;
      const double systematic = model.bias_m + model.sensor_offset_m + model.bias_slope * (d - 1.0) +
                                model.wiggle_amplitude_m * std::sin(2.0 * M_PI * d / model.wiggle_period_m) +
                                model.radial_bias_m * rho * rho;
      const double darkness = std::clamp((0.7 - p.albedo[i]) / 0.65, 0.0, 1.0);
      const double sigma = (model.noise_sigma0_m + model.noise_sigma2_per_m * d * d) *
                           (1.0 + (model.dark_noise_factor - 1.0) * darkness);
      d += s * (systematic + sigma * r_noise);
      if (d < model.min_range_m || d > model.max_range_m) continue;
      const double raw = std::round((d - k.depth_shift_m) / depth_scale_m);
      if (raw < 1.0 || raw > 65535.0) continue;
      img.raw[i] = static_cast<std::uint16_t>(raw);
    }
  }
  return img;
}

/// Step 3: IR amplitude: albedo × cos(incidence) / range², with noise (its own random streams).
IrImage ir_frame(const PixelTruth& p, const SensorRays& rays, const SensorErrorModel& model, std::uint64_t seed) {
  const int w = rays.w, h = rays.h;
  const double s = model.scale, gx = rays.gx, gy = rays.gy;
  IrImage ir;
  ir.width = w;
  ir.height = h;
  ir.value.assign(static_cast<size_t>(w) * h, 0);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < h; ++v) {
    std::mt19937_64 rng(splitmix64(seed ^ splitmix64(static_cast<std::uint64_t>(v) + 0x1f2e3dULL) ^ 0x7a11ULL));
    std::normal_distribution<double> gauss(0.0, 1.0);
    for (int u = 0; u < w; ++u) {
      const size_t i = static_cast<size_t>(v) * w + u;
      const double r_noise = gauss(rng);
      const double t = std::abs(p.truth[i]);
      double amplitude = 0.0;
      if (t > 0.0) {
        const Eigen::Vector2d& xy = rays.table.at(u, v);
        const double range2 = t * t * (1.0 + xy.x() * xy.x() * gx * gx + xy.y() * xy.y() * gy * gy);
        amplitude = model.ir_counts_at_1m * p.albedo[i] * p.cosine[i] / range2;
      }
      amplitude += s * (model.ir_noise_relative * amplitude + model.ir_noise_floor) * r_noise;
      ir.value[i] = static_cast<std::uint16_t>(std::clamp(std::round(amplitude), 0.0, 65535.0));
    }
  }
  return ir;
}

}  // namespace

std::vector<SimulatedFrame> simulate_frames(const geometry::SurfaceQuery& query, const Scene& scene,
                                            const SimulatedSensor& sensor, const SensorErrorModel& model,
                                            const std::vector<std::uint64_t>& seeds, double depth_scale_m) {
  validate_model(model);
  require(depth_scale_m > 0.0 && depth_scale_m < 1.0, "simulate_depth: depth scale {} m per unit is not valid",
          depth_scale_m);
  require(scene.albedo > 0.0 && scene.albedo <= 1.0, "simulate_frame: scene albedo {} must lie in (0, 1]",
          scene.albedo);
  const CameraIntrinsics& k = sensor.intrinsics;
  const RayTable table = make_ray_table(k, 1);
  const double s = model.scale;
  const SensorRays rays{table, k.width, k.height, sensor.world_from_sensor.linear(),
                        sensor.world_from_sensor.translation(), 1.0 / (1.0 + s * model.ray_scale_x),
                        1.0 / (1.0 + s * model.ray_scale_y)};
  const PixelTruth truth = trace_pixels(query, scene, rays, std::cos(model.grazing_limit_rad));
  // Steps 2 and 3 for every frame: the scene's geometry and albedo above are the same, the errors
  // are drawn from each frame's seed.
  std::vector<SimulatedFrame> frames;
  frames.reserve(seeds.size());
  for (const std::uint64_t seed : seeds) {
    SimulatedFrame frame;
    frame.depth = depth_frame(truth, k, model, seed, depth_scale_m);
    frame.ir = ir_frame(truth, rays, model, seed);
    frames.push_back(std::move(frame));
  }
  return frames;
}

SimulatedFrame simulate_frame(const geometry::SurfaceQuery& query, const Scene& scene, const SimulatedSensor& sensor,
                              const SensorErrorModel& model, std::uint64_t seed, double depth_scale_m) {
  return std::move(simulate_frames(query, scene, sensor, model, {seed}, depth_scale_m).front());
}

DepthImage simulate_depth(const geometry::SurfaceQuery& scene, const SimulatedSensor& sensor,
                          const SensorErrorModel& model, std::uint64_t seed, double depth_scale_m) {
  Scene plain;
  return simulate_frame(scene, plain, sensor, model, seed, depth_scale_m).depth;
}

SensorErrorModel scale_systematic_errors(SensorErrorModel m, double factor) {
  require(std::isfinite(factor) && factor >= 0.0, "systematic error scale {} must be >= 0 (0: random errors only)",
          factor);
  for (double* x : {&m.bias_m, &m.bias_slope, &m.sensor_offset_m, &m.sensor_offset_sd_m, &m.wiggle_amplitude_m,
                    &m.radial_bias_m, &m.ray_scale_x, &m.ray_scale_y, &m.ray_scale_sd})
    *x *= factor;
  return m;
}

SensorErrorModel unit_error_model(const SensorErrorModel& base, std::uint64_t seed, size_t index) {
  SensorErrorModel model = base;
  std::mt19937_64 unit_rng(splitmix64(seed ^ (0xabcdefULL + index)));
  std::normal_distribution<double> gauss(0.0, 1.0);
  model.sensor_offset_m += base.sensor_offset_sd_m * gauss(unit_rng);
  model.ray_scale_x += base.ray_scale_sd * gauss(unit_rng);
  model.ray_scale_y += base.ray_scale_sd * gauss(unit_rng);
  return model;
}

Recording simulate_recording(const Scene& scene, const std::vector<SimulatedSensor>& sensors,
                             const SimulationOptions& o, const ProgressCallback& progress) {
  require(!scene.mesh.empty(), "simulate_recording: the scene mesh has no triangles");
  require(!sensors.empty(), "simulate_recording: no sensors");
  require(o.frames >= 1 && o.frames <= 100, "simulate_recording: {} frames per sensor (expected 1 to 100)",
          o.frames);
  validate_model(o.error);
  const geometry::SurfaceQuery query(scene.mesh);
  Recording rec;
  if (!scene.chessboards.empty()) rec.chessboard = scene.chessboards.front().pattern;
  const int total = static_cast<int>(sensors.size()) * o.frames;
  int done = 0;
  for (size_t i = 0; i < sensors.size(); ++i) {
    validate_intrinsics(sensors[i].intrinsics, "simulate_recording: sensor " + sensors[i].name);
    SensorRecording sr;
    sr.name = sensors[i].name;
    sr.intrinsics = sensors[i].intrinsics;
    sr.world_from_sensor = sensors[i].world_from_sensor;
    sr.depth_scale_m = o.depth_scale_m;
    const SensorErrorModel model = unit_error_model(o.error, o.seed, i);
    std::vector<std::uint64_t> seeds;
    for (int f = 0; f < o.frames; ++f)
      seeds.push_back(splitmix64(o.seed * 0x100000001b3ULL + i * 1000003ULL + static_cast<std::uint64_t>(f)));
    std::vector<SimulatedFrame> frames = simulate_frames(query, scene, sensors[i], model, seeds, o.depth_scale_m);
    for (int f = 0; f < o.frames; ++f) {
      sr.frames.push_back(std::move(frames[static_cast<size_t>(f)].depth));
      sr.ir_frames.push_back(std::move(frames[static_cast<size_t>(f)].ir));
      sr.frame_files.push_back(fmt::format("depth_{:04d}.png", f));
    }
    done += o.frames;
    rec.sensors.push_back(std::move(sr));
    if (!report_progress(progress, double(done) / total, "simulating depth frames")) break;
  }
  return rec;
}

Recording simulate_recording(const geometry::TriMesh& mesh, const std::vector<SimulatedSensor>& sensors,
                             const SimulationOptions& o, const ProgressCallback& progress) {
  Scene scene;
  scene.mesh = mesh;
  return simulate_recording(scene, sensors, o, progress);
}

Recording simulate_calibration_session(const std::vector<SimulatedSensor>& sensors,
                                       const CalibrationSessionOptions& o, const ProgressCallback& progress) {
  const SimulationOptions& so = o.simulation;
  require(!sensors.empty(), "simulate_calibration_session: no sensors");
  require(so.frames >= 1 && so.frames <= 100, "simulate_calibration_session: {} frames per sensor (expected 1 to 100)",
          so.frames);
  require(std::isfinite(o.min_distance_m) && o.min_distance_m >= 0.3 && o.max_distance_m >= o.min_distance_m &&
              o.max_distance_m <= 4.5,
          "simulate_calibration_session: distance range [{}, {}] m is not valid (expected within 0.3-4.5 m)",
          o.min_distance_m, o.max_distance_m);
  require(o.max_tilt_rad >= 0.0 && o.max_tilt_rad < 1.3, "simulate_calibration_session: max tilt {} rad is not valid",
          o.max_tilt_rad);
  require(o.frames_per_pose >= 1 && o.frames_per_pose <= 30,
          "simulate_calibration_session: {} frames per board pose (expected 1 to 30)", o.frames_per_pose);
  validate_model(so.error);
  Recording rec;
  rec.chessboard = o.board.pattern;
  rec.frames_per_pose = o.frames_per_pose;
  const int total = static_cast<int>(sensors.size()) * so.frames;
  int done = 0;
  for (size_t i = 0; i < sensors.size(); ++i) {
    const SimulatedSensor& sensor = sensors[i];
    validate_intrinsics(sensor.intrinsics, "simulate_calibration_session: sensor " + sensor.name);
    SensorRecording sr;
    sr.name = sensor.name;
    sr.intrinsics = sensor.intrinsics;
    sr.world_from_sensor = sensor.world_from_sensor;
    sr.depth_scale_m = so.depth_scale_m;
    const SensorErrorModel model = unit_error_model(so.error, so.seed, i);
    const std::uint64_t fseed = o.frame_seed != 0 ? o.frame_seed : so.seed;
    std::mt19937_64 rng(splitmix64(fseed ^ splitmix64(0xb0a2dULL + i)));
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    const CameraIntrinsics& k = sensor.intrinsics;
    for (int f = 0; f < so.frames; ++f) {
      // A pose with every inner corner at least 12 px inside the image.
      Eigen::Isometry3d sensor_from_board = Eigen::Isometry3d::Identity();
      bool ok = false;
      for (int attempt = 0; attempt < 400 && !ok; ++attempt) {
        const double shrink = 1.0 - attempt / 400.0;
        const double d = o.min_distance_m + (o.max_distance_m - o.min_distance_m) * 0.5 * (1.0 + uni(rng));
        sensor_from_board.linear() = (Eigen::AngleAxisd(shrink * o.max_tilt_rad * uni(rng), Vec3::UnitY()) *
                                      Eigen::AngleAxisd(shrink * o.max_tilt_rad * uni(rng), Vec3::UnitX()) *
                                      Eigen::AngleAxisd(shrink * o.max_tilt_rad / 3 * uni(rng), Vec3::UnitZ()))
                                         .matrix();
        sensor_from_board.translation() = Vec3(shrink * 0.35 * d * uni(rng), shrink * 0.3 * d * uni(rng), d);
        ok = true;
        for (int j = 0; j < o.board.pattern.inner_rows && ok; ++j)
          for (int c = 0; c < o.board.pattern.inner_cols && ok; ++c) {
            const Vec3 p = sensor_from_board * o.board.corner_in_board(c, j);
            if (p.z() < 0.3) { ok = false; break; }
            const Eigen::Vector2d uv = project_normalised(k, p.head<2>() / p.z());
            ok = uv.x() >= 12 && uv.y() >= 12 && uv.x() <= k.width - 13 && uv.y() <= k.height - 13;
          }
      }
      require(ok, "simulate_calibration_session: the board does not fit sensor '{}''s view at {}-{} m (a smaller board or "
              "a larger distance)", sensor.name, o.min_distance_m, o.max_distance_m);
      ChessboardPatch board = o.board;
      board.world_from_board = sensor.world_from_sensor * sensor_from_board;
      const Scene scene = make_chessboard_scene(board);
      const geometry::SurfaceQuery query(scene.mesh);
      const std::uint64_t seed =
          splitmix64(fseed * 0x100000001b3ULL + i * 1000003ULL + static_cast<std::uint64_t>(f) + 0xca11bULL);
      std::vector<std::uint64_t> seeds{seed};  // the first frame of a pose as with one frame per pose
      for (int r = 1; r < o.frames_per_pose; ++r) seeds.push_back(splitmix64(seed ^ splitmix64(0xf0a5eULL + r)));
      for (SimulatedFrame& frame : simulate_frames(query, scene, sensor, model, seeds, so.depth_scale_m)) {
        sr.frames.push_back(std::move(frame.depth));
        sr.ir_frames.push_back(std::move(frame.ir));
        sr.frame_files.push_back(fmt::format("depth_{:04d}.png", sr.frame_files.size()));
      }
      if (!report_progress(progress, double(++done) / total, "simulating board frames")) break;
    }
    rec.sensors.push_back(std::move(sr));
  }
  return rec;
}

}  // namespace socketsmith::scan
