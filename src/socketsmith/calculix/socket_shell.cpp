#include "socketsmith/calculix/socket_shell.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/volume/hex_element.h"

namespace socketsmith::calculix {

const std::vector<char>& outside_socket(const DesignedStump& d) {
  require(d.above_socket_brim.empty() || d.above_socket_brim.size() == d.above_brim.size(),
          "check_design: {} socket-brim flags for {} skin nodes", d.above_socket_brim.size(), d.above_brim.size());
  return d.above_socket_brim.empty() ? d.above_brim : d.above_socket_brim;
}

std::vector<std::array<int, 4>> socket_quads_below_brim(const DesignedStump& d, const std::vector<int>& skin_of,
                                                        bool across_brim) {
  const std::vector<char>& no_socket = outside_socket(d);
  std::vector<std::array<int, 4>> socket_quads;  // local skin ids
  for (const auto& q : d.skin->quads) {
    std::array<int, 4> l{skin_of[q[0]], skin_of[q[1]], skin_of[q[2]], skin_of[q[3]]};
    const int above = (no_socket[l[0]] != 0) + (no_socket[l[1]] != 0) + (no_socket[l[2]] != 0) + (no_socket[l[3]] != 0);
    if (above == 0 || (across_brim && above < 4)) socket_quads.push_back(l);
  }
  require(!socket_quads.empty(), "check_design: no skin quad lies wholly below the brim (no socket to check)");
  return socket_quads;
}

namespace {

/// The shell of @p quads on @p s, extruded along its normals, thinned until no quad below the brim
/// folds. A quad laid across the brim onto the lip's tight curve can fold (OpenLimb TT 5.9k, 2 x 2:
/// a twisted quad, two corners of opposite Jacobian; ccx rejected its element): such quads (@p lip)
/// are left out. Below the brim the shell is thinned until none folds (the thickness does not count,
/// docs/VALIDATION.md); one that still does is said.
RigidShell extrude_unfolded(const QuadSurface& s, const std::vector<std::array<int, 4>>& quads,
                            const std::vector<char>& lip, double thickness_m) {
  const auto folded = [&](const std::array<int, 4>& q, double t) {
    volume::HexNodes x;
    for (int a = 0; a < 4; ++a) {
      x[a] = s.points[q[a]];
      x[a + 4] = s.points[q[a]] + t * s.normals[q[a]].normalized();
    }
    return volume::min_corner_jacobian(x) <= 0.0;
  };
  for (double t = thickness_m;; t *= 0.5) {
    std::vector<std::array<int, 4>> kept;
    int below = 0, dropped = 0;
    for (size_t k = 0; k < quads.size(); ++k) {
      const bool f = folded(quads[k], t);
      if (f && lip[k]) {
        ++dropped;
        continue;
      }
      below += f ? 1 : 0;
      kept.push_back(quads[k]);
    }
    if (below == 0 || t < 1e-4) {
      if (below > 0)
        log::warn("validate: {} element(s) of the socket shell below the brim are inverted even {:.2g} mm thin (ccx "
                  "will refuse them): give --shell-subdivision 1, or drop --shell-on-wall",
                  below, t * 1e3);
      if (dropped > 0)
        log::info("validate: {} quad(s) of the socket shell across the brim fold over the lip and are left out", dropped);
      return extrude_shell(s.points, s.normals, kept, t);
    }
  }
}

}  // namespace

RigidShell donned_skin_shell(const DesignedStump& d, const std::vector<std::array<int, 4>>& socket_quads,
                             const Vec3& down, const DesignCheckOptions& o) {
  const auto& skin = *d.skin;
  const int ns = static_cast<int>(skin.nodes.size()), subdivision = o.shell_subdivision;
  require(d.wall_positions.empty() || static_cast<int>(d.wall_positions.size()) == ns,
          "check_design: {} wall positions for {} skin nodes", d.wall_positions.size(), ns);
  std::vector<Vec3> inner(ns), normal(ns);
  for (int i = 0; i < ns; ++i) {
    inner[i] = d.wall_positions.empty() ? d.designed_positions[skin.nodes[i]] : d.wall_positions[i];
    normal[i] = d.skin_normals[i].normalized();
  }
  QuadSurface s = subdivide_quads(inner, normal, socket_quads, subdivision);
  const size_t per = static_cast<size_t>(subdivision) * subdivision;
  const std::vector<char>& no_socket = outside_socket(d);
  const auto across_brim = [&](size_t k) {
    const auto& parent = socket_quads[k / per];
    return std::any_of(parent.begin(), parent.end(), [&](int v) { return no_socket[v] != 0; });
  };
  // used: 1 a point of the shell; 2 of a quad below the brim too. Without shell_on_wall only the
  // lip's own points (of quads across the brim alone) are laid on the wall.
  std::vector<char> used(s.points.size(), 0), off(s.points.size(), 0);
  for (size_t k = 0; k < s.quads.size(); ++k)
    for (int v : s.quads[k]) used[v] = std::max<char>(used[v], across_brim(k) ? 1 : 2);
  for (size_t k = 0; k < s.points.size(); ++k) {
    if (!used[k]) continue;
    if (o.shell_on_wall || (o.shell_lip && used[k] == 1)) {
      if (const auto on = d.wall_surface(s.points[k])) std::tie(s.points[k], s.normals[k]) = *on;
      else off[k] = 1;
    }
    s.points[k] += down;
  }
  std::vector<std::array<int, 4>> quads;
  std::vector<char> lip;  // per kept quad: across the brim
  std::vector<char> kept_off(s.points.size(), 0);  // points below the brim that do not face the wall
  for (size_t k = 0; k < s.quads.size(); ++k) {
    const bool on_lip = across_brim(k);
    const auto& q = s.quads[k];
    if (on_lip && std::any_of(q.begin(), q.end(), [&](int v) { return off[v] != 0; })) continue;
    if (!on_lip)
      for (int v : q) kept_off[v] = off[v];
    quads.push_back(q);
    lip.push_back(on_lip ? 1 : 0);
  }
  if (const auto n = std::count(kept_off.begin(), kept_off.end(), 1); n > 0)
    log::warn("validate: {} point(s) of the socket shell below the brim do not face socketsmith's wall; they keep their "
              "place between the skin nodes", n);
  require(!quads.empty(), "check_design: no socket quad faces socketsmith's wall (the socket does not fit its stump)");
  return extrude_unfolded(s, quads, lip, o.socket_thickness_m);
}

}  // namespace socketsmith::calculix
