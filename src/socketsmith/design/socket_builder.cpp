#include "socketsmith/design/socket_builder.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <limits>
#include <numbers>
#include <numeric>
#include <optional>
#include <string>
#include <unordered_map>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/mesh_boolean.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/geometry/surface_query.h"
#include "socketsmith/design/socket_builder_detail.h"

namespace socketsmith::design {
using namespace socket_detail;
namespace {


void check_options(const SocketOptions& o) {
  require(std::isfinite(o.thickness_m) && o.thickness_m > 0.0 && o.thickness_m <= 0.05,
          "build_socket: thickness_m = {} m is out of range (expected a wall of (0, 50] mm, e.g. 0.005)",
          o.thickness_m);
  for (const auto& [name, v] : {std::pair{"distal_thickness_m", o.distal_thickness_m},
                                std::pair{"brim_thickness_m", o.brim_thickness_m}})
    require(std::isfinite(v) && v >= 0.0 && v <= 0.05,
            "build_socket: {} = {} m is out of range (0 = thickness_m, else a wall of (0, 50] mm)", name, v);
  require(std::isfinite(o.min_feature_m) && o.min_feature_m > 0.0 && o.min_feature_m <= 0.01,
          "build_socket: min_feature_m = {} m is out of range (0, 10 mm] (a printer's smallest feature, e.g. 0.001)",
          o.min_feature_m);
  for (const auto& [name, v] : {std::pair{"thickness_m", o.thickness_m},
                                std::pair{"distal_thickness_m", o.distal_thickness_m},
                                std::pair{"brim_thickness_m", o.brim_thickness_m}})
    require(v == 0.0 || v >= o.min_feature_m,
            "build_socket: {} = {:.2f} mm is below the smallest printable feature ({:.2f} mm); thicken the wall",
            name, v / kMm, o.min_feature_m / kMm);
  require(std::isfinite(o.brim_band_m) && o.brim_band_m >= 0.0 && o.brim_band_m <= 0.02,
          "build_socket: brim_band_m = {} m is out of range [0, 20 mm]", o.brim_band_m);
  require(!o.round_brim || (o.lip_segments >= 2 && o.lip_segments <= 32),
          "build_socket: lip_segments = {} is out of range [2, 32]", o.lip_segments);
  require(!o.distal_pad || (std::isfinite(o.distal_pad_diameter_m) && o.distal_pad_diameter_m > 0.0 &&
                            o.distal_pad_diameter_m <= 0.15),
          "build_socket: distal_pad_diameter_m = {} m is out of range (0, 0.15]", o.distal_pad_diameter_m);
  for (const auto& [name, v] : {std::pair{"flexion", o.alignment.flexion_rad},
                                std::pair{"adduction", o.alignment.adduction_rad}})
    require(std::isfinite(v) && std::abs(v) <= 30.0 * kDeg,
            "build_socket: socket {} {:.1f}° is out of range [−30°, 30°] (bench alignment: a few degrees)", name,
            v / kDeg);
  if (o.attachment.enabled) {
    const SocketAttachment& a = o.attachment;
    for (const auto& [name, v] : {std::pair{"bolt_diameter_m", a.bolt_diameter_m},
                                  std::pair{"hole_diameter_m", a.hole_diameter_m},
                                  std::pair{"hole_spacing_m", a.hole_spacing_m},
                                  std::pair{"platform_diameter_m", a.platform_diameter_m},
                                  std::pair{"platform_thickness_m", a.platform_thickness_m}})
      require(std::isfinite(v) && v > 0.0 && v <= 0.15, "build_socket: attachment {} = {} m is out of range (0, 150 mm]",
              name, v);
    require(a.hole_diameter_m >= a.bolt_diameter_m,
            "build_socket: attachment hole {:.2f} mm is narrower than its {:.1f} mm bolt; give a clearance hole "
            "(ISO 273: M6 → 6.6 mm)",
            a.hole_diameter_m / kMm, a.bolt_diameter_m / kMm);
    require(a.hole_diameter_m >= o.min_feature_m,
            "build_socket: attachment hole {:.2f} mm is below the smallest printable feature ({:.2f} mm)",
            a.hole_diameter_m / kMm, o.min_feature_m / kMm);
    require(a.hole_spacing_m - a.hole_diameter_m >= o.min_feature_m,
            "build_socket: attachment holes {:.1f} mm apart leave {:.2f} mm between {:.1f} mm holes (< {:.2f} mm, the "
            "smallest printable feature); widen the spacing or use thinner bolts",
            a.hole_spacing_m / kMm, (a.hole_spacing_m - a.hole_diameter_m) / kMm, a.hole_diameter_m / kMm,
            o.min_feature_m / kMm);
    require(a.platform_thickness_m >= o.min_feature_m,
            "build_socket: attachment platform_thickness {:.2f} mm is below the smallest printable feature",
            a.platform_thickness_m / kMm);
    require(std::isfinite(a.rotation_rad) && std::isfinite(a.offset_anterior_m) && std::isfinite(a.offset_medial_m) &&
                std::abs(a.offset_anterior_m) <= 0.02 && std::abs(a.offset_medial_m) <= 0.02,
            "build_socket: attachment offset ({:.1f}, {:.1f}) mm is out of range (at most 20 mm each way; align the "
            "rest with the pyramid adapter)",
            a.offset_anterior_m / kMm, a.offset_medial_m / kMm);
    // Ligament from the outermost hole's edge to the platform's rim.
    const double reach = 0.5 * std::sqrt(2.0) * a.hole_spacing_m + 0.5 * a.hole_diameter_m;
    require(0.5 * a.platform_diameter_m - reach >= o.min_feature_m,
            "build_socket: the attachment platform ({:.1f} mm) is too small for holes {:.1f} mm apart: the holes reach "
            "{:.1f} mm from its centre; make platform_diameter_mm at least {:.1f}",
            a.platform_diameter_m / kMm, a.hole_spacing_m / kMm, reach / kMm,
            2.0 * (reach + o.min_feature_m) / kMm);
  }
  require(o.subdivisions >= 0 && o.subdivisions <= 3, "build_socket: subdivisions = {} is out of range [0, 3]",
          o.subdivisions);
  require(o.normal_smoothing_iterations >= 0 && o.normal_smoothing_iterations <= 200,
          "build_socket: normal_smoothing_iterations = {} is out of range [0, 200]", o.normal_smoothing_iterations);
  require(std::isfinite(o.level_step_m) && o.level_step_m > 0.0,
          "build_socket: level_step_m = {} m must be > 0", o.level_step_m);
}

/// One-to-four midpoint subdivision (keeps the geometry, halves the edges).
TriMesh subdivide(const TriMesh& m) {
  TriMesh out;
  out.vertices = m.vertices;
  std::unordered_map<std::uint64_t, int> mid;
  auto midpoint = [&](int a, int b) {
    const auto [it, is_new] = mid.try_emplace(edge_key(a, b), out.num_vertices());
    if (is_new) out.vertices.push_back(0.5 * (m.vertices[a] + m.vertices[b]));
    return it->second;
  };
  for (const auto& t : m.triangles) {
    const int ab = midpoint(t[0], t[1]), bc = midpoint(t[1], t[2]), ca = midpoint(t[2], t[0]);
    out.triangles.push_back({t[0], ab, ca});
    out.triangles.push_back({ab, t[1], bc});
    out.triangles.push_back({ca, bc, t[2]});
    out.triangles.push_back({ab, bc, ca});
  }
  return out;
}

/// Area-weighted vertex normals, then @p passes of neighbour averaging.
std::vector<Vec3> smoothed_normals(const TriMesh& m, int passes) {
  std::vector<Vec3> n(m.vertices.size(), Vec3::Zero());
  for (const auto& t : m.triangles) {
    const Vec3 f = (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]);  // 2 A n
    for (int k = 0; k < 3; ++k) n[t[k]] += f;
  }
  for (auto& v : n) v.normalize();
  if (passes == 0) return n;
  std::vector<std::vector<int>> nb(m.vertices.size());
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) nb[t[k]].push_back(t[(k + 1) % 3]);  // each edge seen from both sides
  for (int p = 0; p < passes; ++p) {
    std::vector<Vec3> next(n.size());
    for (std::size_t i = 0; i < n.size(); ++i) {
      Vec3 s = n[i];
      for (int j : nb[i]) s += n[j];
      next[i] = s.norm() > 0 ? Vec3(s.normalized()) : n[i];
    }
    n.swap(next);
  }
  return n;
}


