#include "socketsmith/tissue/pressure_load.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "socketsmith/core/errors.h"
#include "socketsmith/volume/hex_mesh.h"

namespace socketsmith::tissue {

VectorXd pressure_forces(const volume::SkinSurface& skin, const std::vector<double>& pressure_pa, int num_nodes) {
  require(pressure_pa.size() == skin.nodes.size(), "pressure_forces: {} pressures for {} skin nodes",
          pressure_pa.size(), skin.nodes.size());
  VectorXd f = VectorXd::Zero(3 * static_cast<Eigen::Index>(num_nodes));
  for (size_t i = 0; i < skin.nodes.size(); ++i) {
    require(std::isfinite(pressure_pa[i]), "pressure_forces: pressure at skin node {} is not finite", i);
    f.segment<3>(3 * skin.nodes[i]) -= pressure_pa[i] * skin.area_m2[i] * skin.normal[i];
  }
  return f;
}

namespace {

Eigen::Matrix3d cross_matrix(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

/// Vector area a_q = ½ (c − a) × (d − b) of a quad at x.
Eigen::Vector3d quad_area_vector(const std::array<int, 4>& q, const VectorXd& x) {
  const auto p = [&](int k) { return Eigen::Vector3d(x.segment<3>(3 * q[k])); };
  return 0.5 * (p(2) - p(0)).cross(p(3) - p(1));
}

/// Adds the 3×3 block @p b at (row node, column node) of a matrix with the model's pattern.
void add_block(SparseMatrix& J, int row_node, int col_node, const Eigen::Matrix3d& b) {
  for (int c = 0; c < 3; ++c) {
    const int col = 3 * col_node + c;
    const int* inner = J.innerIndexPtr();
    const int begin = J.outerIndexPtr()[col], end = J.outerIndexPtr()[col + 1];
    const int* it = std::lower_bound(inner + begin, inner + end, 3 * row_node);
    require<Error>(it + 2 < inner + end && *it == 3 * row_node,
                   "FollowerPressure: nodes {} and {} share a skin quad but not an element of the pattern", row_node,
                   col_node);
    double* v = J.valuePtr() + (it - inner);
    for (int r = 0; r < 3; ++r) v[r] += b(r, c);
  }
}

}  // namespace

void skin_areas_and_normals(const volume::SkinSurface& skin, const VectorXd& x, std::vector<double>& area_m2,
                            std::vector<Eigen::Vector3d>& normal) {
  const size_t n = skin.nodes.size();
  area_m2.assign(n, 0.0);
  normal.assign(n, Eigen::Vector3d::Zero());
  std::vector<int> local(static_cast<size_t>(x.size() / 3), -1);
  for (size_t i = 0; i < n; ++i) local.at(static_cast<size_t>(skin.nodes[i])) = static_cast<int>(i);
  for (const auto& q : skin.quads) {
    const Eigen::Vector3d a = quad_area_vector(q, x);
    for (int nd : q) {
      const int l = local[static_cast<size_t>(nd)];
      area_m2[l] += 0.25 * a.norm();
      normal[l] += a;
    }
  }
  for (auto& v : normal)
    if (v.squaredNorm() > 0) v.normalize();
}

FollowerPressure::FollowerPressure(const volume::SkinSurface& skin, std::vector<double> pressure_pa, int num_nodes)
    : skin_(skin), pressure_pa_(std::move(pressure_pa)), num_nodes_(num_nodes) {
  require(pressure_pa_.size() == skin.nodes.size(), "FollowerPressure: {} pressures for {} skin nodes",
          pressure_pa_.size(), skin.nodes.size());
  for (size_t i = 0; i < pressure_pa_.size(); ++i)
    require(std::isfinite(pressure_pa_[i]), "FollowerPressure: pressure at skin node {} is not finite", i);
  std::vector<int> local(static_cast<size_t>(num_nodes), -1);
  for (size_t i = 0; i < skin.nodes.size(); ++i) local.at(static_cast<size_t>(skin.nodes[i])) = static_cast<int>(i);
  quads_of_.resize(skin.nodes.size());
  for (size_t q = 0; q < skin.quads.size(); ++q)
    for (int nd : skin.quads[q]) quads_of_[static_cast<size_t>(local.at(static_cast<size_t>(nd)))].push_back(static_cast<int>(q));
}

VectorXd FollowerPressure::forces(const VectorXd& x) const {
  std::vector<double> area;
  std::vector<Eigen::Vector3d> normal;
  skin_areas_and_normals(skin_, x, area, normal);
  VectorXd f = VectorXd::Zero(3 * static_cast<Eigen::Index>(num_nodes_));
  for (size_t i = 0; i < skin_.nodes.size(); ++i) f.segment<3>(3 * skin_.nodes[i]) = -pressure_pa_[i] * area[i] * normal[i];
  return f;
}

void FollowerPressure::add_jacobian(const VectorXd& x, double scale, SparseMatrix& J) const {
  // f_k = −p_k A_k n_k, n_k = s_k/|s_k|, s_k = Σ_q a_q, A_k = Σ_q ¼|a_q|:
  //   ∂f_k/∂x_j = −p_k Σ_{q ∋ k, j} (¼ n_k â_qᵀ + A_k/|s_k| (I − n_k n_kᵀ)) ∂a_q/∂x_j,
  // with â_q = a_q/|a_q| and, for the quad (a, b, c, d), u = c − a, v = d − b:
  //   ∂a_q/∂a = ½[v]×, ∂a_q/∂c = −½[v]×, ∂a_q/∂b = −½[u]×, ∂a_q/∂d = ½[u]×.
  std::vector<Eigen::Vector3d> a(skin_.quads.size());
  for (size_t q = 0; q < skin_.quads.size(); ++q) a[q] = quad_area_vector(skin_.quads[q], x);
  for (size_t k = 0; k < skin_.nodes.size(); ++k) {
    if (pressure_pa_[k] == 0.0) continue;
    Eigen::Vector3d s = Eigen::Vector3d::Zero();
    double area = 0.0;
    for (int q : quads_of_[k]) {
      s += a[static_cast<size_t>(q)];
      area += 0.25 * a[static_cast<size_t>(q)].norm();
    }
    const double sn = s.norm();
    if (sn == 0.0) continue;
    const Eigen::Vector3d n = s / sn;
    const Eigen::Matrix3d tangential = (area / sn) * (Eigen::Matrix3d::Identity() - n * n.transpose());
    for (int q : quads_of_[k]) {
      const auto& quad = skin_.quads[static_cast<size_t>(q)];
      const Eigen::Vector3d& aq = a[static_cast<size_t>(q)];
      const double an = aq.norm();
      if (an == 0.0) continue;
      const Eigen::Matrix3d M = -scale * pressure_pa_[k] * (0.25 * n * (aq / an).transpose() + tangential);
      const auto p = [&](int i) { return Eigen::Vector3d(x.segment<3>(3 * quad[static_cast<size_t>(i)])); };
      const Eigen::Matrix3d U = 0.5 * cross_matrix(p(2) - p(0)), V = 0.5 * cross_matrix(p(3) - p(1));
      const int row = skin_.nodes[k];
      add_block(J, row, quad[0], M * V);
      add_block(J, row, quad[2], -M * V);
      add_block(J, row, quad[1], -M * U);
      add_block(J, row, quad[3], M * U);
    }
  }
}

PressureLoadResult solve_uniform_pressure(const volume::HexMesh& mesh, double pressure_pa,
                                          const TissueMaterial& material, const MassSpringOptions& options,
                                          const StaticSolverOptions& solver_options) {
  require(std::isfinite(pressure_pa), "uniform pressure is not finite");
  const auto t0 = std::chrono::steady_clock::now();
  PressureLoadResult res;
  const MassSpringModel model(mesh, material, options);
  const DofMap dofs = fixed_node_dofs(mesh, "uniform pressure solve");
  StaticSolver solver(model, dofs, solver_options);
  const auto skin = volume::extract_skin_surface(mesh);
  const VectorXd f = pressure_forces(skin, std::vector<double>(skin.nodes.size(), pressure_pa), mesh.num_nodes());
  for (Eigen::Index i = 0; i < f.size() / 3; ++i) res.applied_force_sum_n += f.segment<3>(3 * i).norm();
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < f.size() / 3; ++i) total += f.segment<3>(3 * i);
  res.total_force_n = total.norm();
  const auto t1 = std::chrono::steady_clock::now();
  res.positions = model.rest_positions();
  res.solve = solver.solve(f, res.positions);
  const auto t2 = std::chrono::steady_clock::now();
  res.seconds_setup = std::chrono::duration<double>(t1 - t0).count();
  res.seconds_solve = std::chrono::duration<double>(t2 - t1).count();
  require<SolverError>(res.solve.converged, "static solve under {:.1f} kPa did not converge: {}", pressure_pa / 1e3,
                       res.solve.message);
  const VectorXd u = res.positions - model.rest_positions();
  for (Eigen::Index i = 0; i < u.size() / 3; ++i) res.max_displacement_m = std::max(res.max_displacement_m, u.segment<3>(3 * i).norm());
  for (int n : skin.nodes) res.mean_skin_displacement_m += u.segment<3>(3 * n).norm();
  if (!skin.nodes.empty()) res.mean_skin_displacement_m /= static_cast<double>(skin.nodes.size());
  volume::HexMesh deformed = mesh;
  for (int n = 0; n < mesh.num_nodes(); ++n) deformed.nodes[n] = res.positions.segment<3>(3 * n);
  res.volume_change = volume::total_volume(deformed) / volume::total_volume(mesh) - 1.0;
  return res;
}

}  // namespace socketsmith::tissue
