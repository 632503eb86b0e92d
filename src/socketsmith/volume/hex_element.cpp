#include "socketsmith/volume/hex_element.h"

#include <cmath>

#include <Eigen/Dense>

namespace socketsmith::volume {
namespace {

/// Gradients of the 8 shape functions at the 8 Gauss points (±1/√3), computed once.
struct GaussTable {
  std::array<std::array<Vec3, 8>, 8> dN;  // [gauss point][node]
  GaussTable() {
    const double g = 1.0 / std::sqrt(3.0);
    for (int p = 0; p < 8; ++p) {
      const double xi = g * kHexCorners[p][0], eta = g * kHexCorners[p][1], zeta = g * kHexCorners[p][2];
      for (int k = 0; k < 8; ++k) {
        const double a = kHexCorners[k][0], b = kHexCorners[k][1], c = kHexCorners[k][2];
        dN[p][k] = Vec3(0.125 * a * (1 + b * eta) * (1 + c * zeta), 0.125 * b * (1 + a * xi) * (1 + c * zeta),
                        0.125 * c * (1 + a * xi) * (1 + b * eta));
      }
    }
  }
};
const GaussTable& gauss() {
  static const GaussTable table;
  return table;
}

Eigen::Matrix3d jacobian(const HexNodes& x, const std::array<Vec3, 8>& dN) {
  Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
  for (int k = 0; k < 8; ++k) J += x[k] * dN[k].transpose();
  return J;
}

}  // namespace

const std::array<std::array<Vec3, 8>, 8>& hex_gauss_shape_derivatives() { return gauss().dN; }

double hex_volume(const HexNodes& x) {
  double v = 0.0;
  for (const auto& dN : gauss().dN) v += jacobian(x, dN).determinant();
  return v;
}

double hex_volume_gradient(const HexNodes& x, HexGradient& grad) {
  for (auto& g : grad) g.setZero();
  double v = 0.0;
  for (const auto& dN : gauss().dN) {
    const Eigen::Matrix3d J = jacobian(x, dN);
    Eigen::Matrix3d cof;
    cof.col(0) = J.col(1).cross(J.col(2));
    cof.col(1) = J.col(2).cross(J.col(0));
    cof.col(2) = J.col(0).cross(J.col(1));
    v += J.col(0).dot(cof.col(0));
    for (int k = 0; k < 8; ++k) grad[k] += cof * dN[k];
  }
  return v;
}

void hex_volume_hessian(const HexNodes& x, HexHessian& hess) {
  hess.setZero();
  for (const auto& dN : gauss().dN) {
    const Eigen::Matrix3d J = jacobian(x, dN);
    for (int a = 0; a < 8; ++a) {
      for (int b = a + 1; b < 8; ++b) {
        const Vec3 w = J * dN[a].cross(dN[b]);
        // ∂²V/∂x_a,i ∂x_b,j = ε_ijk w_k  (= -[w]x); the (b,a) block is its transpose.
        Eigen::Matrix3d block;
        block << 0, w.z(), -w.y(), -w.z(), 0, w.x(), w.y(), -w.x(), 0;
        hess.block<3, 3>(3 * a, 3 * b) += block;
        hess.block<3, 3>(3 * b, 3 * a) += block.transpose();
      }
    }
  }
}

namespace {
/// Edge vectors leaving corner k along +ξ, +η, +ζ (columns), unnormalised.
Eigen::Matrix3d corner_edges(const HexNodes& x, int k) {
  // kCornerNeighbour[k][d]: the corner that differs from k in reference axis d.
  static constexpr int kCornerNeighbour[8][3] = {{1, 3, 4}, {0, 2, 5}, {3, 1, 6}, {2, 0, 7},
                                                 {5, 7, 0}, {4, 6, 1}, {7, 5, 2}, {6, 4, 3}};
  Eigen::Matrix3d E;
  for (int d = 0; d < 3; ++d)
    E.col(d) = (x[kCornerNeighbour[k][d]] - x[k]) * static_cast<double>(-kHexCorners[k][d]);
  return E;
}
}  // namespace

std::array<double, 8> corner_scaled_jacobians(const HexNodes& x) {
  std::array<double, 8> out{};
  for (int k = 0; k < 8; ++k) {
    Eigen::Matrix3d E = corner_edges(x, k);
    for (int d = 0; d < 3; ++d) {
      const double len = E.col(d).norm();
      E.col(d) = len > 0 ? Vec3(E.col(d) / len) : Vec3::Zero();
    }
    out[k] = E.determinant();
  }
  return out;
}

double min_corner_jacobian(const HexNodes& x) {
  double m = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 8; ++k) m = std::min(m, corner_edges(x, k).determinant());
  return m;
}

}  // namespace socketsmith::volume