/// The part of @p m below the brim (the vertices with f = h − brim(θ) < 0), clipped along the brim
/// curve. A vertex within kOnCurve of the curve (in height) with an edge across it is a rim vertex
/// itself (rim error below kOnCurve), instead of the curve crossing each of its edges a few µm
/// from it: those rim vertices' lips, each with its own wall offset, folded over one another (the
/// AAOP example's band loop: four rim vertices within 4 µm, wall offsets of 5.1 and 5.9 mm among
/// them, and no smoothing or subdivision could build the socket). No vertex moves: the kept faces
/// stay on the stump surface.
CutSurface cut_below_brim(const TriMesh& m, const std::vector<Vec3>& normal, const geometry::LimbFrame& frame,
                          const BrimLine& brim) {
  constexpr double kOnCurve = 5e-6;  // [m]
  auto f = [&](const Vec3& p) {
    const geometry::Cylindrical c = frame.to_cylindrical(p);
    return c.h - brim.height(c.theta);
  };
  const std::size_t nv = m.vertices.size();
  std::vector<double> s(nv);
  for (std::size_t i = 0; i < nv; ++i) s[i] = f(m.vertices[i]);
  std::vector<char> on(nv, 0);
  for (const auto& tri : m.triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = tri[k], b = tri[(k + 1) % 3];
      if ((s[a] < 0.0) == (s[b] < 0.0)) continue;
      on[a] = on[a] || std::abs(s[a]) < kOnCurve;
      on[b] = on[b] || std::abs(s[b]) < kOnCurve;
    }
  for (std::size_t i = 0; i < nv; ++i)
    if (on[i])
      s[i] = 0.0;
    else if (s[i] == 0.0)
      s[i] = std::numeric_limits<double>::min();  // on the curve with no edge across it: outside

  CutSurface out;
  std::vector<int> kept(nv, -1);
  auto keep = [&](int v) {
    if (kept[v] < 0) {
      kept[v] = out.mesh.num_vertices();
      out.mesh.vertices.push_back(m.vertices[v]);
      out.normal.push_back(normal[v]);
      out.on_rim.push_back(on[v]);
    }
    return kept[v];
  };
  std::unordered_map<std::uint64_t, int> crossing;
  auto cross = [&](int a, int b) {  // s[a] < 0 < s[b]
    const auto [it, is_new] = crossing.try_emplace(edge_key(a, b), out.mesh.num_vertices());
    if (!is_new) return it->second;
    const Vec3 pa = m.vertices[a], pb = m.vertices[b];
    double lo = 0.0, hi = 1.0;  // f(lo) < 0 <= f(hi): bisection against the exact curve
    for (int k = 0; k < 40; ++k) {
      const double mid = 0.5 * (lo + hi);
      (f(pa + mid * (pb - pa)) < 0.0 ? lo : hi) = mid;
    }
    // Keep the new vertex a little away from the edge's ends, so no triangle degenerates.
    const double t = std::clamp(0.5 * (lo + hi), 1e-3, 1.0 - 1e-3);
    out.mesh.vertices.push_back(pa + t * (pb - pa));
    out.normal.push_back(((1.0 - t) * normal[a] + t * normal[b]).normalized());
    out.on_rim.push_back(1);
    return it->second;
  };
  for (const auto& tri : m.triangles) {
    if (on[tri[0]] && on[tri[1]] && on[tri[2]]) {  // a sliver along the curve: kept if inside
      if (f((m.vertices[tri[0]] + m.vertices[tri[1]] + m.vertices[tri[2]]) / 3.0) < 0.0)
        out.mesh.triangles.push_back({keep(tri[0]), keep(tri[1]), keep(tri[2])});
      continue;
    }
    std::array<int, 4> poly{};
    int n = 0;
    for (int k = 0; k < 3; ++k) {  // Sutherland–Hodgman against s <= 0 (the vertices on the curve kept)
      const int a = tri[k], b = tri[(k + 1) % 3];
      if (s[a] <= 0.0) poly[n++] = keep(a);
      if (s[a] < 0.0 && s[b] > 0.0) poly[n++] = cross(a, b);
      if (s[a] > 0.0 && s[b] < 0.0) poly[n++] = cross(b, a);
    }
    if (n >= 3) out.mesh.triangles.push_back({poly[0], poly[1], poly[2]});
    if (n == 4) out.mesh.triangles.push_back({poly[0], poly[2], poly[3]});
  }
  return out;
}

