// Where a static solve stands against the stiffness's stability: the tangent's smallest
// eigenvalue, each element's stable range of compression, and the state described for a failed
// solve's message (StaticSolver's diagnosis, static_solver.h).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/tissue/static_solver.h"
#include "socketsmith/volume/box_mesher.h"
#include "socketsmith/volume/hex_element.h"

namespace socketsmith::tissue {

TangentStability tangent_stability(const MassSpringModel& model, const DofMap& dofs, const VectorXd& x) {
  require(x.size() == model.num_dofs() && x.allFinite(), "tangent_stability: x has {} entries (expected 3N = {})",
          x.size(), model.num_dofs());
  TangentStability out;
  if (dofs.num_reduced() == 0) return out;
  SparseMatrix J, K;
  model.jacobian(x, JacobianKind::Exact, J);
  dofs.reduce_matrix(J, K);
  K *= -1.0;
  K.makeCompressed();
  out.computed = true;
  out.max_diagonal = K.diagonal().maxCoeff();
  Eigen::SparseLU<SparseMatrix> lu;
  lu.compute(K);
  if (lu.info() != Eigen::Success) return out;  // numerically singular: determinant_sign stays 0
  out.determinant_sign = lu.signDeterminant() < 0 ? -1 : 1;
  // Inverse iteration: the eigenvalue of smallest magnitude and its mode.
  const Eigen::Index n = K.rows();
  VectorXd v(n);
  for (Eigen::Index i = 0; i < n; ++i) v[i] = 1.0 + 0.5 * std::sin(0.7 * static_cast<double>(i));
  v.normalize();
  double mu = 0.0;
  for (int it = 0; it < 100; ++it) {
    VectorXd w = lu.solve(v);
    if (!w.allFinite() || w.norm() == 0) break;
    v = w.normalized();
    const VectorXd Kv = K * v;
    mu = v.dot(Kv);
    if ((Kv - mu * v).norm() <= 1e-8 * out.max_diagonal) {
      out.softest_converged = true;
      break;
    }
  }
  out.softest_eigenvalue = mu;
  VectorXd full = VectorXd::Zero(model.num_dofs());
  dofs.add_expanded(v, full);
  double best = -1;
  for (int i = 0; i < model.num_nodes(); ++i) {
    const double a = full.segment<3>(3 * i).norm();
    if (a > best) {
      best = a;
      out.softest_mode_node = i;
    }
  }
  return out;
}

ElementStabilityRange element_stability_range(const MassSpringModel& model) {
  volume::BoxMeshOptions box;
  box.size = volume::Vec3::Constant(0.01);
  box.divisions = {1, 1, 1};
  const MassSpringModel cube(volume::mesh_box(box), model.material(), model.options());
  const VectorXd x0 = cube.rest_positions();
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int i = 0; i < 8; ++i) c += x0.segment<3>(3 * i) / 8.0;
  // Orthonormal basis of the 18 deformation modes (complement of the 6 rigid ones).
  Eigen::MatrixXd rigid = Eigen::MatrixXd::Zero(24, 6);
  for (int i = 0; i < 8; ++i)
    for (int a = 0; a < 3; ++a) {
      rigid(3 * i + a, a) = 1.0;
      rigid.block<3, 1>(3 * i, 3 + a) = Eigen::Vector3d::Unit(a).cross(x0.segment<3>(3 * i) - c);
    }
  const Eigen::MatrixXd q = Eigen::HouseholderQR<Eigen::MatrixXd>(rigid).householderQ();
  const Eigen::MatrixXd basis = q.rightCols(18);
  SparseMatrix J;
  auto smallest = [&](double dv) {
    const double scale = std::cbrt(1.0 + dv);
    VectorXd x = x0;
    for (int i = 0; i < 8; ++i) x.segment<3>(3 * i) = c + scale * (x0.segment<3>(3 * i) - c);
    cube.jacobian(x, JacobianKind::Exact, J);
    const Eigen::MatrixXd k = -(basis.transpose() * Eigen::MatrixXd(J) * basis);
    return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(0.5 * (k + k.transpose()), Eigen::EigenvaluesOnly)
        .eigenvalues()[0];
  };
  auto edge = [&](double direction) {
    // Scan in steps of 0.25 % up to 50 %, then bisect the first sign change.
    double stable = 0.0;
    for (double dv = 0.0025; dv <= 0.5 + 1e-12; dv += 0.0025) {
      if (smallest(direction * dv) > 0) {
        stable = dv;
        continue;
      }
      double lo = stable, hi = dv;
      for (int it = 0; it < 20; ++it) {
        const double mid = 0.5 * (lo + hi);
        (smallest(direction * mid) > 0 ? lo : hi) = mid;
      }
      return direction * lo;
    }
    return direction * 0.5;
  };
  ElementStabilityRange range;
  if (smallest(0.0) <= 0) {
    range.min_volume_change = range.max_volume_change = 0.0;
    return range;
  }
  range.min_volume_change = edge(-1.0);
  range.max_volume_change = edge(1.0);
  return range;
}

int StaticSolver::count_outside_stable_range(const VectorXd& x, ElementStabilityRange& range) const {
  range = element_stability_range(model_);
  const VectorXd v = model_.element_volumes(x), v0 = model_.element_volumes(model_.rest_positions());
  int n = 0;
  for (Eigen::Index e = 0; e < v.size(); ++e) {
    const double dv = (v[e] - v0[e]) / v0[e];
    if (dv < range.min_volume_change || dv > range.max_volume_change) ++n;
  }
  return n;
}

/// Worst element (smallest corner scaled Jacobian) and the range of volume changes at x.
void StaticSolver::describe_state(const VectorXd& x, StaticResult& res) const {
  const auto& mesh = model_.mesh();
  const VectorXd v = model_.element_volumes(x);
  res.worst_element = -1;
  res.worst_scaled_jacobian = std::numeric_limits<double>::infinity();
  res.min_volume_change = std::numeric_limits<double>::infinity();
  res.max_volume_change = -std::numeric_limits<double>::infinity();
  volume::HexNodes xe, x0;
  for (int e = 0; e < mesh.num_hexahedra(); ++e) {
    for (int k = 0; k < 8; ++k) {
      xe[k] = x.segment<3>(3 * mesh.hexahedra[e][k]);
      x0[k] = model_.rest_positions().segment<3>(3 * mesh.hexahedra[e][k]);
    }
    const auto sj = volume::corner_scaled_jacobians(xe);
    const double m = *std::min_element(sj.begin(), sj.end());
    if (m < res.worst_scaled_jacobian) {
      res.worst_scaled_jacobian = m;
      res.worst_element = e;
    }
    const double v0 = volume::hex_volume(x0);
    const double dv = (v[e] - v0) / v0;
    res.min_volume_change = std::min(res.min_volume_change, dv);
    res.max_volume_change = std::max(res.max_volume_change, dv);
  }
  if (res.worst_element < 0) {
    res.worst_scaled_jacobian = 1.0;
    res.min_volume_change = res.max_volume_change = 0.0;
  }
}

/// Why the continuation stalled at x (the last equilibrium), in words.
}  // namespace socketsmith::tissue
