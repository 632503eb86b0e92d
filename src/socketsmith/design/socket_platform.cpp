// The socket's distal platform: a flat pad, or the attachment block with its bolt holes, joined
// to the shell by exact Booleans (socket_builder_detail.h says why this is apart).
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

namespace socketsmith::design::socket_detail {
namespace {

/// The pylon's upward direction in the limb frame (SocketAlignment).
Vec3 pylon_up(const geometry::LimbFrame& frame, const SocketAlignment& al) {
  return (frame.axis - std::tan(al.flexion_rad) * frame.anterior + std::tan(al.adduction_rad) * frame.medial())
      .normalized();
}


PlatformFrame platform_frame(const geometry::LimbFrame& frame, const SocketOptions& o) {
  PlatformFrame f;
  f.up = pylon_up(frame, o.alignment);
  f.anterior = (frame.anterior - frame.anterior.dot(f.up) * f.up).normalized();
  f.medial = f.up.cross(f.anterior);
  if (f.medial.dot(frame.medial()) < 0) f.medial = -f.medial;
  f.origin = frame.origin;
  if (o.attachment.enabled)
    f.origin += o.attachment.offset_anterior_m * f.anterior + o.attachment.offset_medial_m * f.medial;
  return f;
}

/// Hole centres of the four-hole pattern in the platform's plane.
std::vector<Eigen::Vector2d> hole_pattern(const SocketAttachment& a) {
  std::vector<Eigen::Vector2d> out;
  const double h = 0.5 * a.hole_spacing_m, c = std::cos(a.rotation_rad), s = std::sin(a.rotation_rad);
  for (const auto& [x, y] : {std::pair{h, h}, std::pair{-h, h}, std::pair{-h, -h}, std::pair{h, -h}})
    out.emplace_back(c * x - s * y, s * x + c * y);
  return out;
}


/// A closed block: the flat disc of radius R at z = z0 below, and above every point of a polar
/// grid the height top(j, k) (ring j of `rings`, sector k; ring 0 is the centre).
TriMesh platform_block(const PlatformFrame& f, double R, int rings, double z0,
                       const std::vector<std::vector<double>>& top, double phase) {
  TriMesh m;
  const int N = kPlatformSectors;
  auto xy = [&](int j, int k) {
    const double r = R * j / rings, phi = phase + 2 * kPi * k / N;
    return Eigen::Vector2d(r * std::cos(phi), r * std::sin(phi));
  };
  // Top grid: centre, then rings 1..J of N vertices.
  m.vertices.push_back(f.at(0, 0, top[0][0]));
  for (int j = 1; j <= rings; ++j)
    for (int k = 0; k < N; ++k) {
      const auto q = xy(j, k);
      m.vertices.push_back(f.at(q.x(), q.y(), top[j][k]));
    }
  auto T = [&](int j, int k) { return j == 0 ? 0 : 1 + (j - 1) * N + ((k % N) + N) % N; };
  // Top faces look up (+z) when (anterior, medial, up) is right-handed.
  for (int k = 0; k < N; ++k) m.triangles.push_back({T(0, 0), T(1, k), T(1, k + 1)});
  for (int j = 1; j < rings; ++j)
    for (int k = 0; k < N; ++k) {
      m.triangles.push_back({T(j, k), T(j + 1, k), T(j + 1, k + 1)});
      m.triangles.push_back({T(j, k), T(j + 1, k + 1), T(j, k + 1)});
    }
  // Bottom: the flat disc (centre + rim), facing down.
  const int bc = m.num_vertices();
  m.vertices.push_back(f.at(0, 0, z0));
  for (int k = 0; k < N; ++k) {
    const auto q = xy(rings, k);
    m.vertices.push_back(f.at(q.x(), q.y(), z0));
  }
  auto B = [&](int k) { return bc + 1 + ((k % N) + N) % N; };
  for (int k = 0; k < N; ++k) m.triangles.push_back({bc, B(k + 1), B(k)});
  // Side: from the bottom rim up to the top grid's outer ring, facing out.
  for (int k = 0; k < N; ++k) {
    m.triangles.push_back({B(k), B(k + 1), T(rings, k + 1)});
    m.triangles.push_back({B(k), T(rings, k + 1), T(rings, k)});
  }
  // (anterior, medial, up) is left-handed for the other side's limb: the faces then look in.
  if (geometry::signed_volume(m) < 0) geometry::flip_orientation(m);
  return m;
}

/// A prism of kHoleSides sides around (x, y) from z0 to z1, its sides tangent to the circle of
/// radius r (the hole is never narrower than 2r).
void add_drill(TriMesh& m, const PlatformFrame& f, const Eigen::Vector2d& c, double r, double z0, double z1,
               double phase) {
  const int N = kHoleSides;
  const double rv = r / std::cos(kPi / N);
  const int b = m.num_vertices();
  m.vertices.push_back(f.at(c.x(), c.y(), z0));
  m.vertices.push_back(f.at(c.x(), c.y(), z1));
  for (int k = 0; k < N; ++k) {
    const double phi = phase + 2 * kPi * k / N;
    m.vertices.push_back(f.at(c.x() + rv * std::cos(phi), c.y() + rv * std::sin(phi), z0));
    m.vertices.push_back(f.at(c.x() + rv * std::cos(phi), c.y() + rv * std::sin(phi), z1));
  }
  auto lo = [&](int k) { return b + 2 + 2 * (((k % N) + N) % N); };
  auto hi = [&](int k) { return lo(k) + 1; };
  for (int k = 0; k < N; ++k) {
    m.triangles.push_back({b, lo(k + 1), lo(k)});      // bottom, facing down
    m.triangles.push_back({b + 1, hi(k), hi(k + 1)});  // top, facing up
    m.triangles.push_back({lo(k), lo(k + 1), hi(k + 1)});
    m.triangles.push_back({lo(k), hi(k + 1), hi(k)});
  }
}

/// The shell's three walls (inner = the cavity, middle, outer) probed along the pylon line from
/// below the whole solid.
struct PylonWalls {
  TriMesh outer, mid;
  geometry::SurfaceQuery outer_q, mid_q, inner_q;
  const PlatformFrame& f;
  double z_low_m;

