#include "socketsmith/tissue/static_solver.h"

#include <cmath>
#include <mutex>

#include <dlfcn.h>

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

/// CHOLMOD's supernodes on these meshes are small: OpenBLAS's own threads only add overhead
/// (measured: a 1k-node solve took 4.6 s wall with them, 2.7 s without). Ask OpenBLAS, when it
/// is the BLAS in use, to run single-threaded; other BLAS libraries are left alone.
void limit_blas_threads() {
  static std::once_flag once;
  std::call_once(once, [] {
    using SetThreads = void (*)(int);
    if (auto* f = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) f(1);
  });
}

}  // namespace

struct StaticSolver::Impl {
  SparseMatrix J, J_red, K, K_red;
  Cholmod chol;
  bool analyzed = false;
  bool factor_valid = false;
  double shift = 0.0;  // diagonal shift added when K_psd is only semi-definite
  int last_krylov_iterations = 0;
  int krylov_after_factor = -1;  // Krylov iterations of the first solve after the last factorisation
};

StaticSolver::StaticSolver(const MassSpringModel& model, const DofMap& dofs, const StaticSolverOptions& options)
    : model_(model), dofs_(dofs), options_(options), impl_(std::make_unique<Impl>()) {
  limit_blas_threads();
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

/// One Newton solve toward @p f_ext from @p x, at most @p max_iterations iterations, to
/// residual @p tol. Accumulates statistics into @p res; on failure @p x holds the last iterate.
bool StaticSolver::newton(const VectorXd& f_ext, VectorXd& x, int max_iterations, double tol, StaticResult& res) {
  Impl& s = *impl_;
  VectorXd r = static_residual(model_, dofs_, f_ext, x);
  double rnorm = r.norm();
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
        s.krylov_after_factor = -1;  // measured by the next Krylov solve
        return true;
      }
      // Semi-definite (e.g. an unconstrained rigid mode): shift by a small multiple of the diagonal.
      s.shift = s.shift == 0 ? 1e-10 * s.K_red.diagonal().cwiseAbs().maxCoeff() : s.shift * 100;
    }
    s.factor_valid = false;
    return false;
  };
  // Refactorise when the preconditioner has aged: BiCGSTAB needs clearly more iterations than it
  // did right after the last factorisation (and more than the configured floor).
  auto stale = [&] {
    return s.krylov_after_factor >= 0 &&
           s.last_krylov_iterations > std::max(options_.refactor_krylov_iterations, 2 * s.krylov_after_factor);
  };
  for (int it = 0; it < max_iterations; ++it, ++res.iterations) {
    if (!std::isfinite(rnorm)) {
      res.message = "diverged: residual is not finite";
      return false;
    }
    if (rnorm <= tol) {
      res.residual_n = rnorm;
      return true;
    }
    const bool fresh = !s.factor_valid || stale();
    if (fresh) {
      if (!factorize()) {
        res.message = "the stiffness matrix is singular: the model is not constrained against rigid motion";
        return false;
      }
    }
    model_.jacobian(x, JacobianKind::Exact, s.J);
    dofs_.reduce_matrix(s.J, s.J_red);
    s.J_red *= -1.0;  // solve (−J) δ = r
    Eigen::BiCGSTAB<SparseMatrix, FactorPreconditioner> krylov;
    krylov.preconditioner().factor = &s.chol;
    krylov.setTolerance(options_.krylov_rel_tol);
    krylov.setMaxIterations(options_.max_krylov_iterations);
    krylov.compute(s.J_red);
    VectorXd delta = krylov.solve(r);
    const int kit = static_cast<int>(krylov.iterations());
    res.krylov_iterations += kit;
    s.last_krylov_iterations = kit;
    if (s.krylov_after_factor < 0) s.krylov_after_factor = kit;
    const bool krylov_ok = krylov.info() == Eigen::Success && delta.allFinite();
    if (!krylov_ok) {
      // Fall back to the SPD (modified Newton) direction and refresh the factorisation next time.
      delta = s.chol.solve(r);
      s.factor_valid = false;
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
        log::debug("  Newton {}: |r| {:.3e} -> {:.3e} N, step {:.3g}, {} Krylov iterations{}", it, rnorm, n_try, t,
                   kit, krylov_ok ? "" : " (Krylov failed)");
        x = x_try;
        r = std::move(r_try);
        rnorm = n_try;
        accepted = true;
        break;
      }
    }
    if (!accepted) {
      if (!fresh) {
        s.factor_valid = false;  // retry with a fresh factorisation at this iterate
        continue;
      }
      res.residual_n = rnorm;
      res.message = fmt::format("diverged: no step along the Newton direction reduces the residual ({:.3g} N)", rnorm);
      return false;
    }
  }
  res.residual_n = rnorm;
  res.message = fmt::format("not converged after {} iterations (residual {:.3g} N, tolerance {:.3g} N)", max_iterations,
                            rnorm, tol);
  return false;
}

