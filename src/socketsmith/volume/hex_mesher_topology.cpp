// The topology of the hexahedral limb mesh on one grid size: the grid aligned with the limb frame,
// the cells inside the skin kept as a manifold core, and the pillow layer extruded from the core's
// boundary to the skin (hex_mesher_detail.h says why this is apart from the node moves).
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <queue>

#include "socketsmith/core/errors.h"
#include "socketsmith/volume/hex_mesher_detail.h"

namespace socketsmith::volume::hex_mesher_detail {
namespace {

Grid make_grid(const TriMesh& skin, const geometry::LimbFrame& frame, double cut_h, double h) {
  Grid g;
  g.origin = frame.origin;
  const Vec3 e3 = frame.axis.normalized();
  const Vec3 e1 = frame.anterior.normalized();
  const Vec3 e2 = e3.cross(e1).normalized();
  g.R.col(0) = e1;
  g.R.col(1) = e2;
  g.R.col(2) = e3;
  g.h = h;
  Vec3 lo = Vec3::Constant(1e30), hi = Vec3::Constant(-1e30);
  for (const auto& v : skin.vertices) {
    const Vec3 q = g.to_local(v);
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  // x, y: one padding cell each side; z: top plane exactly at the cut, one padding cell below.
  g.nx = static_cast<int>(std::ceil((hi.x() - lo.x()) / h)) + 3;
  g.ny = static_cast<int>(std::ceil((hi.y() - lo.y()) / h)) + 3;
  const int cells_z = static_cast<int>(std::ceil((cut_h - lo.z()) / h)) + 1;
  g.nz = cells_z + 1;
  const Vec3 mid = 0.5 * (lo + hi);
  g.q0 = Vec3(mid.x() - 0.5 * (g.nx - 1) * h, mid.y() - 0.5 * (g.ny - 1) * h, cut_h - cells_z * h);
  return g;
}

/// Inside flags of every grid node for a closed surface, by parity of crossings along x-lines.
/// The lines are shifted by a tiny irrational fraction of h so that they never run through a
/// vertex or an edge, and nodes on the top plane are classified just below it.
std::vector<std::uint8_t> classify_inside(const Grid& g, const TriMesh& mesh) {
  const double dy = 1.2345e-5 * g.h, dz = -2.3456e-5 * g.h;
  std::vector<std::vector<double>> hits(static_cast<size_t>(g.ny) * g.nz);
  std::vector<Vec3> q(mesh.vertices.size());
  for (size_t v = 0; v < q.size(); ++v) q[v] = g.to_local(mesh.vertices[v]);
  for (const auto& t : mesh.triangles) {
    const Vec3 &a = q[t[0]], &b = q[t[1]], &c = q[t[2]];
    const double ymin = std::min({a.y(), b.y(), c.y()}), ymax = std::max({a.y(), b.y(), c.y()});
    const double zmin = std::min({a.z(), b.z(), c.z()}), zmax = std::max({a.z(), b.z(), c.z()});
    const int j0 = std::max(0, static_cast<int>(std::ceil((ymin - dy - g.q0.y()) / g.h)));
    const int j1 = std::min(g.ny - 1, static_cast<int>(std::floor((ymax - dy - g.q0.y()) / g.h)));
    const int k0 = std::max(0, static_cast<int>(std::ceil((zmin - dz - g.q0.z()) / g.h)));
    const int k1 = std::min(g.nz - 1, static_cast<int>(std::floor((zmax - dz - g.q0.z()) / g.h)));
    const double det = (b.y() - a.y()) * (c.z() - a.z()) - (c.y() - a.y()) * (b.z() - a.z());
    if (std::abs(det) < 1e-30) continue;  // parallel to x: a shifted line never crosses it
    for (int k = k0; k <= k1; ++k)
      for (int j = j0; j <= j1; ++j) {
        const double py = g.q0.y() + j * g.h + dy, pz = g.q0.z() + k * g.h + dz;
        const double l1 = ((py - a.y()) * (c.z() - a.z()) - (c.y() - a.y()) * (pz - a.z())) / det;
        const double l2 = ((b.y() - a.y()) * (pz - a.z()) - (py - a.y()) * (b.z() - a.z())) / det;
        if (l1 < 0.0 || l2 < 0.0 || l1 + l2 > 1.0) continue;
        hits[static_cast<size_t>(k) * g.ny + j].push_back(a.x() + l1 * (b.x() - a.x()) + l2 * (c.x() - a.x()));
      }
  }
  std::vector<std::uint8_t> inside(g.num_nodes(), 0);
  for (int k = 0; k < g.nz; ++k)
    for (int j = 0; j < g.ny; ++j) {
      auto& line = hits[static_cast<size_t>(k) * g.ny + j];
      if (line.empty()) continue;
      std::sort(line.begin(), line.end());
      size_t m = 0;
      for (int i = 0; i < g.nx; ++i) {
        const double x = g.q0.x() + i * g.h;
        while (m < line.size() && line[m] < x) ++m;
        if (m % 2 == 1) inside[g.node(i, j, k)] = 1;
      }
    }
  return inside;
}

}  // namespace

SkinParts split_skin(const HexMesherInput& in) {
  SkinParts parts;
  const int first_cap = in.first_cap_triangle < 0 ? in.skin.num_triangles() : in.first_cap_triangle;
  parts.side.vertices = in.skin.vertices;
  parts.side.triangles.assign(in.skin.triangles.begin(), in.skin.triangles.begin() + first_cap);
  std::map<std::pair<int, int>, int> owner;  // edge -> 1 side, 2 cap, 3 both
  for (int t = 0; t < in.skin.num_triangles(); ++t) {
    const auto& tri = in.skin.triangles[t];
    for (int e = 0; e < 3; ++e) {
      const int a = tri[e], b = tri[(e + 1) % 3];
      owner[{std::min(a, b), std::max(a, b)}] |= (t < first_cap ? 1 : 2);
    }
  }
  for (const auto& [e, o] : owner)
    if (o == 3) parts.rim.push_back({in.skin.vertices[e.first], in.skin.vertices[e.second]});
  return parts;
}

Vec3 closest_on_segments(const std::vector<std::array<Vec3, 2>>& segs, const Vec3& p) {
  Vec3 best = p;
  double best_d = std::numeric_limits<double>::infinity();
  for (const auto& s : segs) {
    const Vec3 d = s[1] - s[0];
    const double l2 = d.squaredNorm();
    const double t = l2 > 0 ? std::clamp((p - s[0]).dot(d) / l2, 0.0, 1.0) : 0.0;
    const Vec3 c = s[0] + t * d;
    const double dist = (c - p).squaredNorm();
    if (dist < best_d) {
      best_d = dist;
      best = c;
    }
  }
  return best;
}

namespace {

// Neighbour cell offsets of the 6 faces of kHexFaces (bottom, top, -y, +x, +y, -x).
constexpr int kFaceDir[6][3] = {{0, 0, -1}, {0, 0, 1}, {0, -1, 0}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0}};

/// Cell-set state on the grid: core flags and the rules that keep its boundary manifold.
struct Core {
  const Grid& g;
  std::vector<std::uint8_t> in;        // per cell
  std::vector<std::uint8_t> allowed;   // per cell: all corners inside the skin
  std::vector<double> score;           // per cell: min corner distance to the skin (higher = safer)

