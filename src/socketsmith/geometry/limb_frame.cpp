#include "socketsmith/geometry/limb_frame.h"

#include <algorithm>
#include <cctype>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_checks.h"

#include <fmt/format.h>

namespace socketsmith::geometry {

namespace {
std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}
}  // namespace

std::string to_string(LimbType type) {
  return type == LimbType::Transtibial ? "transtibial" : "transfemoral";
}

LimbType parse_limb_type(const std::string& text) {
  const std::string t = lower(text);
  if (t == "transtibial" || t == "tt") return LimbType::Transtibial;
  if (t == "transfemoral" || t == "tf") return LimbType::Transfemoral;
  fail("limb type '{}' is not known (expected 'transtibial' or 'transfemoral')", text);
}

std::string to_string(Side side) { return side == Side::Right ? "right" : "left"; }

Side parse_side(const std::string& text) {
  const std::string t = lower(text);
  if (t == "right" || t == "r") return Side::Right;
  if (t == "left" || t == "l") return Side::Left;
  fail("side '{}' is not known (expected 'right' or 'left')", text);
}

}  // namespace socketsmith::geometry

// ---------------------------------------------------------------------------------------------
// Slices, axis and anterior estimation.

#include <Eigen/Eigenvalues>
#include <map>

namespace socketsmith::geometry {

Slice slice_surface(const TriMesh& mesh, const Vec3& point, const Vec3& normal) {
  Slice slice;
  const Vec3 n = normal.normalized();
  Vec3 first_moment = Vec3::Zero();
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    const auto& tri = mesh.triangles[t];
    std::array<double, 3> s{};
    int above = 0;
    for (int k = 0; k < 3; ++k) {
      s[k] = n.dot(mesh.vertices[tri[k]] - point);
      if (s[k] >= 0.0) ++above;
    }
    if (above == 0 || above == 3) continue;
    std::array<Vec3, 2> pts;
    int found = 0;
    for (int k = 0; k < 3 && found < 2; ++k) {
      const int a = k, b = (k + 1) % 3;
      if ((s[a] >= 0.0) == (s[b] >= 0.0)) continue;
      const double w = s[a] / (s[a] - s[b]);
      pts[found++] = mesh.vertices[tri[a]] + w * (mesh.vertices[tri[b]] - mesh.vertices[tri[a]]);
    }
    if (found < 2) continue;
    const Vec3 tangent = n.cross(triangle_normal(mesh, t));
    if ((pts[1] - pts[0]).dot(tangent) < 0.0) std::swap(pts[0], pts[1]);
    const double cross = (pts[0] - point).cross(pts[1] - point).dot(n);
    slice.area += 0.5 * cross;
    first_moment += cross * ((pts[0] - point) + (pts[1] - point));
    slice.perimeter += (pts[1] - pts[0]).norm();
    slice.segments.push_back(pts);
  }
  if (slice.area != 0.0) slice.centroid = point + first_moment / (6.0 * slice.area);
  return slice;
}

namespace {

/// Heights of the vertices along @p axis from @p origin.
std::pair<double, double> height_range(const TriMesh& mesh, const Vec3& origin, const Vec3& axis) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& v : mesh.vertices) {
    const double h = (v - origin).dot(axis);
    lo = std::min(lo, h);
    hi = std::max(hi, h);
  }
  return {lo, hi};
}

/// Vertices on boundary edges (edges used by one triangle).
std::vector<int> boundary_vertices(const TriMesh& mesh) {
  std::map<std::pair<int, int>, int> count;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      ++count[{std::min(a, b), std::max(a, b)}];
    }
  std::vector<int> out;
  for (const auto& [e, c] : count)
    if (c == 1) {
      out.push_back(e.first);
      out.push_back(e.second);
    }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

Vec3 any_perpendicular(const Vec3& axis) {
  const Vec3 trial = std::abs(axis.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  return (trial - trial.dot(axis) * axis).normalized();
}

}  // namespace

