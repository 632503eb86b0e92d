#pragma once
/// @file mass_spring_model.h
/// Hexahedral mass-spring soft-tissue models of the thesis (ch. 3.2, docs/method.md §1):
///  - MSS:    Golec springs only (eq. 2) — isotropic, Young's modulus E, Poisson ratio 1/4;
///  - MSS-CS: the thesis model, MSS + volume-dependent corrective springs (eqs. 4–8);
///  - MSS-CF: Golec's hybrid model (Golec et al. 2020, Visual Computer 36:809), MSS springs
///            matched to the shear modulus + an energy depending on the element volume only;
///  - FE:     not a lattice — hexahedral finite elements (St Venant–Kirchhoff, 2×2×2 Gauss; the
///            element CalculiX calls C3D8, hyperelastic_hex.h) on the same mesh, with E and ν.
///            The Golec springs are kept for their dampers only (the dynamic simulation's damping).
///  - neo-Hookean: the same elements with a compressible neo-Hookean material (CalculiX's
///            *HYPERELASTIC, NEO HOOKE with C10 = μ/2, D1 = 2/K; hyperelastic_hex.h), for large
///            strains.
///
/// State vectors are flattened node-major: x = (x0, y0, z0, x1, ...), size 3N, metres.
/// Forces are internal forces on the nodes [N]; the Jacobian is J = ∂f/∂x [N/m] and the
/// stiffness K = −J.

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <memory>

#include "socketsmith/tissue/elastic_terms.h"
#include "socketsmith/tissue/hyperelastic_hex.h"
#include "socketsmith/volume/hex_element.h"
#include "socketsmith/volume/hex_mesh.h"

namespace socketsmith::tissue {

using Eigen::VectorXd;
using SparseMatrix = Eigen::SparseMatrix<double>;

/// Physical constants of the soft tissue.
struct TissueMaterial {
  double youngs_modulus_pa = 50e3;  ///< E [Pa], > 0 (soft tissue: 10–200 kPa)
  double density_kg_m3 = 1060.0;    ///< ρ [kg/m^3], > 0 (thesis: 1060)
};

/// The tissue models. StVenantKirchhoff and NeoHookean are the continuum models (hexahedral
/// finite elements, hyperelastic_hex.h); their names in files and on the command line are "fe"
/// and "neo-hookean" (to_string, parse_tissue_model).
enum class TissueModelKind { Mss, MssCs, MssCf, StVenantKirchhoff, NeoHookean };

/// True for the continuum (finite-element) models: StVenantKirchhoff and NeoHookean.
inline bool is_continuum(TissueModelKind kind) {
  return kind == TissueModelKind::StVenantKirchhoff || kind == TissueModelKind::NeoHookean;
}

/// "mss", "mss-cs", "mss-cf", "fe", "neo-hookean".
std::string to_string(TissueModelKind kind);
/// @throws InvalidInputError for an unknown name.
TissueModelKind parse_tissue_model(const std::string& name);

/// Damping law of the spring dampers (eq. 3).
enum class DampingLaw {
  /// c = ζ · 2 √(k (m1 + m2)) / l0 read with l0 in metres, i.e. the printed formula taken as a
  /// damper coefficient in N·s/m. Dimensionally odd (docs/method.md §1.2, "Damping"); heavily
  /// over-damped on mm meshes.
  ThesisEq3,
  /// c = ζ · 2 √(k m1 m2 / (m1 + m2)) [N·s/m]: ζ = 1 critically damps each spring's own mode.
  Critical,
};
std::string to_string(DampingLaw law);
DampingLaw parse_damping_law(const std::string& name);

/// Options of the model.
struct MassSpringOptions {
  TissueModelKind kind = TissueModelKind::MssCs;
  CorrectiveSpringConstants corrective = CorrectiveSpringConstants::cube_targets();
  double cf_poisson_ratio = 0.49;  ///< MSS-CF target Poisson ratio ν [-], in [0.25, 0.5)
  /// Poisson ratio ν of the continuum models (fe, neo-hookean) [-], in [0, 0.5) (the thesis's
  /// Abaqus check: 0.45)
  double fe_poisson_ratio = 0.45;
  /// How the continuum models' hexahedra integrate their energy: CalculiX's C3D8 (full) or F-bar
  /// (neo-hookean only; docs/tissue.md, "Locking").
  HexFormulation hex_formulation = HexFormulation::Full;
  DampingLaw damping_law = DampingLaw::Critical;
  double damping_ratio = 1.0;      ///< ζ multiplying the damping law [-], ≥ 0
};

/// Which Jacobian to assemble.
enum class JacobianKind {
  Exact,         ///< J = ∂f/∂x including the non-symmetric corrective-spring volume coupling
  SymmetricPsd,  ///< −K with K symmetric positive semi-definite: springs' negative transverse terms
                 ///< dropped, the corrective volume coupling r ⊗ ∇k' replaced by its symmetric
                 ///< projection on ∇V when that is positive: for CG and as a preconditioner
};

/// A hexahedral mass-spring model. Built once; evaluating forces does not modify it.
class MassSpringModel {
 public:
  /// @throws InvalidInputError for E ≤ 0, ρ ≤ 0, constants out of range, NaN nodes;
  ///         TopologyError for inverted hexahedra.
  MassSpringModel(const volume::HexMesh& mesh, const TissueMaterial& material,
                  const MassSpringOptions& options = {});

