#include "socketsmith/geometry/shape_compare.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>

#include "socketsmith/core/enum_names.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/socket_cavity.h"
#include "socketsmith/geometry/surface_query.h"

namespace socketsmith::geometry {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kRimMargin = 0.005;  // [m] the automatic crop lies this far below an opening

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

bool has_boundary(const TriMesh& m) { return !check_mesh(m).is_closed(); }

/// The frame's 3×3 basis (anterior, anterior × axis, axis) as columns.
Eigen::Matrix3d basis(const LimbFrame& f) {
  Eigen::Matrix3d b;
  const Vec3 ax = f.axis.normalized();
  const Vec3 an = (f.anterior - f.anterior.dot(ax) * ax).normalized();
  b.col(0) = an;
  b.col(1) = ax.cross(an);
  b.col(2) = ax;
  return b;
}

/// The rigid transform that carries frame @p from onto frame @p to (origins and bases).
RigidTransform frame_onto(const LimbFrame& from, const LimbFrame& to) {
  RigidTransform t;
  t.rotation = basis(to) * basis(from).transpose();
  t.translation = to.origin - t.rotation * from.origin;
  return t;
}

/// Area of the triangles around each vertex / 3.
std::vector<double> vertex_areas(const TriMesh& m) {
  std::vector<double> a(m.vertices.size(), 0.0);
  for (int t = 0; t < m.num_triangles(); ++t)
    for (int v : m.triangles[t]) a[v] += triangle_area(m, t) / 3.0;
  return a;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const size_t i = static_cast<size_t>(std::floor(pos));
  const double w = pos - static_cast<double>(i);
  return i + 1 < v.size() ? (1 - w) * v[i] + w * v[i + 1] : v[i];
}

}  // namespace

constexpr EnumName<ShapeKind> kShapeKinds[] = {
    {ShapeKind::Auto, "auto"}, {ShapeKind::Surface, "surface"}, {ShapeKind::Socket, "socket"}};
constexpr EnumName<AlignmentSeed> kAlignmentSeeds[] = {
    {AlignmentSeed::Auto, "auto"},           {AlignmentSeed::Frames, "frames"}, {AlignmentSeed::Landmarks, "landmarks"},
    {AlignmentSeed::Identity, "identity"}, {AlignmentSeed::None, "none"}};

std::string to_string(ShapeKind kind) { return name_of(kShapeKinds, kind); }

ShapeKind parse_shape_kind(const std::string& text) {
  if (const auto kind = find_named(kShapeKinds, lower(text))) return *kind;
  fail("shape kind '{}' is not known (expected auto, surface or socket)", text);
}

std::string to_string(AlignmentSeed seed) { return name_of(kAlignmentSeeds, seed); }

AlignmentSeed parse_alignment_seed(const std::string& text) {
  if (const auto seed = find_named(kAlignmentSeeds, lower(text))) return *seed;
  fail("alignment seed '{}' is not known (expected auto, frames, landmarks, identity or none)", text);
}

TriMesh largest_shell(const TriMesh& mesh, int* dropped) {
  auto parts = split_components(mesh);
  if (dropped) *dropped = std::max(0, static_cast<int>(parts.size()) - 1);
  if (parts.size() <= 1) return mesh;
  return *std::max_element(parts.begin(), parts.end(),
                           [](const TriMesh& x, const TriMesh& y) { return surface_area(x) < surface_area(y); });
}

std::optional<double> radius_at(const SurfaceQuery& surface, const LimbFrame& frame, double theta_rad, double h_m) {
  const auto hit = surface.first_hit(frame.on_axis(h_m), frame.radial(theta_rad));
  if (!hit) return std::nullopt;
  return hit->distance;
}