double lowest_open_boundary_height(const TriMesh& skin, const LimbFrame& frame) {
  const auto bv = boundary_vertices(skin);
  if (bv.empty()) return height_range(skin, frame.origin, frame.axis).second;
  double lo = std::numeric_limits<double>::infinity();
  for (int v : bv) lo = std::min(lo, (skin.vertices[v] - frame.origin).dot(frame.axis));
  return lo;
}

void set_anterior(LimbFrame& frame, const Vec3& direction) {
  const Vec3 d = direction - direction.dot(frame.axis) * frame.axis;
  require(d.norm() > 0.05 * direction.norm() && direction.norm() > 0.0,
          "anterior direction ({:.3g}, {:.3g}, {:.3g}) is (nearly) parallel to the limb axis "
          "({:.3g}, {:.3g}, {:.3g}); give a direction pointing to the front of the limb",
          direction.x(), direction.y(), direction.z(), frame.axis.x(), frame.axis.y(), frame.axis.z());
  frame.anterior = d.normalized();
}

namespace {

/// Extents of @p skin perpendicular to @p axis: the largest over 12 directions [m].
double width_across(const TriMesh& skin, const Vec3& axis) {
  const Vec3 u = any_perpendicular(axis), v = axis.cross(u).normalized();
  double width = 0.0;
  for (int k = 0; k < 12; ++k) {
    const double a = std::numbers::pi * k / 12.0;
    const auto [lo, hi] = height_range(skin, Vec3::Zero(), std::cos(a) * u + std::sin(a) * v);
    width = std::max(width, hi - lo);
  }
  return width;
}

/// Centroids of the 13 sections normal to @p axis between 20 % and 80 % of the closed part (below
/// the lowest open boundary when @p open), the sections taken about @p centre; empty ones skipped.
std::vector<Vec3> section_centroids(const TriMesh& skin, const Vec3& centre, const Vec3& axis, bool open) {
  LimbFrame tmp;
  tmp.origin = centre;
  tmp.axis = axis;
  const auto [lo, hi_all] = height_range(skin, centre, axis);
  const double hi = open ? lowest_open_boundary_height(skin, tmp) : hi_all;
  std::vector<Vec3> cs;
  for (int k = 0; k <= 12; ++k) {
    const double h = lo + (0.2 + 0.6 * k / 12.0) * (hi - lo);
    const Slice s = slice_surface(skin, centre + h * axis, axis);
    if (s.area != 0.0) cs.push_back(s.centroid);
  }
  return cs;
}

/// Mean centroid of the sections normal to @p axis between 20 % and 80 % of the closed part, the
/// sections taken about @p centre; @p centre itself when fewer than three sections exist.
Vec3 section_centre(const TriMesh& skin, const Vec3& centre, const Vec3& axis, bool open) {
  const std::vector<Vec3> cs = section_centroids(skin, centre, axis, open);
  const int n = static_cast<int>(cs.size());
  if (n < 3) return centre;
  Vec3 sum = Vec3::Zero();
  for (const Vec3& c : cs) sum += c;
  // Only the position across the axis: keep the centre's height.
  const Vec3 c = sum / n;
  return c - (c - centre).dot(axis) * axis;
}

/// Origin at the most distal skin point's height, placeholder anterior, and the taper check.
LimbFrame finish_frame(const TriMesh& skin, const Vec3& axis, const Vec3& centre) {
  LimbFrame frame;
  frame.axis = axis;
  const auto [lo, hi] = height_range(skin, centre, axis);
  (void)hi;
  frame.origin = centre + lo * axis;
  frame.anterior = any_perpendicular(axis);
  frame.anterior_estimated = true;
  frame.side_estimated = true;
  // A limb tapers to its distal end: the section near the end is clearly smaller than mid-limb.
  const double top = lowest_open_boundary_height(skin, frame);
  const Slice s_mid = slice_surface(skin, frame.on_axis(0.5 * top), axis);
  const Slice s_end = slice_surface(skin, frame.on_axis(0.03 * top), axis);
  if (s_mid.area != 0.0 && std::abs(s_end.area) < 0.75 * std::abs(s_mid.area)) return frame;
  // Open at both ends with neither end clearly the narrower (a limb's distal opening is closed with
  // a dome before this: volume::prepare_limb) is a different mistake from a box or a cylinder.
  const int loops = check_mesh(skin).boundary_loops;
  require(loops < 2,
          "the surface is open at both ends ({} open boundaries) and does not taper to either: a residual "
          "limb must be closed at its distal end; close the distal opening in the scanner or CAD software "
          "and give the file again",
          loops);
  fail("the surface does not taper to a rounded distal end (section area 3 % from the end is "
       "{:.0f} % of mid-length): not a residual limb; check the file (a box or cylinder?)",
       s_mid.area != 0.0 ? 100.0 * std::abs(s_end.area / s_mid.area) : 0.0);
  return frame;
}

}  // namespace

