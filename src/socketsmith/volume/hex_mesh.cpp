#include "socketsmith/volume/hex_mesh.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "socketsmith/core/errors.h"
#include "socketsmith/volume/hex_element.h"

namespace socketsmith::volume {

int HexMesh::count_tag(NodeTag tag) const {
  return static_cast<int>(std::count_if(node_tags.begin(), node_tags.end(),
                                        [tag](std::uint8_t t) { return (t & tag) != 0; }));
}

std::vector<BoundaryQuad> boundary_quads(const HexMesh& mesh) {
  // Key a face by its sorted node ids; a face seen once is on the boundary.
  struct Entry {
    int count = 0;
    BoundaryQuad quad{};
  };
  auto key_of = [](std::array<int, 4> q) {
    std::sort(q.begin(), q.end());
    return q;
  };
  struct KeyHash {
    size_t operator()(const std::array<int, 4>& k) const {
      size_t h = 1469598103934665603ull;
      for (int v : k) h = (h ^ static_cast<size_t>(v)) * 1099511628211ull;
      return h;
    }
  };
  std::unordered_map<std::array<int, 4>, Entry, KeyHash> faces;
  faces.reserve(mesh.hexahedra.size() * 6);
  for (int e = 0; e < mesh.num_hexahedra(); ++e) {
    const Hex& h = mesh.hexahedra[e];
    for (int f = 0; f < 6; ++f) {
      BoundaryQuad q{{h[kHexFaces[f][0]], h[kHexFaces[f][1]], h[kHexFaces[f][2]], h[kHexFaces[f][3]]}, e, f};
      Entry& entry = faces[key_of(q.nodes)];
      if (entry.count++ == 0) entry.quad = q;
    }
  }
  std::vector<BoundaryQuad> out;
  for (const auto& [key, entry] : faces)
    if (entry.count == 1) out.push_back(entry.quad);
  // Deterministic order (hash-map iteration order is not).
  std::sort(out.begin(), out.end(), [](const BoundaryQuad& a, const BoundaryQuad& b) {
    return a.hexahedron != b.hexahedron ? a.hexahedron < b.hexahedron : a.local_face < b.local_face;
  });
  return out;
}

void tag_boundary_nodes(HexMesh& mesh) {
  mesh.node_tags.resize(mesh.nodes.size(), kNodeNone);
  for (auto& t : mesh.node_tags) t &= static_cast<std::uint8_t>(~kNodeSurface);
  for (const auto& q : boundary_quads(mesh))
    for (int n : q.nodes) mesh.node_tags[n] |= kNodeSurface;
}

geometry::TriMesh boundary_surface(const HexMesh& mesh) {
  geometry::TriMesh out;
  out.vertices = mesh.nodes;
  for (const auto& q : boundary_quads(mesh)) {
    out.triangles.push_back({q.nodes[0], q.nodes[1], q.nodes[2]});
    out.triangles.push_back({q.nodes[0], q.nodes[2], q.nodes[3]});
  }
  return out;
}

double total_volume(const HexMesh& mesh) {
  double v = 0.0;
  for (const Hex& h : mesh.hexahedra) v += hex_volume(gather(mesh.nodes, h));
  return v;
}

HexQuality hex_quality(const HexMesh& mesh) {
  HexQuality q;
  if (mesh.hexahedra.empty()) return q;
  q.min_scaled_jacobian = 1.0;
  double sum = 0.0;
  for (const Hex& h : mesh.hexahedra) {
    const HexNodes x = gather(mesh.nodes, h);
    const auto sj = corner_scaled_jacobians(x);
    const double m = *std::min_element(sj.begin(), sj.end());
    q.min_scaled_jacobian = std::min(q.min_scaled_jacobian, m);
    sum += m;
    if (min_corner_jacobian(x) <= 0.0) ++q.inverted;
    double lmin = std::numeric_limits<double>::infinity(), lmax = 0.0;
    for (const auto& e : kHexEdges) {
      const double l = (x[e[0]] - x[e[1]]).norm();
      lmin = std::min(lmin, l);
      lmax = std::max(lmax, l);
    }
    q.max_aspect_ratio = std::max(q.max_aspect_ratio, lmin > 0 ? lmax / lmin : std::numeric_limits<double>::infinity());
  }
  q.mean_scaled_jacobian = sum / static_cast<double>(mesh.hexahedra.size());
  return q;
}

void validate(const HexMesh& mesh) {
  require(!mesh.hexahedra.empty(), "HexMesh: no hexahedra (expected a non-empty volume mesh)");
  require(mesh.node_tags.size() == mesh.nodes.size(),
          "HexMesh: node_tags has {} entries but there are {} nodes", mesh.node_tags.size(), mesh.nodes.size());
  for (int i = 0; i < mesh.num_nodes(); ++i)
    require(mesh.nodes[i].allFinite(), "HexMesh: node {} has a non-finite coordinate ({}, {}, {})", i,
            mesh.nodes[i].x(), mesh.nodes[i].y(), mesh.nodes[i].z());
  for (int e = 0; e < mesh.num_hexahedra(); ++e) {
    for (int n : mesh.hexahedra[e])
      require(n >= 0 && n < mesh.num_nodes(), "HexMesh: hexahedron {} references node {} (valid: 0..{})", e, n,
              mesh.num_nodes() - 1);
    const double j = min_corner_jacobian(gather(mesh.nodes, mesh.hexahedra[e]));
    if (!(j > 0.0))
      fail<TopologyError>(
          "HexMesh: hexahedron {} is inverted or degenerate (corner Jacobian {:.3g} m^3); check the node order "
          "(VTK/C3D8: bottom face counter-clockwise seen from above)",
          e, j);
  }
}

std::vector<std::vector<ElementRun>> colour_element_runs(int num_nodes, const std::vector<Hex>& hexahedra,
                                                         int run_length) {
  require(run_length >= 1, "colour_element_runs: run length {} (expected ≥ 1)", run_length);
  const auto ne = static_cast<int>(hexahedra.size());
  const int runs = (ne + run_length - 1) / run_length;
  // The runs touching every node (CSR, each run listed once per node), then first fit: a run takes
  // the smallest colour none of the runs sharing a node with it and coloured before it has.
  std::vector<int> start(static_cast<size_t>(num_nodes) + 1, 0), last(static_cast<size_t>(num_nodes), -1);
  const auto for_each_node_of_run = [&](int r, const auto& visit) {
    for (int e = r * run_length; e < std::min(ne, (r + 1) * run_length); ++e)
      for (int n : hexahedra[static_cast<size_t>(e)]) {
        require(n >= 0 && n < num_nodes, "colour_element_runs: element {} has node {} (expected 0..{})", e, n,
                num_nodes - 1);
        if (last[static_cast<size_t>(n)] == r) continue;
        last[static_cast<size_t>(n)] = r;
        visit(n);
      }
  };
  for (int r = 0; r < runs; ++r) for_each_node_of_run(r, [&](int n) { ++start[static_cast<size_t>(n) + 1]; });
  for (size_t i = 1; i < start.size(); ++i) start[i] += start[i - 1];
  std::vector<int> fill(start.begin(), start.end() - 1), runs_of(static_cast<size_t>(start.back()));
  std::fill(last.begin(), last.end(), -1);
  for (int r = 0; r < runs; ++r)
    for_each_node_of_run(r, [&](int n) { runs_of[static_cast<size_t>(fill[static_cast<size_t>(n)]++)] = r; });
  std::vector<int> colour(static_cast<size_t>(runs), -1);
  std::vector<char> taken;
  std::vector<std::vector<ElementRun>> groups;
  std::fill(last.begin(), last.end(), -1);
  for (int r = 0; r < runs; ++r) {
    taken.assign(groups.size() + 1, 0);
    for_each_node_of_run(r, [&](int n) {
      for (int k = start[static_cast<size_t>(n)]; k < start[static_cast<size_t>(n) + 1]; ++k) {
        const int c = colour[static_cast<size_t>(runs_of[static_cast<size_t>(k)])];
        if (c >= 0) taken[static_cast<size_t>(c)] = 1;
      }
    });
    const auto c = static_cast<size_t>(std::find(taken.begin(), taken.end(), 0) - taken.begin());
    if (c == groups.size()) groups.emplace_back();
    groups[c].push_back({r * run_length, std::min(ne, (r + 1) * run_length)});
    colour[static_cast<size_t>(r)] = static_cast<int>(c);
  }
  return groups;
}

}  // namespace socketsmith::volume