std::vector<double> signed_deviation(const TriMesh& from, const TriMesh& to, double max_distance_m,
                                     const std::vector<char>& use) {
  require(use.empty() || use.size() == from.vertices.size(), "signed_deviation: {} flags for {} vertices", use.size(),
          from.vertices.size());
  const SurfaceQuery q(to);
  std::vector<Vec3> face_n(to.triangles.size());
  for (int t = 0; t < to.num_triangles(); ++t) face_n[t] = triangle_normal(to, t);
  const double cos_limit = std::cos(45.0 * std::numbers::pi / 180.0);
  std::vector<double> out(from.vertices.size(), kNaN);
  SurfaceHit hint;
  for (size_t v = 0; v < from.vertices.size(); ++v) {
    if (!use.empty() && !use[v]) continue;
    const Vec3& p = from.vertices[v];
    hint = hint.triangle >= 0 ? q.closest_point(p, hint) : q.closest_point(p);
    if (hint.triangle < 0 || hint.distance > max_distance_m) continue;
    const Vec3 d = p - hint.point;
    const double nd = face_n[hint.triangle].dot(d);
    if (hint.distance > 1e-9 && std::abs(nd) < cos_limit * hint.distance) continue;  // beyond the rim
    out[v] = -nd;  // p inside `to` (d against its outward normal): `to` lies outside `from`
  }
  return out;
}

DeviationStats deviation_stats(const TriMesh& mesh, const std::vector<double>& values, const std::vector<char>& use) {
  DeviationStats s;
  const auto area = vertex_areas(mesh);
  std::vector<double> vals;
  double w = 0, m1 = 0, m2 = 0;
  for (size_t v = 0; v < values.size(); ++v) {
    if (!use[v]) continue;
    ++s.points;
    if (!std::isfinite(values[v])) continue;
    ++s.covered;
    vals.push_back(values[v]);
    w += area[v];
    m1 += area[v] * values[v];
    m2 += area[v] * values[v] * values[v];
  }
  if (vals.empty() || w <= 0) return s;
  s.mean_m = m1 / w;
  s.rms_m = std::sqrt(m2 / w);
  s.sd_m = std::sqrt(std::max(0.0, m2 / w - s.mean_m * s.mean_m));
  s.min_m = *std::min_element(vals.begin(), vals.end());
  s.max_m = *std::max_element(vals.begin(), vals.end());
  s.p05_m = percentile(vals, 0.05);
  s.p95_m = percentile(vals, 0.95);
  return s;
}

