#pragma once
/// @file hyperelastic_hex.h
/// Hexahedral finite elements for the soft tissue: trilinear 8-node bricks, full 2×2×2 Gauss
/// integration (CalculiX's C3D8), with one of two hyperelastic materials (`HyperelasticLaw`):
///  - St Venant–Kirchhoff: S = λ tr(E) I + 2μ E with the Green–Lagrange strain E = ½(FᵀF − I),
///    W = λ/2 tr(E)² + μ E:E — CalculiX's `*ELASTIC` under NLGEOM;
///  - compressible neo-Hookean: W = C10 (Ī1 − 3) + (1/D1)(J − 1)², Ī1 = J^(−2/3) tr(FᵀF),
///    C10 = μ/2, D1 = 2/K (K = E/(3(1 − 2ν)) the bulk modulus) — CalculiX's `*HYPERELASTIC,
///    NEO HOOKE` (C10, D1), the constants calculix/calculix_deck.cpp writes.
/// On the same mesh socketsmith and CalculiX then solve the same discrete problem; at rest both
/// materials have the small-strain linear elastic tangent of the element (λ = K − 2μ/3).
///
/// Per Gauss point g with reference shape-function gradients g_a = ∇_X N_a and weight w = det J₀:
///   F = Σ_a x_a g_aᵀ,   W = Σ_g w W(F),   f_a = −Σ_g w P(F) g_a   (internal force),
///   K = Σ_g w Gᵀ A G,   A = ∂P/∂F (9×9 on vec(F), column-major),  G = ∂vec(F)/∂x_e (9×24),
/// with P = ∂W/∂F the first Piola–Kirchhoff stress. The material is a value inside the elements;
/// both laws share these loops.

#include <array>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/volume/hex_mesh.h"

namespace socketsmith::tissue {

/// Lamé constants from Young's modulus E [Pa] and Poisson's ratio ν.
struct Lame {
  double lambda = 0.0;  ///< λ = E ν / ((1 + ν)(1 − 2ν)) [Pa]
  double mu = 0.0;      ///< μ = E / (2(1 + ν)) [Pa]
};
/// @throws InvalidInputError for E ≤ 0 or ν outside [0, 0.5).
Lame lame_constants(double youngs_modulus_pa, double poisson_ratio);

/// Strain energy of the continuum elements.
enum class HyperelasticLaw {
  StVenantKirchhoff,  ///< W = λ/2 tr(E)² + μ E:E; defined for any F (softens in strong compression)
  NeoHookean,         ///< W = C10 (Ī1 − 3) + (1/D1)(J − 1)²; +∞ for J ≤ 0
};

/// How an element integrates its energy.
enum class HexFormulation {
  Full,  ///< every term at the 2×2×2 Gauss points: CalculiX's C3D8; locks as ν → 0.5 (docs/tissue.md, "Locking")
  /// F-bar with the element's mean dilatation: F̄ = (J̄/J)^(1/3) F at each Gauss point, J̄ = v/V
  /// the element's volume ratio (its Gauss-integrated J). For the neo-Hookean law
  /// W(F̄) = C10 (Ī1(F) − 3) + (J̄ − 1)²/D1: the deviatoric part at the Gauss points, one volume
  /// change per element (Simo–Taylor–Pister's Q1/P0), an energy with a symmetric exact tangent that
  /// passes the patch test. Does not lock in volume; CalculiX's nearest element is C3D8I.
  FBar,
};
/// "c3d8", "fbar".
const char* to_string(HexFormulation f);
/// @throws InvalidInputError for an unknown name.
HexFormulation parse_hex_formulation(const std::string& name);

/// One material point of an isotropic hyperelastic law: W(F), P(F) = ∂W/∂F and A(F) = ∂P/∂F.
/// vec(F) is column-major: index i + 3j holds F_ij.
class HyperelasticMaterial {
 public:
  using Tangent = Eigen::Matrix<double, 9, 9>;

  /// @throws InvalidInputError for E ≤ 0 or ν outside [0, 0.5).
  HyperelasticMaterial(HyperelasticLaw law, double youngs_modulus_pa, double poisson_ratio);

