#pragma once
/// @file hex_fe.h
/// Hexahedral finite elements for the soft tissue: trilinear 8-node bricks, full 2×2×2 Gauss
/// integration, a St Venant–Kirchhoff material (S = λ tr(E) I + 2μ E with the Green–Lagrange
/// strain E = ½(FᵀF − I)). This is the element CalculiX calls C3D8 with a linear elastic material
/// under NLGEOM, so on the same mesh socketsmith and CalculiX solve the same discrete problem; at
/// rest its tangent is the small-strain linear elastic stiffness of the same element.
///
/// Per Gauss point g with reference shape-function gradients g_a = ∇_X N_a and weight w = det J₀:
///   F = Σ_a x_a g_aᵀ,   f_a = −Σ_g w F S g_a   (internal force),   W = Σ_g w (λ/2 tr(E)² + μ E:E),
///   K_ab = Σ_g w [ (g_aᵀ S g_b) I + λ (F g_a)(F g_b)ᵀ + μ ((g_a·g_b) F Fᵀ + (F g_b)(F g_a)ᵀ) ].

#include <array>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/volume/hex_mesh.h"

namespace socketsmith::tissue {

/// Lamé constants from Young's modulus E [Pa] and Poisson's ratio ν.
struct Lame {
  double lambda = 0.0;  ///< λ = E ν / ((1 + ν)(1 − 2ν)) [Pa]
  double mu = 0.0;      ///< μ = E / (2(1 + ν)) [Pa]
};
Lame lame_constants(double youngs_modulus_pa, double poisson_ratio);

/// The elements of a hexahedral mesh, precomputed at rest. Immutable after construction.
class HexFeElements {
 public:
  using ElementMatrix = Eigen::Matrix<double, 24, 24>;

  /// @throws InvalidInputError for E ≤ 0, ν outside [0, 0.5); TopologyError for a hexahedron
  ///         whose Jacobian is not positive at a Gauss point.
  HexFeElements(const volume::HexMesh& mesh, double youngs_modulus_pa, double poisson_ratio);

  int num_elements() const { return static_cast<int>(hexes_.size()); }

  /// Adds the internal forces −∂W/∂x at node positions @p x (3N, node-major) to @p f.
  void add_forces(const Eigen::VectorXd& x, Eigen::VectorXd& f) const;
  /// Strain energy W at @p x [J].
  double energy(const Eigen::VectorXd& x) const;
  /// Stiffness K_e = ∂²W/∂x_e² of element @p e at @p x (24×24, node-major in the element's node
  /// order). @p psd: the stress in the geometric term is projected on its positive part, so K_e is
  /// symmetric positive semi-definite (for CG and as a preconditioner).
  void element_stiffness(int e, const Eigen::VectorXd& x, bool psd, ElementMatrix& K) const;

 private:
  struct GaussPoint {
    std::array<Eigen::Vector3d, 8> grad;  // ∇_X N_a [1/m]
    double weight = 0.0;                  // det J₀ [m³]
  };
  Eigen::Matrix3d deformation_gradient(const volume::Hex& hex, const GaussPoint& gp, const Eigen::VectorXd& x) const;
  Eigen::Matrix3d stress(const Eigen::Matrix3d& F) const;

  std::vector<volume::Hex> hexes_;
  std::vector<std::array<GaussPoint, 8>> gauss_;
  Lame lame_;
};

}  // namespace socketsmith::tissue
