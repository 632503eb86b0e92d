#include "socketsmith/tissue/mass_spring_model.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "socketsmith/core/enum_names.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/tissue/spring.h"
#include "socketsmith/volume/hex_element.h"

namespace socketsmith::tissue {
namespace {

using Eigen::Matrix3d;
using volume::Vec3;

/// The material and every option the model reads, checked once so that a wrong case file fails
/// here with the value and its expected range, not later as a diverging solve.
void check_inputs(const TissueMaterial& material, const MassSpringOptions& options) {
  const double E = material.youngs_modulus_pa, rho = material.density_kg_m3;
  require(std::isfinite(E) && E > 0, "MassSpringModel: Young's modulus {} Pa (expected > 0, e.g. 50e3)", E);
  require(std::isfinite(rho) && rho > 0, "MassSpringModel: density {} kg/m^3 (expected > 0, e.g. 1060)", rho);
  require(options.hex_formulation == HexFormulation::Full || options.kind == TissueModelKind::NeoHookean,
          "MassSpringModel: the F-bar element is for the neo-Hookean model only (model '{}'; use \"model\": "
          "\"neo-hookean\" or the c3d8 element)", to_string(options.kind));
  const auto& cs = options.corrective;
  require(std::isfinite(cs.golec_a) && cs.golec_a > 0, "MassSpringModel: Golec A = {} (expected > 0)", cs.golec_a);
  require(std::isfinite(cs.alpha) && cs.alpha > 1, "MassSpringModel: alpha = {} (expected > 1, eq. 4)", cs.alpha);
  require(std::isfinite(cs.c) && cs.c >= 0, "MassSpringModel: C = {} (expected ≥ 0)", cs.c);
  require(std::isfinite(cs.beta) && cs.beta > 0, "MassSpringModel: beta = {} (expected > 0)", cs.beta);
  require(std::isfinite(cs.spring_modulus_ratio) && cs.spring_modulus_ratio > 0,
          "MassSpringModel: spring modulus ratio {} (expected > 0)", cs.spring_modulus_ratio);
  require(std::isfinite(cs.dead_zone) && cs.dead_zone >= 0 && cs.dead_zone < 0.5,
          "MassSpringModel: corrective dead zone {} (expected in [0, 0.5), a fraction of the volume)", cs.dead_zone);
  require(options.cf_poisson_ratio >= 0.25 && options.cf_poisson_ratio < 0.5,
          "MassSpringModel: MSS-CF Poisson ratio {} (expected in [0.25, 0.5))", options.cf_poisson_ratio);
  require(std::isfinite(options.fe_poisson_ratio) && options.fe_poisson_ratio >= 0 && options.fe_poisson_ratio < 0.5,
          "MassSpringModel: FE Poisson ratio {} (expected in [0, 0.5); soft tissue: 0.45-0.49)", options.fe_poisson_ratio);
  require(options.damping_ratio >= 0, "MassSpringModel: damping ratio {} (expected ≥ 0)", options.damping_ratio);
}

/// The modulus the springs are built with, and for MSS-CF the bulk modulus they lack.
struct LatticeModuli {
  double spring_modulus_pa;
  double cf_bulk_increment_pa;  // ΔK of MSS-CF, 0 for the other models [Pa]
};

/// Golec's hybrid model matches the spring lattice (ν = 1/4) to the shear modulus μ = E / (2(1+ν))
/// and adds ΔK = K − 5μ/3 through the volume energy; MSS-CS scales E by its ratio, MSS takes E.
LatticeModuli lattice_moduli(double E, const MassSpringOptions& options) {
  LatticeModuli moduli{options.kind == TissueModelKind::MssCs ? options.corrective.spring_modulus_ratio * E : E, 0.0};
  if (options.kind == TissueModelKind::MssCf) {
    const double nu = options.cf_poisson_ratio;
    const double mu = E / (2 * (1 + nu));
    moduli.spring_modulus_pa = 2.5 * mu;
    moduli.cf_bulk_increment_pa = E / (3 * (1 - 2 * nu)) - 5.0 * mu / 3.0;
  }
  return moduli;
}

/// Stiffness of one element's edge, face-diagonal and body-diagonal springs [N/m] (eq. 2).
struct HexSpringStiffness {
  double edge, face, body;
};

/// Golec's split of the element's stiffness E_s l_e between its three kinds of springs by A.
HexSpringStiffness hex_spring_stiffness(double golec_a, double spring_modulus_pa, double edge_length_m) {
  const double A = golec_a;
  const double denom = 10.0 + 7.5 * A;
  return {(0.75 * A + 2.0) * spring_modulus_pa * edge_length_m / denom, 1.5 * A * spring_modulus_pa * edge_length_m / denom,
          3.0 * spring_modulus_pa * edge_length_m / denom};
}

}  // namespace

constexpr EnumName<TissueModelKind> kModelKinds[] = {
    {TissueModelKind::Mss, "mss"},   {TissueModelKind::MssCs, "mss-cs"}, {TissueModelKind::MssCf, "mss-cf"},
    {TissueModelKind::StVenantKirchhoff, "fe"}, {TissueModelKind::NeoHookean, "neo-hookean"}};
constexpr EnumName<DampingLaw> kDampingLaws[] = {{DampingLaw::ThesisEq3, "thesis-eq3"}, {DampingLaw::Critical, "critical"}};

std::string to_string(TissueModelKind kind) { return name_of(kModelKinds, kind); }

TissueModelKind parse_tissue_model(const std::string& name) {
  return parse_named(kModelKinds, name, "unknown tissue model '{}' (expected mss-cs, mss-cf, mss, fe or neo-hookean)");
}

std::string to_string(DampingLaw law) { return name_of(kDampingLaws, law); }

DampingLaw parse_damping_law(const std::string& name) {
  return parse_named(kDampingLaws, name, "unknown damping law '{}' (expected critical or thesis-eq3)");
}

MassSpringModel::MassSpringModel(const volume::HexMesh& mesh, const TissueMaterial& material,
                                 const MassSpringOptions& options)
    : mesh_(mesh), material_(material), options_(options) {
  check_inputs(material, options);
  if (mesh_.node_tags.size() != mesh_.nodes.size()) mesh_.node_tags.resize(mesh_.nodes.size(), volume::kNodeNone);
  volume::validate(mesh_);
  const int n = mesh_.num_nodes();
  rest_.resize(3 * n);
  for (int i = 0; i < n; ++i) rest_.segment<3>(3 * i) = mesh_.nodes[i];

  auto elements = std::make_shared<HexesAtRest>();
  elements->reserve(mesh_.hexahedra.size());
  masses_ = VectorXd::Zero(n);
  for (const auto& hex : mesh_.hexahedra) {
    const double v0 = volume::hex_volume(volume::gather(mesh_.nodes, hex));
    elements->push_back({hex, v0, std::cbrt(v0)});                                  // eq. 7
    for (int k = 0; k < 8; ++k) masses_[hex[k]] += material.density_kg_m3 * v0 / 8.0;  // eq. 1
  }
  elements_ = elements;
  pattern_ = std::make_shared<const BlockPattern>(n, *elements_);
  build_terms();
}

void MassSpringModel::build_terms() {
  const double E = material_.youngs_modulus_pa;
  const LatticeModuli moduli = lattice_moduli(E, options_);
  springs_ = std::make_shared<const SpringTerm>(golec_springs(moduli.spring_modulus_pa), elements_, *pattern_);
  switch (options_.kind) {
    case TissueModelKind::Mss: terms_ = {springs_}; break;
    case TissueModelKind::MssCs:
      corrective_ = std::make_shared<const CorrectiveSpringTerm>(elements_, mesh_, options_.corrective, E);
      terms_ = {springs_, corrective_};
      break;
    case TissueModelKind::MssCf:
      terms_ = {springs_, std::make_shared<const VolumeEnergyTerm>(elements_, moduli.cf_bulk_increment_pa)};
      break;
    case TissueModelKind::StVenantKirchhoff:
    case TissueModelKind::NeoHookean:
      // The springs stay for their dampers only (the dynamic simulation's damping).
      continuum_ = std::make_shared<const HyperelasticTerm>(std::make_shared<const HyperelasticHexElements>(
          mesh_, E, options_.fe_poisson_ratio,
          options_.kind == TissueModelKind::NeoHookean ? HyperelasticLaw::NeoHookean
                                                       : HyperelasticLaw::StVenantKirchhoff,
          options_.hex_formulation));
      terms_ = {continuum_};
      break;
  }
}

std::vector<SpringTerm::Spring> MassSpringModel::golec_springs(double spring_modulus_pa) const {
  std::vector<SpringTerm::Spring> springs;
  std::unordered_map<std::uint64_t, int> spring_index;
  spring_index.reserve(elements_->size() * 14);
  auto add_spring = [&](int i, int j, double k) {
    if (i > j) std::swap(i, j);
    const std::uint64_t key = (static_cast<std::uint64_t>(i) << 32) | static_cast<std::uint32_t>(j);
    auto [it, inserted] = spring_index.try_emplace(key, static_cast<int>(springs.size()));
    if (inserted) {
      const double rest = (mesh_.nodes[j] - mesh_.nodes[i]).norm();
      require(rest > 0, "MassSpringModel: nodes {} and {} coincide (zero-length spring)", i, j);
      springs.push_back({i, j, 0.0, rest, 0.0, {0, 0, 0, 0}});
    }
    springs[it->second].k += k;
  };
  for (const auto& el : *elements_) {
    const auto& hex = el.nodes;
    const HexSpringStiffness ks = hex_spring_stiffness(options_.corrective.golec_a, spring_modulus_pa, el.edge_length);
    for (const auto& e : volume::kHexEdges) add_spring(hex[e[0]], hex[e[1]], ks.edge);
    for (const auto& e : volume::kHexFaceDiagonals) add_spring(hex[e[0]], hex[e[1]], ks.face);
    for (const auto& e : volume::kHexBodyDiagonals) add_spring(hex[e[0]], hex[e[1]], ks.body);
  }
  for (auto& s : springs) {
    const double m1 = masses_[s.i], m2 = masses_[s.j];
    const double c = options_.damping_law == DampingLaw::ThesisEq3 ? 2.0 * std::sqrt(s.k * (m1 + m2)) / s.rest
                                                                    : 2.0 * std::sqrt(s.k * m1 * m2 / (m1 + m2));
    s.damping = options_.damping_ratio * c;
  }
  return springs;
}

VectorXd MassSpringModel::dof_masses() const {
  VectorXd m(num_dofs());
  for (int i = 0; i < num_nodes(); ++i) m.segment<3>(3 * i).setConstant(masses_[i]);
  return m;
}

bool MassSpringModel::has_energy() const {
  return std::all_of(terms_.begin(), terms_.end(), [](const auto& t) { return t->has_energy(); });
}

VectorXd MassSpringModel::elastic_forces(const VectorXd& x) const {
  require(x.size() == num_dofs(), "elastic_forces: x has {} entries (expected 3N = {})", x.size(), num_dofs());
  VectorXd f = VectorXd::Zero(num_dofs());
  for (const auto& t : terms_) t->add_forces(x, f);
  return f;
}

void MassSpringModel::add_damping_forces(const VectorXd& x, const VectorXd& v, VectorXd& f) const {
  for (const auto& s : springs_->springs()) {
    const Vec3 d = state_node(x, s.j) - state_node(x, s.i);
    const Vec3 u = d.normalized();
    const Vec3 fi = s.damping * u.dot(state_node(v, s.j) - state_node(v, s.i)) * u;
    f.segment<3>(3 * s.i) += fi;
    f.segment<3>(3 * s.j) -= fi;
  }
}

double MassSpringModel::energy(const VectorXd& x) const {
  require<Error>(has_energy(), "energy: the MSS-CS corrective springs are not conservative (no energy exists)");
  double w = 0.0;
  for (const auto& t : terms_) t->add_energy(x, w);
  return w;
}

bool MassSpringModel::forces_and_energy(const VectorXd& x, VectorXd& f, double& w) const {
  require<Error>(has_energy(), "energy: the MSS-CS corrective springs are not conservative (no energy exists)");
  require(x.size() == num_dofs() && f.size() == num_dofs(), "forces_and_energy: {} / {} entries (expected 3N = {})",
          x.size(), f.size(), num_dofs());
  // Summed apart, so that a term rejecting the state after another has added leaves f untouched.
  VectorXd sum = VectorXd::Zero(num_dofs());
  double energy = 0.0;
  for (const auto& t : terms_)
    if (!t->add_forces_and_energy(x, sum, energy)) return false;
  f += sum;
  w = energy;
  return true;
}

void MassSpringModel::jacobian(const VectorXd& x, JacobianKind kind, SparseMatrix& J,
                               const VectorXd* corrective_slopes) const {
  require(x.size() == num_dofs(), "jacobian: x has {} entries (expected 3N = {})", x.size(), num_dofs());
  require(!corrective_slopes || corrective_slopes->size() == num_elements(),
          "jacobian: {} corrective slopes (expected one per element, {})",
          corrective_slopes ? corrective_slopes->size() : 0, num_elements());
  const SparseMatrix& pattern = pattern_->matrix();
  if (J.rows() != pattern.rows() || J.nonZeros() != pattern.nonZeros()) J = pattern;
  double* val = J.valuePtr();
  std::fill(val, val + J.nonZeros(), 0.0);
  // The terms add K = −J; negated at the end.
  const StiffnessRequest request{kind == JacobianKind::SymmetricPsd, corrective_slopes};
  for (const auto& t : terms_) t->add_stiffness(x, request, *pattern_, val);
  for (Eigen::Index k = 0; k < J.nonZeros(); ++k) val[k] = -val[k];
}

void MassSpringModel::damping_matrix(const VectorXd& x, SparseMatrix& D) const {
  const SparseMatrix& pattern = pattern_->matrix();
  if (D.rows() != pattern.rows() || D.nonZeros() != pattern.nonZeros()) D = pattern;
  double* val = D.valuePtr();
  std::fill(val, val + D.nonZeros(), 0.0);
  for (const auto& s : springs_->springs()) {
    const Vec3 u = (state_node(x, s.j) - state_node(x, s.i)).normalized();
    const Matrix3d C = s.damping * u * u.transpose();
    pattern_->add(val, s.blocks[0], s.i, C);
    pattern_->add(val, s.blocks[1], s.j, -C);
    pattern_->add(val, s.blocks[2], s.i, -C);
    pattern_->add(val, s.blocks[3], s.j, C);
  }
}

VectorXd MassSpringModel::element_volumes(const VectorXd& x) const {
  VectorXd v(num_elements());
  for (int e = 0; e < num_elements(); ++e) v[e] = volume::hex_volume(state_hex(x, (*elements_)[e].nodes));
  return v;
}

double MassSpringModel::total_volume(const VectorXd& x) const { return element_volumes(x).sum(); }

VectorXd MassSpringModel::element_volume_changes(const VectorXd& x) const {
  VectorXd dv = element_volumes(x);
  for (int e = 0; e < num_elements(); ++e) dv[e] = dv[e] / (*elements_)[e].rest_volume - 1.0;
  return dv;
}

double MassSpringModel::corrective_stiffness(int e, double dv, double* slope) const {
  require(e >= 0 && e < num_elements(), "corrective_stiffness: element {} (expected 0..{})", e, num_elements() - 1);
  if (!corrective_) {
    if (slope) *slope = 0.0;
    return 0.0;
  }
  return corrective_->stiffness(dv, (*elements_)[e].edge_length, slope);
}

double MassSpringModel::min_corner_jacobian(const VectorXd& x) const {
  double m = std::numeric_limits<double>::infinity();
  for (const auto& el : *elements_) m = std::min(m, volume::min_corner_jacobian(state_hex(x, el.nodes)));
  return m;
}

bool MassSpringModel::has_inverted_element(const VectorXd& x) const {
  // Each term asks for the elements it needs sound: the lattices their corners (the springs),
  // the continuum models their Gauss points.
  return std::any_of(terms_.begin(), terms_.end(), [&](const auto& t) { return t->min_jacobian(x) <= 0; });
}

}  // namespace socketsmith::tissue
