#include "socketsmith/scan/simulated_sensor.h"

#include <algorithm>
#include <cmath>
#include <limits>
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
                           m.grazing_limit_rad, m.min_range_m, m.max_range_m};
  for (double v : values) require(std::isfinite(v), "SensorErrorModel: a parameter is not finite");
  require(m.scale >= 0.0, "SensorErrorModel: scale {} must be >= 0 (0: noise free)", m.scale);
  require(m.sensor_offset_sd_m >= 0.0, "SensorErrorModel: sensor_offset_sd_m {} must be >= 0", m.sensor_offset_sd_m);
  require(m.wiggle_period_m > 0.0, "SensorErrorModel: wiggle_period_m {} must be positive", m.wiggle_period_m);
  require(m.noise_sigma0_m >= 0.0 && m.noise_sigma2_per_m >= 0.0, "SensorErrorModel: noise sigmas must be >= 0");
  require(m.flying_pixel_probability >= 0.0 && m.flying_pixel_probability <= 1.0 &&
              m.random_invalid_probability >= 0.0 && m.random_invalid_probability <= 1.0,
          "SensorErrorModel: probabilities must lie in [0, 1]");
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

/// Adds a grid of n1 × n2 quads spanning origin + [0,1]·e1 + [0,1]·e2 (normal e1 × e2).
void add_grid_face(geometry::TriMesh& m, const Vec3& origin, const Vec3& e1, const Vec3& e2, int n1, int n2) {
  const int base = m.num_vertices();
  for (int j = 0; j <= n2; ++j)
    for (int i = 0; i <= n1; ++i) m.vertices.push_back(origin + e1 * (double(i) / n1) + e2 * (double(j) / n2));
  auto id = [&](int i, int j) { return base + j * (n1 + 1) + i; };
  for (int j = 0; j < n2; ++j)
    for (int i = 0; i < n1; ++i) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
}