  PylonWalls(const CutSurface& cut, const std::vector<double>& s, const TriMesh& solid, const PlatformFrame& frame)
      : outer(offset_wall(cut, s, 1.0)),
        mid(offset_wall(cut, s, 0.5)),
        outer_q(outer),
        mid_q(mid),
        inner_q(cut.mesh),
        f(frame),
        z_low_m(lowest_z(solid, frame) - 0.01) {}

  /// First crossing of the vertical (pylon) line through (x, y) with a wall, from below.
  std::optional<double> up_hit(const geometry::SurfaceQuery& q, double x, double y) const {
    const auto h = q.first_hit(f.at(x, y, z_low_m), f.up);
    if (!h) return std::nullopt;
    return z_low_m + h->distance;
  }

  /// The cut surface moved out by `fraction` of the wall thickness s along its normals.
  static TriMesh offset_wall(const CutSurface& cut, const std::vector<double>& s, double fraction) {
    TriMesh m = cut.mesh;
    for (int i = 0; i < cut.mesh.num_vertices(); ++i)
      m.vertices[i] = cut.mesh.vertices[i] + fraction * s[i] * cut.normal[i];  // 1.0 * s is s exactly
    return m;
  }

  static double lowest_z(const TriMesh& solid, const PlatformFrame& frame) {
    double z = std::numeric_limits<double>::infinity();
    for (const auto& v : solid.vertices) z = std::min(z, frame.z_of(v));
    return z;
  }
};

/// The block's top over its polar grid (on the middle of the wall), the highest of it, and the
/// lowest outer-wall point over the disc.
struct BlockTop {
  std::vector<std::vector<double>> top_m;
  double z_outer_min_m, z_top_max_m;
};

BlockTop sample_block_top(const PylonWalls& walls, const PlatformFrame& f, double R, int rings, double phase) {
  BlockTop b;
  std::vector<std::vector<double>>& top = b.top_m;
  top.assign(rings + 1, std::vector<double>(kPlatformSectors));
  double z_out_min = std::numeric_limits<double>::infinity(), z_top_max = -z_out_min;
  for (int j = 0; j <= rings; ++j)
    for (int k = 0; k < kPlatformSectors; ++k) {
      if (j == 0 && k > 0) {
        top[0][k] = top[0][0];
        continue;
      }
      const double r = R * j / rings, phi = phase + 2 * kPi * k / kPlatformSectors;
      const double x = r * std::cos(phi), y = r * std::sin(phi);
      const auto zm = walls.up_hit(walls.mid_q, x, y);
      require(zm.has_value(),
              "build_socket: the distal platform ({:.0f} mm across) is wider than the socket's distal end: the pylon "
              "line {:.1f} mm from its centre misses the socket; make the platform (or pad) diameter smaller",
              2 * R / kMm, r / kMm);
      top[j][k] = *zm;
      z_top_max = std::max(z_top_max, *zm);
      if (const auto zo = walls.up_hit(walls.outer_q, x, y)) z_out_min = std::min(z_out_min, *zo);
    }
  for (const auto& v : walls.outer.vertices)
    if (f.xy_of(v).norm() <= R) z_out_min = std::min(z_out_min, f.z_of(v));
  b.z_outer_min_m = z_out_min;
  b.z_top_max_m = z_top_max;
  return b;
}

/// Sets the attachment's holes (centres, radius, each drill's top above the cavity) in @p pb and
/// returns the flat face lowered to platform_thickness_m below the cavity over every hole.
double place_holes(PlatformBuild& pb, const PylonWalls& walls, const SocketAttachment& at, double z_face_m) {
  double z_face = z_face_m;
  pb.holes = hole_pattern(at);
  pb.hole_radius = 0.5 * at.hole_diameter_m;
  for (std::size_t h = 0; h < pb.holes.size(); ++h) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    // The cavity over the hole: its axis, 8 points at half its radius and 32 on its circle.
    for (int k = -1; k < 40; ++k) {
      const double phi = 2 * kPi * k / (k < 8 ? 8 : 32);
      const double rr = k < 0 ? 0.0 : k < 8 ? 0.5 * pb.hole_radius : pb.hole_radius / std::cos(kPi / kHoleSides);
      const Eigen::Vector2d q = pb.holes[h] + rr * Eigen::Vector2d(std::cos(phi), std::sin(phi));
      const auto zi = walls.up_hit(walls.inner_q, q.x(), q.y());
      require(zi.has_value(),
              "build_socket: attachment hole {} at ({:.1f}, {:.1f}) mm from the pylon axis does not reach the "
              "socket's cavity; use a smaller hole spacing or offset",
              h + 1, pb.holes[h].x() / kMm, pb.holes[h].y() / kMm);
      lo = std::min(lo, *zi);
      hi = std::max(hi, *zi);
    }
    z_face = std::min(z_face, lo - at.platform_thickness_m);
    pb.hole_top.push_back(hi + std::max(2 * kMm, pb.hole_radius));
  }
  return z_face;
}

/// Unites the block with the shell and, with an attachment, drills its holes.
void join_block_and_drills(Attempt& a, const PlatformBuild& pb, bool attach, int rings,
                           const std::vector<std::vector<double>>& top_m, double phase) {
  const PlatformFrame& f = pb.frame;
  // The shell passed the self-intersection test; the block and the drills are valid by
  // construction (and the result is checked again).
  geometry::BooleanOptions unchecked;
  unchecked.check_operands = false;
  a.solid = geometry::mesh_boolean(a.solid, platform_block(f, pb.radius, rings, pb.z_face, top_m, phase),
                                   geometry::BooleanOperation::Union, unchecked);
  if (attach) {
    TriMesh drills;
    for (std::size_t h = 0; h < pb.holes.size(); ++h)
      add_drill(drills, f, pb.holes[h], pb.hole_radius, pb.z_face - 1 * kMm, pb.hole_top[h],
                0.5 * kPi / kHoleSides + phase);
    if (geometry::signed_volume(drills) < 0) geometry::flip_orientation(drills);  // as the block
    a.solid = geometry::mesh_boolean(a.solid, drills, geometry::BooleanOperation::Difference, unchecked);
  }
}

/// The platform's report: where its face is, how tall it climbs, and the holes' depths.
void fill_platform_report(PlatformBuild& pb, const PylonWalls& walls, const SocketAttachment& at, bool attach,
                          double tallest_m) {
  const PlatformFrame& f = pb.frame;
  const double R = pb.radius, z_face = pb.z_face;
  SocketPlatform& r = pb.report;
  r.is_built = true;
  r.centre = f.at(0, 0, z_face);
  r.normal = -f.up;
  r.anterior = f.anterior;
  r.medial = f.medial;
  r.diameter_m = 2 * R;
  r.max_height_m = tallest_m;
  if (attach) {
    r.hole_diameter_m = at.hole_diameter_m;
    r.min_hole_depth_m = std::numeric_limits<double>::infinity();
    for (std::size_t h = 0; h < pb.holes.size(); ++h) {
      r.hole_centres.push_back(f.at(pb.holes[h].x(), pb.holes[h].y(), z_face));
      const auto zi = walls.up_hit(walls.inner_q, pb.holes[h].x(), pb.holes[h].y());
      r.min_hole_depth_m = std::min(r.min_hole_depth_m, *zi - z_face);
    }
    const double reach = pb.holes.front().norm() + pb.hole_radius;
    r.smallest_feature_m = std::min({at.hole_diameter_m, at.hole_spacing_m - 2 * pb.hole_radius, R - reach});
  }
}

}  // namespace

