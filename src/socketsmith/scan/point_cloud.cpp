#include "socketsmith/scan/point_cloud.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <unordered_map>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Orthogonal_k_neighbor_search.h>
#include <CGAL/Search_traits_3.h>

#include "socketsmith/core/errors.h"

namespace socketsmith::scan {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point3 = Kernel::Point_3;
using KnnSearch = CGAL::Orthogonal_k_neighbor_search<CGAL::Search_traits_3<Kernel>>;
using KdTree = KnnSearch::Tree;

/// Mean distance of every point to its k nearest other points.
std::vector<double> mean_knn_distances(const std::vector<Vec3>& points, int k) {
  std::vector<Point3> pts;
  pts.reserve(points.size());
  for (const Vec3& p : points) pts.emplace_back(p.x(), p.y(), p.z());
  KdTree tree(pts.begin(), pts.end());
  tree.build();
  std::vector<double> mean(points.size(), 0.0);
  const long n = static_cast<long>(pts.size());
#pragma omp parallel for schedule(static)
  for (long i = 0; i < n; ++i) {
    KnnSearch search(tree, pts[static_cast<size_t>(i)], static_cast<unsigned>(k + 1));
    double sum = 0.0;
    int count = 0;
    bool skipped_self = false;
    for (const auto& [q, d2] : search) {
      if (!skipped_self && d2 == 0.0) {  // the query itself
        skipped_self = true;
        continue;
      }
      if (count == k) break;
      sum += std::sqrt(d2);
      ++count;
    }
    mean[static_cast<size_t>(i)] = count > 0 ? sum / count : 0.0;
  }
  return mean;
}

std::int64_t cell_key(long ix, long iy, long iz) {
  constexpr long kOff = 1 << 20;
  return ((ix + kOff) << 42) ^ ((iy + kOff) << 21) ^ (iz + kOff);
}

}  // namespace

void PointCloud::append(const PointCloud& other) {
  points.insert(points.end(), other.points.begin(), other.points.end());
  normals.insert(normals.end(), other.normals.begin(), other.normals.end());
  sensor.insert(sensor.end(), other.sensor.begin(), other.sensor.end());
}

PointCloud back_project(const DepthImage& image, const CameraIntrinsics& k, const Eigen::Isometry3d& world_from_sensor,
                        const BackProjectionOptions& o, int sensor_index, const RayTable* rays,
                        const ErrorCompensation* compensation) {
  validate_intrinsics(k, "back_project");
  require(image.width == k.width && image.height == k.height,
          "back_project: depth frame is {}x{} px but the intrinsics are for {}x{} (wrong intrinsics file for this "
          "sensor?)",
          image.width, image.height, k.width, k.height);
  require(o.normal_step_px >= 1, "back_project: normal_step_px {} must be at least 1", o.normal_step_px);
  require(o.min_depth_m >= 0.0 && o.max_depth_m > o.min_depth_m,
          "back_project: depth range [{}, {}] m is empty", o.min_depth_m, o.max_depth_m);
  RayTable own;
  if (rays == nullptr || rays->upsample != o.upsample || rays->width != k.width * o.upsample) {
    own = make_ray_table(k, o.upsample);
    rays = &own;
  }
  const DepthMap dm = to_depth_map(image, k.depth_shift_m, o.upsample, o.max_depth_jump_m);
  const int w = dm.width, h = dm.height, step = o.normal_step_px * o.upsample;
  const double cos_max = std::cos(std::clamp(o.max_view_angle_rad, 0.0, M_PI / 2));
  auto valid = [&](int u, int v) {
    const float d = dm.at(u, v);
    return d > 0.0f && d >= o.min_depth_m && d <= o.max_depth_m && std::isfinite(rays->at(u, v).x());
  };
  const double up = o.upsample;
  auto point = [&](int u, int v) -> Vec3 {
    const double d = dm.at(u, v);
    const Eigen::Vector2d& xy = rays->at(u, v);
    const Vec3 p(xy.x() * d, xy.y() * d, d);
    if (compensation == nullptr) return p;
    return compensation->apply(p, (u + 0.5) / up - 0.5, (v + 0.5) / up - 0.5);
  };
  // Neighbour difference along one axis: central when both sides are valid and on the same
  // surface, one-sided otherwise.
  auto tangent = [&](int u, int v, int du, int dv, const Vec3& p, Vec3& t) {
    const int ua = u + du, va = v + dv, ub = u - du, vb = v - dv;
    const double d = dm.at(u, v);
    const bool a = ua >= 0 && ua < w && va >= 0 && va < h && valid(ua, va) &&
                   std::abs(dm.at(ua, va) - d) <= o.max_depth_jump_m;
    const bool b = ub >= 0 && ub < w && vb >= 0 && vb < h && valid(ub, vb) &&
                   std::abs(dm.at(ub, vb) - d) <= o.max_depth_jump_m;
    if (a && b) t = point(ua, va) - point(ub, vb);
    else if (a) t = point(ua, va) - p;
    else if (b) t = p - point(ub, vb);
    else return false;
    return true;
  };
  PointCloud cloud;
  const Eigen::Matrix3d R = world_from_sensor.linear();
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      if (!valid(u, v)) continue;
      const Vec3 p = point(u, v);
      Vec3 tu, tv;
      if (!tangent(u, v, step, 0, p, tu) || !tangent(u, v, 0, step, p, tv)) continue;
      Vec3 n = tu.cross(tv);
      const double len = n.norm();
      if (!(len > 0.0)) continue;
      n /= len;
      const Vec3 ray = p.normalized();
      if (n.dot(ray) > 0.0) n = -n;  // face the sensor
      if (-n.dot(ray) < cos_max) continue;
      cloud.points.push_back(world_from_sensor * p);
      cloud.normals.push_back(R * n);
      cloud.sensor.push_back(sensor_index);
    }
  return cloud;
}