  HyperelasticLaw law() const { return law_; }
  const Lame& lame() const { return lame_; }
  /// C10 = μ/2 [Pa] of the neo-Hookean law (CalculiX's first constant).
  double c10() const { return 0.5 * lame_.mu; }
  /// D1 = 2/K [1/Pa] of the neo-Hookean law (CalculiX's second constant), K = λ + 2μ/3.
  double d1() const { return 2.0 / bulk_modulus(); }
  /// Bulk modulus K = λ + 2μ/3 = E/(3(1 − 2ν)) [Pa].
  double bulk_modulus() const { return lame_.lambda + 2.0 * lame_.mu / 3.0; }
  /// True when the law is defined only for J = det F > 0 (neo-Hookean).
  bool needs_positive_volume() const { return law_ == HyperelasticLaw::NeoHookean; }

  /// Energy density W(F) [J/m³]; +∞ for the neo-Hookean law when det F ≤ 0.
  double energy_density(const Eigen::Matrix3d& F) const;
  /// First Piola–Kirchhoff stress P = ∂W/∂F [Pa]. @pre det F > 0 when needs_positive_volume().
  Eigen::Matrix3d first_piola(const Eigen::Matrix3d& F) const;
  /// W(F), and P(F) into @p P when given, sharing det F and its cube root (the forces need both
  /// at every Gauss point). @pre det F > 0 when needs_positive_volume() and @p P is given;
  /// without @p P, +∞ there.
  double energy_and_stress(const Eigen::Matrix3d& F, Eigen::Matrix3d* P) const;
  /// A = ∂P/∂F [Pa] (symmetric 9×9). @p psd: a symmetric positive semi-definite surrogate —
  /// St Venant–Kirchhoff: the stress S in the geometric term δ_ik S_JL projected on its positive
  /// part (the material term is PSD already); neo-Hookean: A projected on its positive eigen-part
  /// (IPC Toolkit's project_to_psd; skipped when A is already positive definite).
  /// @pre det F > 0 when needs_positive_volume().
  Tangent tangent(const Eigen::Matrix3d& F, bool psd) const;

  /// The same law without its volumetric part (neo-Hookean: W = C10 (Ī1 − 3), K taken as 0 in
  /// the stress and tangent; bulk_modulus() still the law's): F-bar's Gauss-point part.
  HyperelasticMaterial deviatoric_part() const;

 private:
  HyperelasticLaw law_;
  Lame lame_;
  double volumetric_scale_ = 1.0;  // 0: the deviatoric part only
};

/// A homogeneous uniaxial stress state F = diag(t, t, s) of a material: lateral stresses
/// P11 = P22 = 0, axial nominal (first Piola–Kirchhoff) stress P33 given.
struct UniaxialStressState {
  bool found = false;          ///< false when the law has no such state on the path from rest
                               ///< (St Venant–Kirchhoff past its compressive limit point)
  double axial_stretch = 1.0;  ///< s [-]
  double lateral_stretch = 1.0;  ///< t [-]
};
/// Solves for the uniaxial stress state of @p material under the nominal stress
/// @p nominal_stress_pa (< 0: compression): Newton on (s, t) with load continuation from rest,
/// so the state is the one the loading path reaches. The analytic reference of the cube
/// experiment for the continuum models.
UniaxialStressState uniaxial_stress_state(const HyperelasticMaterial& material, double nominal_stress_pa);

/// The elements of a hexahedral mesh, precomputed at rest. Immutable after construction.
///
/// Inverted integration points (neo-Hookean): at a Gauss point with J = det F ≤ 0 energy() is
/// +∞ (a line search on the energy rejects the state), and add_forces() and element_stiffness()
/// throw SolverError naming the element — they never return NaN. Solvers avoid that state by
/// checking min_gauss_jacobian() (MassSpringModel::has_inverted_element()) before evaluating
/// forces. The St Venant–Kirchhoff energy is defined for any F and never throws.
class HyperelasticHexElements {
 public:
  using ElementMatrix = Eigen::Matrix<double, 24, 24>;

  /// @throws InvalidInputError for E ≤ 0, ν outside [0, 0.5); TopologyError for a hexahedron
  ///         whose Jacobian is not positive at a Gauss point.
  ///         InvalidInputError for HexFormulation::FBar with a law other than neo-Hookean.
  HyperelasticHexElements(const volume::HexMesh& mesh, double youngs_modulus_pa, double poisson_ratio,
                          HyperelasticLaw law = HyperelasticLaw::StVenantKirchhoff,
                          HexFormulation formulation = HexFormulation::Full);

