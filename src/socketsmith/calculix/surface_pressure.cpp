#include "socketsmith/calculix/surface_pressure.h"

#include <algorithm>

#include <Eigen/Dense>

#include "socketsmith/core/errors.h"
#include "socketsmith/volume/hex_element.h"

namespace socketsmith::calculix {

std::vector<Vec3> deformed_surface_normals(const volume::HexMesh& mesh, const std::vector<Vec3>& positions,
                                           const std::vector<HexFace>& faces, const std::vector<int>& nodes,
                                           std::vector<double>* areas) {
  const int nn = mesh.num_nodes();
  require(static_cast<int>(positions.size()) == nn, "deformed_surface_normals: {} positions for {} nodes",
          positions.size(), nn);
  std::vector<Vec3> sum(nn, Vec3::Zero());
  std::vector<double> area_sum(areas ? nn : 0, 0.0);
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
    if (areas)
      for (int v : q) area_sum[v] += 0.25 * area.norm();
  }
  std::vector<Vec3> out;
  out.reserve(nodes.size());
  for (int v : nodes) {
    require(v >= 0 && v < nn, "deformed_surface_normals: node {} is out of range ({} nodes)", v, nn);
    const double len = sum[v].norm();
    out.push_back(len > 0 ? Vec3(sum[v] / len) : Vec3::Zero());
  }
  if (areas) {
    areas->clear();
    for (int v : nodes) areas->push_back(area_sum[v]);
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

std::vector<double> nodal_force_pressure(const volume::HexMesh& mesh, const std::vector<Vec3>& positions,
                                         const DatBlock& stresses, const std::vector<int>& nodes,
                                         const std::vector<Vec3>& normals, const std::vector<double>& areas,
                                         std::vector<Vec3>* forces) {
  const int nn = mesh.num_nodes(), ne = mesh.num_hexahedra();
  require(static_cast<int>(positions.size()) == nn, "nodal_force_pressure: {} positions for {} nodes", positions.size(), nn);
  require(nodes.size() == normals.size() && nodes.size() == areas.size(),
          "nodal_force_pressure: {} nodes, {} normals, {} areas", nodes.size(), normals.size(), areas.size());
  // CalculiX's 2×2×2 points run ξ fastest, then η, then ζ; ours follow kHexCorners (a ring in
  // each ζ layer): CalculiX point k is our point kCcxToOurs[k].
  static constexpr int kCcxToOurs[8] = {0, 1, 3, 2, 4, 5, 7, 6};
  std::vector<std::array<Eigen::Matrix3d, 8>> sigma;
  std::vector<int> points(ne, 0);  // rows per element: 8 (full) or 1 (reduced integration)
  std::vector<int> highest(ne, 0);
  std::vector<int> index(ne, -1);
  for (const auto& r : stresses.rows) {
    require(r.size() == 8, "nodal_force_pressure: a stress row has {} numbers (expected 8)", r.size());
    const int e = static_cast<int>(r[0]) - 1, g = static_cast<int>(r[1]) - 1;
    if (e >= ne) continue;  // not a stump element
    require(e >= 0 && g >= 0 && g < 8, "nodal_force_pressure: stress row for element {}, point {}", r[0], r[1]);
    if (index[e] < 0) {
      index[e] = static_cast<int>(sigma.size());
      sigma.emplace_back();
      sigma.back().fill(Eigen::Matrix3d::Zero());
    }
    Eigen::Matrix3d s;
    s << r[2], r[5], r[6], r[5], r[3], r[7], r[6], r[7], r[4];  // sxx syy szz sxy sxz syz
    sigma[index[e]][kCcxToOurs[g]] = s;
    ++points[e];
    highest[e] = std::max(highest[e], g + 1);
  }
  std::vector<char> wanted(nn, 0);
  for (int v : nodes) {
    require(v >= 0 && v < nn, "nodal_force_pressure: node {} is out of range ({} nodes)", v, nn);
    wanted[v] = 1;
  }
  std::vector<Vec3> force(nn, Vec3::Zero());
  const auto& dN = volume::hex_gauss_shape_derivatives();
  for (int e = 0; e < ne; ++e) {
    const auto& h = mesh.hexahedra[e];
    if (!std::any_of(h.begin(), h.end(), [&](int v) { return wanted[v] != 0; })) continue;
    require(index[e] >= 0 && (points[e] == 8 || points[e] == 1) && highest[e] == points[e],
            "nodal_force_pressure: element {} (at the surface) has {} stress rows (expected 8, or 1 for reduced "
            "integration); the deck must print them (*EL PRINT)",
            e + 1, points[e]);
    // f_a += w det J σ J⁻ᵀ ∂N_a/∂ξ at each point: the 2×2×2 rule (unit weights), or one point at the
    // centre with weight 8 for reduced integration.
    const auto x = volume::gather(positions, h);
    const auto add_point = [&](const std::array<Vec3, 8>& d, double weight, const Eigen::Matrix3d& s) {
      Eigen::Matrix3d J = Eigen::Matrix3d::Zero();  // ∂x/∂ξ
      for (int a = 0; a < 8; ++a) J += x[a] * d[a].transpose();
      const Eigen::Matrix3d Jit = J.inverse().transpose();
      const double w = weight * J.determinant();
      for (int a = 0; a < 8; ++a) force[h[a]] += w * (s * (Jit * d[a]));
    };
    if (points[e] == 8) {
      for (int g = 0; g < 8; ++g) add_point(dN[g], 1.0, sigma[index[e]][g]);
    } else {
      std::array<Vec3, 8> d0;
      for (int a = 0; a < 8; ++a)
        d0[a] = 0.125 * Vec3(volume::kHexCorners[a][0], volume::kHexCorners[a][1], volume::kHexCorners[a][2]);
      add_point(d0, 8.0, sigma[index[e]][0]);
    }
  }
  std::vector<double> p(nodes.size(), 0.0);
  for (size_t k = 0; k < nodes.size(); ++k)
    if (areas[k] > 0) p[k] = -normals[k].dot(force[nodes[k]]) / areas[k];
  if (forces) {
    forces->resize(nodes.size());
    for (size_t k = 0; k < nodes.size(); ++k) (*forces)[k] = force[nodes[k]];
  }
  return p;
}

}  // namespace socketsmith::calculix