  bool at(int i, int j, int k) const {
    if (i < 0 || j < 0 || k < 0 || i >= g.cx() || j >= g.cy() || k >= g.cz()) return false;
    return in[g.cell(i, j, k)] != 0;
  }
  bool valid(int i, int j, int k) const {
    return i >= 0 && j >= 0 && k >= 0 && i < g.cx() && j < g.cy() && k < g.cz();
  }

  /// Keeps the largest face-connected component.
  int keep_largest_component() {
    std::vector<int> comp(in.size(), -1);
    int best = -1, best_size = 0, ncomp = 0;
    for (int c0 = 0; c0 < static_cast<int>(in.size()); ++c0) {
      if (!in[c0] || comp[c0] >= 0) continue;
      int size = 0;
      std::queue<int> q;
      q.push(c0);
      comp[c0] = ncomp;
      while (!q.empty()) {
        const int c = q.front();
        q.pop();
        ++size;
        const int i = c % g.cx(), j = (c / g.cx()) % g.cy(), k = c / (g.cx() * g.cy());
        for (const auto& d : kFaceDir) {
          const int a = i + d[0], b = j + d[1], e = k + d[2];
          if (!at(a, b, e)) continue;
          const int n = g.cell(a, b, e);
          if (comp[n] < 0) {
            comp[n] = ncomp;
            q.push(n);
          }
        }
      }
      if (size > best_size) {
        best_size = size;
        best = ncomp;
      }
      ++ncomp;
    }
    for (size_t c = 0; c < in.size(); ++c)
      if (in[c] && comp[c] != best) in[c] = 0;
    return ncomp;
  }

