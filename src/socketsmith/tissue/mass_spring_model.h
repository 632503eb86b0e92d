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

/// How the corrective-spring stiffness depends on the relative volume change δv = (V−V0)/V0.
enum class CorrectiveLaw {
  /// k' = C E l_e max(|δv| − d, 0)^β: the thesis's eq. 8 as printed (d = 0). With β = 2 it
  /// stiffens (pushes the diagonals apart) for compression and expansion alike.
  Symmetric,
  /// k' = C E l_e max(−δv − d, 0)^β: acts in compression only, never inflates an expanding element.
  CompressionOnly,
};
std::string to_string(CorrectiveLaw law);
CorrectiveLaw parse_corrective_law(const std::string& name);

/// Constants of the MSS-CS corrective springs (eqs. 4–8) and of Golec's A (eq. 2).
struct CorrectiveSpringConstants {
  double golec_a = 0.5;  ///< A of eq. 2 [-], > 0 (Golec: results insensitive in 0.1–100)
  double alpha = 1.4;    ///< rest-length ratio l'/l of eq. 4 [-], > 1
  double c = 25.0;       ///< C of eq. 8 [-], ≥ 0
  double beta = 2.0;     ///< exponent β of eq. 8 [-], > 0
  CorrectiveLaw law = CorrectiveLaw::Symmetric;
  /// Golec springs are built with E_s = spring_modulus_ratio · E [-], > 0. The thesis uses 1;
  /// a value below 1 offsets the stiffness the corrective springs add in compression (as
  /// Golec's hybrid model lowers its springs to the shear modulus).
  double spring_modulus_ratio = 1.0;
  /// Dead zone d of the corrective law [-], in [0, 0.5): the corrective springs carry nothing
  /// until an element has lost (gained, symmetric law) more than d of its volume. With d > 0 and
  /// β > 1 the model is exactly the Golec lattice — its linearisation — for |δv| ≤ d, however
  /// large C is, so a linear design and the nonlinear model agree at small loads. 0 in the thesis.
  double dead_zone = 0.0;

  /// The thesis's hand-tuned constants: A = 0.5, α = 1.4, C = 25, β = 2 (symmetric law).
  static CorrectiveSpringConstants thesis();
  /// The constants found by `socketsmith calibrate cube` with the stability check and no dead
  /// zone (docs/VALIDATION.md): 6.39 % / 2.56 % on the cube, short of the 5 % / 2 %;
  /// cube_targets() (the default) keeps its tangent at rest.
  static CorrectiveSpringConstants recommended();
  /// Constants that meet the cube targets (5 % / 2 %) on a stable lattice, found by
  /// `socketsmith calibrate cube --max-c 100000`; not the default (docs/VALIDATION.md says why).
  static CorrectiveSpringConstants cube_fit();
  /// The default of every command: recommended's A and spring ratio (the same linearisation, so
  /// every linear design is unchanged) with a dead zone and a steep law, found by `socketsmith
  /// calibrate cube --law compression-only --max-c 100000 --keep-linearisation recommended
  /// --min-dead-zone 0.001 --max-dead-zone 0.03`: meets the cube targets (4.47 % / 1.77 %) and
  /// carries the sheared cube (docs/VALIDATION.md).
  static CorrectiveSpringConstants cube_targets();
  /// "thesis", "recommended", "cube-fit" or "cube-targets". @throws InvalidInputError otherwise.
  static CorrectiveSpringConstants preset(const std::string& name);
};

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
  int num_elements() const { return static_cast<int>(elements_.size()); }
  int num_springs() const { return static_cast<int>(springs_.size()); }
  const volume::HexMesh& mesh() const { return mesh_; }
  const TissueMaterial& material() const { return material_; }
  const MassSpringOptions& options() const { return options_; }

  /// The material of the continuum models (fe, neo-hookean); null for the lattices.
  const HyperelasticMaterial* continuum_material() const { return continuum_ ? &continuum_->material() : nullptr; }

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
  bool has_energy() const { return options_.kind != TissueModelKind::MssCs; }
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
  double element_edge_length(int e) const { return elements_.at(static_cast<size_t>(e)).edge_length; }
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
  struct Spring {
    int i, j;
    double k;         // [N/m]
    double rest;      // [m]
    double damping;   // [N·s/m]
    int blocks[4];    // value offsets of the (i,i), (i,j), (j,i), (j,j) blocks in the pattern
  };
  struct Element {
    volume::Hex nodes;
    double rest_volume;  // V0 [m^3]
    double edge_length;  // l_e = V0^(1/3) [m] (eq. 7)
  };
  struct Corrective {  // per-element template, 16 per element
    int a, b;          // local node indices
    double rest;       // α · geometric length [m]
  };

  void build_pattern();
  int block_offset(int row_node, int col_node) const;
  double corrective_law(double dv, double edge_length, double* dk_ddv) const;
  void add_block(double* values, int offset, int col_node, const Eigen::Matrix3d& b) const;
  /// Element @p el's MSS-CF volumetric stiffness (ΔK/V0 ∇V ∇Vᵀ + ΔK δv ∇²V, the second term not for
  /// @p psd) added into the values @p val of K = −J at the element's blocks @p eb.
  void add_cf_stiffness(const Element& el, const int* eb, const volume::HexNodes& xe,
                        const volume::HexGradient& grad, double dv, bool psd, double* val) const;
  /// Element @p e's MSS-CS corrective springs (k'(δv) and the coupling r ⊗ ∇k', or its symmetric
  /// PSD surrogate) added likewise; @p corrective_slopes: frozen dk'/dδv per element, or null.
  void add_cs_stiffness(size_t e, const Element& el, const int* eb, const volume::HexNodes& xe,
                        const volume::HexGradient& grad, double dv, bool psd, const VectorXd* corrective_slopes,
                        double* val) const;

  volume::HexMesh mesh_;
  TissueMaterial material_;
  MassSpringOptions options_;
  VectorXd rest_;
  VectorXd masses_;
  std::vector<Spring> springs_;
  std::vector<Element> elements_;
  std::vector<Corrective> corrective_;  // rest lengths per element: 16 × num_elements
  double cf_bulk_increment_pa_ = 0.0;   // ΔK of MSS-CF [Pa]
  // continuum models only (shared: immutable, the model stays copyable)
  std::shared_ptr<const HyperelasticHexElements> continuum_;

  // Block-sparse pattern of all node pairs sharing an element (3×3 blocks).
  SparseMatrix pattern_;
  std::vector<int> col_nnz_;         // non-zeros per column of node n's three columns
  std::vector<int> element_blocks_;  // 64 per element: offset of block (a, b)
};

}  // namespace socketsmith::tissue