StaticResult StaticSolver::solve(const VectorXd& f_ext, VectorXd& x) {
  require(f_ext.size() == model_.num_dofs() && x.size() == model_.num_dofs(),
          "StaticSolver::solve: f_ext has {} and x {} entries (expected 3N = {})", f_ext.size(), x.size(),
          model_.num_dofs());
  require(f_ext.allFinite(), "StaticSolver::solve: external forces contain NaN or inf");
  require(x.allFinite(), "StaticSolver::solve: initial positions contain NaN or inf");
  StaticResult res;
  res.reference_force_n = std::max(dofs_.restrict_vector(f_ext).norm(), options_.force_scale_n);
  const double tol = options_.rel_tol * res.reference_force_n + options_.abs_tol_n;
  if (model_.min_corner_jacobian(x) <= 0) {
    res.message = "initial state has an inverted element";
    return res;
  }
  const VectorXd x0 = x;
  // 1. Plain Newton from the warm start (the common case: a small load change).
  res.converged = newton(f_ext, x, options_.continuation_newton_iterations, tol, res);
  // 2. Otherwise, load continuation from the load the initial state already balances,
  //    f(λ) = f₀ + λ (f_ext − f₀) with f₀ = −f_int(x₀), λ: 0 → 1 in adaptive steps.
  if (!res.converged) {
    log::debug("StaticSolver: direct Newton failed ({}); continuing the load", res.message);
    x = x0;
    const VectorXd f0 = -model_.elastic_forces(x0);
    double lambda = 0.0, step = 0.25;
    const double loose_tol = std::max(tol, 1e3 * options_.rel_tol * res.reference_force_n);
    while (lambda < 1.0) {
      const double target = std::min(1.0, lambda + step);
      VectorXd x_try = x;
      const VectorXd f = f0 + target * (f_ext - f0);
      const bool last = target >= 1.0;
      log::debug("StaticSolver: load step {:.4g} -> {:.4g}", lambda, target);
      if (newton(f, x_try, options_.continuation_newton_iterations, last ? tol : loose_tol, res)) {
        x = std::move(x_try);
        step = std::min(2.0 * (target - lambda), 1.0);
        lambda = target;
        ++res.load_steps;
      } else {
        step = 0.5 * (target - lambda);
        if (step < options_.min_load_step) {
          res.message = fmt::format("diverged: load continuation stalled at {:.1f}% of the load ({})", 100 * lambda,
                                    res.message);
          break;
        }
      }
    }
    res.converged = lambda >= 1.0;
  }
  if (res.converged) {
    res.message = fmt::format("converged in {} iterations{}, residual {:.3g} N", res.iterations,
                              res.load_steps > 0 ? fmt::format(" ({} load steps)", res.load_steps) : std::string(),
                              res.residual_n);
  }
  log::debug("StaticSolver: {} ({} Krylov iterations, {} factorisations)", res.message, res.krylov_iterations,
             res.factorizations);
  return res;
}

}  // namespace socketsmith::tissue