/// Keeps the largest edge-connected component (by triangle count) of the cut surface.
int keep_largest_component(CutSurface& cut) {
  const int nt = cut.mesh.num_triangles();
  std::vector<int> parent(cut.mesh.vertices.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const auto& t : cut.mesh.triangles) {
    parent[find(t[0])] = find(t[1]);
    parent[find(t[1])] = find(t[2]);
  }
  std::map<int, int> count;
  for (const auto& t : cut.mesh.triangles) ++count[find(t[0])];
  if (count.size() <= 1) return 0;
  const int best = std::max_element(count.begin(), count.end(), [](auto& a, auto& b) { return a.second < b.second; })->first;
  CutSurface out;
  std::vector<int> map(cut.mesh.vertices.size(), -1);
  for (const auto& t : cut.mesh.triangles) {
    if (find(t[0]) != best) continue;
    std::array<int, 3> nt3{};
    for (int k = 0; k < 3; ++k) {
      if (map[t[k]] < 0) {
        map[t[k]] = out.mesh.num_vertices();
        out.mesh.vertices.push_back(cut.mesh.vertices[t[k]]);
        out.normal.push_back(cut.normal[t[k]]);
        out.on_rim.push_back(cut.on_rim[t[k]]);
      }
      nt3[k] = map[t[k]];
    }
    out.mesh.triangles.push_back(nt3);
  }
  const int dropped = nt - out.mesh.num_triangles();
  cut = std::move(out);
  return dropped;
}



}  // namespace