  /// Adds the cells that are not connected to the grid border through non-core cells.
  int fill_cavities() {
    std::vector<std::uint8_t> reach(in.size(), 0);
    std::queue<int> q;
    for (int k = 0; k < g.cz(); ++k)
      for (int j = 0; j < g.cy(); ++j)
        for (int i = 0; i < g.cx(); ++i) {
          const bool border = i == 0 || j == 0 || k == 0 || i == g.cx() - 1 || j == g.cy() - 1 || k == g.cz() - 1;
          const int c = g.cell(i, j, k);
          if (border && !in[c]) {
            reach[c] = 1;
            q.push(c);
          }
        }
    while (!q.empty()) {
      const int c = q.front();
      q.pop();
      const int i = c % g.cx(), j = (c / g.cx()) % g.cy(), k = c / (g.cx() * g.cy());
      for (const auto& d : kFaceDir) {
        const int a = i + d[0], b = j + d[1], e = k + d[2];
        if (!valid(a, b, e)) continue;
        const int n = g.cell(a, b, e);
        if (!in[n] && !reach[n]) {
          reach[n] = 1;
          q.push(n);
        }
      }
    }
    int added = 0;
    for (size_t c = 0; c < in.size(); ++c)
      if (!in[c] && !reach[c]) {
        in[c] = 1;
        ++added;
      }
    return added;
  }

  /// Resolves one non-manifold configuration among @p cells (some in, some out): adds the best
  /// allowed out-cell, or else removes the weakest in-cell. Returns true if something changed.
  bool resolve(const std::vector<std::array<int, 3>>& cells) {
    int add = -1, remove = -1;
    double add_score = -1e30, remove_score = 1e30;
    for (const auto& c : cells) {
      if (!valid(c[0], c[1], c[2])) continue;
      const int id = g.cell(c[0], c[1], c[2]);
      if (in[id]) {
        if (score[id] < remove_score) {
          remove_score = score[id];
          remove = id;
        }
      } else if (allowed[id] && score[id] > add_score) {
        add_score = score[id];
        add = id;
      }
    }
    if (add >= 0) {
      in[add] = 1;
      return true;
    }
    if (remove >= 0) {
      in[remove] = 0;
      return true;
    }
    return false;
  }

