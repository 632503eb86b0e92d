#include "socketsmith/tissue/static_solver.h"

#include <cmath>

#include <Eigen/CholmodSupport>
#include <Eigen/IterativeLinearSolvers>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"

namespace socketsmith::tissue {
namespace {

using Cholmod = Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower>;

/// Eigen preconditioner that applies an existing CHOLMOD factorisation.
class FactorPreconditioner {
 public:
  using Scalar = double;
  using RealScalar = double;
  using StorageIndex = int;
  enum { ColsAtCompileTime = Eigen::Dynamic, MaxColsAtCompileTime = Eigen::Dynamic };
  FactorPreconditioner() = default;
  template <class M>
  explicit FactorPreconditioner(const M&) {}
  template <class M>
  FactorPreconditioner& analyzePattern(const M&) { return *this; }
  template <class M>
  FactorPreconditioner& factorize(const M&) { return *this; }
  template <class M>
  FactorPreconditioner& compute(const M&) { return *this; }
  template <class Rhs>
  VectorXd solve(const Rhs& b) const { return factor ? VectorXd(factor->solve(b)) : VectorXd(b); }
  Eigen::ComputationInfo info() { return Eigen::Success; }
  const Cholmod* factor = nullptr;
};

}  // namespace

struct StaticSolver::Impl {
  SparseMatrix J, J_red, K, K_red;
  Cholmod chol;
  bool analyzed = false;
  bool factor_valid = false;
  double shift = 0.0;  // diagonal shift added when K_psd is only semi-definite
  int last_krylov_iterations = 0;
};

StaticSolver::StaticSolver(const MassSpringModel& model, const DofMap& dofs, const StaticSolverOptions& options)
    : model_(model), dofs_(dofs), options_(options), impl_(std::make_unique<Impl>()) {
  require(dofs.num_full() == model.num_dofs(), "StaticSolver: DofMap has {} DOFs, model has {}", dofs.num_full(),
          model.num_dofs());
  require(options.rel_tol > 0 && options.max_iterations >= 1 && options.max_line_search >= 1,
          "StaticSolver: invalid options (rel_tol {} > 0, max_iterations {} ≥ 1, max_line_search {} ≥ 1)",
          options.rel_tol, options.max_iterations, options.max_line_search);
  if (options_.force_scale_n <= 0) {
    // E · l² with l the mean element edge: the force that strains one element by 100 %.
    const double vol = model.mesh().num_hexahedra() > 0 ? volume::total_volume(model.mesh()) / model.num_elements() : 0;
    options_.force_scale_n = model.material().youngs_modulus_pa * std::pow(vol, 2.0 / 3.0) * 1e-3;
  }
}

StaticSolver::~StaticSolver() = default;

VectorXd static_residual(const MassSpringModel& model, const DofMap& dofs, const VectorXd& f_ext, const VectorXd& x) {
  return dofs.restrict_vector(model.elastic_forces(x) + f_ext);
}

StaticResult StaticSolver::solve(const VectorXd& f_ext, VectorXd& x) {
  require(f_ext.size() == model_.num_dofs() && x.size() == model_.num_dofs(),
          "StaticSolver::solve: f_ext has {} and x {} entries (expected 3N = {})", f_ext.size(), x.size(),
          model_.num_dofs());
  require(f_ext.allFinite(), "StaticSolver::solve: external forces contain NaN or inf");
  require(x.allFinite(), "StaticSolver::solve: initial positions contain NaN or inf");
  Impl& s = *impl_;
  StaticResult res;
  const VectorXd f_ext_red = dofs_.restrict_vector(f_ext);
  res.reference_force_n = std::max(f_ext_red.norm(), options_.force_scale_n);
  const double tol = options_.rel_tol * res.reference_force_n + options_.abs_tol_n;

  if (model_.min_corner_jacobian(x) <= 0) {
    res.message = "initial state has an inverted element";
    return res;
  }
  VectorXd r = static_residual(model_, dofs_, f_ext, x);
  double rnorm = r.norm();
  // Reuse the factorisation of the previous solve (warm start) unless it struggled.
  int& krylov_since_factor = s.last_krylov_iterations;

  auto factorize = [&]() -> bool {
    model_.jacobian(x, JacobianKind::SymmetricPsd, s.K);
    dofs_.reduce_matrix(s.K, s.K_red);
    s.K_red *= -1.0;  // K_psd = −J_psd
    if (!s.analyzed) {
      s.chol.analyzePattern(s.K_red);
      s.analyzed = true;
    }
    for (int attempt = 0; attempt < 6; ++attempt) {
      s.chol.setShift(s.shift);
      s.chol.factorize(s.K_red);
      if (s.chol.info() == Eigen::Success) {
        ++res.factorizations;
        s.factor_valid = true;
        return true;
      }
      // Semi-definite (e.g. an unconstrained rigid mode): shift by a small multiple of the diagonal.
      s.shift = s.shift == 0 ? 1e-10 * s.K_red.diagonal().cwiseAbs().maxCoeff() : s.shift * 100;
    }
    s.factor_valid = false;
    return false;
  };

  for (res.iterations = 0; res.iterations < options_.max_iterations; ++res.iterations) {
    if (!std::isfinite(rnorm)) {
      res.message = "diverged: residual is not finite";
      break;
    }
    if (rnorm <= tol) {
      res.converged = true;
      break;
    }
    if (!s.factor_valid || krylov_since_factor > options_.refactor_krylov_iterations) {
      if (!factorize()) {
        res.message = "the stiffness matrix is singular: the model is not constrained against rigid motion";
        break;
      }
    }
    model_.jacobian(x, JacobianKind::Exact, s.J);
    dofs_.reduce_matrix(s.J, s.J_red);
    // Solve (−J) δ = r.
    s.J_red *= -1.0;
    Eigen::BiCGSTAB<SparseMatrix, FactorPreconditioner> krylov;
    krylov.preconditioner().factor = &s.chol;
    krylov.setTolerance(options_.krylov_rel_tol);
    krylov.setMaxIterations(options_.max_krylov_iterations);
    krylov.compute(s.J_red);
    VectorXd delta = krylov.solve(r);
    res.krylov_iterations += static_cast<int>(krylov.iterations());
    krylov_since_factor = static_cast<int>(krylov.iterations());
    if (krylov.info() != Eigen::Success || !delta.allFinite()) {
      // Fall back to the SPD (modified Newton) direction and refresh the factorisation next time.
      delta = s.chol.solve(r);
      krylov_since_factor = options_.refactor_krylov_iterations + 1;
    }
    if (options_.max_step_m > 0) {
      const double m = delta.cwiseAbs().maxCoeff();
      if (m > options_.max_step_m) delta *= options_.max_step_m / m;
    }
    // Backtracking line search on ‖r‖, rejecting inverted elements.
    double t = 1.0;
    bool accepted = false;
    VectorXd x_try(x.size());
    for (int ls = 0; ls < options_.max_line_search; ++ls, t *= 0.5) {
      x_try = x;
      dofs_.add_expanded(t * delta, x_try);
      if (model_.min_corner_jacobian(x_try) <= 0) continue;
      VectorXd r_try = static_residual(model_, dofs_, f_ext, x_try);
      const double n_try = r_try.norm();
      if (std::isfinite(n_try) && n_try < (1.0 - 1e-4 * t) * rnorm) {
        x = x_try;
        r = std::move(r_try);
        rnorm = n_try;
        accepted = true;
        break;
      }
    }
    if (!accepted) {
      if (krylov_since_factor <= options_.refactor_krylov_iterations) {
        krylov_since_factor = options_.refactor_krylov_iterations + 1;  // retry with a fresh factorisation
        continue;
      }
      res.message = fmt::format("diverged: no step along the Newton direction reduces the residual ({:.3g} N)", rnorm);
      break;
    }
  }
  res.residual_n = rnorm;
  if (res.converged) {
    res.message = fmt::format("converged in {} iterations, residual {:.3g} N", res.iterations, rnorm);
  } else if (res.message.empty()) {
    res.message = fmt::format("not converged after {} iterations (residual {:.3g} N, tolerance {:.3g} N)",
                              res.iterations, rnorm, tol);
  }
  log::debug("StaticSolver: {} ({} Krylov iterations, {} factorisations)", res.message, res.krylov_iterations,
             res.factorizations);
  return res;
}

}  // namespace socketsmith::tissue
