#pragma once
/// @file hex_element.h
/// Geometry of one trilinear 8-node hexahedron: exact volume, its gradient and Hessian with
/// respect to the node positions, corner Jacobians.
///
/// The volume of a trilinear hexahedron is V = ∫ det J dξ over [-1,1]^3. det J is at most
/// quadratic in each reference coordinate, so the 2×2×2 Gauss rule integrates it exactly:
/// V = Σ_g det J(ξ_g) (unit weights). Derivatives follow from ∂det J/∂J = cof J and
/// ∂²det J/∂J_il ∂J_jm = ε_ijk ε_lmn J_kn.

#include <array>

#include <Eigen/Core>

#include "socketsmith/volume/hex_mesh.h"

namespace socketsmith::volume {

using HexNodes = std::array<Vec3, 8>;
using HexGradient = std::array<Vec3, 8>;
using HexHessian = Eigen::Matrix<double, 24, 24>;

/// Gradients ∂N_k/∂(ξ, η, ζ) of the 8 trilinear shape functions at the 8 Gauss points of the
/// 2×2×2 rule (ξ = ±1/√3 in the order of kHexCorners, unit weights): [gauss point][node].
const std::array<std::array<Vec3, 8>, 8>& hex_gauss_shape_derivatives();

/// Gathers the 8 node positions of element @p hex from @p positions.
template <class Positions>
HexNodes gather(const Positions& positions, const Hex& hex) {
  HexNodes x;
  for (int k = 0; k < 8; ++k) x[k] = positions[hex[k]];
  return x;
}

/// Exact volume of the trilinear hexahedron [m^3] (negative when inverted).
double hex_volume(const HexNodes& x);

/// Volume and its gradient ∂V/∂x_k [m^2] for the 8 nodes.
double hex_volume_gradient(const HexNodes& x, HexGradient& grad);

/// Hessian ∂²V/∂x∂x [m], 24×24, node-major (3 rows per node).
void hex_volume_hessian(const HexNodes& x, HexHessian& hess);

/// Scaled Jacobian at each of the 8 corners (det of the three unit edge vectors), in [-1, 1].
std::array<double, 8> corner_scaled_jacobians(const HexNodes& x);

/// Smallest corner Jacobian determinant (unnormalised) — ≤ 0 means inverted/degenerate [m^3].
double min_corner_jacobian(const HexNodes& x);

}  // namespace socketsmith::volume