  /// Repairs edges shared by two diagonal core cells only, and vertices whose core (or non-core)
  /// cells form more than one face-connected group in their 2×2×2 block. Returns the number of
  /// changes.
  int make_manifold() {
    int changes = 0;
    for (int pass = 0; pass < 50; ++pass) {
      int pass_changes = 0;
      // Edges along each axis.
      for (int axis = 0; axis < 3; ++axis) {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        for (int k = 0; k < g.cz() + 1; ++k)
          for (int j = 0; j < g.cy() + 1; ++j)
            for (int i = 0; i < g.cx() + 1; ++i) {
              std::array<int, 3> base{i, j, k};
              if (base[axis] >= (axis == 0 ? g.cx() : axis == 1 ? g.cy() : g.cz())) continue;
              std::array<std::array<int, 3>, 4> cells;
              std::array<bool, 4> on{};
              for (int m = 0; m < 4; ++m) {
                std::array<int, 3> c = base;
                c[u] -= (m == 0 || m == 3) ? 1 : 0;
                c[v] -= (m == 0 || m == 1) ? 1 : 0;
                cells[m] = c;
                on[m] = at(c[0], c[1], c[2]);
              }
              // cells in cyclic order around the edge: 0 (-u,-v), 1 (0,-v), 2 (0,0), 3 (-u,0)
              const bool diag = (on[0] && on[2] && !on[1] && !on[3]) || (on[1] && on[3] && !on[0] && !on[2]);
              if (diag && resolve({cells.begin(), cells.end()})) ++pass_changes;
            }
      }
      // Vertices.
      for (int k = 0; k <= g.cz(); ++k)
        for (int j = 0; j <= g.cy(); ++j)
          for (int i = 0; i <= g.cx(); ++i) {
            std::array<std::array<int, 3>, 8> cells;
            std::array<bool, 8> on{};
            int n_on = 0;
            for (int m = 0; m < 8; ++m) {
              cells[m] = {i - 1 + (m & 1), j - 1 + ((m >> 1) & 1), k - 1 + ((m >> 2) & 1)};
              on[m] = at(cells[m][0], cells[m][1], cells[m][2]);
              n_on += on[m];
            }
            if (n_on == 0 || n_on == 8) continue;
            auto components = [&](bool state) {
              int seen = 0, count = 0;
              for (int s = 0; s < 8; ++s) {
                if (on[s] != state || (seen >> s & 1)) continue;
                ++count;
                int stack[8], top = 0;
                stack[top++] = s;
                seen |= 1 << s;
                while (top) {
                  const int a = stack[--top];
                  for (int bit = 0; bit < 3; ++bit) {
                    const int b = a ^ (1 << bit);
                    if (on[b] == state && !(seen >> b & 1)) {
                      seen |= 1 << b;
                      stack[top++] = b;
                    }
                  }
                }
              }
              return count;
            };
            if (components(true) > 1 || components(false) > 1)
              if (resolve({cells.begin(), cells.end()})) ++pass_changes;
          }
      changes += pass_changes;
      if (pass_changes == 0) break;
    }
    return changes;
  }
};

}  // namespace

double min_scaled_jacobian(const std::vector<Vec3>& x, const Hex& hex) {
  const auto sj = corner_scaled_jacobians(gather(x, hex));
  return *std::min_element(sj.begin(), sj.end());
}

namespace {

/// Edges of the pillow quads (the core boundary surface), as a neighbour list.
template <class Quads>
std::vector<std::vector<int>> pillow_edges(const Quads& quads) {
  return quad_edge_neighbours(quads, [](const auto& q) { return std::array<int, 4>(q.nodes); });
}

/// Rounds the staircase of the core before the pillow is extruded: Laplacian smoothing of the
/// core boundary within itself, and of the core interior, keeping the cut plane planar and no
/// core element inverted. A staircase corner would otherwise give the pillow a wedge-shaped,
/// nearly flat element.
void round_staircase(Build& b, std::vector<std::vector<int>> boundary_nb, const std::vector<Vec3>& normal_sum,
                     int iterations) {
  HexMesh& mesh = b.mesh;
  const int n_nodes = mesh.num_nodes();
  boundary_nb.resize(n_nodes);
  std::vector<std::vector<int>> nb(n_nodes);
  for (const Hex& hx : mesh.hexahedra)
    for (const auto& e : kHexEdges) {
      nb[hx[e[0]]].push_back(hx[e[1]]);
      nb[hx[e[1]]].push_back(hx[e[0]]);
    }
  for (auto& v : nb) {
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
  }
  std::vector<std::vector<int>> elements(n_nodes);
  for (int e = 0; e < mesh.num_hexahedra(); ++e)
    for (int n : mesh.hexahedra[e]) elements[n].push_back(e);
  auto worst = [&](int n) {
    double q = 1.0;
    for (int e : elements[n]) q = std::min(q, min_scaled_jacobian(mesh.nodes, mesh.hexahedra[e]));
    return q;
  };
  const Vec3 axis = b.grid.R.col(2);
  for (int it = 0; it < iterations; ++it) {
    for (int n = 0; n < n_nodes; ++n) {
      const bool on_boundary = normal_sum[n].squaredNorm() > 0.0;
      const auto& list = on_boundary ? boundary_nb[n] : nb[n];
      Vec3 avg = Vec3::Zero();
      int cnt = 0;
      for (int m : list)
        if (b.kind[n] != kTopPlane || b.kind[m] == kTopPlane) {
          avg += mesh.nodes[m];
          ++cnt;
        }
      if (cnt == 0) continue;
      Vec3 d = 0.5 * (avg / cnt - mesh.nodes[n]);
      if (b.kind[n] == kTopPlane) d -= d.dot(axis) * axis;  // stay on the cut plane
      const double before = worst(n);
      mesh.nodes[n] += d;
      if (worst(n) < std::min(before, 0.4)) mesh.nodes[n] -= d;  // keep the core well shaped
    }
  }
}

/// The core: the cells whose corners are all inside the skin and at least @p core_offset cells from
/// its side, reduced to one manifold component without cavities (the counts go into @p b).
Core core_cells(Build& b, const std::vector<std::uint8_t>& inside, const SurfaceQuery& side_query, double h,
                double core_offset) {
  const Grid& g = b.grid;
  // Distance of inside nodes to the side of the skin.
  std::vector<double> dist(g.num_nodes(), -1.0);
  std::vector<int> ids;
  for (int n = 0; n < g.num_nodes(); ++n)
    if (inside[n]) ids.push_back(n);
#pragma omp parallel for schedule(dynamic, 256)
  for (int m = 0; m < static_cast<int>(ids.size()); ++m) {
    const int n = ids[m];
    const int i = n % g.nx, j = (n / g.nx) % g.ny, k = n / (g.nx * g.ny);
    dist[n] = side_query.closest_point(g.world(i, j, k)).distance;
  }

  Core core{g, std::vector<std::uint8_t>(g.num_cells(), 0), std::vector<std::uint8_t>(g.num_cells(), 0),
            std::vector<double>(g.num_cells(), -1.0)};
  for (int k = 0; k < g.cz(); ++k)
    for (int j = 0; j < g.cy(); ++j)
      for (int i = 0; i < g.cx(); ++i) {
        bool all_in = true;
        double dmin = std::numeric_limits<double>::infinity();
        for (const auto& c : kHexCorners) {
          const int n = g.node(i + (c[0] > 0), j + (c[1] > 0), k + (c[2] > 0));
          all_in = all_in && inside[n];
          dmin = std::min(dmin, dist[n]);
        }
        const int id = g.cell(i, j, k);
        core.allowed[id] = all_in;
        core.score[id] = all_in ? dmin : -1.0;
        core.in[id] = all_in && dmin >= core_offset * h;
      }
  b.components_dropped = core.keep_largest_component() - 1;
  b.cavities_filled = core.fill_cavities();
  b.manifold_changes = core.make_manifold();
  if (b.manifold_changes > 0) b.components_dropped += core.keep_largest_component() - 1;
  require<TopologyError>(std::any_of(core.in.begin(), core.in.end(), [](auto v) { return v != 0; }),
                         "mesh_limb: no grid cell of size {:.1f} mm fits inside the skin; the limb is "
                         "too thin for this size: ask for more nodes (--target-nodes)", h * 1e3);
  return core;
}

/// A face of the core's boundary, with its outward normal: the base of one pillow hexahedron.
struct PillowQuad {
  std::array<int, 4> nodes;
  Vec3 normal;
};

/// The pillow layer: every core boundary node copied onto the skin (or the rim, on the cut plane)
/// after the core's staircase is rounded, and one hexahedron per boundary quad.
void extrude_pillow(Build& b, const std::vector<PillowQuad>& pillow, const SkinParts& parts,
                    const SurfaceQuery& side_query, int presmooth_iterations) {
  // Extrude every pillow quad to the skin.
  std::vector<int> copy(b.mesh.num_nodes(), -1);
  std::vector<Vec3> normal_sum(b.mesh.num_nodes(), Vec3::Zero());
  for (const auto& q : pillow)
    for (int n : q.nodes) normal_sum[n] += q.normal;
  const int num_core_nodes = b.mesh.num_nodes();
  round_staircase(b, pillow_edges(pillow), normal_sum, presmooth_iterations);
  for (int n = 0; n < num_core_nodes; ++n) {
    if (normal_sum[n].squaredNorm() == 0.0) continue;
    copy[n] = b.mesh.num_nodes();
    const bool rim = b.kind[n] == kTopPlane;
    Vec3 p;
    if (rim) {
      p = closest_on_segments(parts.rim, b.mesh.nodes[n]);
    } else {
      const Vec3 dir = normal_sum[n].normalized();
      p = side_query.closest_point(b.mesh.nodes[n]).point; (void)dir;
    }
    b.mesh.nodes.push_back(p);
    b.kind.push_back(rim ? kRimNode : kSkinNode);
    b.copy_of.push_back(n);
  }
  for (const auto& q : pillow) {
    Hex hex;
    for (int m = 0; m < 4; ++m) {
      hex[m] = q.nodes[m];
      hex[4 + m] = copy[q.nodes[m]];
    }
    b.mesh.hexahedra.push_back(hex);
  }
  b.pillow_hexahedra = static_cast<int>(pillow.size());
}

}  // namespace

Build build_topology(const HexMesherInput& in, const SkinParts& parts, const SurfaceQuery& side_query,
                     double h, double core_offset, int presmooth_iterations) {
  Build b;
  b.grid = make_grid(in.skin, in.frame, in.cut_height_m, h);
  const Grid& g = b.grid;
  const auto inside = classify_inside(g, in.skin);

  Core core = core_cells(b, inside, side_query, h, core_offset);

  // Core nodes and hexahedra.
  std::vector<int> node_id(g.num_nodes(), -1);
  auto core_node = [&](int i, int j, int k) {
    const int n = g.node(i, j, k);
    if (node_id[n] < 0) {
      node_id[n] = b.mesh.num_nodes();
      b.mesh.nodes.push_back(g.world(i, j, k));
      b.kind.push_back(k == g.nz - 1 ? kTopPlane : kInterior);
      b.copy_of.push_back(-1);
    }
    return node_id[n];
  };
  std::vector<PillowQuad> pillow;
  for (int k = 0; k < g.cz(); ++k)
    for (int j = 0; j < g.cy(); ++j)
      for (int i = 0; i < g.cx(); ++i) {
        if (!core.at(i, j, k)) continue;
        Hex hex;
        for (int c = 0; c < 8; ++c)
          hex[c] = core_node(i + (kHexCorners[c][0] > 0), j + (kHexCorners[c][1] > 0), k + (kHexCorners[c][2] > 0));
        b.mesh.hexahedra.push_back(hex);
        for (int f = 0; f < 6; ++f) {
          const int a = i + kFaceDir[f][0], bb = j + kFaceDir[f][1], e = k + kFaceDir[f][2];
          if (core.at(a, bb, e)) continue;
          if (f == 1 && k == g.cz() - 1) continue;  // on the cut plane: stays planar
          PillowQuad q;
          for (int m = 0; m < 4; ++m) q.nodes[m] = hex[kHexFaces[f][m]];
          q.normal = g.R * Vec3(kFaceDir[f][0], kFaceDir[f][1], kFaceDir[f][2]);
          pillow.push_back(q);
        }
      }
  b.core_hexahedra = b.mesh.num_hexahedra();

  extrude_pillow(b, pillow, parts, side_query, presmooth_iterations);
  b.mesh.node_tags.assign(b.mesh.nodes.size(), kNodeNone);
  return b;
}

}  // namespace socketsmith::volume::hex_mesher_detail
