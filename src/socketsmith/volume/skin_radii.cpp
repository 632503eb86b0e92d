// The skin's radius about the limb axis, tabulated over heights and angles (SkinRadii, measured
// by rays against the skin): what the bone template is sized and fitted from. Apart from
// bone_template.cpp because measuring the skin is not building bones.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "socketsmith/core/errors.h"
#include "socketsmith/volume/bone_template.h"
#include "socketsmith/volume/shape_math.h"

namespace socketsmith::volume {

namespace {
using Eigen::Vector2d;
using geometry::Vec3;
using shape::clamp01;
using shape::kPi;
using shape::lerp;
constexpr double kInf = std::numeric_limits<double>::infinity();

/// The skin's vertices in the limb frame: height along the axis, anterior and medial coordinates
/// [m], and the lowest and highest heights.
struct SkinCoordinates {
  std::vector<double> hv, av, mv;
  double bottom = kInf, top_closed = -kInf;
};

SkinCoordinates skin_coordinates(const geometry::TriMesh& skin, const geometry::LimbFrame& frame) {
  const int nv = skin.num_vertices();
  SkinCoordinates c;
  c.hv.resize(static_cast<std::size_t>(nv));
  c.av.resize(c.hv.size());
  c.mv.resize(c.hv.size());
  const Vec3 medial = frame.medial();
  for (int v = 0; v < nv; ++v) {
    const Vec3& p = skin.vertices[static_cast<std::size_t>(v)];
    require(p.allFinite(), "measure_skin_radii: skin vertex {} has a non-finite coordinate", v);
    const Vec3 d = p - frame.origin;
    c.hv[static_cast<std::size_t>(v)] = d.dot(frame.axis);
    c.av[static_cast<std::size_t>(v)] = d.dot(frame.anterior);
    c.mv[static_cast<std::size_t>(v)] = d.dot(medial);
    c.bottom = std::min(c.bottom, c.hv[static_cast<std::size_t>(v)]);
    c.top_closed = std::max(c.top_closed, c.hv[static_cast<std::size_t>(v)]);
  }
  return c;
}

/// The lowest height of a boundary edge (used once: the proximal end of an open skin); infinity
/// for a closed skin.
double lowest_boundary_height(const geometry::TriMesh& skin, const std::vector<double>& hv) {
  const int nv = skin.num_vertices();
  std::vector<std::uint64_t> edges;
  edges.reserve(static_cast<std::size_t>(3 * skin.num_triangles()));
  for (const auto& t : skin.triangles)
    for (int e = 0; e < 3; ++e) {
      const int a = t[static_cast<std::size_t>(e)], b = t[static_cast<std::size_t>((e + 1) % 3)];
      require(a >= 0 && a < nv && b >= 0 && b < nv, "measure_skin_radii: a triangle refers to vertex {} of {}",
              std::max(a, b), nv);
      edges.push_back((static_cast<std::uint64_t>(std::min(a, b)) << 32) | static_cast<std::uint64_t>(std::max(a, b)));
    }
  std::sort(edges.begin(), edges.end());
  double boundary_low = kInf;
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i == 1) {
      boundary_low = std::min({boundary_low, hv[static_cast<std::size_t>(edges[i] >> 32)],
                               hv[static_cast<std::size_t>(edges[i] & 0xffffffffu)]});
    }
    i = j;
  }
  return boundary_low;
}

/// Plane section at height h: one segment per triangle crossing h (vertices at h count as above),
/// in (anterior, medial) coordinates.
void section_at(const geometry::TriMesh& skin, const SkinCoordinates& c, double h,
                std::vector<std::array<Vector2d, 2>>& segments) {
  segments.clear();
  for (const auto& t : skin.triangles) {
    Vector2d pts[2];
    int n = 0;
    for (int e = 0; e < 3 && n < 2; ++e) {
      const auto i0 = static_cast<std::size_t>(t[static_cast<std::size_t>(e)]);
      const auto i1 = static_cast<std::size_t>(t[static_cast<std::size_t>((e + 1) % 3)]);
      const bool above0 = c.hv[i0] >= h, above1 = c.hv[i1] >= h;
      if (above0 == above1) continue;
      const double s = (h - c.hv[i0]) / (c.hv[i1] - c.hv[i0]);
      pts[n++] = Vector2d(lerp(c.av[i0], c.av[i1], s), lerp(c.mv[i0], c.mv[i1], s));
    }
    if (n == 2) segments.push_back({pts[0], pts[1]});
  }
}