std::optional<Vec3> open_rim_centroid(const TriMesh& skin) {
  const auto bv = boundary_vertices(skin);
  if (bv.empty()) return std::nullopt;
  Vec3 c = Vec3::Zero();
  for (int v : bv) c += skin.vertices[v];
  return c / static_cast<double>(bv.size());
}

namespace {

/// A first axis (distal to proximal) and a point on it, before refinement.
struct AxisGuess {
  Vec3 axis, centre;
};

/// An open scan: the distal end is the skin point farthest from the rim; the axis joins them.
AxisGuess axis_from_rim(const TriMesh& skin) {
  const Vec3 rim = *open_rim_centroid(skin);
  Vec3 tip = skin.vertices.front();
  for (const auto& v : skin.vertices)
    if ((v - rim).squaredNorm() > (tip - rim).squaredNorm()) tip = v;
  require((rim - tip).norm() > 0.0, "limb surface is degenerate (its rim and its far end coincide)");
  return {(rim - tip).normalized(), 0.5 * (rim + tip)};
}

/// A closed surface: the area-weighted PCA's long axis through @p mean, checked to be elongated,
/// pointing to the wider (proximal) end.
AxisGuess axis_from_pca(const TriMesh& skin, const Vec3& mean) {
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int t = 0; t < skin.num_triangles(); ++t) {
    const auto& tri = skin.triangles[t];
    const Vec3 c = (skin.vertices[tri[0]] + skin.vertices[tri[1]] + skin.vertices[tri[2]]) / 3.0 - mean;
    cov += triangle_area(skin, t) * c * c.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Vec3 axis = eig.eigenvectors().col(2).normalized();
  // Elongation check in the PCA frame.
  const auto [lo, hi] = height_range(skin, mean, axis);
  double width = 0.0;
  for (int c = 0; c < 2; ++c) {
    const auto [a, b] = height_range(skin, mean, eig.eigenvectors().col(c).normalized());
    width = std::max(width, b - a);
  }
  require(hi - lo >= 1.2 * width,
          "the surface is {:.0f} mm long and {:.0f} mm wide: not elongated like a residual limb "
          "(expected a length of at least 1.2 x the width); check that the file is a limb scan",
          (hi - lo) * 1e3, width * 1e3);
  // Proximal = the wider end.
  const Slice s_lo = slice_surface(skin, mean + (lo + 0.08 * (hi - lo)) * axis, axis);
  const Slice s_hi = slice_surface(skin, mean + (hi - 0.08 * (hi - lo)) * axis, axis);
  if (std::abs(s_lo.area) > std::abs(s_hi.area)) axis = -axis;
  return {axis, mean};
}

/// Refinement: up to three times, the line through the cross-section centroids, unless the fit is
/// degenerate or turns the axis by more than 25°.
void refine_axis(const TriMesh& skin, bool open, AxisGuess& g) {
  for (int iter = 0; iter < 3; ++iter) {
    const std::vector<Vec3> cs = section_centroids(skin, g.centre, g.axis, open);
    if (cs.size() < 3) break;
    Vec3 m = Vec3::Zero();
    for (const auto& c : cs) m += c;
    m /= static_cast<double>(cs.size());
    Eigen::Matrix3d cc = Eigen::Matrix3d::Zero();
    for (const auto& c : cs) cc += (c - m) * (c - m).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> e2(cc);
    Vec3 a = e2.eigenvectors().col(2).normalized();
    if (a.dot(g.axis) < 0.0) a = -a;
    // Guard against a degenerate fit (centroids nearly coincident): keep the axis.
    if (e2.eigenvalues()(2) < 1e-12 || a.dot(g.axis) < std::cos(25.0 * std::numbers::pi / 180.0)) break;
    g.axis = a;
    g.centre = m;
  }
}

}  // namespace