/// Directed boundary edges (a → b as they appear in a triangle) of a surface (socket_builder_detail.h).
std::vector<std::array<int, 2>> socket_detail::directed_boundary_edges(const TriMesh& m) {
  std::unordered_map<std::uint64_t, int> count;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) ++count[edge_key(t[k], t[(k + 1) % 3])];
  std::vector<std::array<int, 2>> out;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k)
      if (count[edge_key(t[k], t[(k + 1) % 3])] == 1) out.push_back({t[k], t[(k + 1) % 3]});
  return out;
}

double clearance_hole_diameter_m(const std::string& bolt) {
  if (bolt == "M4") return 4.5 * kMm;
  if (bolt == "M5") return 5.5 * kMm;
  if (bolt == "M6") return 6.6 * kMm;
  if (bolt == "M8") return 9.0 * kMm;
  fail("socket attachment: bolt '{}' is not known (M4, M5, M6 or M8; or give hole_diameter_mm)", bolt);
}

double bolt_diameter_m(const std::string& bolt) {
  (void)clearance_hole_diameter_m(bolt);
  return std::stod(bolt.substr(1)) * kMm;
}

double asked_thickness_m(const SocketOptions& o, double h_m, double brim_h_m) {
  const double distal = o.distal_thickness_m > 0 ? o.distal_thickness_m : o.thickness_m;
  const double at_brim = o.brim_thickness_m > 0 ? o.brim_thickness_m : o.thickness_m;
  if (distal == at_brim || !(brim_h_m > 0)) return distal;
  const double s = std::clamp(h_m / brim_h_m, 0.0, 1.0);
  return distal + s * (at_brim - distal);
}

namespace {
SocketResult build_socket_once(const TriMesh& inner_in, const geometry::LimbFrame& frame, const BrimLine& brim,
                               const SocketOptions& options);
}  // namespace

SocketResult build_socket(const TriMesh& inner_in, const geometry::LimbFrame& frame, const BrimLine& brim,
                          const SocketOptions& options) {
  // A coarse stump surface (a few thousand nodes) can leave an offset that self-intersects however
  // smooth the normals: refine the surface once more (midpoint subdivision) and try again, up to
  // two subdivisions.
  SocketOptions o = options;
  for (;;) {
    try {
      SocketResult r = build_socket_once(inner_in, frame, brim, o);
      if (o.subdivisions != options.subdivisions)
        r.notes.push_back(fmt::format("the stump surface was subdivided {} time(s) so that the offset does not "
                                      "self-intersect",
                                      o.subdivisions));
      return r;
    } catch (const TopologyError& e) {
      if (o.subdivisions >= std::max(2, options.subdivisions) || o.subdivisions > options.subdivisions ||
          std::string(e.what()).find("self-intersects") == std::string::npos)
        throw;
      ++o.subdivisions;
    }
  }
}

