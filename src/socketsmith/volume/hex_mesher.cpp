#include "socketsmith/volume/hex_mesher.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <map>
#include <numeric>
#include <queue>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/geometry/surface_query.h"
#include "socketsmith/volume/hex_element.h"

namespace socketsmith::volume {
namespace {

using geometry::SurfaceQuery;
using geometry::TriMesh;

/// Structured grid aligned with the limb frame. Local coordinates q = R^T (x − origin).
struct Grid {
  Vec3 origin = Vec3::Zero();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // columns: anterior, axis × anterior, axis
  Vec3 q0 = Vec3::Zero();                            // local coordinates of node (0,0,0)
  double h = 0.0;
  int nx = 0, ny = 0, nz = 0;  // nodes per direction (cells: n − 1)

  int cx() const { return nx - 1; }
  int cy() const { return ny - 1; }
  int cz() const { return nz - 1; }
  int node(int i, int j, int k) const { return (k * ny + j) * nx + i; }
  int cell(int i, int j, int k) const { return (k * cy() + j) * cx() + i; }
  int num_nodes() const { return nx * ny * nz; }
  int num_cells() const { return cx() * cy() * cz(); }
  Vec3 local(int i, int j, int k) const { return q0 + h * Vec3(i, j, k); }
  Vec3 world(int i, int j, int k) const { return origin + R * local(i, j, k); }
  Vec3 to_local(const Vec3& x) const { return R.transpose() * (x - origin); }
};

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

/// The side of the skin (cap triangles removed) and the rim loop segments (cap ∩ side edges).
struct SkinParts {
  TriMesh side;
  std::vector<std::array<Vec3, 2>> rim;
};

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

double min_scaled_jacobian(const std::vector<Vec3>& x, const Hex& hex) {
  const auto sj = corner_scaled_jacobians(gather(x, hex));
  return *std::min_element(sj.begin(), sj.end());
}

/// Everything built on one grid size (used for the node-count search and the final mesh).
struct Build {
  Grid grid;
  HexMesh mesh;
  std::vector<int> copy_of;        // mesh node -> core node it was extruded from (-1 for core)
  std::vector<std::uint8_t> kind;  // 0 interior core, 1 core on top plane, 2 skin copy, 3 rim copy
  int core_hexahedra = 0;
  int pillow_hexahedra = 0;
  int manifold_changes = 0;
  int cavities_filled = 0;
  int components_dropped = 0;
};

constexpr std::uint8_t kInterior = 0, kTopPlane = 1, kSkinNode = 2, kRimNode = 3;

/// Edges of the pillow quads (the core boundary surface), as a neighbour list.
template <class Quads>
std::vector<std::vector<int>> pillow_edges(const Quads& quads) {
  std::vector<std::vector<int>> nb;
  for (const auto& q : quads)
    for (int m = 0; m < 4; ++m) {
      const int a = q.nodes[m], c = q.nodes[(m + 1) % 4];
      if (static_cast<int>(nb.size()) <= std::max(a, c)) nb.resize(std::max(a, c) + 1);
      nb[a].push_back(c);
      nb[c].push_back(a);
    }
  for (auto& v : nb) {
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
  }
  return nb;
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

Build build_topology(const HexMesherInput& in, const SkinParts& parts, const SurfaceQuery& side_query,
                     double h, double core_offset, int presmooth_iterations) {
  Build b;
  b.grid = make_grid(in.skin, in.frame, in.cut_height_m, h);
  const Grid& g = b.grid;
  const auto inside = classify_inside(g, in.skin);

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
  struct PillowQuad {
    std::array<int, 4> nodes;
    Vec3 normal;
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
  b.mesh.node_tags.assign(b.mesh.nodes.size(), kNodeNone);
  return b;
}

/// Node → incident elements and node → edge neighbours.
struct Adjacency {
  std::vector<std::vector<int>> elements;
  std::vector<std::vector<int>> neighbours;
};

Adjacency adjacency(const HexMesh& mesh) {
  Adjacency a;
  a.elements.resize(mesh.nodes.size());
  a.neighbours.resize(mesh.nodes.size());
  for (int e = 0; e < mesh.num_hexahedra(); ++e) {
    for (int n : mesh.hexahedra[e]) a.elements[n].push_back(e);
    for (const auto& ed : kHexEdges) {
      const int p = mesh.hexahedra[e][ed[0]], q = mesh.hexahedra[e][ed[1]];
      a.neighbours[p].push_back(q);
      a.neighbours[q].push_back(p);
    }
  }
  for (auto& v : a.neighbours) {
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
  }
  return a;
}

double local_quality(const HexMesh& mesh, const Adjacency& adj, int n) {
  double q = 1.0;
  for (int e : adj.elements[n]) q = std::min(q, min_scaled_jacobian(mesh.nodes, mesh.hexahedra[e]));
  return q;
}

/// Moves node @p n to @p target if that improves its worst incident element, or keeps every
/// incident element above @p goal when they all were. Returns true when moved.
bool try_move(HexMesh& mesh, const Adjacency& adj, int n, const Vec3& target, double goal) {
  const Vec3 old = mesh.nodes[n];
  const double before = local_quality(mesh, adj, n);
  mesh.nodes[n] = target;
  const double after = local_quality(mesh, adj, n);
  if (after > before || (before >= goal && after >= goal)) return true;
  mesh.nodes[n] = old;
  return false;
}

/// Projection of a node of each kind onto its constraint.
struct Projector {
  const SurfaceQuery& side;
  const SkinParts& parts;
  const Grid& grid;
  double cut_h_local;  // local z of the cut plane

  Vec3 operator()(std::uint8_t kind, const Vec3& p) const {
    switch (kind) {
      case kSkinNode:
        return side.closest_point(p).point;
      case kRimNode:
        return closest_on_segments(parts.rim, p);
      case kTopPlane: {
        Vec3 q = grid.to_local(p);
        q.z() = cut_h_local;
        return grid.origin + grid.R * q;
      }
      default:
        return p;
    }
  }
};

void smooth(Build& b, const Projector& project, int iterations, double goal) {
  HexMesh& mesh = b.mesh;
  const Adjacency adj = adjacency(mesh);
  // Surface neighbours: surface nodes of the same kind family connected by an edge.
  auto same_family = [&](int a, int c) {
    const auto ka = b.kind[a], kc = b.kind[c];
    if (ka == kRimNode) return kc == kRimNode;
    if (ka == kSkinNode) return kc == kSkinNode || kc == kRimNode;
    if (ka == kTopPlane) return kc == kTopPlane || kc == kRimNode;
    return true;
  };
  for (int it = 0; it < iterations; ++it) {
    for (int n = 0; n < mesh.num_nodes(); ++n) {
      Vec3 avg = Vec3::Zero();
      int cnt = 0;
      for (int m : adj.neighbours[n])
        if (same_family(n, m)) {
          avg += mesh.nodes[m];
          ++cnt;
        }
      if (cnt == 0) continue;
      avg /= cnt;
      const Vec3 target = project(b.kind[n], mesh.nodes[n] + 0.6 * (avg - mesh.nodes[n]));
      try_move(mesh, adj, n, target, goal);
    }
  }
  // Quality pass: nodes of poor elements try shorter relaxations and small pattern-search steps.
  const double h = b.grid.h;
  for (int pass = 0; pass < 6; ++pass) {
    int improved = 0;
    for (int e = 0; e < mesh.num_hexahedra(); ++e) {
      if (min_scaled_jacobian(mesh.nodes, mesh.hexahedra[e]) >= goal) continue;
      for (int n : mesh.hexahedra[e]) {
        const double before = local_quality(mesh, adj, n);
        Vec3 best = mesh.nodes[n];
        double best_q = before;
        for (double step : {0.25 * h, 0.1 * h, 0.04 * h})
          for (int d = 0; d < 6; ++d) {
            Vec3 t = mesh.nodes[n];
            t[d / 2] += (d % 2 ? -step : step);
            t = project(b.kind[n], t);
            const Vec3 old = mesh.nodes[n];
            mesh.nodes[n] = t;
            const double q = local_quality(mesh, adj, n);
            mesh.nodes[n] = old;
            if (q > best_q + 1e-6) {
              best_q = q;
              best = t;
            }
          }
        if (best_q > before) {
          mesh.nodes[n] = best;
          ++improved;
        }
      }
    }
    if (improved == 0) break;
  }
}

/// Tags nodes inside bones, snaps the bone-interface nodes onto the bone surfaces where quality
/// allows, and removes elements whose 8 nodes are all in bone.
/// Fraction of a hexahedron inside a closed surface, from 27 interior sample points.
double bone_fraction(const HexNodes& x, const SurfaceQuery& bone) {
  int inside = 0;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      for (int c = 0; c < 3; ++c) {
        const double xi = (a - 1) * 2.0 / 3.0, eta = (b - 1) * 2.0 / 3.0, zeta = (c - 1) * 2.0 / 3.0;
        Vec3 p = Vec3::Zero();
        for (int m = 0; m < 8; ++m)
          p += x[m] * (1 + xi * kHexCorners[m][0]) * (1 + eta * kHexCorners[m][1]) * (1 + zeta * kHexCorners[m][2]) / 8.0;
        inside += bone.is_inside(p) ? 1 : 0;
      }
  return inside / 27.0;
}

/// Tags the nodes of bones fixed + bone and removes the elements whose 8 nodes are all bone.
/// Returns the number of elements removed.
int tag_bone_and_remove(HexMesh& mesh, const std::vector<int>& bone_of) {
  for (int n = 0; n < mesh.num_nodes(); ++n)
    if (bone_of[n] >= 0) mesh.node_tags[n] |= kNodeBone | kNodeFixed;
  const auto before = mesh.hexahedra.size();
  std::erase_if(mesh.hexahedra, [&](const Hex& hx) {
    return std::all_of(hx.begin(), hx.end(), [&](int n) { return bone_of[n] >= 0; });
  });
  return static_cast<int>(before - mesh.hexahedra.size());
}

/// Number of nodes of @p hx in a bone; @p bone receives the last such bone's index.
int count_bone_nodes(const Hex& hx, const std::vector<int>& bone_of, int& bone) {
  int count = 0;
  for (int n : hx)
    if (bone_of[n] >= 0) {
      ++count;
      bone = bone_of[n];
    }
  return count;
}

struct BoneReport {
  int removed = 0;   ///< elements wholly in bone, removed
  int snapped = 0;   ///< nodes moved onto a bone surface
  int held = 0;      ///< nodes that could not move without spoiling an element
};

template <class Project>
BoneReport apply_bones(HexMesh& mesh, const std::vector<geometry::TriMesh>& bones, std::vector<std::uint8_t>& kind,
                       const Project& project, double h, double goal) {
  BoneReport rep;
  if (bones.empty()) return rep;
  std::vector<SurfaceQuery> queries;
  std::vector<geometry::Aabb> boxes;
  for (const auto& bone : bones) {
    queries.emplace_back(bone);
    boxes.push_back(geometry::bounding_box(bone));
  }
  std::vector<int> bone_of(mesh.nodes.size(), -1);
#pragma omp parallel for schedule(dynamic, 256)
  for (int n = 0; n < mesh.num_nodes(); ++n)
    for (size_t b = 0; b < bones.size(); ++b) {
      const Vec3& p = mesh.nodes[n];
      if ((p.array() < boxes[b].min.array()).any() || (p.array() > boxes[b].max.array()).any()) continue;
      if (queries[b].is_inside(p)) {
        bone_of[n] = static_cast<int>(b);
        break;
      }
    }
  // Conform to the bone surfaces: along every edge that crosses a bone surface, the end node
  // nearer to the surface is moved onto it (at most half an edge, so elements stay well shaped;
  // a move that would spoil an element below the quality goal is not made). Snapped nodes
  // belong to the bone.
  const Adjacency adj = adjacency(mesh);
  std::vector<double> dist(mesh.nodes.size(), -1.0);
  std::vector<int> near_bone(mesh.nodes.size(), -1);
  auto distance_to = [&](int n, int bone) {
    if (dist[n] < 0.0) dist[n] = queries[bone].closest_point(mesh.nodes[n]).distance;
    return dist[n];
  };
  for (int n = 0; n < mesh.num_nodes(); ++n) {
    if (bone_of[n] < 0) continue;
    for (int m : adj.neighbours[n]) {
      if (bone_of[m] >= 0) continue;
      const int pick = distance_to(n, bone_of[n]) <= distance_to(m, bone_of[n]) ? n : m;
      near_bone[pick] = bone_of[n];
    }
  }
  for (int n = 0; n < mesh.num_nodes(); ++n) {
    if (near_bone[n] < 0 || (kind[n] != kInterior && kind[n] != kTopPlane)) continue;  // skin nodes stay
    const Vec3 target = project(kind[n], queries[near_bone[n]].closest_point(mesh.nodes[n]).point);
    if (try_move(mesh, adj, n, target, goal)) {
      bone_of[n] = near_bone[n];
      ++rep.snapped;
    } else {
      ++rep.held;
    }
  }
  rep.removed += tag_bone_and_remove(mesh, bone_of);

  // Bone nodes still used by a kept element but strictly inside the bone: onto the surface too.
  const Adjacency adj2 = adjacency(mesh);
  for (int n = 0; n < mesh.num_nodes(); ++n) {
    if (bone_of[n] < 0 || near_bone[n] >= 0 || adj2.elements[n].empty()) continue;
    if (kind[n] != kInterior && kind[n] != kTopPlane) continue;
    const Vec3 target = project(kind[n], queries[bone_of[n]].closest_point(mesh.nodes[n]).point);
    const Vec3 start = mesh.nodes[n];
    for (double f : {1.0, 0.6, 0.3})
      if (try_move(mesh, adj2, n, start + f * (target - start), goal)) break;
  }

  // An element with 6 or 7 nodes on the bone wraps the bone between its chord faces: its free
  // nodes join the bone when they are close to it and can move, and the element is removed.
  for (int round = 0; round < 3; ++round)
    for (const Hex& hx : mesh.hexahedra) {
      int bone = -1;
      const int count = count_bone_nodes(hx, bone_of, bone);
      if (count < 6 || count == 8) continue;
      for (int n : hx) {
        if (bone_of[n] >= 0 || (kind[n] != kInterior && kind[n] != kTopPlane)) continue;
        const auto hit = queries[bone].closest_point(mesh.nodes[n]);
        if (hit.distance > 0.75 * h) continue;
        if (try_move(mesh, adj2, n, project(kind[n], hit.point), goal)) bone_of[n] = bone;
      }
    }
  // What still wraps the bone: elements with at least 6 bone nodes and more bone than tissue
  // inside (27-point sample) give the bone their last nodes (close to it, held where they are).
  for (const Hex& hx : mesh.hexahedra) {
    int bone = -1;
    const int count = count_bone_nodes(hx, bone_of, bone);
    if (count < 6 || count == 8) continue;
    if (bone_fraction(gather(mesh.nodes, hx), queries[bone]) <= 0.5) continue;
    bool close = true;
    for (int n : hx)
      if (bone_of[n] < 0) close = close && queries[bone].closest_point(mesh.nodes[n]).distance <= 0.75 * h;
    if (!close) continue;
    for (int n : hx)
      if (bone_of[n] < 0) bone_of[n] = bone;
  }
  rep.removed += tag_bone_and_remove(mesh, bone_of);
  return rep;
}

/// Drops unused nodes and renumbers (keeps the per-node arrays aligned).
void compact(HexMesh& mesh, std::vector<std::uint8_t>& kind) {
  std::vector<int> map(mesh.nodes.size(), -1);
  int next = 0;
  for (const Hex& hx : mesh.hexahedra)
    for (int n : hx)
      if (map[n] < 0) map[n] = 0;
  std::vector<Vec3> nodes;
  std::vector<std::uint8_t> tags, kinds;
  for (size_t n = 0; n < mesh.nodes.size(); ++n)
    if (map[n] == 0) {
      map[n] = next++;
      nodes.push_back(mesh.nodes[n]);
      tags.push_back(mesh.node_tags[n]);
      kinds.push_back(kind[n]);
    }
  for (Hex& hx : mesh.hexahedra)
    for (int& n : hx) n = map[n];
  mesh.nodes = std::move(nodes);
  mesh.node_tags = std::move(tags);
  kind = std::move(kinds);
}

/// Nodes a final mesh built on this topology will have (bone-interior nodes excluded).
int estimated_nodes(const Build& b, const std::vector<geometry::TriMesh>& bones,
                    const std::vector<SurfaceQuery>& bone_queries) {
  if (bones.empty()) return b.mesh.num_nodes();
  std::vector<std::uint8_t> in_bone(b.mesh.nodes.size(), 0);
  std::vector<geometry::Aabb> boxes;
  for (const auto& q : bone_queries) boxes.push_back(geometry::bounding_box(q.mesh()));
#pragma omp parallel for schedule(dynamic, 256)
  for (int n = 0; n < b.mesh.num_nodes(); ++n)
    for (size_t k = 0; k < bone_queries.size(); ++k) {
      const auto& q = bone_queries[k];
      const auto& box = boxes[k];
      const Vec3& p = b.mesh.nodes[n];
      if ((p.array() < box.min.array()).any() || (p.array() > box.max.array()).any()) continue;
      if (q.is_inside(p)) {
        in_bone[n] = 1;
        break;
      }
    }
  std::vector<std::uint8_t> used(b.mesh.nodes.size(), 0);
  for (const Hex& hx : b.mesh.hexahedra) {
    bool all = true;
    for (int n : hx) all = all && in_bone[n];
    if (!all)
      for (int n : hx) used[n] = 1;
  }
  return static_cast<int>(std::count(used.begin(), used.end(), 1));
}

}  // namespace

HexMesherResult mesh_limb(const HexMesherInput& in, const HexMesherOptions& opt) {
  const auto t0 = std::chrono::steady_clock::now();
  require(opt.cell_size_m > 0.0 || opt.target_nodes >= 100,
          "mesh_limb: target of {} nodes is too small (expected at least 100)", opt.target_nodes);
  require(opt.core_offset >= 0.0 && opt.core_offset <= 2.0, "mesh_limb: core_offset {} outside [0, 2]",
          opt.core_offset);
  require(in.first_cap_triangle >= 0 && in.first_cap_triangle < in.skin.num_triangles(),
          "mesh_limb: the skin has no proximal cap (first_cap_triangle = {}); trim and cap it first",
          in.first_cap_triangle);
  const SkinParts parts = split_skin(in);
  require<TopologyError>(!parts.rim.empty(), "mesh_limb: the skin's cap does not meet its side");
  const SurfaceQuery side_query(parts.side);
  std::vector<SurfaceQuery> bone_queries;
  for (const auto& bone : in.bones) bone_queries.emplace_back(bone);

  HexMesherResult res;
  res.skin_volume_m3 = geometry::signed_volume(in.skin);
  for (const auto& bone : in.bones) res.bone_volume_m3 += geometry::signed_volume(bone);
  const double tissue_estimate = res.skin_volume_m3 - res.bone_volume_m3;
  require(res.skin_volume_m3 > 0.0, "mesh_limb: the skin encloses a volume of {:.3g} m^3 (inside-out?)",
          res.skin_volume_m3);
  // The grid size comes from the tissue's volume: bones that fill the skin would make it 0 or NaN.
  require(res.bone_volume_m3 < 0.9 * res.skin_volume_m3,
          "mesh_limb: the bones ({:.0f} % of the skin's volume) leave no tissue to mesh: bones must lie inside the "
          "skin and fill less than 90 % of it",
          100.0 * res.bone_volume_m3 / res.skin_volume_m3);

  // Grid size: from the target node count, refined by building the topology.
  double h = opt.cell_size_m;
  Build b;
  if (h > 0.0) {
    b = build_topology(in, parts, side_query, h, opt.core_offset, opt.presmooth_iterations);
  } else {
    h = std::cbrt(tissue_estimate / opt.target_nodes);
    for (int it = 0; it < 6; ++it) {
      report_progress(opt.progress, 0.05 + 0.05 * it, "mesh: choosing the grid size");
      b = build_topology(in, parts, side_query, h, opt.core_offset, opt.presmooth_iterations);
      const int n = estimated_nodes(b, in.bones, bone_queries);
      const double ratio = static_cast<double>(n) / opt.target_nodes;
      log::debug("mesh_limb: h = {:.2f} mm -> {} nodes ({:.1f} % of target)", h * 1e3, n, 100 * ratio);
      if (std::abs(ratio - 1.0) < 0.04) break;
      h *= std::cbrt(ratio);
    }
  }
  // Smoothing, bones and the quality check. At the coarsest sizes (a few hundred nodes: a bone's tip
  // a cell or two from the skin) one grid can keep a few inverted elements where one 2 % finer or
  // coarser does not, so a size chosen from target_nodes is retried with the cell nudged by ±2 %,
  // ±4 %, ±6 % before giving up; a cell size the caller set is used as it is.
  const double h_chosen = h;
  constexpr double kRetryScales[] = {1.0, 0.98, 1.02, 0.96, 1.04, 0.94, 1.06};
  const int attempts = opt.cell_size_m > 0.0 ? 1 : static_cast<int>(std::size(kRetryScales));
  BoneReport bone_report;
  for (int attempt = 0; attempt < attempts; ++attempt) {
    if (attempt > 0) {
      log::debug("mesh_limb: {} element(s) inverted at h = {:.2f} mm; retrying at {:.2f} mm", res.quality.inverted,
                 h * 1e3, h_chosen * kRetryScales[attempt] * 1e3);
      h = h_chosen * kRetryScales[attempt];
      b = build_topology(in, parts, side_query, h, opt.core_offset, opt.presmooth_iterations);
    }
    report_progress(opt.progress, 0.45, "mesh: smoothing and optimising");
    const Projector project{side_query, parts, b.grid, in.cut_height_m};
    smooth(b, project, opt.smoothing_iterations, opt.quality_goal);

    report_progress(opt.progress, 0.75, "mesh: bones");
    bone_report = apply_bones(b.mesh, in.bones, b.kind, project, b.grid.h, opt.bone_quality_goal);
    compact(b.mesh, b.kind);
    res.quality = hex_quality(b.mesh);
    if (res.quality.inverted == 0) {
      if (attempt > 0)
        res.notes.push_back(fmt::format("grid cell {:+.0f} % off the size for {} nodes: that size left inverted "
                                        "elements",
                                        100 * (kRetryScales[attempt] - 1.0), opt.target_nodes));
      break;
    }
  }
  res.cell_size_m = h;
  res.core_hexahedra = b.core_hexahedra;
  res.pillow_hexahedra = b.pillow_hexahedra;
  if (b.manifold_changes > 0)
    res.notes.push_back(fmt::format("{} grid cells added or removed to keep the core manifold", b.manifold_changes));
  if (b.components_dropped > 0)
    res.notes.push_back(fmt::format("{} small disconnected core part(s) dropped", b.components_dropped));
  res.removed_bone_hexahedra = bone_report.removed;
  if (!in.bones.empty())
    res.notes.push_back(fmt::format("bones: {} nodes snapped onto bone surfaces, {} held in place (quality), {} "
                                    "elements inside bones removed",
                                    bone_report.snapped, bone_report.held, bone_report.removed));
  for (int n = 0; n < b.mesh.num_nodes(); ++n) {
    if (b.kind[n] == kSkinNode) b.mesh.node_tags[n] |= kNodeSurface;
    if (b.kind[n] == kRimNode) b.mesh.node_tags[n] |= kNodeSurface | kNodeProximal;
    if (b.kind[n] == kTopPlane) b.mesh.node_tags[n] |= kNodeProximal;
    if (opt.fix_proximal && (b.kind[n] == kTopPlane || b.kind[n] == kRimNode)) b.mesh.node_tags[n] |= kNodeFixed;
  }

  // Report.
  require<TopologyError>(res.quality.inverted == 0,
                         "mesh_limb: {} element(s) remain inverted after optimisation (min scaled Jacobian "
                         "{:.3f}); try another stump size (mesh.target_nodes in a case file, --target-nodes on the "
                         "command line) or check the skin for folds",
                         res.quality.inverted, res.quality.min_scaled_jacobian);
  const SurfaceQuery skin_query(in.skin);
  for (int n = 0; n < b.mesh.num_nodes(); ++n)
    if (b.kind[n] == kSkinNode || b.kind[n] == kRimNode)
      res.max_skin_distance_m = std::max(res.max_skin_distance_m, skin_query.closest_point(b.mesh.nodes[n]).distance);
  // Chordal deviation: centres of the skin quads (not on the skin by construction) to the skin.
  {
    const SkinSurface surf = extract_skin_surface(b.mesh);
    for (const auto& q : surf.quads) {
      const Vec3 c = 0.25 * (b.mesh.nodes[q[0]] + b.mesh.nodes[q[1]] + b.mesh.nodes[q[2]] + b.mesh.nodes[q[3]]);
      res.max_face_deviation_m = std::max(res.max_face_deviation_m, skin_query.closest_point(c).distance);
    }
  }
  res.mesh_volume_m3 = total_volume(b.mesh);
  res.tissue_volume_m3 = res.mesh_volume_m3;
  res.mesh = std::move(b.mesh);
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  report_progress(opt.progress, 1.0, "mesh: done");
  return res;
}

geometry::TriMesh SkinSurface::triangles() const {
  geometry::TriMesh m;
  m.vertices = positions;
  std::map<int, int> local;
  for (size_t i = 0; i < nodes.size(); ++i) local[nodes[i]] = static_cast<int>(i);
  for (const auto& q : quads) {
    m.triangles.push_back({local.at(q[0]), local.at(q[1]), local.at(q[2])});
    m.triangles.push_back({local.at(q[0]), local.at(q[2]), local.at(q[3])});
  }
  return m;
}

SkinSurface extract_skin_surface(const HexMesh& mesh) {
  SkinSurface s;
  std::vector<int> local(mesh.nodes.size(), -1);
  for (const auto& bq : boundary_quads(mesh)) {
    bool skin = true;
    for (int n : bq.nodes) skin = skin && mesh.has_tag(n, kNodeSurface);
    if (!skin) continue;
    // A quad on the cut plane has only proximal nodes; skin quads have at least one non-rim node.
    bool all_proximal = true;
    for (int n : bq.nodes) all_proximal = all_proximal && mesh.has_tag(n, kNodeProximal);
    if (all_proximal) continue;
    s.quads.push_back(bq.nodes);
    const Vec3 a = mesh.nodes[bq.nodes[0]], b = mesh.nodes[bq.nodes[1]], c = mesh.nodes[bq.nodes[2]],
               d = mesh.nodes[bq.nodes[3]];
    const Vec3 an = 0.5 * (c - a).cross(d - b);  // area vector of the (possibly warped) quad
    for (int n : bq.nodes) {
      if (local[n] < 0) {
        local[n] = static_cast<int>(s.nodes.size());
        s.nodes.push_back(n);
        s.area_m2.push_back(0.0);
        s.normal.push_back(Vec3::Zero());
        s.positions.push_back(mesh.nodes[n]);
      }
      s.area_m2[local[n]] += 0.25 * an.norm();
      s.normal[local[n]] += an;
    }
  }
  for (auto& n : s.normal)
    if (n.squaredNorm() > 0) n.normalize();
  return s;
}

}  // namespace socketsmith::volume
