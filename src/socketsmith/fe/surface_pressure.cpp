#include "socketsmith/fe/surface_pressure.h"

#include <Eigen/Dense>

#include "socketsmith/core/errors.h"

namespace socketsmith::fe {

std::vector<Vec3> deformed_surface_normals(const volume::HexMesh& mesh, const std::vector<Vec3>& positions,
                                           const std::vector<HexFace>& faces, const std::vector<int>& nodes) {
  const int nn = mesh.num_nodes();
  require(static_cast<int>(positions.size()) == nn, "deformed_surface_normals: {} positions for {} nodes",
          positions.size(), nn);
  std::vector<Vec3> sum(nn, Vec3::Zero());
  for (const auto& f : faces) {
    require(f.hexahedron >= 0 && f.hexahedron < mesh.num_hexahedra() && f.local_face >= 0 && f.local_face < 6,
            "deformed_surface_normals: face ({}, {}) is out of range", f.hexahedron, f.local_face);
    const auto& h = mesh.hexahedra[f.hexahedron];
    Vec3 centre = Vec3::Zero();
    for (int v : h) centre += positions[v];
    centre /= 8.0;
    std::array<int, 4> q{};
    Vec3 face_centre = Vec3::Zero();
    for (int k = 0; k < 4; ++k) {
      q[k] = h[volume::kHexFaces[f.local_face][k]];
      face_centre += 0.25 * positions[q[k]];
    }
    // Area vector of a (possibly warped) quad: half the cross product of its diagonals.
    Vec3 area = 0.5 * (positions[q[2]] - positions[q[0]]).cross(positions[q[3]] - positions[q[1]]);
    if (area.dot(face_centre - centre) < 0) area = -area;
    for (int v : q) sum[v] += 0.25 * area;
  }
  std::vector<Vec3> out;
  out.reserve(nodes.size());
  for (int v : nodes) {
    require(v >= 0 && v < nn, "deformed_surface_normals: node {} is out of range ({} nodes)", v, nn);
    const double len = sum[v].norm();
    out.push_back(len > 0 ? Vec3(sum[v] / len) : Vec3::Zero());
  }
  return out;
}

std::vector<double> normal_surface_pressure(const FrdBlock& stress, const std::vector<int>& nodes,
                                            const std::vector<Vec3>& normals, int num_mesh_nodes) {
  require(nodes.size() == normals.size(), "normal_surface_pressure: {} nodes but {} normals", nodes.size(),
          normals.size());
  const auto sxx = stress.dense("SXX", num_mesh_nodes), syy = stress.dense("SYY", num_mesh_nodes),
             szz = stress.dense("SZZ", num_mesh_nodes), sxy = stress.dense("SXY", num_mesh_nodes),
             syz = stress.dense("SYZ", num_mesh_nodes), szx = stress.dense("SZX", num_mesh_nodes);
  std::vector<double> p(nodes.size(), 0.0);
  for (size_t k = 0; k < nodes.size(); ++k) {
    const int v = nodes[k];
    require(v >= 0 && v < num_mesh_nodes, "normal_surface_pressure: node {} is out of range ({} nodes)", v,
            num_mesh_nodes);
    Eigen::Matrix3d s;
    s << sxx[v], sxy[v], szx[v], sxy[v], syy[v], syz[v], szx[v], syz[v], szz[v];
    const Vec3& n = normals[k];
    p[k] = -n.dot(s * n);
  }
  return p;
}

}  // namespace socketsmith::fe