  int num_nodes() const { return static_cast<int>(masses_.size()); }
  int num_dofs() const { return 3 * num_nodes(); }
  int num_elements() const { return static_cast<int>(elements_->size()); }
  int num_springs() const { return static_cast<int>(springs_->springs().size()); }
  const volume::HexMesh& mesh() const { return mesh_; }
  const TissueMaterial& material() const { return material_; }
  const MassSpringOptions& options() const { return options_; }

  /// The material of the continuum models (fe, neo-hookean); null for the lattices.
  const HyperelasticMaterial* continuum_material() const {
    return continuum_ ? &continuum_->elements().material() : nullptr;
  }
  /// The terms whose sum is the elastic energy (elastic_terms.h): the springs and MSS-CS's
  /// corrective springs or MSS-CF's volume energy for the lattices; the elements for the
  /// continuum models.
  const std::vector<std::shared_ptr<const ElasticTerm>>& terms() const { return terms_; }

  /// Rest positions (3N) [m].
  const VectorXd& rest_positions() const { return rest_; }
  /// Nodal masses (N) [kg], eq. 1.
  const VectorXd& masses() const { return masses_; }
  /// Mass per DOF (3N) [kg].
  VectorXd dof_masses() const;

  /// Elastic internal forces at positions @p x (3N) [N], springs + corrective terms.
  VectorXd elastic_forces(const VectorXd& x) const;
  /// Adds the damper forces at (x, v) to @p f.
  void add_damping_forces(const VectorXd& x, const VectorXd& v, VectorXd& f) const;

  /// True when the elastic forces derive from an energy (MSS, MSS-CF, FE, neo-Hookean; not MSS-CS).
  bool has_energy() const;
  /// Elastic energy [J]. @throws Error when has_energy() is false.
  double energy(const VectorXd& x) const;
  /// The elastic forces added to @p f and the energy in @p energy, when the state is admissible:
  /// false (@p f untouched) when has_inverted_element(x). One pass over the elements for the
  /// continuum models (a line search's trial point needs all three); separate passes otherwise.
  /// @throws Error when has_energy() is false.
  bool forces_and_energy(const VectorXd& x, VectorXd& f, double& energy) const;

  /// Jacobian J = ∂f/∂x (3N × 3N) of the elastic forces, written into @p J (pattern reused).
  /// @param corrective_slopes MSS-CS only, optional (num_elements()): the slope dk'/dδv [N/m] of
  ///        each element's corrective law to use in the volume coupling instead of the law's own
  ///        slope at x — a secant or look-ahead slope, so that solvers can put into the matrix the
  ///        stiffness the law will have where the step goes (the dead-zone law is flat at x, steep
  ///        a little further). The corrective springs' own stiffness k'(δv) stays the one at x.
  void jacobian(const VectorXd& x, JacobianKind kind, SparseMatrix& J,
                const VectorXd* corrective_slopes = nullptr) const;
  /// Damping matrix D = −∂f_damp/∂v (symmetric PSD) at positions @p x.
  void damping_matrix(const VectorXd& x, SparseMatrix& D) const;

  /// Volume of every element at @p x [m^3].
  VectorXd element_volumes(const VectorXd& x) const;
  /// Relative volume change δv = (V − V0)/V0 of every element at @p x [-].
  VectorXd element_volume_changes(const VectorXd& x) const;
  /// Edge length l_e = V0^(1/3) of element @p e [m] (eq. 7).
  double element_edge_length(int e) const { return elements_->at(static_cast<size_t>(e)).edge_length; }
  /// Corrective-spring stiffness k'(δv) = C E l_e g(δv) of element @p e at volume change @p dv
  /// [N/m] (eq. 8 with the dead zone), and its slope dk'/dδv [N/m] in @p slope when given. 0
  /// for MSS and MSS-CF.
  double corrective_stiffness(int e, double dv, double* slope = nullptr) const;
  /// Sum of element volumes [m^3].
  double total_volume(const VectorXd& x) const;
  /// Smallest corner Jacobian over all elements (≤ 0: some element inverted) [m^3].
  double min_corner_jacobian(const VectorXd& x) const;
  /// True when some element is inverted where this model needs it not to be: at a corner for the
  /// lattices (their springs and volumes see the corners), at a Gauss point for the continuum
  /// models (their energy lives at the integration points only, and CalculiX checks the same
  /// points; a strongly sheared brick may fold a corner while every integration point is
  /// sound). Solvers reject such states before evaluating forces: the neo-Hookean forces are
  /// undefined there (HyperelasticHexElements throws).
  bool has_inverted_element(const VectorXd& x) const;

 private:
  /// The terms of options_.kind.
  void build_terms();
  /// Golec's springs of every element with the modulus @p spring_modulus_pa (eq. 2) and their
  /// dampers (eq. 3), one per node pair.
  std::vector<SpringTerm::Spring> golec_springs(double spring_modulus_pa) const;

  volume::HexMesh mesh_;
  TissueMaterial material_;
  MassSpringOptions options_;
  VectorXd rest_;
  VectorXd masses_;
  // Shared and immutable: the model stays cheap to copy.
  std::shared_ptr<const HexesAtRest> elements_;
  std::shared_ptr<const BlockPattern> pattern_;
  std::shared_ptr<const SpringTerm> springs_;               // the lattices' term; every model's dampers
  std::shared_ptr<const CorrectiveSpringTerm> corrective_;  // MSS-CS only
  std::shared_ptr<const HyperelasticTerm> continuum_;       // the continuum models only
  std::vector<std::shared_ptr<const ElasticTerm>> terms_;   // the elastic energy's terms, in order
};

}  // namespace socketsmith::tissue
