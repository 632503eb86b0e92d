#include "socketsmith/design/ischial_check.h"

#include <cmath>
#include <map>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/surface_query.h"

namespace socketsmith::design {

geometry::TriMesh socket_cavity_surface(const SocketResult& socket, const geometry::LimbFrame& frame) {
  const auto& solid = socket.solid;
  require(socket.face_kind.size() == solid.triangles.size(),
          "socket_cavity_surface: the socket has {} face kinds for {} triangles (expected one per triangle)",
          socket.face_kind.size(), solid.triangles.size());
  geometry::TriMesh cavity;
  std::map<int, int> local;  // solid vertex → cavity vertex
  const auto id = [&](int v) {
    const auto [it, is_new] = local.emplace(v, cavity.num_vertices());
    if (is_new) cavity.vertices.push_back(solid.vertices[v]);
    return it->second;
  };
  for (size_t t = 0; t < solid.triangles.size(); ++t) {
    if (socket.face_kind[t] != SocketFace::Inner) continue;
    const auto& f = solid.triangles[t];
    // The solid's inner wall faces into the cavity; the cavity's outward normal is the opposite.
    cavity.triangles.push_back({id(f[0]), id(f[2]), id(f[1])});
  }
  require(!cavity.triangles.empty(), "socket_cavity_surface: the socket has no inner wall");
  // Boundary edges (a directed edge whose reverse is absent) and their loops.
  std::map<std::pair<int, int>, int> directed;
  for (const auto& f : cavity.triangles)
    for (int k = 0; k < 3; ++k) ++directed[{f[k], f[(k + 1) % 3]}];
  std::map<int, int> next;  // boundary: a → b
  for (const auto& [e, n] : directed)
    if (!directed.count({e.second, e.first})) next[e.first] = e.second;
  std::vector<std::vector<int>> loops;
  while (!next.empty()) {
    std::vector<int> loop;
    int v = next.begin()->first;
    while (next.count(v)) {
      loop.push_back(v);
      const int w = next.at(v);
      next.erase(v);
      v = w;
    }
    loops.push_back(std::move(loop));
  }
  require(!loops.empty(), "socket_cavity_surface: the socket's inner wall has no rim (a closed inner wall?)");
  const auto height = [&](int v) { return frame.to_cylindrical(cavity.vertices[v]).h; };
  const auto mean_h = [&](const std::vector<int>& loop) {
    double m = 0.0;
    for (int u : loop) m += height(u);
    return m / static_cast<double>(loop.size());
  };
  size_t rim = 0;
  for (size_t k = 1; k < loops.size(); ++k)
    if (mean_h(loops[k]) > mean_h(loops[rim])) rim = k;
  for (size_t k = 0; k < loops.size(); ++k) {
    const auto& loop = loops[k];
    const size_t n = loop.size();
    if (k == rim) {
      // The brim's cap: each rim vertex joined to the axis at its own height. The wall holds a → b;
      // the cap holds b → a.
      std::vector<int> on_axis(n);
      for (size_t j = 0; j < n; ++j) {
        on_axis[j] = cavity.num_vertices();
        cavity.vertices.push_back(frame.on_axis(height(loop[j])));
      }
      for (size_t j = 0; j < n; ++j) {
        const size_t jn = (j + 1) % n;
        cavity.triangles.push_back({loop[jn], loop[j], on_axis[j]});
        cavity.triangles.push_back({loop[jn], on_axis[j], on_axis[jn]});
      }
    } else {
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (int u : loop) c += cavity.vertices[u];
      c /= static_cast<double>(n);
      const int ci = cavity.num_vertices();
      cavity.vertices.push_back(c);
      for (size_t j = 0; j < n; ++j) cavity.triangles.push_back({loop[(j + 1) % n], loop[j], ci});
    }
  }
  return cavity;
}

IschialCheck check_ischial_tuberosity(const BrimLine& brim, const geometry::LimbFrame& frame,
                                      const Eigen::Vector3d& tuberosity, const SocketResult& socket,
                                      const IschialCheckOptions& options) {
  require(options.seat_tolerance_m > 0.0 && options.seat_above_tolerance_m >= 0.0,
          "check_ischial_tuberosity: seat tolerances {} m below, {} m above must be positive", options.seat_tolerance_m,
          options.seat_above_tolerance_m);
  require(tuberosity.allFinite(), "check_ischial_tuberosity: the tuberosity's position is not finite");
  IschialCheck r;
  if (brim.kind() != BrimTemplate::Ics && brim.kind() != BrimTemplate::Quad) return r;
  r.applies = true;
  r.kind = brim.kind() == BrimTemplate::Ics ? "containment" : "seat";
  r.tuberosity = tuberosity;
  const geometry::Cylindrical q = frame.to_cylindrical(tuberosity);
  r.tuberosity_theta_rad = q.theta;
  r.tuberosity_h_m = q.h;
  r.brim_h_m = brim.height(q.theta);
  const geometry::SurfaceQuery cavity(socket_cavity_surface(socket, frame));
  r.inside_cavity = cavity.is_inside(tuberosity);
  r.cavity_margin_m = std::abs(cavity.signed_distance(tuberosity)) * (r.inside_cavity ? 1.0 : -1.0);
  const double deg = 3.14159265358979323846 / 180.0;
  // mm to one decimal, without a "-0.0" for a value a rounding error below zero.
  const auto mm1 = [](double m) { return std::round(m * 1e4) / 10.0 + 0.0; };
  if (r.kind == "containment") {
    r.height_margin_m = r.brim_h_m - r.tuberosity_h_m;
    r.met = r.inside_cavity;
    r.summary = fmt::format("ischial tuberosity {} the socket's cavity: {:.1f} mm from its surface, the brim {:.1f} mm "
                            "above it at {:.0f}°",
                            r.inside_cavity ? "INSIDE" : "OUTSIDE", mm1(std::abs(r.cavity_margin_m)),
                            mm1(r.height_margin_m), q.theta / deg);
  } else {
    r.height_margin_m = r.tuberosity_h_m - r.brim_h_m;
    const bool on_seat =
        r.height_margin_m >= -options.seat_above_tolerance_m && r.height_margin_m <= options.seat_tolerance_m;
    r.met = on_seat && !(r.inside_cavity && r.cavity_margin_m > options.seat_above_tolerance_m);
    r.summary = fmt::format("ischial tuberosity {} the seat: {:.1f} mm above the brim at {:.0f}° ({} the cavity, {:.1f} "
                            "mm from its surface)",
                            r.met ? "ON" : "NOT on", mm1(r.height_margin_m), q.theta / deg,
                            r.inside_cavity ? "inside" : "outside", mm1(std::abs(r.cavity_margin_m)));
  }
  return r;
}

}  // namespace socketsmith::design