LimbFrame estimate_limb_axis(const TriMesh& skin) {
  require(skin.num_triangles() >= 4, "limb surface has {} triangles (expected a scanned limb)",
          skin.num_triangles());
  const std::optional<Vec3> centroid = area_centroid(skin);
  require(centroid.has_value(), "limb surface has zero area");
  const Vec3 mean = *centroid;
  const bool open = !boundary_vertices(skin).empty();
  AxisGuess g = open ? axis_from_rim(skin) : axis_from_pca(skin, mean);
  refine_axis(skin, open, g);
  if (open) {
    const auto [lo, hi] = height_range(skin, g.centre, g.axis);
    const double width = width_across(skin, g.axis);
    require(hi - lo >= 1.0 * width,
            "the surface is {:.0f} mm long and {:.0f} mm wide: not elongated like a residual limb "
            "(expected an open scan at least as long as it is wide); check that the file is a limb scan, or give "
            "its long axis (limb.axis in a case file, --axis x,y,z on the command line)",
            (hi - lo) * 1e3, width * 1e3);
  }
  return finish_frame(skin, g.axis, g.centre);
}

LimbFrame limb_frame_along(const TriMesh& skin, const Vec3& axis_direction) {
  require(skin.num_triangles() >= 4, "limb surface has {} triangles (expected a scanned limb)", skin.num_triangles());
  require(axis_direction.allFinite() && axis_direction.norm() > 0.0,
          "limb axis ({:.3g}, {:.3g}, {:.3g}) is not a direction (give a non-zero x,y,z)", axis_direction.x(),
          axis_direction.y(), axis_direction.z());
  Vec3 axis = axis_direction.normalized();
  Vec3 centre = Vec3::Zero();
  for (const auto& v : skin.vertices) centre += v;
  centre /= static_cast<double>(skin.vertices.size());
  const auto rim = open_rim_centroid(skin);
  if (rim && (*rim - centre).dot(axis) < 0.0) axis = -axis;
  for (int round = 0; round < 3; ++round) centre = section_centre(skin, centre, axis, rim.has_value());
  return finish_frame(skin, axis, centre);
}

namespace {
/// Direction (perpendicular to the axis) in which the outlines of the sections between fractions
/// @p lo and @p hi of the closed part are most skewed: the largest third moment of the outline
/// about the section centroid, summed over 9 sections.
Vec3 outline_skew_direction(const TriMesh& skin, const LimbFrame& frame, double lo, double hi) {
  const double top = lowest_open_boundary_height(skin, frame);
  const Vec3 u = frame.anterior;
  const Vec3 v = frame.axis.cross(u).normalized();
  constexpr int kDirections = 360;
  std::vector<double> skew(kDirections, 0.0);
  for (int k = 0; k <= 8; ++k) {
    const double h = (lo + (hi - lo) * k / 8.0) * top;
    const Slice s = slice_surface(skin, frame.on_axis(h), frame.axis);
    if (s.area == 0.0 || s.perimeter <= 0.0) continue;
    const double scale = std::sqrt(std::abs(s.area));
    for (int d = 0; d < kDirections; ++d) {
      const double th = 2.0 * std::numbers::pi * d / kDirections;
      const Vec3 dir = std::cos(th) * u + std::sin(th) * v;
      double m3 = 0.0;
      for (const auto& seg : s.segments) {
        const double len = (seg[1] - seg[0]).norm();
        const double x = (0.5 * (seg[0] + seg[1]) - s.centroid).dot(dir) / scale;
        m3 += len * x * x * x;
      }
      skew[d] += m3 / s.perimeter;
    }
  }
  const int best = static_cast<int>(std::max_element(skew.begin(), skew.end()) - skew.begin());
  const double th = 2.0 * std::numbers::pi * best / kDirections;
  return std::cos(th) * u + std::sin(th) * v;
}
}  // namespace

