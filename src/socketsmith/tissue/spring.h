#pragma once
/// @file spring.h
/// The two-node linear spring shared by every model: energy ½ k (l − L)², force on node i
/// f_i = k (l − L) u with u = (x_j − x_i)/l (pulls i towards j when stretched), f_j = −f_i.

#include <Eigen/Core>

namespace socketsmith::tissue {

/// Force on node i of a spring (i, j) of stiffness @p k [N/m] and rest length @p rest [m].
/// @pre x_i ≠ x_j.
inline Eigen::Vector3d spring_force(const Eigen::Vector3d& xi, const Eigen::Vector3d& xj, double k, double rest) {
  const Eigen::Vector3d d = xj - xi;
  const double l = d.norm();
  return k * (l - rest) / l * d;
}

/// Hessian of ½ k (l − L)² with respect to x_j (= ∂²/∂x_i², = −∂²/∂x_i∂x_j) [N/m]:
/// k [u uᵀ + (1 − L/l)(I − u uᵀ)]. With @p psd the transverse term of a compressed spring
/// (l < L, negative) is dropped so the block is positive semi-definite.
inline Eigen::Matrix3d spring_hessian(const Eigen::Vector3d& xi, const Eigen::Vector3d& xj, double k, double rest,
                                      bool psd) {
  const Eigen::Vector3d d = xj - xi;
  const double l = d.norm();
  const Eigen::Vector3d u = d / l;
  const Eigen::Matrix3d uu = u * u.transpose();
  double t = 1.0 - rest / l;
  if (psd && t < 0) t = 0;
  return k * (uu + t * (Eigen::Matrix3d::Identity() - uu));
}

}  // namespace socketsmith::tissue