/// The distance from the axis along direction d to the nearest segment of a section; infinity
/// when the ray meets none.
double nearest_hit(const std::vector<std::array<Vector2d, 2>>& segments, const Vector2d& d) {
  double best = kInf;
  for (const auto& sg : segments) {
    const Vector2d e = sg[1] - sg[0];
    const double den = d.x() * e.y() - d.y() * e.x();
    if (std::abs(den) < 1e-18) continue;
    // Solve t d = p0 + u e.
    const double t = (sg[0].x() * e.y() - sg[0].y() * e.x()) / den;
    const double u = (sg[0].x() * d.y() - sg[0].y() * d.x()) / den;
    // A ray through a shared endpoint must hit one of its two segments despite rounding.
    if (t > 0.0 && u >= -1e-9 && u <= 1.0 + 1e-9) best = std::min(best, t);
  }
  return best;
}

/// Casts a ray from the axis at each of the table's heights and angles into the skin's section:
/// the nearest hit into r.radius_m (left at -1 where the ray misses). Returns whether any ray hit.
bool cast_radii(const geometry::TriMesh& skin, const SkinCoordinates& c, SkinRadii& r) {
  const int num_heights = r.num_heights, num_angles = r.num_angles;
  std::vector<double> ca(static_cast<std::size_t>(num_angles)), sa(ca.size());
  for (int j = 0; j < num_angles; ++j) {
    ca[static_cast<std::size_t>(j)] = std::cos(2.0 * kPi * j / num_angles);
    sa[static_cast<std::size_t>(j)] = std::sin(2.0 * kPi * j / num_angles);
  }
  std::vector<std::array<Vector2d, 2>> segments;
  bool any = false;
  for (int k = 0; k < num_heights; ++k) {
    section_at(skin, c, lerp(r.h_lo_m, r.h_hi_m, static_cast<double>(k) / (num_heights - 1)), segments);
    for (int j = 0; j < num_angles; ++j) {
      const double best = nearest_hit(segments, Vector2d(ca[static_cast<std::size_t>(j)], sa[static_cast<std::size_t>(j)]));
      if (best < kInf) {
        r.radius_m[static_cast<std::size_t>(k) * static_cast<std::size_t>(num_angles) + static_cast<std::size_t>(j)] = best;
        any = true;
      }
    }
  }
  return any;
}

/// Fills the misses of each row with a hit: the nearest hit in the same row (the mean of the two
/// at the same angular distance). Returns which rows had a hit.
std::vector<bool> fill_misses_in_rows(SkinRadii& r) {
  const int num_heights = r.num_heights, num_angles = r.num_angles;
  std::vector<bool> row_ok(static_cast<std::size_t>(num_heights), false);
  for (int k = 0; k < num_heights; ++k) {
    double* row = &r.radius_m[static_cast<std::size_t>(k) * static_cast<std::size_t>(num_angles)];
    std::vector<double> orig(row, row + num_angles);
    bool has = false;
    for (int j = 0; j < num_angles; ++j) has = has || orig[static_cast<std::size_t>(j)] > 0;
    if (!has) continue;
    row_ok[static_cast<std::size_t>(k)] = true;
    for (int j = 0; j < num_angles; ++j) {
      if (orig[static_cast<std::size_t>(j)] > 0) continue;
      for (int off = 1; off <= num_angles / 2; ++off) {
        const double l = orig[static_cast<std::size_t>((j - off + num_angles) % num_angles)];
        const double rr = orig[static_cast<std::size_t>((j + off) % num_angles)];
        if (l > 0 || rr > 0) {
          row[j] = (l > 0 && rr > 0) ? 0.5 * (l + rr) : std::max(l, rr);
          break;
        }
      }
    }
  }
  return row_ok;
}