geometry::TriMesh make_box_cells(const Vec3& size, const Vec3& center, const Eigen::Vector3i& cells) {
  const Vec3 lo = center - 0.5 * size;
  const Vec3 X = Vec3::UnitX() * size.x(), Y = Vec3::UnitY() * size.y(), Z = Vec3::UnitZ() * size.z();
  geometry::TriMesh m;
  add_grid_face(m, lo + X, Y, Z, cells.y(), cells.z());  // +x
  add_grid_face(m, lo, Z, Y, cells.z(), cells.y());      // -x
  add_grid_face(m, lo + Y, Z, X, cells.z(), cells.x());  // +y
  add_grid_face(m, lo, X, Z, cells.x(), cells.z());      // -y
  add_grid_face(m, lo + Z, X, Y, cells.x(), cells.y());  // +z
  add_grid_face(m, lo, Y, X, cells.y(), cells.x());      // -z
  return geometry::weld_vertices(m, 1e-9);
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

DepthImage simulate_depth(const geometry::SurfaceQuery& scene, const SimulatedSensor& sensor,
                          const SensorErrorModel& model, std::uint64_t seed, double depth_scale_m) {
  validate_model(model);
  require(depth_scale_m > 0.0 && depth_scale_m < 1.0, "simulate_depth: depth scale {} m per unit is not valid",
          depth_scale_m);
  const CameraIntrinsics& k = sensor.intrinsics;
  const RayTable rays = make_ray_table(k, 1);
  const int w = k.width, h = k.height;
  const geometry::TriMesh& mesh = scene.mesh();
  const geometry::Aabb box = geometry::bounding_box(mesh);
  const Eigen::Matrix3d R = sensor.world_from_sensor.linear();
  const Vec3 origin = sensor.world_from_sensor.translation();
  const double cos_grazing = std::cos(model.grazing_limit_rad);

  // 1. Exact depth along the optical axis (0: no surface), −1 for a grazing return.
  std::vector<double> truth(static_cast<size_t>(w) * h, 0.0);
#pragma omp parallel for schedule(dynamic, 4)
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector2d& xy = rays.at(u, v);
      if (!std::isfinite(xy.x())) continue;  // outside the lens model's valid range
      const Vec3 dir = R * Vec3(xy.x(), xy.y(), 1.0);
      if (!ray_meets_box(origin, dir, box)) continue;
      const auto hit = scene.first_hit(origin, dir);
      if (!hit) continue;
      const double d = (R.transpose() * (hit->point - origin)).z();
      const double c = std::abs(geometry::triangle_normal(mesh, hit->triangle).dot(dir.normalized()));
      truth[static_cast<size_t>(v) * w + u] = c < cos_grazing ? -d : d;
    }

  // 2. Errors, flying pixels, losses; one random stream per row (deterministic under OpenMP).
  DepthImage img;
  img.width = w;
  img.height = h;
  img.scale_m = depth_scale_m;
  img.raw.assign(truth.size(), 0);
  const double s = model.scale;
  const double half_diag = std::hypot(w / 2.0, h / 2.0);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < h; ++v) {
    std::mt19937_64 rng(splitmix64(seed ^ splitmix64(static_cast<std::uint64_t>(v) + 0x51ed27ULL)));
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    std::normal_distribution<double> gauss(0.0, 1.0);
    for (int u = 0; u < w; ++u) {
      const double t = truth[static_cast<size_t>(v) * w + u];
      // Draw every random number for every pixel so the stream does not depend on the scene.
      const double r_fly = uni(rng), r_mix = uni(rng), r_lost = uni(rng), r_noise = gauss(rng);
      if (t <= 0.0) continue;
      double d = t;
      // Flying pixels: mix with the neighbour across the strongest depth edge.
      double far_step = 0.0;
      const int du[4] = {1, -1, 0, 0}, dv[4] = {0, 0, 1, -1};
      for (int q = 0; q < 4; ++q) {
        const int un = u + du[q], vn = v + dv[q];
        if (un < 0 || un >= w || vn < 0 || vn >= h) continue;
        const double tn = std::abs(truth[static_cast<size_t>(vn) * w + un]);
        const double step = tn == 0.0 ? model.flying_background_m : tn - t;
        if (std::abs(step) > model.edge_jump_m && std::abs(step) > std::abs(far_step)) far_step = step;
      }
      if (far_step != 0.0 && r_fly < s * model.flying_pixel_probability) d += (0.1 + 0.8 * r_mix) * far_step;
      if (r_lost < s * model.random_invalid_probability) continue;
      const double rho = std::hypot(u - k.cx, v - k.cy) / half_diag;
      const double systematic = model.bias_m + model.sensor_offset_m + model.bias_slope * (d - 1.0) +
                                model.wiggle_amplitude_m * std::sin(2.0 * M_PI * d / model.wiggle_period_m) +
                                model.radial_bias_m * rho * rho;
      const double sigma = model.noise_sigma0_m + model.noise_sigma2_per_m * d * d;
      d += s * (systematic + sigma * r_noise);
      if (d < model.min_range_m || d > model.max_range_m) continue;
      const double raw = std::round((d - k.depth_shift_m) / depth_scale_m);
      if (raw < 1.0 || raw > 65535.0) continue;
      img.raw[static_cast<size_t>(v) * w + u] = static_cast<std::uint16_t>(raw);
    }
  }
  return img;
}