namespace {

/// The perimeter of the section of @p m at height @p h.
double perimeter_at(const TriMesh& m, const geometry::LimbFrame& frame, double h) {
  return geometry::slice_surface(m, frame.on_axis(h), frame.axis).perimeter;
}

/// The checks of the stump surface and the brim on it: finite, manifold, oriented, the brim between
/// its distal end and its top. Returns the height of its distal end.
double checked_stump_bottom(const TriMesh& inner_in, const geometry::LimbFrame& frame, const BrimLine& brim) {
  require(!inner_in.empty(), "build_socket: the stump surface has no triangles (expected the deformed skin)");
  const geometry::MeshCheckReport rep = geometry::check_mesh(inner_in);
  require(rep.non_finite_vertices == 0, "build_socket: the stump surface has {} vertices with NaN/inf coordinates",
          rep.non_finite_vertices);
  require(rep.out_of_range_indices == 0, "build_socket: the stump surface has {} vertex indices out of range",
          rep.out_of_range_indices);
  require<TopologyError>(rep.is_manifold(),
                         "build_socket: the stump surface has {} non-manifold edges; repair it (socketsmith check mesh)",
                         rep.non_manifold_edges);
  require<TopologyError>(rep.is_oriented(),
                         "build_socket: the stump surface has {} inconsistently oriented edges; repair it",
                         rep.inconsistently_oriented_edges);

  double top = -std::numeric_limits<double>::infinity(), bottom = std::numeric_limits<double>::infinity();
  for (const auto& v : inner_in.vertices) {
    const double h = frame.to_cylindrical(v).h;
    top = std::max(top, h);
    bottom = std::min(bottom, h);
  }
  const double brim_top = brim.max_height(), brim_low = brim.min_height();
  require(brim_top < top - 1e-4,
          "build_socket: the brim reaches h = {:.1f} mm, above the top of the stump surface ({:.1f} mm); "
          "lower its key points below the cut",
          brim_top / kMm, top / kMm);
  require(brim_low > bottom, "build_socket: the brim dips to h = {:.1f} mm, below the distal end ({:.1f} mm); raise it",
          brim_low / kMm, bottom / kMm);
  return bottom;
}

/// Every boundary edge of the wall kept below the brim lies on the brim (else the surface has a hole
/// below it), and there is such an edge.
void check_rim_on_brim(const CutSurface& cut, const geometry::LimbFrame& frame) {
  // Every boundary edge of the kept wall must lie on the brim (else the surface has a hole below it).
  const auto rim = directed_boundary_edges(cut.mesh);
  for (const auto& e : rim)
    require<TopologyError>(cut.on_rim[e[0]] && cut.on_rim[e[1]],
                           "build_socket: the stump surface is open below the brim (a hole or boundary at h = "
                           "{:.1f} mm); close it (a closed skin) or lower the brim below its open edge",
                           frame.to_cylindrical(cut.mesh.vertices[e[0]]).h / kMm);
  require<TopologyError>(!rim.empty(), "build_socket: the brim does not cut the stump surface; check the frame and the brim heights");
}

/// The cavity's volume, by a fan to the rim centroid (the fan's tetrahedra have zero volume); an
/// inside-out surface fails here.
double cavity_volume(const CutSurface& cut) {
  Vec3 c = Vec3::Zero();
  int nrim = 0;
  for (int i = 0; i < cut.mesh.num_vertices(); ++i)
    if (cut.on_rim[i]) {
      c += cut.mesh.vertices[i];
      ++nrim;
    }
  c /= std::max(nrim, 1);
  double cavity = 0.0;
  for (const auto& t : cut.mesh.triangles)
    cavity += (cut.mesh.vertices[t[0]] - c).dot((cut.mesh.vertices[t[1]] - c).cross(cut.mesh.vertices[t[2]] - c)) / 6.0;
  require(cavity > 0.0,
          "build_socket: the stump surface is inside-out (cavity volume {:.3g} m^3); flip its triangles", cavity);
  return cavity;
}

/// Why a socket solid cannot be printed (its volume, a self-intersection), or nothing; a solid that
/// is not even a closed surface is an internal error.
std::string shell_problem(const TriMesh& solid, const char* stage) {
  const geometry::MeshCheckReport sr = geometry::check_mesh(solid);
  if (!sr.is_valid_closed_surface()) {
    const auto problems = sr.problems();
    fail<TopologyError>("build_socket: internal: the socket solid ({}) is not a valid closed surface ({}); please "
                        "report",
                        stage, problems.empty() ? std::string("?") : problems.front());
  }
  const double vol = geometry::signed_volume(solid);
  if (vol <= 0.0) return fmt::format("its volume is {:.3g} m^3", vol);
  if (geometry::has_self_intersections(solid)) return "it self-intersects";
  return {};
}

/// Joins the distal platform to the shell @p a. The Booleans' result is exact; rounded to double, two
/// intersection points a few nm apart can merge (a degenerate triangle) when the block's grid lines up
/// with the wall's vertices (generated limbs are symmetric about planes through the axis). The block
/// and the drills are then turned by a fraction of a sector and joined again.
PlatformBuild join_platform(Attempt& a, const CutSurface& cut, const std::vector<double>& offset,
                            const geometry::LimbFrame& frame, const SocketOptions& options) {
  const TriMesh shell = a.solid;
  PlatformBuild pb;
  std::string problem;
  for (const double phase : {0.0137, 0.0291, 0.0457, 0.0611}) {
    a.solid = shell;
    try {
      pb = add_platform(a, cut, offset, frame, options, phase);
    } catch (const TopologyError& e) {
      problem = e.what();
      continue;
    }
    const geometry::MeshCheckReport sr = geometry::check_mesh(a.solid);
    if (!sr.is_valid_closed_surface()) {
      const auto p = sr.problems();
      problem = p.empty() ? std::string("?") : p.front();
      continue;
    }
    problem = shell_problem(a.solid, "with its distal platform");
    if (problem.empty()) break;
  }
  require<TopologyError>(problem.empty(),
                         "build_socket: the socket with its distal platform fails the final check ({}); change the "
                         "platform diameter or the alignment slightly",
                         problem);
  return pb;
}

/// The rim's heights and their error against the brim curve.
void measure_rim(SocketResult& r, const CutSurface& cut, const geometry::LimbFrame& frame, const BrimLine& brim) {
  r.rim_min_h_m = std::numeric_limits<double>::infinity();
  r.rim_max_h_m = -std::numeric_limits<double>::infinity();
  for (int i = 0; i < cut.mesh.num_vertices(); ++i) {
    if (!cut.on_rim[i]) continue;
    const geometry::Cylindrical q = frame.to_cylindrical(cut.mesh.vertices[i]);
    r.rim_min_h_m = std::min(r.rim_min_h_m, q.h);
    r.rim_max_h_m = std::max(r.rim_max_h_m, q.h);
    r.max_rim_error_m = std::max(r.max_rim_error_m, std::abs(q.h - brim.height(q.theta)));
  }
}

/// Circumferences of the full rings below the brim, and of the undeformed limb at the same heights.
void measure_levels(SocketResult& r, const CutSurface& cut, const geometry::LimbFrame& frame,
                    const SocketOptions& options, double bottom) {
  for (double h = options.level_step_m; h < r.rim_min_h_m - 1e-6; h += options.level_step_m) {
    if (h <= bottom) continue;
    SocketLevel l;
    l.h_m = h;
    l.inner_circumference_m = perimeter_at(cut.mesh, frame, h);
    l.limb_circumference_m = std::numeric_limits<double>::quiet_NaN();
    l.reduction_percent = std::numeric_limits<double>::quiet_NaN();
    if (options.undeformed_skin) {
      l.limb_circumference_m = perimeter_at(*options.undeformed_skin, frame, h);
      if (l.limb_circumference_m > 0)
        l.reduction_percent = 100.0 * (1.0 - l.inner_circumference_m / l.limb_circumference_m);
    }
    r.levels.push_back(l);
  }
}

}  // namespace