  int num_elements() const { return static_cast<int>(hexes_.size()); }
  const HyperelasticMaterial& material() const { return material_; }
  HexFormulation formulation() const { return formulation_; }
  /// Element @p e's nodes (the mesh's hexahedron @p e).
  const volume::Hex& hex(int e) const { return hexes_[static_cast<size_t>(e)]; }

  /// Adds the internal forces −∂W/∂x at node positions @p x (3N, node-major) to @p f.
  /// @throws SolverError when the law needs J > 0 and some Gauss point has J ≤ 0.
  void add_forces(const Eigen::VectorXd& x, Eigen::VectorXd& f) const;
  /// Energy and, when @p f is given, internal forces added to it, in one pass over the Gauss
  /// points (a solver's trial point needs both, and the inversion check): false — @p f untouched,
  /// @p energy +∞ — when the law needs J > 0 and some Gauss point has J ≤ 0.
  bool evaluate(const Eigen::VectorXd& x, Eigen::VectorXd* f, double& energy) const;
  /// Strain energy W at @p x [J] (+∞ when the law needs J > 0 and some Gauss point has J ≤ 0).
  double energy(const Eigen::VectorXd& x) const;
  /// Stiffness K_e = ∂²W/∂x_e² of element @p e at @p x (24×24, node-major in the element's node
  /// order). @p psd: built from the material's PSD tangent, so K_e is symmetric positive
  /// semi-definite (for CG and as a preconditioner).
  /// @throws SolverError when the law needs J > 0 and a Gauss point of @p e has J ≤ 0.
  void element_stiffness(int e, const Eigen::VectorXd& x, bool psd, ElementMatrix& K) const;
  /// Calls @p add(e, K_e) for every element, K_e computed and added in parallel (OpenMP): runs of
  /// consecutive elements go colour by colour (volume::colour_element_runs), so @p add runs
  /// concurrently only for elements that share no node — it may scatter into per-node storage
  /// without locks — and the sum a caller assembles is the same whatever the number of threads.
  /// @throws as element_stiffness (what @p add received before is then incomplete).
  void for_each_element_stiffness(const Eigen::VectorXd& x, bool psd,
                                  const std::function<void(int, const ElementMatrix&)>& add) const;
  /// Smallest det(∂x/∂ξ) over every element's Gauss points at @p x, times 8 so that it has the
  /// scale of volume::min_corner_jacobian (edge vectors rather than half-edges) [m³]; ≤ 0: some
  /// integration point is inverted.
  double min_gauss_jacobian(const Eigen::VectorXd& x) const;

 private:
  struct GaussPoint {
    std::array<Eigen::Vector3d, 8> grad;  // ∇_X N_a [1/m]
    double weight = 0.0;                  // det J₀ [m³]
  };
  Eigen::Matrix3d deformation_gradient(const volume::Hex& hex, const GaussPoint& gp, const Eigen::VectorXd& x) const;
  /// F at a Gauss point of element @p e, checked against inversion when the law needs J > 0.
  Eigen::Matrix3d checked_deformation_gradient(size_t e, const GaussPoint& gp, const Eigen::VectorXd& x) const;

  /// Adds w Gᵀ A G of the point @p gp (the blocks on and above the diagonal) to @p K.
  static void add_point_stiffness(const GaussPoint& gp, const HyperelasticMaterial::Tangent& A, ElementMatrix& K);
  /// F at element @p e's Gauss points into @p F; with F-bar also the element's rest volume V and
  /// volume ratio J̄ = Σ_g w J_g / V (else J̄ = 1). False when a point that needs J > 0 has not.
  bool gauss_gradients(size_t e, const Eigen::VectorXd& x, std::array<Eigen::Matrix3d, 8>& F, double& volume,
                       double& jbar) const;
  /// Element @p e's energy at @p x and, when @p fe is given, its nodal internal forces subtracted
  /// into it; false when a point that needs J > 0 has not.
  bool element_energy(size_t e, const Eigen::VectorXd& x, Eigen::Matrix<double, 3, 8>* fe, double& w) const;

  std::vector<volume::Hex> hexes_;
  std::vector<std::array<GaussPoint, 8>> gauss_;
  std::vector<std::vector<volume::ElementRun>> colours_;  // runs sharing no node (volume::colour_element_runs)
  HyperelasticMaterial material_;
  HexFormulation formulation_ = HexFormulation::Full;
  HyperelasticMaterial gauss_material_;  // at the Gauss points: material_, or its deviatoric part (F-bar)
};

}  // namespace socketsmith::tissue