namespace {

/// Refuses an empty shape and options out of range.
void check_compare_input(const TriMesh& a_in, const TriMesh& b_in, const ShapeCompareOptions& o) {
  require(!a_in.empty() && !b_in.empty(), "compare: shape {} has no triangles (expected a limb surface)",
          a_in.empty() ? "A" : "B");
  require(std::isfinite(o.slice_step_m) && o.slice_step_m > 0, "compare: slice step {} mm must be positive",
          o.slice_step_m * 1e3);
  require(o.rotation_seeds >= 1 && o.rotation_seeds <= 72, "compare: {} rotation seeds (expected 1-72)",
          o.rotation_seeds);
  require(std::isfinite(o.crop_height_m) && o.crop_height_m >= 0,
          "compare: crop height {} mm must be positive (0: automatic)", o.crop_height_m * 1e3);
}

/// A: its largest shell into r.a, and its limb frame (axis and front from the skin) into r.frame.
/// Returns the height of A's opening along the axis [m].
double read_shape_a(const TriMesh& a_in, ShapeComparison& r) {
  int dropped = 0;
  r.a = largest_shell(a_in, &dropped);
  if (dropped > 0) r.notes.push_back(fmt::format("A: kept its largest shell (the skin), {} other shell(s) left out", dropped));
  try {
    r.frame = estimate_limb_axis(r.a);
  } catch (const InvalidInputError& e) {
    fail("compare: shape A: {}", e.what());
  }
  if (!has_boundary(r.a)) r.notes.push_back("A is closed: its proximal cap is left out by the crop");
  const double a_top = lowest_open_boundary_height(r.a, r.frame);
  set_anterior(r.frame, estimate_anterior_from_skin(r.a, r.frame));
  return a_top;
}

/// B as compared, before the alignment: the surface, and its limb frame in B's own coordinates
/// when it can have one.
struct ShapeB {
  TriMesh surface;
  std::optional<LimbFrame> frame;
};

/// B read as a socket: its cavity, with the socket's frame unless the seed is the identity (or
/// none). A socket that surrounds A's axis where it is needs no frame of its own.
ShapeB read_socket_b(const TriMesh& b_in, const ShapeCompareOptions& o, ShapeComparison& r) {
  ShapeB b;
  const auto rep = check_mesh(b_in);
  require(rep.is_closed() && rep.is_oriented(),
          "compare: B is read as a socket but is not a closed, oriented solid ({} boundary edges): give the socket "
          "solid, or --b-kind surface to compare it as a surface",
          rep.boundary_edges);
  const bool b_in_a_coordinates = surrounds_axis(b_in, r.frame);  // the socket surrounds A's axis where it is
  if (o.seed != AlignmentSeed::Identity && o.seed != AlignmentSeed::None) {
    try {
      b.frame = estimate_socket_frame(b_in);
    } catch (const InvalidInputError& e) {
      require(b_in_a_coordinates, "compare: B: {}", e.what());
    }
  }
  require(b_in_a_coordinates || b.frame,
          "compare: the socket B does not surround A's axis where it is: align them (--seed frames) or check the units");
  b.surface = cavity_surface(b_in, b_in_a_coordinates ? r.frame : *b.frame);
  r.notes.push_back(fmt::format("B is a socket: its cavity ({} of its {} triangles) is compared",
                                b.surface.num_triangles(), b_in.num_triangles()));
  return b;
}

/// B read as a surface: its largest shell, with a limb frame of its own when the seed uses frames.
ShapeB read_surface_b(const TriMesh& b_in, const ShapeCompareOptions& o, ShapeComparison& r) {
  ShapeB b;
  int dropped = 0;
  b.surface = largest_shell(b_in, &dropped);
  if (dropped > 0) r.notes.push_back(fmt::format("B: kept its largest shell, {} other shell(s) left out", dropped));
  if (o.seed == AlignmentSeed::Frames || o.seed == AlignmentSeed::Auto) {
    try {
      LimbFrame f = estimate_limb_axis(b.surface);
      set_anterior(f, estimate_anterior_from_skin(b.surface, f));
      b.frame = f;
    } catch (const InvalidInputError& e) {
      require(o.seed != AlignmentSeed::Frames, "compare: shape B: {}", e.what());
      r.notes.push_back(fmt::format("B has no limb frame of its own ({}): seeded by the identity only", e.what()));
    }
  }
  return b;
}

/// B: a surface or a socket's cavity (r.b_kind: as given, or told apart by whether its centre lies
/// outside a closed surface).
ShapeB read_shape_b(const TriMesh& b_in, const ShapeCompareOptions& o, ShapeComparison& r) {
  r.b_kind = o.b_kind;
  if (r.b_kind == ShapeKind::Auto) {
    const bool closed = !has_boundary(b_in);
    r.b_kind = closed && !SurfaceQuery(b_in).is_inside(bounding_box(b_in).center()) ? ShapeKind::Socket
                                                                                     : ShapeKind::Surface;
  }
  return r.b_kind == ShapeKind::Socket ? read_socket_b(b_in, o, r) : read_surface_b(b_in, o, r);
}

/// Height of @p p along the frame's axis above its origin [m].
double height_in(const LimbFrame& frame, const Vec3& p) { return (p - frame.origin).dot(frame.axis); }

/// ICP of @p b onto A (@p qa) from @p from, on the samples below @p crop_m in A's frame.
IcpResult icp_below_crop(const TriMesh& b, const SurfaceQuery& qa, const LimbFrame& frame, const RigidTransform& from,
                         const IcpOptions& io, double crop_m) {
  return align_icp(b, qa, from, io, [&frame, crop_m](const Vec3& x) { return height_in(frame, x) < crop_m; });
}

using NamedSeeds = std::vector<std::pair<std::string, RigidTransform>>;

/// The seed from the landmarks common to A and B (at least 3).
std::pair<std::string, RigidTransform> landmark_seed(const ShapeCompareOptions& o) {
  std::map<std::string, Vec3> la(o.landmarks_a.begin(), o.landmarks_a.end());
  std::vector<Vec3> from, to;
  std::string codes;
  for (const auto& [code, p] : o.landmarks_b)
    if (la.count(code)) {
      from.push_back(p);
      to.push_back(la[code]);
      codes += (codes.empty() ? "" : ", ") + code;
    }
  require(from.size() >= 3,
          "compare: {} landmark(s) common to A and B (expected at least 3 codes given for both, not on one line)",
          from.size());
  return {fmt::format("landmarks ({})", codes), kabsch(from, to)};
}

/// The alignment seeds for @p seed: the landmarks', the identity, or B's frame onto A's turned
/// about the axis (after the identity when automatic).
NamedSeeds alignment_seeds(AlignmentSeed seed, const ShapeCompareOptions& o, const std::optional<LimbFrame>& frame_b,
                           const LimbFrame& frame_a) {
  NamedSeeds seeds;
  if (seed == AlignmentSeed::Landmarks) {
    seeds.push_back(landmark_seed(o));
  } else if (seed == AlignmentSeed::Identity || seed == AlignmentSeed::None) {
    seeds.push_back({"identity (the shapes share their coordinates)", RigidTransform{}});
  } else {
    if (seed == AlignmentSeed::Auto) seeds.push_back({"identity (the shapes share their coordinates)", RigidTransform{}});
    if (frame_b) {
      const RigidTransform onto = frame_onto(*frame_b, frame_a);
      for (int k = 0; k < o.rotation_seeds; ++k) {
        const double turn = 2 * std::numbers::pi * k / o.rotation_seeds;
        seeds.push_back({k == 0 ? std::string("limb frames")
                                : fmt::format("limb frames, turned {:.0f}° about the axis", turn * 180 / std::numbers::pi),
                         rotation_about(frame_a.origin, frame_a.axis, turn).after(onto)});
      }
    }
  }
  return seeds;
}

/// Aligns B onto A: each seed scored by a coarse ICP below the crop, the best refined (a single
/// seed is refined directly). Sets r.seed, r.icp and r.transform.
void align_from_seeds(const NamedSeeds& seeds, const TriMesh& b, const SurfaceQuery& qa, const ShapeCompareOptions& o,
                      double crop, ShapeComparison& r) {
  IcpOptions coarse = o.icp;
  coarse.max_samples = std::min(coarse.max_samples, 1000);
  coarse.max_iterations = std::min(coarse.max_iterations, 25);
  coarse.convergence_m = std::max(coarse.convergence_m, 1e-6);
  double best = std::numeric_limits<double>::infinity();
  RigidTransform start;
  for (const auto& [name, t] : seeds) {
    if (seeds.size() == 1) {
      r.seed = name;
      start = t;
      break;
    }
    IcpResult c;
    try {
      c = icp_below_crop(b, qa, r.frame, t, coarse, crop);
    } catch (const InvalidInputError&) {
      continue;  // this seed does not overlap
    }
    if (c.pairs < 12 || c.samples == 0) continue;
    // Poor overlap is penalised: a seed that pairs few samples may fit those few well.
    const double score = c.rms_m * static_cast<double>(c.samples) / c.pairs + c.rms_distance_m * 1e-3;
    if (score < best) {
      best = score;
      r.seed = name;
      start = c.transform;
    }
  }
  require(std::isfinite(best) || seeds.size() == 1,
          "compare: no seed brought B onto A (tried {}): give landmarks, or check the units and that both are limbs",
          seeds.size());
  if (seeds.size() > 1) r.notes.push_back(fmt::format("{} alignment seeds tried; best: {}", seeds.size(), r.seed));
  r.icp = icp_below_crop(b, qa, r.frame, start, o.icp, crop);
  r.transform = r.icp.transform;
}

/// The lowest point of the open boundary of @p m along @p frame's axis [m] (+inf when closed).
double lowest_opening(const TriMesh& m, const LimbFrame& frame) {
  double top = std::numeric_limits<double>::infinity();
  std::map<std::pair<int, int>, int> count;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) ++count[std::minmax(t[k], t[(k + 1) % 3])];
  for (const auto& [e, c] : count)
    if (c == 1) top = std::min({top, height_in(frame, m.vertices[e.first]), height_in(frame, m.vertices[e.second])});
  return top;
}

