#include "socketsmith/tissue/hyperelastic_hex.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "socketsmith/core/errors.h"
#include "socketsmith/volume/hex_element.h"

namespace socketsmith::tissue {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Tangent = HyperelasticMaterial::Tangent;
using Vec9 = Eigen::Matrix<double, 9, 1>;

namespace {

Matrix3d cross_matrix(const Vector3d& v) {
  Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

/// Cofactor H = ∂J/∂F = J F⁻ᵀ (column j: the cross product of the other two columns of F).
Matrix3d cofactor(const Matrix3d& F) {
  Matrix3d H;
  H.col(0) = F.col(1).cross(F.col(2));
  H.col(1) = F.col(2).cross(F.col(0));
  H.col(2) = F.col(0).cross(F.col(1));
  return H;
}

/// ∂²J/∂vec(F)² (9×9, linear in F): block (j, k) is ∂²J/∂f_j∂f_k for the columns f of F.
Tangent determinant_hessian(const Matrix3d& F) {
  Tangent h = Tangent::Zero();
  const Matrix3d c0 = cross_matrix(F.col(0)), c1 = cross_matrix(F.col(1)), c2 = cross_matrix(F.col(2));
  h.block<3, 3>(0, 3) = -c2;
  h.block<3, 3>(3, 0) = c2;
  h.block<3, 3>(0, 6) = c1;
  h.block<3, 3>(6, 0) = -c1;
  h.block<3, 3>(3, 6) = -c0;
  h.block<3, 3>(6, 3) = c0;
  return h;
}

Vec9 vec(const Matrix3d& m) { return Eigen::Map<const Vec9>(m.data()); }

/// J^(−2/3) by a cube root (a third of pow's cost; the assembly calls it at every Gauss point).
double j_minus_two_thirds(double J) {
  const double c = std::cbrt(J);
  return 1.0 / (c * c);
}

/// IPC-style projection of @p A on its positive eigen-part. A tangent positive semi-definite to
/// round-off (at rest the rotations are exact zero modes) is kept as is; a Cholesky of
/// A + 1e-10 @p scale I tells that cheaply.
void project_to_psd(Tangent& A, double scale) {
  const Tangent shifted = A + 1e-10 * scale * Tangent::Identity();
  Eigen::LLT<Tangent> llt(shifted);
  if (llt.info() == Eigen::Success) return;
  Eigen::SelfAdjointEigenSolver<Tangent> eig(A);
  A = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
}

/// Consecutive elements per run of the parallel loops (volume::colour_element_runs): long enough
/// that a run's elements share nodes and cache lines, short enough that each colour has runs for
/// every thread.
constexpr int kRunLength = 64;

}  // namespace

Lame lame_constants(double E, double nu) {
  require(std::isfinite(E) && E > 0, "finite elements: Young's modulus {} Pa (expected > 0, e.g. 50e3)", E);
  require(std::isfinite(nu) && nu >= 0 && nu < 0.5,
          "finite elements: Poisson ratio {} (expected in [0, 0.5); soft tissue: 0.45-0.49)", nu);
  return {E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))};
}

const char* to_string(HexFormulation f) { return f == HexFormulation::FBar ? "fbar" : "c3d8"; }

HexFormulation parse_hex_formulation(const std::string& name) {
  if (name == "c3d8") return HexFormulation::Full;
  if (name == "fbar") return HexFormulation::FBar;
  fail("unknown element formulation '{}' (expected c3d8 or fbar)", name);
}

HyperelasticMaterial::HyperelasticMaterial(HyperelasticLaw law, double E, double nu)
    : law_(law), lame_(lame_constants(E, nu)) {}

HyperelasticMaterial HyperelasticMaterial::deviatoric_part() const {
  require(law_ == HyperelasticLaw::NeoHookean,
          "finite elements: only the neo-Hookean law splits into a deviatoric and a volumetric part (F-bar needs "
          "\"model\": \"neo-hookean\")");
  HyperelasticMaterial m = *this;
  m.volumetric_scale_ = 0.0;
  return m;
}

double HyperelasticMaterial::energy_density(const Matrix3d& F) const { return energy_and_stress(F, nullptr); }