/// Joins the platform to the shell @p a (and drills the holes). The block's top follows the middle
/// of the wall (inner + half the offset), so it lies inside the wall's material: the union adds
/// material below the wall and never into the cavity. Its flat face lies kPlatformGap_m below the
/// lowest outer-wall point over the disc and, with holes, platform_thickness_m below the cavity
/// over every hole.
PlatformBuild add_platform(Attempt& a, const CutSurface& cut, const std::vector<double>& s,
                           const geometry::LimbFrame& frame, const SocketOptions& o, double phase) {
  const bool attach = o.attachment.enabled;
  PlatformBuild pb;
  pb.frame = platform_frame(frame, o);
  const PlatformFrame& f = pb.frame;
  pb.radius = 0.5 * (attach ? o.attachment.platform_diameter_m : o.distal_pad_diameter_m);
  const double R = pb.radius;
  const PylonWalls walls(cut, s, a.solid, f);
  const int rings = std::max(4, static_cast<int>(std::ceil(R / (1.5 * kMm))));
  const BlockTop block = sample_block_top(walls, f, R, rings, phase);
  double z_face = block.z_outer_min_m - kPlatformGap_m;
  if (attach) z_face = place_holes(pb, walls, o.attachment, z_face);
  const double tallest = block.z_top_max_m - z_face;
  const double limit = std::max(2 * R, 0.04) + (attach ? o.attachment.platform_thickness_m : 0.0);
  require(tallest <= limit,
          "build_socket: the distal platform ({:.0f} mm across) would climb {:.0f} mm up the socket's side (more than "
          "{:.0f} mm): it is wider than the socket's distal end; make the platform (or pad) diameter smaller",
          2 * R / kMm, tallest / kMm, limit / kMm);
  pb.z_face = z_face;
  join_block_and_drills(a, pb, attach, rings, block.top_m, phase);
  fill_platform_report(pb, walls, o.attachment, attach, tallest);
  return pb;
}

}  // namespace socketsmith::design::socket_detail