/// B's opening in A's frame lowers the crop: both must be closed below it. When the crop is
/// lowered, B is aligned again below the new crop. Returns the crop [m].
double crop_below_b_opening(const TriMesh& b, const SurfaceQuery& qa, const ShapeCompareOptions& o, AlignmentSeed seed,
                            double crop, ShapeComparison& r) {
  if (!has_boundary(r.b)) return crop;
  const double b_top = lowest_opening(r.b, r.frame);
  const double b_limit = b_top - kRimMargin;
  require(b_limit > 2 * o.slice_step_m, "compare: B's opening lies {:.0f} mm above A's distal end: B does not cover A",
          b_top * 1e3);
  require(o.crop_height_m <= b_limit + 1e-9,
          "compare: crop height {:.1f} mm is above B's opening less 5 mm ({:.1f} mm in A's frame): lower --crop-mm",
          o.crop_height_m * 1e3, b_limit * 1e3);
  if (b_limit < crop - 1e-3 && seed != AlignmentSeed::None) {
    r.notes.push_back(fmt::format("crop lowered to {:.1f} mm, below B's opening", b_limit * 1e3));
    crop = b_limit;
    r.icp = icp_below_crop(b, qa, r.frame, r.transform, o.icp, crop);
    r.transform = r.icp.transform;
    r.b = transformed(b, r.transform);
  }
  return std::min(crop, b_limit);
}

