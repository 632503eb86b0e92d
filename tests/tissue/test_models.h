#pragma once
// Shared fixtures of the tissue tests: small lattices, random rigid motions, finite differences.
#include <random>

#include <Eigen/Geometry>

#include "socketsmith/tissue/dof_map.h"
#include "socketsmith/tissue/mass_spring_model.h"
#include "socketsmith/volume/box_mesher.h"

namespace socketsmith::tissue::testing {

inline volume::HexMesh small_lattice(int n = 2, double edge = 0.02) {
  volume::BoxMeshOptions o;
  o.size = volume::Vec3::Constant(edge);
  o.divisions = {n, n, n};
  return volume::mesh_box(o);
}

/// A 3×3×3 lattice of the box [0, a]³ whose interior nodes are moved at random (distorted bricks).
inline volume::HexMesh distorted_lattice(double a, unsigned seed) {
  auto mesh = small_lattice(3, a);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.15 * a / 3, 0.15 * a / 3);
  for (auto& p : mesh.nodes) {
    bool interior = true;
    for (int d = 0; d < 3; ++d) interior = interior && p[d] > 1e-9 && p[d] < a - 1e-9;
    if (interior) p += volume::Vec3(u(rng), u(rng), u(rng));
  }
  return mesh;
}

inline MassSpringOptions options_for(TissueModelKind kind, CorrectiveLaw law = CorrectiveLaw::Symmetric) {
  MassSpringOptions o;
  o.kind = kind;
  o.corrective = law == CorrectiveLaw::Symmetric ? CorrectiveSpringConstants::thesis()
                                                 : CorrectiveSpringConstants::recommended();
  return o;
}

/// Rest positions compressed by 15 % in z, sheared a little and randomly perturbed
/// (so corrective springs are active and no spring is axis-aligned).
inline VectorXd deformed(const MassSpringModel& m, unsigned seed, double noise = 0.05) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  VectorXd x = m.rest_positions();
  const double h = std::cbrt(m.total_volume(x) / m.num_elements());
  for (int i = 0; i < m.num_nodes(); ++i) {
    x[3 * i + 2] *= 0.85;
    x[3 * i + 0] += 0.1 * x[3 * i + 2];
    for (int a = 0; a < 3; ++a) x[3 * i + a] += noise * h * g(rng);
  }
  return x;
}

/// The bench's lattice (bench/tissue_bench.cpp): a 50 mm cube of n³ elements, E 50 kPa, base held,
/// 2 kPa down + 0.4 kPa sideways on the top nodes, with the cube-targets constants (corrective
/// springs silent below 1.33 % volume loss, then C = 1e5).
struct BenchLattice {
  explicit BenchLattice(int n) : model(small_lattice(n, 0.05), {50e3, 1060}, cube_targets()) {
    const std::array<int, 3> div = {n, n, n};
    f = VectorXd::Zero(model.num_dofs());
    const double a = 0.05 / n;
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        constraints.fix_nodes({volume::box_node_index(div, i, j, 0)});
        const int top = volume::box_node_index(div, i, j, n);
        f[dof(top, 2)] = -2e3 * a * a;
        f[dof(top, 0)] = 0.4e3 * a * a;
      }
  }
  static MassSpringOptions cube_targets() {
    MassSpringOptions o;
    o.corrective = CorrectiveSpringConstants::cube_targets();
    return o;
  }
  MassSpringModel model;
  DofConstraints constraints;
  VectorXd f;
};

/// Central finite differences of a vector function @p f at @p x: column c is ∂f/∂x_c (step @p eps).
template <class F>
Eigen::MatrixXd fd_jacobian(const F& f, const VectorXd& x, double eps) {
  Eigen::MatrixXd out;
  for (Eigen::Index c = 0; c < x.size(); ++c) {
    VectorXd p = x, q = x;
    p[c] += eps;
    q[c] -= eps;
    const VectorXd col = (f(p) - f(q)) / (2 * eps);
    if (c == 0) out.resize(col.size(), x.size());
    out.col(c) = col;
  }
  return out;
}

inline Eigen::Matrix3d random_rotation(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::Quaterniond q(g(rng), g(rng), g(rng), g(rng));
  return q.normalized().toRotationMatrix();
}

inline VectorXd rigid_motion(const VectorXd& x, const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  VectorXd y(x.size());
  for (Eigen::Index i = 0; i < x.size() / 3; ++i) y.segment<3>(3 * i) = R * x.segment<3>(3 * i) + t;
  return y;
}

}  // namespace socketsmith::tissue::testing