int remove_statistical_outliers(PointCloud& cloud, const OutlierOptions& o) {
  require(o.neighbours >= 1, "remove_statistical_outliers: neighbours = {} must be at least 1", o.neighbours);
  require(o.alpha >= 0.0 && std::isfinite(o.alpha), "remove_statistical_outliers: alpha = {} must be >= 0", o.alpha);
  if (cloud.size() <= o.neighbours + 1) return 0;
  const std::vector<double> mean = mean_knn_distances(cloud.points, o.neighbours);
  const double n = static_cast<double>(mean.size());
  const double mu = std::accumulate(mean.begin(), mean.end(), 0.0) / n;
  double var = 0.0;
  for (double m : mean) var += (m - mu) * (m - mu);
  const double limit = mu + o.alpha * std::sqrt(var / n);
  PointCloud kept;
  for (size_t i = 0; i < mean.size(); ++i) {
    if (mean[i] > limit) continue;
    kept.points.push_back(cloud.points[i]);
    kept.normals.push_back(cloud.normals[i]);
    kept.sensor.push_back(cloud.sensor[i]);
  }
  const int removed = cloud.size() - kept.size();
  cloud = std::move(kept);
  return removed;
}

PointCloud grid_simplify(const PointCloud& cloud, double cell_m) {
  require(std::isfinite(cell_m) && cell_m > 0.0, "grid_simplify: cell size {} m must be positive", cell_m);
  struct Acc {
    Vec3 p = Vec3::Zero(), n = Vec3::Zero();
    int count = 0, sensor = 0;
  };
  std::unordered_map<std::int64_t, int> index;
  std::vector<Acc> acc;
  index.reserve(cloud.points.size());
  for (size_t i = 0; i < cloud.points.size(); ++i) {
    const Vec3& p = cloud.points[i];
    const std::int64_t key = cell_key(std::lround(std::floor(p.x() / cell_m)), std::lround(std::floor(p.y() / cell_m)),
                                      std::lround(std::floor(p.z() / cell_m)));
    auto [it, inserted] = index.emplace(key, static_cast<int>(acc.size()));
    if (inserted) acc.push_back({Vec3::Zero(), Vec3::Zero(), 0, cloud.sensor[i]});
    Acc& a = acc[static_cast<size_t>(it->second)];
    a.p += p;
    a.n += cloud.normals[i];
    ++a.count;
  }
  PointCloud out;
  for (const Acc& a : acc) {
    const double len = a.n.norm();
    if (!(len > 1e-12)) continue;  // opposite normals cancelled: a thin wall, drop the cell
    out.points.push_back(a.p / a.count);
    out.normals.push_back(a.n / len);
    out.sensor.push_back(a.sensor);
  }
  return out;
}

std::vector<double> sensor_overlap_fractions(const PointCloud& cloud, int num_sensors, double radius_m) {
  require(num_sensors >= 1 && num_sensors <= 32, "sensor_overlap_fractions: {} sensors (expected 1 to 32)",
          num_sensors);
  require(radius_m > 0.0, "sensor_overlap_fractions: radius {} m must be positive", radius_m);
  std::unordered_map<std::int64_t, std::uint32_t> cells;
  auto cell = [&](const Vec3& p) {
    return Eigen::Vector3i(static_cast<int>(std::floor(p.x() / radius_m)), static_cast<int>(std::floor(p.y() / radius_m)),
                           static_cast<int>(std::floor(p.z() / radius_m)));
  };
  for (size_t i = 0; i < cloud.points.size(); ++i) {
    const Eigen::Vector3i c = cell(cloud.points[i]);
    cells[cell_key(c.x(), c.y(), c.z())] |= (1u << cloud.sensor[i]);
  }
  std::vector<double> hits(static_cast<size_t>(num_sensors), 0.0), total(static_cast<size_t>(num_sensors), 0.0);
  for (size_t i = 0; i < cloud.points.size(); ++i) {
    const int s = cloud.sensor[i];
    const Eigen::Vector3i c = cell(cloud.points[i]);
    std::uint32_t mask = 0;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          auto it = cells.find(cell_key(c.x() + dx, c.y() + dy, c.z() + dz));
          if (it != cells.end()) mask |= it->second;
        }
    total[static_cast<size_t>(s)] += 1.0;
    if ((mask & ~(1u << s)) != 0) hits[static_cast<size_t>(s)] += 1.0;
  }
  for (int s = 0; s < num_sensors; ++s)
    hits[static_cast<size_t>(s)] = total[static_cast<size_t>(s)] > 0 ? hits[static_cast<size_t>(s)] / total[static_cast<size_t>(s)] : 0.0;
  return hits;
}

double average_spacing(const PointCloud& cloud, int neighbours) {
  if (cloud.size() < 2) return 0.0;
  const std::vector<double> mean = mean_knn_distances(cloud.points, std::min(neighbours, cloud.size() - 1));
  return std::accumulate(mean.begin(), mean.end(), 0.0) / static_cast<double>(mean.size());
}

}  // namespace socketsmith::scan