/// The deviation at A's points below the crop, its statistics, the slices and the volumes.
void measure_below_crop(const ShapeCompareOptions& o, ShapeComparison& r) {
  const double crop = r.crop_height_m;
  std::vector<char> use(r.a.vertices.size(), 0);
  for (size_t v = 0; v < use.size(); ++v) use[v] = height_in(r.frame, r.a.vertices[v]) < crop ? 1 : 0;
  r.deviation_m = signed_deviation(r.a, r.b, o.icp.max_distance_m, use);
  r.stats = deviation_stats(r.a, r.deviation_m, use);
  const auto heights = slice_heights(o.slice_step_m, crop);
  const auto sa = measure_slices(r.a, r.frame, heights);
  const auto sb = measure_slices(r.b, r.frame, heights);
  for (size_t k = 0; k < heights.size(); ++k) r.slices.push_back({heights[k], sa[k], sb[k]});
  r.volume_a_m3 = sa.back().volume_below_m3;
  r.volume_b_m3 = sb.back().volume_below_m3;
}

}  // namespace

ShapeComparison compare_shapes(const TriMesh& a_in, const TriMesh& b_in, const ShapeCompareOptions& o) {
  check_compare_input(a_in, b_in, o);
  ShapeComparison r;
  const double a_top = read_shape_a(a_in, r);
  // B: a surface or a socket's cavity, with a frame of its own when it can have one.
  const ShapeB b = read_shape_b(b_in, o, r);

  // The crop: below A's opening (and B's, once aligned).
  const double a_limit = a_top - kRimMargin;
  require(a_limit > 2 * o.slice_step_m, "compare: A is only {:.0f} mm long below its opening: not a limb scan",
          a_top * 1e3);
  double crop = o.crop_height_m > 0 ? std::min(o.crop_height_m, a_limit) : a_limit;
  require(o.crop_height_m <= a_limit + 1e-9,
          "compare: crop height {:.1f} mm is above A's opening less 5 mm ({:.1f} mm): lower --crop-mm", o.crop_height_m * 1e3,
          a_limit * 1e3);
  const SurfaceQuery qa(r.a);

  // Seeds, scored by a coarse ICP; the best refined.
  const AlignmentSeed seed = o.seed == AlignmentSeed::Auto && !o.landmarks_a.empty() && !o.landmarks_b.empty()
                                 ? AlignmentSeed::Landmarks
                                 : o.seed;
  const NamedSeeds seeds = alignment_seeds(seed, o, b.frame, r.frame);
  if (seed == AlignmentSeed::None)
    r.seed = "none (compared where they are)";
  else
    align_from_seeds(seeds, b.surface, qa, o, crop, r);
  r.b = transformed(b.surface, r.transform);
  r.crop_height_m = crop_below_b_opening(b.surface, qa, o, seed, crop, r);
  measure_below_crop(o, r);
  return r;
}

}  // namespace socketsmith::geometry