Recording simulate_recording(const geometry::TriMesh& scene, const std::vector<SimulatedSensor>& sensors,
                             const SimulationOptions& o, const ProgressCallback& progress) {
  require(!scene.empty(), "simulate_recording: the scene mesh has no triangles");
  require(!sensors.empty(), "simulate_recording: no sensors");
  require(o.frames >= 1 && o.frames <= 100, "simulate_recording: {} frames per sensor (expected 1 to 100)",
          o.frames);
  validate_model(o.error);
  const geometry::SurfaceQuery query(scene);
  Recording rec;
  const int total = static_cast<int>(sensors.size()) * o.frames;
  int done = 0;
  for (size_t i = 0; i < sensors.size(); ++i) {
    validate_intrinsics(sensors[i].intrinsics, "simulate_recording: sensor " + sensors[i].name);
    SensorRecording sr;
    sr.name = sensors[i].name;
    sr.intrinsics = sensors[i].intrinsics;
    sr.world_from_sensor = sensors[i].world_from_sensor;
    sr.depth_scale_m = o.depth_scale_m;
    SensorErrorModel model = o.error;
    std::mt19937_64 unit_rng(splitmix64(o.seed ^ (0xabcdefULL + i)));
    model.sensor_offset_m += o.error.sensor_offset_sd_m * std::normal_distribution<double>(0.0, 1.0)(unit_rng);
    for (int f = 0; f < o.frames; ++f) {
      const std::uint64_t seed = splitmix64(o.seed * 0x100000001b3ULL + i * 1000003ULL + static_cast<std::uint64_t>(f));
      sr.frames.push_back(simulate_depth(query, sensors[i], model, seed, o.depth_scale_m));
      sr.frame_files.push_back(fmt::format("depth_{:04d}.png", f));
      if (!report_progress(progress, double(++done) / total, "simulating depth frames")) break;
    }
    rec.sensors.push_back(std::move(sr));
  }
  return rec;
}

geometry::TriMesh make_cylinder(double diameter_m, double height_m, const Vec3& center, int segments, int rings) {
  require(std::isfinite(diameter_m) && diameter_m > 0.0 && std::isfinite(height_m) && height_m > 0.0,
          "make_cylinder: diameter {} m and height {} m must be positive", diameter_m, height_m);
  require(segments >= 8 && rings >= 1, "make_cylinder: need at least 8 segments and 1 ring");
  const double r = diameter_m / 2;
  geometry::TriMesh m;
  for (int j = 0; j <= rings; ++j)
    for (int i = 0; i < segments; ++i) {
      const double a = 2.0 * M_PI * i / segments;
      m.vertices.push_back(center + Vec3(r * std::cos(a), r * std::sin(a), -height_m / 2 + height_m * j / rings));
    }
  auto id = [&](int i, int j) { return j * segments + (i % segments); };
  for (int j = 0; j < rings; ++j)
    for (int i = 0; i < segments; ++i) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  const int cb = m.num_vertices();
  m.vertices.push_back(center - Vec3(0, 0, height_m / 2));
  const int ct = m.num_vertices();
  m.vertices.push_back(center + Vec3(0, 0, height_m / 2));
  for (int i = 0; i < segments; ++i) {
    m.triangles.push_back({cb, id(i + 1, 0), id(i, 0)});
    m.triangles.push_back({ct, id(i, rings), id(i + 1, rings)});
  }
  return m;
}

geometry::TriMesh make_box(const Vec3& size, const Vec3& center) {
  require(size.allFinite() && (size.array() > 0.0).all(), "make_box: sizes must be positive");
  const double cell = 0.02;
  const Eigen::Vector3i cells((size / cell).array().ceil().cast<int>().cwiseMax(1).matrix());
  return make_box_cells(size, center, cells);
}

geometry::TriMesh make_chessboard(int cols, int rows, double square_m, const Vec3& center, double thickness_m) {
  require(cols >= 2 && rows >= 2 && cols <= 100 && rows <= 100,
          "make_chessboard: {}x{} squares (expected 2 to 100 each way)", cols, rows);
  require(std::isfinite(square_m) && square_m > 0.0 && thickness_m > 0.0,
          "make_chessboard: square {} m and thickness {} m must be positive", square_m, thickness_m);
  const Vec3 size(cols * square_m, thickness_m, rows * square_m);
  return make_box_cells(size, center + Vec3(0, thickness_m / 2, 0), Eigen::Vector3i(cols, 1, rows));
}

}  // namespace socketsmith::scan