/// Copies into each row without a hit the nearest row with one (the lower one first).
void fill_empty_rows(SkinRadii& r, const std::vector<bool>& row_ok) {
  const int num_heights = r.num_heights, num_angles = r.num_angles;
  for (int k = 0; k < num_heights; ++k) {
    if (row_ok[static_cast<std::size_t>(k)]) continue;
    for (int off = 1; off < num_heights; ++off) {
      int src = -1;
      if (k - off >= 0 && row_ok[static_cast<std::size_t>(k - off)]) src = k - off;
      else if (k + off < num_heights && row_ok[static_cast<std::size_t>(k + off)]) src = k + off;
      if (src < 0) continue;
      std::copy_n(&r.radius_m[static_cast<std::size_t>(src) * static_cast<std::size_t>(num_angles)], num_angles,
                  &r.radius_m[static_cast<std::size_t>(k) * static_cast<std::size_t>(num_angles)]);
      break;
    }
  }
}

}  // namespace

double SkinRadii::radius(double theta, double h) const {
  require(num_heights >= 2 && num_angles >= 3 &&
              radius_m.size() == static_cast<std::size_t>(num_heights) * static_cast<std::size_t>(num_angles),
          "SkinRadii::radius: the table is empty or inconsistent ({} heights × {} angles, {} values; measure it with "
          "measure_skin_radii)",
          num_heights, num_angles, radius_m.size());
  const double th = std::fmod(theta, 2.0 * kPi) + (theta < 0 ? 2.0 * kPi : 0.0);
  const double u = th / (2.0 * kPi) * num_angles;
  int j0 = static_cast<int>(std::floor(u));
  const double tu = u - j0;
  j0 = ((j0 % num_angles) + num_angles) % num_angles;
  const int j1 = (j0 + 1) % num_angles;
  const double v = clamp01((h - h_lo_m) / (h_hi_m - h_lo_m)) * (num_heights - 1);
  const int k0 = std::min(static_cast<int>(std::floor(v)), num_heights - 2);
  const double tv = v - k0;
  auto at = [&](int k, int j) { return radius_m[static_cast<std::size_t>(k) * static_cast<std::size_t>(num_angles) + static_cast<std::size_t>(j)]; };
  return lerp(lerp(at(k0, j0), at(k0, j1), tu), lerp(at(k0 + 1, j0), at(k0 + 1, j1), tu), tv);
}

double SkinRadii::width_ml(double h) const { return radius(0.5 * kPi, h) + radius(-0.5 * kPi, h); }

SkinRadii measure_skin_radii(const geometry::TriMesh& skin, const geometry::LimbFrame& frame, int num_heights, int num_angles) {
  require(!skin.empty(), "measure_skin_radii: the skin has no triangles (expected a closed limb surface)");
  require(num_heights >= 2 && num_angles >= 8, "measure_skin_radii: {} heights × {} angles (expected at least 2 × 8)",
          num_heights, num_angles);
  const SkinCoordinates c = skin_coordinates(skin, frame);
  const double bottom = c.bottom, top_closed = c.top_closed;
  const double boundary_low = lowest_boundary_height(skin, c.hv);
  const double length = top_closed - bottom;
  require(length > 0.02, "measure_skin_radii: the skin is {:.1f} mm long along the axis (expected a limb, > 20 mm)",
          length * 1e3);
  require(boundary_low == kInf || boundary_low >= bottom + 0.5 * length,
          "measure_skin_radii: the skin is open at h = {:.1f} mm, in its distal half (expected a closed surface, or "
          "one open only at its proximal cut)",
          (boundary_low - bottom) * 1e3);
  SkinRadii r;
  r.bottom_m = bottom;
  r.top_m = std::min(top_closed, boundary_low);
  r.h_lo_m = bottom + std::min(0.002, 0.05 * (r.top_m - bottom));
  r.h_hi_m = r.top_m - std::min(0.002, 0.05 * (r.top_m - bottom));
  r.num_heights = num_heights;
  r.num_angles = num_angles;
  r.radius_m.assign(static_cast<std::size_t>(num_heights) * static_cast<std::size_t>(num_angles), -1.0);
  const bool any = cast_radii(skin, c, r);
  require(any, "measure_skin_radii: no ray from the limb axis meets the skin (is the frame placed on this limb?)");
  // Fill the misses: nearest hit in the same row, then nearest complete row.
  fill_empty_rows(r, fill_misses_in_rows(r));
  return r;
}

}  // namespace socketsmith::volume