namespace {
SocketResult build_socket_once(const TriMesh& inner_in, const geometry::LimbFrame& frame, const BrimLine& brim,
                               const SocketOptions& options) {
  check_options(options);
  require(!brim.spline().empty(), "build_socket: the brim has no key points (pick a template or give key points)");
  const double bottom = checked_stump_bottom(inner_in, frame, brim);

  TriMesh inner = inner_in;
  for (int k = 0; k < options.subdivisions; ++k) inner = subdivide(inner);

  const bool has_platform = options.distal_pad || options.attachment.enabled;
  SocketResult r;
  const int base_passes = options.normal_smoothing_iterations;
  const std::array<int, 3> passes = {base_passes, std::max(4, 4 * base_passes), std::max(16, 16 * base_passes)};
  std::string last_problem;
  for (int attempt = 0; attempt < 3; ++attempt) {
    CutSurface cut = cut_below_brim(inner, smoothed_normals(inner, passes[attempt]), frame, brim);
    require(cut.mesh.num_triangles() > 0, "build_socket: nothing of the stump surface lies below the brim; raise it");
    const int dropped = keep_largest_component(cut);
    check_rim_on_brim(cut, frame);

    const double cavity = cavity_volume(cut);

    const geometry::SurfaceQuery inner_q(cut.mesh);
    const std::vector<double> asked = asked_per_vertex(cut, frame, brim, options);
    std::vector<double> offset = asked;
    const int thickness_passes = correct_offsets(cut, inner_q, asked, offset);
    Attempt a = assemble(cut, frame, options, offset);
    last_problem = shell_problem(a.solid, "shell");
    if (!last_problem.empty()) {
      r.notes.push_back(fmt::format("offset with {} normal-smoothing passes failed ({}); retrying with more smoothing",
                                    passes[attempt], last_problem));
      continue;
    }
    // The lip before any Boolean: the face classification and the brim band refer to it.
    TriMesh lip_mesh;
    lip_mesh.vertices = a.solid.vertices;
    lip_mesh.triangles.assign(a.solid.triangles.begin() + a.inner + a.outer, a.solid.triangles.end());
    const geometry::SurfaceQuery lip_q(lip_mesh);
    if (has_platform) {
      const TriMesh shell = a.solid;
      const PlatformBuild pb = join_platform(a, cut, offset, frame, options);
      a.kind = classify_faces(a.solid, shell, a.kind, inner_q, lip_q, pb);
      r.platform = pb.report;
      if (options.attachment.enabled)
        r.platform.smallest_feature_m = std::min(r.platform.smallest_feature_m, r.platform.min_hole_depth_m);
    }
    if (dropped > 0)
      r.notes.push_back(fmt::format("dropped {} triangles of islands below the brim not connected to the socket", dropped));
    if (attempt > 0)
      r.notes.push_back(fmt::format("the offset needed {} normal-smoothing passes (concave skin with a radius below "
                                    "the {:.1f} mm wall)",
                                    passes[attempt], options.thickness_m / kMm));
    r.normal_smoothing_used = passes[attempt];
    r.thickness_passes = thickness_passes;
    r.inner_triangles = a.inner;
    r.outer_triangles = a.outer;
    r.lip_triangles = a.lip;
    r.shell_volume_m3 = geometry::signed_volume(a.solid);
    r.cavity_volume_m3 = cavity;
    measure_rim(r, cut, frame, brim);
    r.solid = std::move(a.solid);
    r.face_kind = std::move(a.kind);
    measure_thickness(r, inner_q, &lip_q, frame, brim, options);
    measure_levels(r, cut, frame, options, bottom);
    return r;
  }
  fail<TopologyError>("build_socket: the {:.1f} mm offset of the stump surface still fails after {} normal-smoothing "
                      "passes ({}); use a thinner wall or smooth the stump surface",
                      options.thickness_m / kMm, passes.back(), last_problem);
}
}  // namespace

void write_socket_stl(const std::filesystem::path& path, const SocketResult& result) {
  require(!result.solid.empty(), "write_socket_stl: the socket has no triangles (build it first) for '{}'",
          path.string());
  geometry::write_mesh(path, result.solid, units::LengthUnit::Millimetre, geometry::MeshFormat::StlBinary);
}

}  // namespace socketsmith::design