Matrix3d HyperelasticMaterial::first_piola(const Matrix3d& F) const {
  Matrix3d P;
  (void)energy_and_stress(F, &P);
  return P;
}

double HyperelasticMaterial::energy_and_stress(const Matrix3d& F, Matrix3d* P) const {
  const double lambda = lame_.lambda, mu = lame_.mu;
  if (law_ == HyperelasticLaw::StVenantKirchhoff) {
    const Matrix3d E = 0.5 * (F.transpose() * F - Matrix3d::Identity());
    const double tr = E.trace();
    if (P) *P = F * (lambda * tr * Matrix3d::Identity() + 2.0 * mu * E);
    return 0.5 * lambda * tr * tr + mu * E.squaredNorm();
  }
  const double J = F.determinant();
  if (!(J > 0)) {
    SOCKETSMITH_ASSERT(P == nullptr);
    return std::numeric_limits<double>::infinity();
  }
  // W = C10 (J^(−2/3) I1 − 3) + (J − 1)²/D1 with C10 = μ/2, 1/D1 = K/2;
  // P = μ J^(−2/3) F − (μ/3) I1 J^(−5/3) H + K (J − 1) H, with H = ∂J/∂F.
  const double j23 = j_minus_two_thirds(J), I1 = F.squaredNorm(), K = volumetric_scale_ * bulk_modulus();
  if (P) *P = mu * j23 * F + (K * (J - 1) - mu / 3.0 * I1 * j23 / J) * cofactor(F);
  return 0.5 * mu * (j23 * I1 - 3.0) + 0.5 * K * (J - 1) * (J - 1);
}

Tangent HyperelasticMaterial::tangent(const Matrix3d& F, bool psd) const {
  const double lambda = lame_.lambda, mu = lame_.mu;
  Tangent A;
  if (law_ == HyperelasticLaw::StVenantKirchhoff) {
    // ∂(F S)_iJ/∂F_kL = δ_ik S_JL + λ F_iJ F_kL + μ (F_iL F_kJ + (F Fᵀ)_ik δ_JL).
    const Matrix3d E = 0.5 * (F.transpose() * F - Matrix3d::Identity());
    Matrix3d S = lambda * E.trace() * Matrix3d::Identity() + 2.0 * mu * E;
    if (psd) {  // the material term is PSD: clamping the stress of the geometric term suffices
      Eigen::SelfAdjointEigenSolver<Matrix3d> eig(S);
      S = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
    }
    const Matrix3d FFt = F * F.transpose();
    for (int L = 0; L < 3; ++L)
      for (int k = 0; k < 3; ++k)
        for (int J = 0; J < 3; ++J)
          for (int i = 0; i < 3; ++i)
            A(i + 3 * J, k + 3 * L) = (i == k ? S(J, L) : 0.0) + lambda * F(i, J) * F(k, L) +
                                      mu * (F(i, L) * F(k, J) + (J == L ? FFt(i, k) : 0.0));
    return A;
  }
  const double J = F.determinant();
  SOCKETSMITH_ASSERT(J > 0);
  const double I1 = F.squaredNorm(), j23 = j_minus_two_thirds(J), j53 = j23 / J, j83 = j53 / J;
  const double kappa = volumetric_scale_ * bulk_modulus();
  const Vec9 f = vec(F), h = vec(cofactor(F));
  A = (kappa * (J - 1) - mu / 3.0 * I1 * j53) * determinant_hessian(F);
  A.noalias() += (kappa + 5.0 / 9.0 * mu * I1 * j83) * h * h.transpose();
  A.noalias() -= 2.0 / 3.0 * mu * j53 * (f * h.transpose() + h * f.transpose());
  A.diagonal().array() += mu * j23;
  if (psd) project_to_psd(A, mu);
  return A;
}

