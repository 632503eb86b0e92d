#include "socketsmith/scan/accuracy.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/surface_query.h"

namespace socketsmith::scan {
namespace {

using Clock = std::chrono::steady_clock;

/// Signed distances of @p samples to @p surface (in parallel), positive on the side its triangle
/// normals point to, times @p sign.
std::vector<double> distances_to(const std::vector<SurfaceSample>& samples, const geometry::SurfaceQuery& surface,
                                 double sign) {
  std::vector<double> d(samples.size(), 0.0);
  const long n = static_cast<long>(samples.size());
#pragma omp parallel for schedule(dynamic, 256)
  for (long i = 0; i < n; ++i) {
    const Vec3& p = samples[static_cast<size_t>(i)].point;
    const geometry::SurfaceHit h = surface.closest_point(p);
    const double side = geometry::triangle_normal(surface.mesh(), h.triangle).dot(p - h.point);
    d[static_cast<size_t>(i)] = (side < 0.0 ? -sign : sign) * h.distance;
  }
  return d;
}

/// Progress of a sub-step mapped to [lo, hi] of the whole.
ProgressCallback sub_progress(const ProgressCallback& cb, double lo, double hi) {
  if (!cb) return {};
  return [cb, lo, hi](double f, std::string_view stage) { return cb(lo + (hi - lo) * f, stage); };
}

Deviation deviation_of(const std::vector<SurfaceSample>& samples, const std::vector<double>& d) {
  std::vector<double> w(samples.size());
  for (size_t i = 0; i < samples.size(); ++i) w[i] = samples[i].weight;
  return deviation_stats(d, w);
}

}  // namespace

std::vector<SurfaceSample> sample_surface(const geometry::TriMesh& mesh, double spacing_m, int first_triangle,
                                          int end_triangle) {
  require(std::isfinite(spacing_m) && spacing_m > 0.0, "sample_surface: spacing {} m must be positive", spacing_m);
  const int end = end_triangle < 0 ? mesh.num_triangles() : std::min(end_triangle, mesh.num_triangles());
  std::vector<SurfaceSample> out;
  for (int t = std::max(first_triangle, 0); t < end; ++t) {
    const auto& tri = mesh.triangles[static_cast<size_t>(t)];
    const Vec3& a = mesh.vertices[static_cast<size_t>(tri[0])];
    const Vec3& b = mesh.vertices[static_cast<size_t>(tri[1])];
    const Vec3& c = mesh.vertices[static_cast<size_t>(tri[2])];
    const Vec3 cross = (b - a).cross(c - a);
    const double area = 0.5 * cross.norm();
    if (!(area > 0.0)) continue;
    const Vec3 n = cross.normalized();
    const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    const int L = std::clamp(static_cast<int>(std::ceil(longest / spacing_m)), 1, 64);
    const double w = area / (L * L);
    // Upward sub-triangles (i, j), (i+1, j), (i, j+1) and downward ones (i+1, j), (i+1, j+1), (i, j+1)
    // in barycentric steps of 1/L: their centroids.
    auto add = [&](double s, double r) { out.push_back({a + s * (b - a) + r * (c - a), n, w, t}); };
    for (int i = 0; i < L; ++i)
      for (int j = 0; i + j < L; ++j) {
        add((i + 1.0 / 3.0) / L, (j + 1.0 / 3.0) / L);
        if (i + j < L - 1) add((i + 2.0 / 3.0) / L, (j + 2.0 / 3.0) / L);
      }
  }
  return out;
}

Deviation deviation_stats(const std::vector<double>& d, const std::vector<double>& w) {
  require(d.size() == w.size(), "deviation_stats: {} distances but {} weights", d.size(), w.size());
  Deviation r;
  r.samples = static_cast<int>(d.size());
  if (d.empty()) return r;
  double sw = 0.0, s1 = 0.0, s2 = 0.0;
  double ss = 0.0;
  for (size_t i = 0; i < d.size(); ++i) {
    sw += w[i];
    ss += w[i] * d[i];
    s1 += w[i] * std::abs(d[i]);
    s2 += w[i] * d[i] * d[i];
    r.max_m = std::max(r.max_m, std::abs(d[i]));
  }
  r.area_m2 = sw;
  if (sw <= 0.0) return r;
  r.mean_m = s1 / sw;
  r.signed_mean_m = ss / sw;
  r.rms_m = std::sqrt(s2 / sw);
  std::vector<size_t> order(d.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::sort(order.begin(), order.end(), [&](size_t i, size_t j) { return std::abs(d[i]) < std::abs(d[j]); });
  double acc = 0.0;
  for (size_t i : order) {
    acc += w[i];
    r.p95_m = std::abs(d[i]);
    if (acc >= 0.95 * sw) break;
  }
  return r;
}

bool sensor_sees(const SimulatedSensor& sensor, const RayTable& rays, const geometry::SurfaceQuery& scene,
                 const Vec3& p, const Vec3& n, double max_view_angle_rad, double min_range_m, double max_range_m) {
  const Vec3 eye = sensor.world_from_sensor.translation();
  const Vec3 local = sensor.world_from_sensor.inverse() * p;
  if (local.z() < min_range_m || local.z() > max_range_m) return false;
  const Vec3 to_eye = eye - p;
  const double dist = to_eye.norm();
  if (n.dot(to_eye) < std::cos(max_view_angle_rad) * dist) return false;
  const Eigen::Vector2d uv =
      project_normalised(sensor.intrinsics, Eigen::Vector2d(local.x() / local.z(), local.y() / local.z()));
  const int u = static_cast<int>(std::lround(uv.x())), v = static_cast<int>(std::lround(uv.y()));
  if (u < 0 || v < 0 || u >= rays.width || v >= rays.height || !std::isfinite(rays.at(u, v).x())) return false;
  const auto hit = scene.first_hit(eye, p - eye);
  return !hit || hit->distance >= dist - 1e-3;
}

ScanAccuracy measure_scan_accuracy(const geometry::TriMesh& reconstructed, int first_cap_triangle,
                                   const geometry::TriMesh& original, const std::vector<SimulatedSensor>& sensors,
                                   const AccuracyOptions& o) {
  require(!reconstructed.empty() && !original.empty(), "measure_scan_accuracy: a mesh is empty");
  require(std::abs(o.up.norm() - 1.0) < 1e-6, "measure_scan_accuracy: 'up' must be a unit vector");
  const geometry::SurfaceQuery rec_query(reconstructed), orig_query(original);
  auto below = [&](const std::vector<SurfaceSample>& all) {
    std::vector<SurfaceSample> kept;
    for (const SurfaceSample& s : all)
      if (o.up.dot(s.point) <= o.region_top_m) kept.push_back(s);
    return kept;
  };
  const std::vector<SurfaceSample> rec_samples =
      below(sample_surface(reconstructed, o.sample_spacing_m, 0, first_cap_triangle));
  const std::vector<SurfaceSample> orig_samples = below(sample_surface(original, o.sample_spacing_m));
  require(!rec_samples.empty() && !orig_samples.empty(),
          "measure_scan_accuracy: no surface below the region's top {:.1f} mm (is 'up' the limb's proximal "
          "direction?)",
          o.region_top_m * 1e3);

  std::vector<RayTable> rays;
  for (const SimulatedSensor& s : sensors) rays.push_back(make_ray_table(s.intrinsics, 1));
  std::vector<char> seen(orig_samples.size(), 0);
  const long n = static_cast<long>(orig_samples.size());
#pragma omp parallel for schedule(dynamic, 256)
  for (long i = 0; i < n; ++i) {
    const SurfaceSample& s = orig_samples[static_cast<size_t>(i)];
    // The original's orientation is not trusted (open meshes): a sensor on either side counts.
    for (size_t k = 0; k < sensors.size() && !seen[static_cast<size_t>(i)]; ++k)
      seen[static_cast<size_t>(i)] = sensor_sees(sensors[k], rays[k], orig_query, s.point, s.normal, o.max_view_angle_rad) ||
                                     sensor_sees(sensors[k], rays[k], orig_query, s.point, -s.normal, o.max_view_angle_rad);
  }
  std::vector<SurfaceSample> seen_samples, unseen_samples;
  for (size_t i = 0; i < orig_samples.size(); ++i) (seen[i] ? seen_samples : unseen_samples).push_back(orig_samples[i]);

  ScanAccuracy r;
  // Signs: > 0 where the reconstruction lies outside the original. The original's normals are
  // taken as outward when its signed volume (closed by its opening) is positive.
  const double orig_sign = geometry::signed_volume(original) < 0.0 ? -1.0 : 1.0;
  const std::vector<double> d_rec = distances_to(rec_samples, orig_query, orig_sign);
  const std::vector<double> d_seen = distances_to(seen_samples, rec_query, -1.0);
  const std::vector<double> d_unseen = distances_to(unseen_samples, rec_query, -1.0);
  r.reconstructed_to_original = deviation_of(rec_samples, d_rec);
  r.seen_original_to_reconstructed = deviation_of(seen_samples, d_seen);
  r.unseen_original_to_reconstructed = deviation_of(unseen_samples, d_unseen);
  std::vector<double> d_all = d_rec, w_all;
  d_all.insert(d_all.end(), d_seen.begin(), d_seen.end());
  for (const auto& s : rec_samples) w_all.push_back(s.weight);
  for (const auto& s : seen_samples) w_all.push_back(s.weight);
  r.symmetric = deviation_stats(d_all, w_all);
  const double total = r.seen_original_to_reconstructed.area_m2 + r.unseen_original_to_reconstructed.area_m2;
  r.seen_area_fraction = total > 0.0 ? r.seen_original_to_reconstructed.area_m2 / total : 0.0;
  return r;
}

LimbScanResult run_limb_scan_experiment(const geometry::TriMesh& limb, const LimbScanOptions& o,
                                        const ProgressCallback& progress) {
  require(!limb.empty(), "limb scan experiment: the limb mesh has no triangles");
  const geometry::Aabb box = geometry::bounding_box(limb);
  require(box.extent().z() >= 0.5 * box.extent().maxCoeff() && box.extent().maxCoeff() < 2.0,
          "limb scan experiment: the limb is {:.0f} x {:.0f} x {:.0f} mm; expected metres with the long axis along z "
          "(proximal end up)",
          box.extent().x() * 1e3, box.extent().y() * 1e3, box.extent().z() * 1e3);
  LimbScanResult r;
  r.offset = -box.center();
  r.original = limb;
  for (Vec3& v : r.original.vertices) v += r.offset;
  r.rig = default_rig(o.sensors, o.radius_m, o.height_m, Vec3::Zero(), o.intrinsics);
  const auto t0 = Clock::now();
  r.recording = simulate_recording(r.original, r.rig, o.simulation, sub_progress(progress, 0.0, 0.3));
  r.simulate_s = std::chrono::duration<double>(Clock::now() - t0).count();
  if (!o.compensation.empty()) {
    require(o.compensation.size() == r.recording.sensors.size(), "limb scan experiment: {} compensation models for {} "
            "sensors", o.compensation.size(), r.recording.sensors.size());
    for (size_t s = 0; s < r.recording.sensors.size(); ++s) r.recording.sensors[s].compensation = o.compensation[s];
  }
  ReconstructionOptions ro = o.reconstruction;
  r.reconstruction = reconstruct_recording(r.recording, ro, sub_progress(progress, 0.3, 0.9));
  report_progress(progress, 0.9, "measuring the surface distance");
  AccuracyOptions ao = o.accuracy;
  ao.up = ro.up;
  if (std::isfinite(r.reconstruction.cut_height_m)) ao.region_top_m = r.reconstruction.cut_height_m;
  r.accuracy = measure_scan_accuracy(r.reconstruction.mesh, r.reconstruction.first_cap_triangle, r.original, r.rig, ao);
  report_progress(progress, 1.0, "limb scan measured");
  return r;
}

}  // namespace socketsmith::scan
