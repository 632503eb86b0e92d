#include "socketsmith/geometry/slices.h"

#include <cmath>

#include "socketsmith/core/errors.h"

namespace socketsmith::geometry {
namespace {

void check_mesh_input(const TriMesh& mesh, const char* fn) {
  require(!mesh.empty(), "{}: the surface has no triangles (expected a closed limb or cavity surface)", fn);
  const int nv = mesh.num_vertices();
  for (const auto& t : mesh.triangles)
    for (int v : t) require(v >= 0 && v < nv, "{}: a triangle refers to vertex {} of {}", fn, v, nv);
  for (const auto& v : mesh.vertices)
    require(v.allFinite(), "{}: the surface has a vertex with NaN/inf coordinates; repair the mesh", fn);
}

/// Σ over the parts of the triangles below h = H of ∫ h (n·a) dA (see the file comment).
double flux_below(const TriMesh& mesh, const LimbFrame& frame, double H) {
  const Vec3 a = frame.axis.normalized();
  double sum = 0.0;
  for (const auto& tri : mesh.triangles) {
    std::array<Vec3, 3> p;
    std::array<double, 3> h{};
    int below = 0;
    for (int k = 0; k < 3; ++k) {
      p[k] = mesh.vertices[tri[k]];
      h[k] = (p[k] - frame.origin).dot(a);
      // The same side test as slice_surface (a vertex on the plane counts as above), so the
      // clipped polygons close exactly on the cross-section it measures.
      if (h[k] - H < 0.0) ++below;
    }
    if (below == 0) continue;
    // Sutherland–Hodgman against h < H: at most 4 vertices.
    std::array<Vec3, 4> poly;
    int n = 0;
    for (int k = 0; k < 3; ++k) {
      const int j = (k + 1) % 3;
      const double sk = h[k] - H, sj = h[j] - H;
      if (sk < 0.0) poly[n++] = p[k];
      if ((sk < 0.0) != (sj < 0.0)) {
        const double w = sk / (sk - sj);
        poly[n++] = p[k] + w * (p[j] - p[k]);
      }
    }
    // Fan: ∫ h (n·a) dA of a flat triangle = (projected signed area) × mean height.
    for (int k = 1; k + 1 < n; ++k) {
      const Vec3 cr = (poly[k] - poly[0]).cross(poly[k + 1] - poly[0]);
      const double hm = ((poly[0] + poly[k] + poly[k + 1]) / 3.0 - frame.origin).dot(a);
      sum += 0.5 * cr.dot(a) * hm;
    }
  }
  return sum;
}

}  // namespace

double volume_below(const TriMesh& mesh, const LimbFrame& frame, double h_m) {
  check_mesh_input(mesh, "volume_below");
  require(std::isfinite(h_m), "volume_below: the level h = {} is not finite", h_m);
  const Vec3 a = frame.axis.normalized();
  const Slice s = slice_surface(mesh, frame.origin + h_m * a, a);
  return flux_below(mesh, frame, h_m) + h_m * s.area;
}

std::vector<double> slice_heights(double step_m, double top_m) {
  require(std::isfinite(step_m) && step_m > 0, "slice_heights: step {} mm must be positive", step_m * 1e3);
  require(std::isfinite(top_m) && top_m > 0, "slice_heights: top {} mm must be above the distal end (> 0)",
          top_m * 1e3);
  require(top_m / step_m <= 1e5, "slice_heights: {} levels of {} mm up to {} mm is too many (at most 100000)",
          top_m / step_m, step_m * 1e3, top_m * 1e3);
  std::vector<double> h;
  for (int k = 1; k * step_m < top_m * (1 - 1e-9); ++k) h.push_back(k * step_m);
  h.push_back(top_m);
  return h;
}

std::vector<SliceLevel> measure_slices(const TriMesh& mesh, const LimbFrame& frame, const std::vector<double>& heights) {
  check_mesh_input(mesh, "measure_slices");
  const Vec3 a = frame.axis.normalized();
  std::vector<SliceLevel> out;
  out.reserve(heights.size());
  double previous = 0.0;
  for (size_t k = 0; k < heights.size(); ++k) {
    const double h = heights[k];
    require(std::isfinite(h) && (k == 0 || h > heights[k - 1]),
            "measure_slices: level {} at {} mm is not finite or not above the one before (expected ascending heights)",
            k, h * 1e3);
    const Slice s = slice_surface(mesh, frame.origin + h * a, a);
    SliceLevel l;
    l.h_m = h;
    l.circumference_m = s.perimeter;
    l.area_m2 = s.area;
    l.volume_below_m3 = flux_below(mesh, frame, h) + h * s.area;
    l.slab_volume_m3 = l.volume_below_m3 - previous;
    previous = l.volume_below_m3;
    out.push_back(l);
  }
  return out;
}

}  // namespace socketsmith::geometry