UniaxialStressState uniaxial_stress_state(const HyperelasticMaterial& material, double p) {
  require(std::isfinite(p), "uniaxial_stress_state: nominal stress {} Pa (expected finite)", p);
  UniaxialStressState out;
  double s = 1.0, t = 1.0;
  const double tol = 1e-12 * std::max(std::abs(p), material.lame().mu);
  // Load steps small enough that Newton from the previous state converges; a law with a limit
  // point on the path (no state for the next load) makes Newton fail there.
  const int steps = 50;
  for (int k = 1; k <= steps; ++k) {
    const double target = p * k / steps;
    bool converged = false;
    for (int it = 0; it < 50 && !converged; ++it) {
      const Matrix3d F = Eigen::Vector3d(t, t, s).asDiagonal();
      if (material.needs_positive_volume() && !(F.determinant() > 0)) return out;
      const Matrix3d P = material.first_piola(F);
      const Eigen::Vector2d r(P(2, 2) - target, P(0, 0));
      if (r.cwiseAbs().maxCoeff() <= tol) {
        converged = true;
        break;
      }
      const Tangent A = material.tangent(F, false);
      // vec indices: F11 → 0, F22 → 4, F33 → 8; t moves F11 and F22 together.
      Eigen::Matrix2d D;
      D << A(8, 8), A(8, 0) + A(8, 4), A(0, 8), A(0, 0) + A(0, 4);
      const Eigen::Vector2d d = D.partialPivLu().solve(-r);
      if (!d.allFinite()) return out;
      // Keep the stretches positive: at most half the way to zero per iteration.
      double step = 1.0;
      if (s + d[0] <= 0.5 * s) step = std::min(step, -0.5 * s / d[0]);
      if (t + d[1] <= 0.5 * t) step = std::min(step, -0.5 * t / d[1]);
      s += step * d[0];
      t += step * d[1];
    }
    if (!converged) return out;
  }
  out.found = true;
  out.axial_stretch = s;
  out.lateral_stretch = t;
  return out;
}

