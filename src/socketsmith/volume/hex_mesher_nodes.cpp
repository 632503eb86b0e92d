// The moves of the hexahedral limb mesh's nodes once its topology is built: smoothing under the
// skin, rim and cut-plane constraints, and conforming to the bones (hex_mesher_detail.h says why
// this is apart from the topology).
#include <algorithm>
#include <cmath>

#include "socketsmith/volume/hex_mesher_detail.h"

namespace socketsmith::volume::hex_mesher_detail {
namespace {

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

}  // namespace

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

namespace {

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

/// The bone each node lies inside (-1: in none), the bones tried in order.
std::vector<int> bone_of_nodes(const HexMesh& mesh, const std::vector<SurfaceQuery>& queries,
                               const std::vector<geometry::Aabb>& boxes) {
  std::vector<int> bone_of(mesh.nodes.size(), -1);
#pragma omp parallel for schedule(dynamic, 256)
  for (int n = 0; n < mesh.num_nodes(); ++n)
    for (size_t b = 0; b < queries.size(); ++b) {
      const Vec3& p = mesh.nodes[n];
      if ((p.array() < boxes[b].min.array()).any() || (p.array() > boxes[b].max.array()).any()) continue;
      if (queries[b].is_inside(p)) {
        bone_of[n] = static_cast<int>(b);
        break;
      }
    }
  return bone_of;
}

/// What still wraps a bone: elements with at least 6 bone nodes and more bone than tissue inside
/// (27-point sample) give the bone their last nodes (close to it, held where they are).
void give_wrapping_elements_to_bone(const HexMesh& mesh, const std::vector<SurfaceQuery>& queries, double h,
                                    std::vector<int>& bone_of) {
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
}

}  // namespace

BoneReport apply_bones(HexMesh& mesh, const std::vector<geometry::TriMesh>& bones, std::vector<std::uint8_t>& kind,
                       const Projector& project, double h, double goal) {
  BoneReport rep;
  if (bones.empty()) return rep;
  std::vector<SurfaceQuery> queries;
  std::vector<geometry::Aabb> boxes;
  for (const auto& bone : bones) {
    queries.emplace_back(bone);
    boxes.push_back(geometry::bounding_box(bone));
  }
  std::vector<int> bone_of = bone_of_nodes(mesh, queries, boxes);
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
  give_wrapping_elements_to_bone(mesh, queries, h, bone_of);
  rep.removed += tag_bone_and_remove(mesh, bone_of);
  return rep;
}

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

}  // namespace socketsmith::volume::hex_mesher_detail
