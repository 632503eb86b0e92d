#include "socketsmith/tissue/hex_fe.h"

#include <cmath>

#include <Eigen/Dense>

#include "socketsmith/core/errors.h"
#include "socketsmith/volume/hex_element.h"

namespace socketsmith::tissue {

using Eigen::Matrix3d;
using Eigen::Vector3d;

Lame lame_constants(double E, double nu) {
  require(std::isfinite(E) && E > 0, "finite elements: Young's modulus {} Pa (expected > 0, e.g. 50e3)", E);
  require(std::isfinite(nu) && nu >= 0 && nu < 0.5,
          "finite elements: Poisson ratio {} (expected in [0, 0.5); soft tissue: 0.45-0.49)", nu);
  return {E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))};
}

HexFeElements::HexFeElements(const volume::HexMesh& mesh, double E, double nu)
    : hexes_(mesh.hexahedra), lame_(lame_constants(E, nu)) {
  const auto& dN = volume::hex_gauss_shape_derivatives();
  gauss_.resize(hexes_.size());
  for (size_t e = 0; e < hexes_.size(); ++e) {
    const volume::HexNodes X = volume::gather(mesh.nodes, hexes_[e]);
    for (int g = 0; g < 8; ++g) {
      Matrix3d J = Matrix3d::Zero();  // ∂X/∂ξ
      for (int a = 0; a < 8; ++a) J += X[a] * dN[g][a].transpose();
      const double det = J.determinant();
      require<TopologyError>(det > 0,
                             "finite elements: hexahedron {} is inverted or degenerate (Jacobian {:.3g} m^3 at a Gauss "
                             "point); remesh the stump",
                             e, det);
      const Matrix3d Jinv_t = J.inverse().transpose();
      auto& gp = gauss_[e][g];
      gp.weight = det;
      for (int a = 0; a < 8; ++a) gp.grad[a] = Jinv_t * dN[g][a];
    }
  }
}

Matrix3d HexFeElements::deformation_gradient(const volume::Hex& hex, const GaussPoint& gp, const Eigen::VectorXd& x) const {
  Matrix3d F = Matrix3d::Zero();
  for (int a = 0; a < 8; ++a) F += x.segment<3>(3 * hex[a]) * gp.grad[a].transpose();
  return F;
}

Matrix3d HexFeElements::stress(const Matrix3d& F) const {
  const Matrix3d E = 0.5 * (F.transpose() * F - Matrix3d::Identity());
  return lame_.lambda * E.trace() * Matrix3d::Identity() + 2.0 * lame_.mu * E;
}

void HexFeElements::add_forces(const Eigen::VectorXd& x, Eigen::VectorXd& f) const {
  for (size_t e = 0; e < hexes_.size(); ++e) {
    const auto& hex = hexes_[e];
    for (const auto& gp : gauss_[e]) {
      const Matrix3d F = deformation_gradient(hex, gp, x);
      const Matrix3d P = F * stress(F);  // first Piola–Kirchhoff
      for (int a = 0; a < 8; ++a) f.segment<3>(3 * hex[a]) -= gp.weight * (P * gp.grad[a]);
    }
  }
}

double HexFeElements::energy(const Eigen::VectorXd& x) const {
  double w = 0.0;
  for (size_t e = 0; e < hexes_.size(); ++e)
    for (const auto& gp : gauss_[e]) {
      const Matrix3d F = deformation_gradient(hexes_[e], gp, x);
      const Matrix3d E = 0.5 * (F.transpose() * F - Matrix3d::Identity());
      const double tr = E.trace();
      w += gp.weight * (0.5 * lame_.lambda * tr * tr + lame_.mu * E.squaredNorm());
    }
  return w;
}

void HexFeElements::element_stiffness(int e, const Eigen::VectorXd& x, bool psd, ElementMatrix& K) const {
  require(e >= 0 && e < num_elements(), "element_stiffness: element {} (expected 0..{})", e, num_elements() - 1);
  K.setZero();
  const auto& hex = hexes_[static_cast<size_t>(e)];
  const double lambda = lame_.lambda, mu = lame_.mu;
  for (const auto& gp : gauss_[static_cast<size_t>(e)]) {
    const Matrix3d F = deformation_gradient(hex, gp, x);
    Matrix3d S = stress(F);
    if (psd) {
      Eigen::SelfAdjointEigenSolver<Matrix3d> eig(S);
      S = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
    }
    const Matrix3d FFt = F * F.transpose();
    std::array<Vector3d, 8> Fg, Sg;
    for (int a = 0; a < 8; ++a) {
      Fg[a] = F * gp.grad[a];
      Sg[a] = S * gp.grad[a];
    }
    const double w = gp.weight;
    for (int a = 0; a < 8; ++a)
      for (int b = a; b < 8; ++b) {
        const double gg = gp.grad[a].dot(gp.grad[b]);
        Matrix3d B = (gp.grad[a].dot(Sg[b])) * Matrix3d::Identity() + lambda * Fg[a] * Fg[b].transpose() +
                     mu * (gg * FFt + Fg[b] * Fg[a].transpose());
        B *= w;
        K.block<3, 3>(3 * a, 3 * b) += B;
        if (b != a) K.block<3, 3>(3 * b, 3 * a) += B.transpose();
      }
  }
}

}  // namespace socketsmith::tissue