HyperelasticHexElements::HyperelasticHexElements(const volume::HexMesh& mesh, double E, double nu, HyperelasticLaw law,
                                                 HexFormulation formulation)
    : hexes_(mesh.hexahedra), colours_(volume::colour_element_runs(mesh.num_nodes(), mesh.hexahedra, kRunLength)),
      material_(law, E, nu), formulation_(formulation),
      gauss_material_(formulation == HexFormulation::FBar ? material_.deviatoric_part() : material_) {
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

Matrix3d HyperelasticHexElements::deformation_gradient(const volume::Hex& hex, const GaussPoint& gp, const Eigen::VectorXd& x) const {
  Matrix3d F = Matrix3d::Zero();
  for (int a = 0; a < 8; ++a) F.noalias() += x.segment<3>(3 * hex[a]) * gp.grad[a].transpose();
  return F;
}

Matrix3d HyperelasticHexElements::checked_deformation_gradient(size_t e, const GaussPoint& gp, const Eigen::VectorXd& x) const {
  const Matrix3d F = deformation_gradient(hexes_[e], gp, x);
  if (material_.needs_positive_volume()) {
    const double J = F.determinant();
    require<SolverError>(J > 0,
                         "finite elements: element {} is inverted at a Gauss point (J = {:.3g}), where the neo-Hookean "
                         "stress is undefined; reject such states before evaluating forces (MassSpringModel::has_inverted_element)",
                         e, J);
  }
  return F;
}

void HyperelasticHexElements::add_forces(const Eigen::VectorXd& x, Eigen::VectorXd& f) const {
  double w = 0.0;
  if (evaluate(x, &f, w)) return;
  // Inverted somewhere: the serial pass names the element.
  for (size_t e = 0; e < hexes_.size(); ++e)
    for (const auto& gp : gauss_[e]) (void)checked_deformation_gradient(e, gp, x);
}

bool HyperelasticHexElements::gauss_gradients(size_t e, const Eigen::VectorXd& x, std::array<Matrix3d, 8>& F,
                                             double& volume, double& jbar) const {
  const bool fbar = formulation_ == HexFormulation::FBar, check = material_.needs_positive_volume();
  double deformed = 0.0;
  volume = 0.0;
  for (int g = 0; g < 8; ++g) {
    const auto& gp = gauss_[e][g];
    F[g] = deformation_gradient(hexes_[e], gp, x);
    if (!check && !fbar) continue;
    const double J = F[g].determinant();
    if (check && !(J > 0)) return false;
    volume += gp.weight;
    deformed += gp.weight * J;
  }
  jbar = fbar ? deformed / volume : 1.0;
  return true;
}

bool HyperelasticHexElements::element_energy(size_t e, const Eigen::VectorXd& x, Eigen::Matrix<double, 3, 8>* fe,
                                             double& w) const {
  const bool fbar = formulation_ == HexFormulation::FBar;
  const auto& points = gauss_[e];
  std::array<Matrix3d, 8> F;
  double volume = 0.0, Jbar = 1.0;
  if (!gauss_gradients(e, x, F, volume, Jbar)) return false;
  // F-bar's volumetric part: V · K/2 (J̄ − 1)² with J̄ = v/V, its stress K (J̄ − 1) H at every point.
  const double K = material_.bulk_modulus();
  w = fbar ? volume * 0.5 * K * (Jbar - 1) * (Jbar - 1) : 0.0;
  for (int g = 0; g < 8; ++g) {
    const auto& gp = points[g];
    if (!fe) {
      w += gp.weight * gauss_material_.energy_density(F[g]);
      continue;
    }
    Matrix3d P;
    w += gp.weight * gauss_material_.energy_and_stress(F[g], &P);
    if (fbar) P += K * (Jbar - 1) * cofactor(F[g]);
    for (int a = 0; a < 8; ++a) fe->col(a).noalias() -= gp.weight * (P * gp.grad[a]);
  }
  return true;
}

bool HyperelasticHexElements::evaluate(const Eigen::VectorXd& x, Eigen::VectorXd* f, double& energy) const {
  std::vector<double> w_e(hexes_.size(), 0.0);
  Eigen::VectorXd sum;  // the forces, added to *f only when no Gauss point is inverted
  if (f) sum = Eigen::VectorXd::Zero(f->size());
  // Colour by colour: the runs of one colour share no node, so each element adds its 24 nodal
  // forces to `sum` directly, and every entry gets its terms in the same order whatever the threads.
  for (const auto& group : colours_) {
    const int n = static_cast<int>(group.size());
    int bad = 0;
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : bad)
    for (int k = 0; k < n; ++k)
      for (int e = group[static_cast<size_t>(k)].begin; e < group[static_cast<size_t>(k)].end; ++e) {
        const auto ue = static_cast<size_t>(e);
        double w = 0.0;
        Eigen::Matrix<double, 3, 8> fe = Eigen::Matrix<double, 3, 8>::Zero();
        if (!element_energy(ue, x, f ? &fe : nullptr, w)) {
          ++bad;
          continue;
        }
        w_e[ue] = w;
        if (f)
          for (int a = 0; a < 8; ++a) sum.segment<3>(3 * hexes_[ue][a]) += fe.col(a);
      }
    if (bad > 0) {
      energy = std::numeric_limits<double>::infinity();
      return false;
    }
  }
  if (f) *f += sum;
  energy = 0.0;
  for (double w : w_e) energy += w;
  return true;
}

double HyperelasticHexElements::energy(const Eigen::VectorXd& x) const {
  double w = 0.0;
  (void)evaluate(x, nullptr, w);  // +∞ when a Gauss point is inverted for a law that needs J > 0
  return w;
}

