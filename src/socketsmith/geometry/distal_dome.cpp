#include "socketsmith/geometry/distal_dome.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <tuple>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "socketsmith/geometry/mesh_repair.h"

namespace socketsmith::geometry {
namespace {

/// One rim vertex's spoke in the rim's frame: radial direction, distance from the axis, height
/// along the axis (distal positive), and the inward slope of the surface there (axial per radial
/// step towards the axis; 0 when the surface does not turn inward going distally).
struct Spoke {
  Vec3 u = Vec3::Zero();
  double r = 0.0;
  double z = 0.0;
  double slope = 0.0;
};

/// The spokes of @p rim about centre @p c and distal axis @p a; the surface's slope at a rim vertex
/// is from the mean distance from the axis and height of its neighbours off the rim to its own
/// (distances, not the neighbours' mean point, which lies inside the surface by the chord's sag).
std::vector<Spoke> rim_spokes(const TriMesh& mesh, const std::vector<int>& rim, const Vec3& c, const Vec3& a) {
  const auto r_z = [&](int v) {
    const Vec3 w = mesh.vertices[v] - c;
    const double z = w.dot(a);
    return std::pair{(w - z * a).norm(), z};
  };
  std::vector<int> slot(mesh.vertices.size(), -1);
  for (std::size_t i = 0; i < rim.size(); ++i) slot[rim[i]] = static_cast<int>(i);
  std::vector<Vec3> off_sum(rim.size(), Vec3::Zero());  // (r, z, count)
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const int i = slot[t[k]];
      if (i < 0) continue;
      for (int m = 1; m < 3; ++m) {
        const int w = t[(k + m) % 3];
        if (slot[w] >= 0) continue;
        const auto [r, z] = r_z(w);
        off_sum[i] += Vec3(r, z, 1.0);
      }
    }
  std::vector<Spoke> spokes(rim.size());
  for (std::size_t i = 0; i < rim.size(); ++i) {
    Spoke& s = spokes[i];
    std::tie(s.r, s.z) = r_z(rim[i]);
    const Vec3 w = mesh.vertices[rim[i]] - c;
    if (s.r > 0.0) s.u = (w - s.z * a) / s.r;
    if (off_sum[i].z() == 0.0 || s.r == 0.0) continue;
    const double dr = s.r - off_sum[i].x() / off_sum[i].z(), dz = s.z - off_sum[i].y() / off_sum[i].z();
    if (dz > 0.0 && dr < 0.0) s.slope = dz / -dr;
  }
  return spokes;
}

/// The apex's height above the rim's centroid: half the median depth at which the rims' tangents
/// reach the axis, within [0.15, 1] × the rim's equivalent radius and past every rim vertex.
double dome_depth(const std::vector<Spoke>& spokes, double r_eq) {
  std::vector<double> reach;
  double z_max = -1e300;
  for (const Spoke& s : spokes) {
    z_max = std::max(z_max, s.z);
    if (s.slope > 0.0) reach.push_back(s.z + s.r * s.slope);
  }
  double h = r_eq;
  if (!reach.empty()) {
    auto mid = reach.begin() + static_cast<std::ptrdiff_t>(reach.size() / 2);
    std::nth_element(reach.begin(), mid, reach.end());
    h = 0.5 * *mid;
  }
  return std::max(std::clamp(h, 0.15 * r_eq, r_eq), z_max + 0.15 * r_eq);
}

}  // namespace

std::string DistalDome::describe() const {
  return fmt::format("the distal opening ({} edges, {:.0f} mm across) closed with a dome {:.1f} mm deep: the "
                     "tip's shape is assumed, not scanned",
                     rim_edges, rim_width_m * 1e3, depth_m * 1e3);
}

std::optional<DistalDome> close_distal_opening(TriMesh& mesh) {
  const std::vector<std::vector<int>> loops = open_boundary_loops(mesh);
  if (loops.size() != 2) return std::nullopt;
  const Vec3 n0 = newell_normal(mesh.vertices, loops[0]), n1 = newell_normal(mesh.vertices, loops[1]);
  const bool first_smaller = n0.norm() <= n1.norm();
  const std::vector<int>& rim = first_smaller ? loops[0] : loops[1];
  const Vec3 n = first_smaller ? n0 : n1;
  if (!(n.norm() > 0.0) || !(n.norm() < 0.5 * (first_smaller ? n1 : n0).norm())) return std::nullopt;
  // The loop runs the way a patch closing it faces like the surface: outwards, so distally.
  const Vec3 a = n.normalized();
  Vec3 c = Vec3::Zero();
  double perimeter = 0.0;
  for (std::size_t i = 0; i < rim.size(); ++i) {
    c += mesh.vertices[rim[i]];
    perimeter += (mesh.vertices[rim[(i + 1) % rim.size()]] - mesh.vertices[rim[i]]).norm();
  }
  c /= static_cast<double>(rim.size());
  const double r_eq = std::sqrt(0.5 * n.norm() / std::numbers::pi);
  const std::vector<Spoke> spokes = rim_spokes(mesh, rim, c, a);
  const double h = dome_depth(spokes, r_eq);
  const Vec3 apex = c + h * a;
  // Rings about one rim edge apart along a spoke (roughly h + r_eq long).
  const double edge = perimeter / static_cast<double>(rim.size());
  const int rings = std::clamp(static_cast<int>(std::ceil((h + r_eq) / edge)), 2, 64);

  DistalDome dome;
  dome.rim_edges = static_cast<int>(rim.size());
  dome.rim_width_m = 2.0 * r_eq;
  dome.depth_m = h;
  const int nv0 = mesh.num_vertices(), nt0 = static_cast<int>(mesh.triangles.size());
  const int n_rim = static_cast<int>(rim.size());
  std::vector<int> prev = rim, ring(rim.size());
  for (int k = 1; k < rings; ++k) {
    const double t = static_cast<double>(k) / rings;
    for (int i = 0; i < n_rim; ++i) {
      const Spoke& s = spokes[i];
      // Control point: where the rim's tangent meets the apex's plane (vertical tangent: above the rim).
      const double rho = s.slope > 0.0 ? std::clamp(s.r - (h - s.z) / s.slope, 0.0, s.r) : s.r;
      const Vec3 p1 = apex + rho * s.u;
      ring[i] = mesh.num_vertices();
      mesh.vertices.push_back((1 - t) * (1 - t) * mesh.vertices[rim[i]] + 2 * t * (1 - t) * p1 + t * t * apex);
    }
    for (int i = 0; i < n_rim; ++i) {
      const int j = (i + 1) % n_rim;
      mesh.triangles.push_back({prev[i], prev[j], ring[j]});
      mesh.triangles.push_back({prev[i], ring[j], ring[i]});
    }
    prev = ring;
  }
  const int tip = mesh.num_vertices();
  mesh.vertices.push_back(apex);
  for (int i = 0; i < n_rim; ++i) mesh.triangles.push_back({prev[i], prev[(i + 1) % n_rim], tip});
  dome.added_vertices = mesh.num_vertices() - nv0;
  dome.added_triangles = static_cast<int>(mesh.triangles.size()) - nt0;
  return dome;
}

}  // namespace socketsmith::geometry
