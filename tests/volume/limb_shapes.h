#pragma once
/// @file limb_shapes.h
/// Analytic limb-like shapes for mesher tests: a capsule (cylinder + hemispherical distal end)
/// open or capped at the top, and a cylindrical "bone" with rounded ends.

#include <algorithm>
#include <cmath>
#include <vector>

#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::volume::test {

using geometry::Vec3;

/// Capsule of radius R and total height H (hemisphere z in [0, R], cylinder up to H).
inline double capsule_radius(double z, double R) {
  if (z >= R) return R;
  const double d = R - z;
  return std::sqrt(std::max(0.0, R * R - d * d));
}

inline geometry::TriMesh capsule(double R, double H, bool open, int rings = 120, int segments = 96) {
  // Uniform rings in z give poor triangles at the pole; use angle-uniform rings on the cap.
  geometry::TriMesh m;
  const int cap_rings = rings / 4;
  m.vertices.push_back(Vec3::Zero());
  std::vector<double> zs;
  for (int r = 1; r <= cap_rings; ++r) zs.push_back(R - R * std::cos(0.5 * M_PI * r / cap_rings));
  const int body = rings - cap_rings;
  for (int r = 1; r <= body; ++r) zs.push_back(R + (H - R) * r / body);
  for (double z : zs)
    for (int k = 0; k < segments; ++k) {
      const double th = 2 * M_PI * k / segments;
      const double rr = capsule_radius(z, R);
      m.vertices.push_back(Vec3(rr * std::cos(th), rr * std::sin(th), z));
    }
  const int nr = static_cast<int>(zs.size());
  auto v = [&](int r, int k) { return 1 + (r - 1) * segments + (k % segments); };
  for (int k = 0; k < segments; ++k) m.triangles.push_back({0, v(1, k + 1), v(1, k)});
  for (int r = 1; r < nr; ++r)
    for (int k = 0; k < segments; ++k) {
      m.triangles.push_back({v(r, k), v(r, k + 1), v(r + 1, k + 1)});
      m.triangles.push_back({v(r, k), v(r + 1, k + 1), v(r + 1, k)});
    }
  if (!open) {
    m.vertices.push_back(Vec3(0, 0, H));
    const int pole = m.num_vertices() - 1;
    for (int k = 0; k < segments; ++k) m.triangles.push_back({pole, v(nr, k), v(nr, k + 1)});
  }
  return m;
}

/// Frame of the capsule: axis +z, origin at the distal pole, anterior +y.
inline geometry::LimbFrame capsule_frame() {
  geometry::LimbFrame f;
  f.origin = Vec3::Zero();
  f.axis = Vec3::UnitZ();
  f.anterior = Vec3::UnitY();
  return f;
}

}  // namespace socketsmith::volume::test