Vec3 estimate_anterior_from_skin(const TriMesh& skin, const LimbFrame& frame) {
  // The outline's third moment about the section centroid (its skewness) points to the
  // postero-medial calf bulge; anterior is kSkewToAnterior from it, towards lateral.
  const Vec3 d = outline_skew_direction(skin, frame, 0.3, 0.7);
  // theta grows by a right-hand turn about the axis for a right limb, left-hand for a left one.
  constexpr double kSkewToAnterior = 120.0 * std::numbers::pi / 180.0;
  const double phi = (frame.side == Side::Right ? -1.0 : 1.0) * kSkewToAnterior;
  return std::cos(phi) * d + std::sin(phi) * frame.axis.cross(d);
}

ThighFrontEstimate estimate_anterior_from_thigh(const TriMesh& skin, const LimbFrame& frame, bool side_given) {
  ThighFrontEstimate out;
  const Vec3 skew = outline_skew_direction(skin, frame, 0.25, 0.6);
  // First harmonic of the rim height around the axis: h ≈ c0 + c1 cos φ + s1 sin φ.
  const auto bv = boundary_vertices(skin);
  const Vec3 u = frame.anterior, v = frame.axis.cross(u).normalized();
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (int i : bv) {
    const Vec3 d = skin.vertices[i] - frame.origin;
    const double phi = std::atan2(d.dot(v), d.dot(u));
    const Eigen::Vector3d row(1.0, std::cos(phi), std::sin(phi));
    A += row * row.transpose();
    b += row * d.dot(frame.axis);
  }
  const Eigen::Vector3d c = bv.size() >= 6 ? Eigen::Vector3d(A.ldlt().solve(b)) : Eigen::Vector3d::Zero();
  const double rise = 2.0 * c.tail<2>().norm();
  if (rise < 0.02) {
    out.how = fmt::format("the thigh outline's posterior fullness; the rim is level ({:.0f} mm), so the side cannot be told",
                          rise * 1e3);
    const Vec3 a = -(skew - skew.dot(frame.axis) * frame.axis);
    out.anterior = a.norm() > 0 ? Vec3(a.normalized()) : u;
    return out;
  }
  const double phi_low = std::atan2(-c(2), -c(1));
  const Vec3 medial = std::cos(phi_low) * u + std::sin(phi_low) * v;
  // Right limb: medial = axis × anterior, so anterior = −axis × medial; left: the opposite.
  const Vec3 a_right = -frame.axis.cross(medial);
  if (side_given) {
    out.how = fmt::format("the rim rises {:.0f} mm from the groin (medial) to the hip, and the given side", rise * 1e3);
    out.anterior = frame.side == Side::Right ? a_right : Vec3(-a_right);
    return out;
  }
  out.side_found = true;
  out.side = a_right.dot(skew) < 0.0 ? Side::Right : Side::Left;
  out.how = fmt::format("the rim rises {:.0f} mm from the groin (medial) to the hip; the thigh is fuller posteriorly, "
                        "so a {} limb",
                        rise * 1e3, to_string(out.side));
  out.anterior = out.side == Side::Right ? a_right : Vec3(-a_right);
  return out;
}

}  // namespace socketsmith::geometry