void HyperelasticHexElements::element_stiffness(int e, const Eigen::VectorXd& x, bool psd, ElementMatrix& K) const {
  require(e >= 0 && e < num_elements(), "element_stiffness: element {} (expected 0..{})", e, num_elements() - 1);
  K.setZero();
  const auto ue = static_cast<size_t>(e);
  if (formulation_ == HexFormulation::Full) {
    for (const auto& gp : gauss_[ue]) add_point_stiffness(gp, material_.tangent(checked_deformation_gradient(ue, gp, x), psd), K);
  } else {
    // F-bar: Π_e = Σ_g w W_dev(F_g) + V U(J̄), J̄ = Σ_g w J_g / V, U = K/2 (J̄ − 1)². Its Hessian:
    // Σ_g w Gᵀ (A_dev + U'(J̄) ∂²J/∂F²) G + U''/V b bᵀ with b = Σ_g w Gᵀ vec(H_g) = V ∂J̄/∂x_e.
    std::array<Matrix3d, 8> F;
    double volume = 0.0, Jbar = 1.0;
    if (!gauss_gradients(ue, x, F, volume, Jbar))
      for (const auto& gp : gauss_[ue]) (void)checked_deformation_gradient(ue, gp, x);  // throws, naming the element
    const double kappa = material_.bulk_modulus(), dU = kappa * (Jbar - 1);
    Eigen::Matrix<double, 24, 1> b = Eigen::Matrix<double, 24, 1>::Zero();
    for (int g = 0; g < 8; ++g) {
      const auto& gp = gauss_[ue][g];
      Tangent A = gauss_material_.tangent(F[g], false);
      A.noalias() += dU * determinant_hessian(F[g]);
      if (psd) project_to_psd(A, material_.lame().mu);
      add_point_stiffness(gp, A, K);
      const Matrix3d H = cofactor(F[g]);
      for (int a = 0; a < 8; ++a) b.segment<3>(3 * a) += gp.weight * (H * gp.grad[a]);
    }
    K.noalias() += (kappa / volume) * b * b.transpose();  // PSD; the lower blocks are mirrored below
  }
  for (int a = 1; a < 8; ++a)
    K.block(3 * a, 0, 3, 3 * a) = K.block(0, 3 * a, 3 * a, 3).transpose();
}

void HyperelasticHexElements::add_point_stiffness(const GaussPoint& gp, const Tangent& A, ElementMatrix& K) {
  Eigen::Matrix<double, 9, 24> AG;
  // G = ∂vec(F)/∂x_e has G(i + 3j, 3a + m) = δ_im g_a,j, so (A G)(:, 3a + n) = Σ_l A(:, n + 3l) g_a,l
    // and (Gᵀ A G)(3a + m, :) = Σ_j g_a,j (A G)(m + 3j, :): K = Σ_g w Gᵀ A G without forming G.
    for (int a = 0; a < 8; ++a) {
      const Vector3d& g = gp.grad[a];
      for (int n = 0; n < 3; ++n) AG.col(3 * a + n) = A.col(n) * g[0] + A.col(n + 3) * g[1] + A.col(n + 6) * g[2];
    }
    // K is symmetric: the blocks on and above the diagonal, mirrored below at the end.
    for (int a = 0; a < 8; ++a) {
      const Vector3d g = gp.weight * gp.grad[a];
      const int cols = 24 - 3 * a;
      K.block(3 * a, 3 * a, 3, cols).noalias() += g[0] * AG.block(0, 3 * a, 3, cols) +
                                                  g[1] * AG.block(3, 3 * a, 3, cols) +
                                                  g[2] * AG.block(6, 3 * a, 3, cols);
  }
}

void HyperelasticHexElements::for_each_element_stiffness(const Eigen::VectorXd& x, bool psd,
                                                         const std::function<void(int, const ElementMatrix&)>& add) const {
  for (const auto& group : colours_) {
    const int n = static_cast<int>(group.size());
    bool failed = false;
#pragma omp parallel
    {
      ElementMatrix K;
#pragma omp for schedule(dynamic, 1)
      for (int k = 0; k < n; ++k) {
        try {
          for (int e = group[static_cast<size_t>(k)].begin; e < group[static_cast<size_t>(k)].end; ++e) {
            element_stiffness(e, x, psd, K);
            add(e, K);
          }
        } catch (const Error&) {
#pragma omp atomic write
          failed = true;
        }
      }
    }
    if (failed)  // again on this thread, for the exception and its message
      for (const auto& run : group)
        for (int e = run.begin; e < run.end; ++e) {
          ElementMatrix K;
          element_stiffness(e, x, psd, K);
        }
  }
}

double HyperelasticHexElements::min_gauss_jacobian(const Eigen::VectorXd& x) const {
  const int ne = num_elements();
  double m = std::numeric_limits<double>::infinity();
#pragma omp parallel for schedule(static) reduction(min : m)
  for (int e = 0; e < ne; ++e) {
    const auto ue = static_cast<size_t>(e);
    for (const auto& gp : gauss_[ue])
      m = std::min(m, 8.0 * gp.weight * deformation_gradient(hexes_[ue], gp, x).determinant());
  }
  return m;
}

}  // namespace socketsmith::tissue
