#include "socketsmith/tissue/static_solver.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <mutex>
#include <vector>

#include <dlfcn.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include <Eigen/Dense>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseLU>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/tissue/newton_loop.h"
#include "socketsmith/tissue/sparse_cholesky.h"
#include "socketsmith/volume/hex_element.h"

namespace socketsmith::tissue {
namespace {

using Cholmod = SparseCholesky<Eigen::Lower>;

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

#ifdef _OPENMP
namespace {
/// The cores other processes leave free, at most @p allowed. The 1-minute load average counts this
/// process's own running thread too, so one is given back: OpenMP's dynamic teams (cores − load)
/// gave a solve running for more than a few seconds one thread on 2 cores however idle the
/// machine was (8k closed loop: 52.9 s with them, 45.0 s with 2 threads; same outputs).
int free_cores(int allowed) {
  double load = 0.0;
  if (getloadavg(&load, 1) != 1) return allowed;
  const double busy = std::max(0.0, load - 1.0);
  const int free = static_cast<int>(std::lround(static_cast<double>(omp_get_num_procs()) - busy));
  return std::clamp(free, 1, allowed);
}
}  // namespace
#endif

void limit_solver_threads() {
  // CHOLMOD's supernodes on these meshes are small: OpenBLAS's own threads only add overhead
  // (measured: a 1k-node solve took 4.6 s wall with them, 2.7 s without). Ask OpenBLAS, when it
  // is the BLAS in use, to run single-threaded; other BLAS libraries are left alone.
  static std::once_flag once;
  std::call_once(once, [] {
    using SetThreads = void (*)(int);
    if (auto* f = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) f(1);
  });
#ifdef _OPENMP
  // The solvers' own loops (element forces and stiffness, gap queries) get the free cores, no
  // more than the thread allowed before its first solve (OMP_NUM_THREADS, or 1 set by the GUI's
  // worker). CHOLMOD's regions, which ask for 4 threads whatever the setting, run serial
  // (SerialParallelRegions in sparse_cholesky.h). Per thread: call it on each solving thread.
  thread_local const int allowed = omp_get_max_threads();
  omp_set_dynamic(0);
  omp_set_num_threads(free_cores(allowed));
#endif
}

SerialParallelRegions::SerialParallelRegions() {
#ifdef _OPENMP
  levels_ = omp_get_max_active_levels();
  omp_set_max_active_levels(0);
#endif
}

SerialParallelRegions::~SerialParallelRegions() {
#ifdef _OPENMP
  omp_set_max_active_levels(levels_);
#endif
}

struct StaticSolver::Impl {
  Impl(const MassSpringModel& m, const DofMap& d, const StaticSolverOptions& o) : model(m), dofs(d), opt(o) {}
  const MassSpringModel& model;
  const DofMap& dofs;
  const StaticSolverOptions& opt;  // the solver's (its force scale is set after this is made)
  SparseMatrix J, J_red, K, K_red;
  Cholmod chol;
  Eigen::SparseLU<SparseMatrix> lu;  // fallback when BiCGSTAB fails with a fresh preconditioner
  bool lu_analyzed = false;
  // Line searches that found no acceptable step in this solve, and how many of them had trial
  // points rejected because an element inverted.
  int failed_searches = 0;
  int failed_searches_inverting = 0;
  double shift = 0.0;  // diagonal shift added when K_psd is only semi-definite
  int last_krylov_iterations = 0;
  int krylov_after_factor = -1;  // Krylov iterations of the first solve after the last factorisation

  /// The preconditioner: the PSD stiffness at @p x factorised (shifted when only semi-definite).
  /// False when it stays singular.
  bool factorize(const VectorXd& x, StaticResult& res);
  /// The preconditioner has aged: BiCGSTAB needs clearly more iterations than it did right after
  /// the last factorisation (and more than the configured floor).
  bool stale() const {
    return krylov_after_factor >= 0 && last_krylov_iterations > std::max(opt.refactor_krylov_iterations, 2 * krylov_after_factor);
  }
  /// Newton's direction at @p x for the residual @p r (BiCGSTAB on the exact tangent, preconditioned;
  /// sparse LU when that fails with a @p fresh preconditioner). False: retry this iterate with a
  /// fresh factorisation.
  bool direction(const AppliedLoad& load, const VectorXd& x, const VectorXd& r, bool fresh, StaticResult& res,
                 VectorXd& delta, int& kit, bool& krylov_ok);
  /// Backtracking line search on ‖r‖ along @p delta, rejecting inverted elements; on success @p x,
  /// @p r and @p rnorm are the accepted point's.
  bool line_search(const AppliedLoad& load, const VectorXd& delta, int it, int kit, bool krylov_ok, VectorXd& x,
                   VectorXd& r, double& rnorm, int& inverted_trials);
};

bool StaticSolver::Impl::factorize(const VectorXd& x, StaticResult& res) {
  model.jacobian(x, JacobianKind::SymmetricPsd, K);
  dofs.reduce_matrix(K, K_red);
  K_red *= -1.0;  // K_psd = −J_psd
  for (int attempt = 0; attempt < 6; ++attempt) {
    if (chol.factorize(K_red, shift)) {
      ++res.factorizations;
      krylov_after_factor = -1;  // measured by the next Krylov solve
      return true;
    }
    // Semi-definite (e.g. an unconstrained rigid mode): shift by a small multiple of the diagonal.
    shift = shift == 0 ? 1e-10 * K_red.diagonal().cwiseAbs().maxCoeff() : shift * 100;
  }
  return false;
}

bool StaticSolver::Impl::direction(const AppliedLoad& load, const VectorXd& x, const VectorXd& r, bool fresh,
                                   StaticResult& res, VectorXd& delta, int& kit, bool& krylov_ok) {
  model.jacobian(x, JacobianKind::Exact, J);
  if (load.moving) load.moving->add_jacobian(x, load.scale, J);
  dofs.reduce_matrix(J, J_red);
  J_red *= -1.0;  // solve (−J) δ = r
  Eigen::BiCGSTAB<SparseMatrix, FactorPreconditioner> krylov;
  krylov.preconditioner().factor = &chol;
  krylov.setTolerance(opt.krylov_rel_tol);
  krylov.setMaxIterations(opt.max_krylov_iterations);
  krylov.compute(J_red);
  delta = krylov.solve(r);
  kit = static_cast<int>(krylov.iterations());
  res.krylov_iterations += kit;
  last_krylov_iterations = kit;
  if (krylov_after_factor < 0) krylov_after_factor = kit;
  krylov_ok = krylov.info() == Eigen::Success && delta.allFinite();
  if (!krylov_ok && !fresh) {
    chol.invalidate();  // retry this iterate with a fresh preconditioner
    return false;
  }
  if (!krylov_ok) {
    // BiCGSTAB failed even with a fresh preconditioner (e.g. an indefinite tangent): solve the
    // true tangent by sparse LU, so that the direction is the exact Newton direction.
    J_red.makeCompressed();
    if (!lu_analyzed) {
      lu.analyzePattern(J_red);
      lu_analyzed = true;
    }
    lu.factorize(J_red);
    if (lu.info() == Eigen::Success) delta = lu.solve(r);
    if (lu.info() == Eigen::Success && delta.allFinite()) {
      ++res.direct_solves;
    } else {
      delta = chol.solve(r);  // singular tangent: the SPD (modified Newton) direction
    }
    chol.invalidate();
  }
  if (opt.max_step_m > 0) {
    const double m = delta.cwiseAbs().maxCoeff();
    if (m > opt.max_step_m) delta *= opt.max_step_m / m;
  }
  return true;
}

bool StaticSolver::Impl::line_search(const AppliedLoad& load, const VectorXd& delta, int it, int kit, bool krylov_ok,
                                     VectorXd& x, VectorXd& r, double& rnorm, int& inverted_trials) {
  double t = 1.0;
  inverted_trials = 0;
  VectorXd x_try(x.size());
  for (int ls = 0; ls < opt.max_line_search; ++ls, t *= 0.5) {
    x_try = x;
    dofs.add_expanded(t * delta, x_try);
    if (model.has_inverted_element(x_try)) {
      ++inverted_trials;
      continue;
    }
    VectorXd r_try = static_residual(model, dofs, load.at(x_try), x_try);
    const double n_try = r_try.norm();
    if (std::isfinite(n_try) && n_try < (1.0 - 1e-4 * t) * rnorm) {
      log::debug("  Newton {}: |r| {:.3e} -> {:.3e} N, step {:.3g}, {} Krylov iterations{}{}", it, rnorm, n_try, t, kit,
                 krylov_ok ? "" : " (Krylov failed)",
                 inverted_trials > 0 ? fmt::format(", {} trial step(s) inverted an element", inverted_trials) : "");
      x = x_try;
      r = std::move(r_try);
      rnorm = n_try;
      return true;
    }
  }
  return false;
}

StaticSolver::StaticSolver(const MassSpringModel& model, const DofMap& dofs, const StaticSolverOptions& options)
    : model_(model), dofs_(dofs), options_(options), impl_(std::make_unique<Impl>(model, dofs, options_)) {
  limit_solver_threads();
  require(dofs.num_full() == model.num_dofs(), "StaticSolver: DofMap has {} DOFs, model has {}", dofs.num_full(),
          model.num_dofs());
  require(options.stall_iterations >= 0, "StaticSolver: stall_iterations {} (expected ≥ 0)", options.stall_iterations);
  require(options.stall_reduction > 0 && options.stall_reduction < 1,
          "StaticSolver: stall_reduction {} (expected in (0, 1))", options.stall_reduction);
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

std::string StaticSolver::stall_diagnosis(const VectorXd& x, StaticResult& res, double path_stiffness_ratio) const {
  const Impl& s = *impl_;
  describe_state(x, res);
  std::vector<std::string> signs;
  std::string facts;
  if (res.worst_element >= 0) {
    const auto& hex = model_.mesh().hexahedra[res.worst_element];
    volume::HexNodes x0, xe;
    for (int k = 0; k < 8; ++k) {
      x0[k] = model_.rest_positions().segment<3>(3 * hex[k]);
      xe[k] = x.segment<3>(3 * hex[k]);
    }
    const auto sj0 = volume::corner_scaled_jacobians(x0);
    const double rest_sj = *std::min_element(sj0.begin(), sj0.end());
    const double dv = volume::hex_volume(xe) / volume::hex_volume(x0) - 1.0;
    const bool collapsing = res.worst_scaled_jacobian < 0.05 || res.worst_scaled_jacobian < 0.1 * rest_sj;
    facts += fmt::format("element {} is {} (corner scaled Jacobian {:.3g}, {:.3g} at rest; volume change {:+.1f}%)",
                         res.worst_element, collapsing ? "collapsing" : "the most distorted", res.worst_scaled_jacobian,
                         rest_sj, 100 * dv);
    if (collapsing) signs.push_back(fmt::format("element {} collapses", res.worst_element));
  }
  if (s.failed_searches > 0)
    facts += fmt::format("; {} of {} failed line searches had trial steps that invert an element", s.failed_searches_inverting,
                         s.failed_searches);
  ElementStabilityRange range;
  res.elements_outside_stable_range = count_outside_stable_range(x, range);
  facts += fmt::format("; element volume changes {:+.1f}% to {:+.1f}% ({} element(s) outside {:+.1f}% to {:+.1f}%, the "
                       "range in which one cube element of this model is stable)",
                       100 * res.min_volume_change, 100 * res.max_volume_change, res.elements_outside_stable_range,
                       100 * range.min_volume_change, 100 * range.max_volume_change);
  std::string indication;
  if (res.elements_outside_stable_range > 0)
    indication = fmt::format("{} element(s) beyond the volume change at which one element of this model is stable",
                             res.elements_outside_stable_range);
  if (path_stiffness_ratio > 0) {
    facts += fmt::format("; the last load step's secant stiffness is {:.2g}% of the first's", 100 * path_stiffness_ratio);
    if (path_stiffness_ratio < 0.05) signs.push_back("the load-displacement path is nearly flat");
  }
  if (options_.stability_check_max_dofs > 0 && dofs_.num_reduced() <= options_.stability_check_max_dofs) {
    res.stability = tangent_stability(model_, dofs_, x);
    const auto& st = res.stability;
    if (st.computed) {
      facts += fmt::format("; tangent at that state: det {}, softest eigenvalue {:.3g} N/m ({:.2g} of the largest "
                           "diagonal{}, largest at node {})",
                           st.determinant_sign < 0 ? "< 0" : st.determinant_sign > 0 ? "> 0" : "= 0 (singular)",
                           st.softest_eigenvalue, st.softest_eigenvalue / st.max_diagonal,
                           st.softest_converged ? "" : ", not converged", st.softest_mode_node);
      if (st.determinant_sign < 0) signs.push_back("the tangent has a negative eigenvalue (unstable equilibrium)");
      if (st.determinant_sign == 0 ||
          (st.softest_converged && std::abs(st.softest_eigenvalue) < 1e-4 * st.max_diagonal))
        signs.push_back("the tangent is nearly singular");
    }
  }
  std::string verdict;
  if (signs.empty() && indication.empty()) {
    verdict = "no sign of a loss of stability was found";
  } else {
    if (!indication.empty()) signs.push_back(indication);
    verdict = signs.size() == 1 && !indication.empty() ? "the tissue model likely loses stability here ("
                                                       : "the tissue model loses stability here (";
    for (size_t i = 0; i < signs.size(); ++i) verdict += (i ? ", " : "") + signs[i];
    verdict += "): a property of the model under this load, not an inaccurate linear solve (docs/tissue.md)";
  }
  return fmt::format("at the last equilibrium {}; {}", facts, verdict);
}

/// The static solve's half of Newton (newton_loop.h): the iterate x, its residual r = Pᵀ(f_int + f_ext),
/// BiCGSTAB on the exact tangent preconditioned by the reused CHOLMOD factor of K_psd (renewed
/// when it has aged, or for a retry), a backtracking line search on ‖r‖ that rejects inverted
/// elements.
class StaticSolver::Newton final : public NewtonProblem {
 public:
  Newton(StaticSolver::Impl& s, const AppliedLoad& load, VectorXd& x, double tol, StaticResult& res)
      : s_(s), load_(load), x_(x), tol_(tol), res_(res), r_(static_residual(s.model, s.dofs, load.at(x), x)),
        rnorm_(r_.norm()) {}
  double residual_norm() const override { return rnorm_; }
  double tolerance() const override { return tol_; }
  Result direction() override {
    fresh_ = !s_.chol.valid() || s_.stale();
    if (fresh_ && !s_.factorize(x_, res_)) {
      reason_ = "the stiffness matrix is singular: the model is not constrained against rigid motion";
      return Result::Failed;
    }
    return s_.direction(load_, x_, r_, fresh_, res_, delta_, kit_, krylov_ok_) ? Result::Done : Result::RetryFresh;
  }
  Result line_search() override {
    int inverted_trials = 0;
    if (s_.line_search(load_, delta_, it_, kit_, krylov_ok_, x_, r_, rnorm_, inverted_trials)) {
      ++it_;
      return Result::Done;
    }
    if (!fresh_) {
      s_.chol.invalidate();  // retry with a fresh factorisation at this iterate
      return Result::RetryFresh;
    }
    ++s_.failed_searches;
    if (inverted_trials > 0) ++s_.failed_searches_inverting;
    return Result::Failed;
  }
  std::string stop_reason() const override { return reason_; }

 private:
  StaticSolver::Impl& s_;
  const AppliedLoad& load_;
  VectorXd& x_;
  double tol_;
  StaticResult& res_;
  VectorXd r_, delta_;
  double rnorm_;
  bool fresh_ = false, krylov_ok_ = false;
  int kit_ = 0, it_ = 0;
  std::string reason_;
};

/// One Newton solve toward @p load from @p x, at most @p max_iterations iterations, to
/// residual @p tol. Accumulates statistics into @p res; on failure @p x holds the last iterate.
bool StaticSolver::newton(const AppliedLoad& load, VectorXd& x, int max_iterations, double tol, StaticResult& res,
                          int stall_iterations) {
  Newton problem(*impl_, load, x, tol, res);
  NewtonLoopOptions o;
  o.max_iterations = max_iterations;
  o.stall_iterations = stall_iterations;
  o.stall_reduction = options_.stall_reduction;
  const NewtonOutcome out = run_newton(problem, o);
  res.iterations += out.iterations;
  res.residual_n = out.residual;
  if (!out.ok()) res.message = out.message;
  return out.ok();
}

StaticResult StaticSolver::solve(const VectorXd& f_ext, VectorXd& x) {
  require(f_ext.size() == model_.num_dofs() && x.size() == model_.num_dofs(),
          "StaticSolver::solve: f_ext has {} and x {} entries (expected 3N = {})", f_ext.size(), x.size(),
          model_.num_dofs());
  require(f_ext.allFinite(), "StaticSolver::solve: external forces contain NaN or inf");
  return solve_load({f_ext, nullptr, 0.0}, x);
}

StaticResult StaticSolver::solve(const PositionDependentLoad& load, VectorXd& x) {
  require(x.size() == model_.num_dofs(), "StaticSolver::solve: x has {} entries (expected 3N = {})", x.size(),
          model_.num_dofs());
  return solve_load({VectorXd::Zero(model_.num_dofs()), &load, 1.0}, x);
}

bool StaticSolver::continue_load(const AppliedLoad& load, const VectorXd& x0, double tol, VectorXd& x,
                                 StaticResult& res) {
  x = x0;
  const VectorXd f0 = -model_.elastic_forces(x0);
  double lambda = 0.0, step = 0.25;
  const double loose_tol = std::max(tol, 1e3 * options_.rel_tol * res.reference_force_n);
  // Secant stiffness of the path, Δλ/‖Δx‖, of the first and of the last accepted load step: their
  // ratio tells how much the structure has softened (→ 0 at a limit point or a collapse).
  double first_stiffness = 0.0, last_stiffness = 0.0;
  while (lambda < 1.0) {
    const double target = std::min(1.0, lambda + step);
    VectorXd x_try = x;
    const AppliedLoad f{(1.0 - target) * f0 + target * load.constant, load.moving, target * load.scale};
    const bool last = target >= 1.0;
    log::debug("StaticSolver: load step {:.4g} -> {:.4g}", lambda, target);
    if (newton(f, x_try, options_.continuation_newton_iterations, last ? tol : loose_tol, res)) {
      const double moved = (x_try - x).norm();
      if (moved > 0) {
        last_stiffness = (target - lambda) / moved;
        if (first_stiffness == 0.0) first_stiffness = last_stiffness;
      }
      x = std::move(x_try);
      step = std::min(2.0 * (target - lambda), 1.0);
      lambda = target;
      ++res.load_steps;
    } else {
      step = 0.5 * (target - lambda);
      const double ratio = first_stiffness > 0 ? last_stiffness / first_stiffness : 0.0;
      const bool flat = res.load_steps >= 2 && ratio > 0 && ratio < options_.collapse_stiffness_ratio;
      if (step < options_.min_load_step || flat) {
        res.load_fraction = lambda;
        res.message = fmt::format("diverged: load continuation stalled at {:.1f}% of the load ({}{}); {}", 100 * lambda,
                                  res.message,
                                  flat ? fmt::format("; stopped: the path's stiffness fell below {:.2g}% of its initial "
                                                     "value (collapse_stiffness_ratio)",
                                                     100 * options_.collapse_stiffness_ratio)
                                       : std::string(),
                                  stall_diagnosis(x, res, ratio));
        break;
      }
    }
  }
  return lambda >= 1.0;
}

void StaticSolver::check_stability(const VectorXd& x, StaticResult& res) const {
  res.stability = tangent_stability(model_, dofs_, x);
  ElementStabilityRange range;
  res.elements_outside_stable_range = count_outside_stable_range(x, range);
  if (res.stability.determinant_sign < 0) {
    res.converged = false;
    res.message = fmt::format(
        "unstable: converged to an equilibrium (residual {:.3g} N) whose tangent has a negative eigenvalue "
        "(det < 0; softest eigenvalue {:.3g} N/m, largest at node {}; element volume changes {:+.1f}% to {:+.1f}%): "
        "the tissue model cannot hold this state (docs/tissue.md)",
        res.residual_n, res.stability.softest_eigenvalue, res.stability.softest_mode_node,
        100 * res.min_volume_change, 100 * res.max_volume_change);
  }
}

StaticResult StaticSolver::solve_load(const AppliedLoad& load, VectorXd& x) {
  require(x.allFinite(), "StaticSolver::solve: initial positions contain NaN or inf");
  StaticResult res;
  if (model_.has_inverted_element(x)) {
    res.message = "initial state has an inverted element";
    return res;
  }
  const VectorXd f_start = load.at(x);
  require(f_start.size() == model_.num_dofs() && f_start.allFinite(),
          "StaticSolver::solve: the external forces at the initial state contain NaN or inf (or have {} entries, "
          "expected {})", f_start.size(), model_.num_dofs());
  res.reference_force_n = std::max(dofs_.restrict_vector(f_start).norm(), options_.force_scale_n);
  const double tol = options_.rel_tol * res.reference_force_n + options_.abs_tol_n;
  impl_->failed_searches = impl_->failed_searches_inverting = 0;
  const VectorXd x0 = x;
  // 1. Plain Newton from the warm start (the common case: a small load change).
  res.converged = newton(load, x, options_.continuation_newton_iterations, tol, res, options_.stall_iterations);
  if (res.converged) res.load_fraction = 1.0;
  // 2. Otherwise, load continuation from the load the initial state already balances,
  //    f(λ) = f₀ + λ (f_ext − f₀) with f₀ = −f_int(x₀), λ: 0 → 1 in adaptive steps (a
  //    position-dependent part of f_ext is scaled by λ as it moves).
  if (!res.converged) {
    log::debug("StaticSolver: direct Newton failed ({}); continuing the load", res.message);
    res.converged = continue_load(load, x0, tol, x, res);
    if (res.converged) res.load_fraction = 1.0;
  }
  if (res.worst_element < 0) describe_state(x, res);
  if (res.converged && options_.check_stability && options_.stability_check_max_dofs > 0 &&
      dofs_.num_reduced() <= options_.stability_check_max_dofs)
    check_stability(x, res);
  if (res.converged) {
    res.message = fmt::format("converged in {} iterations{}, residual {:.3g} N", res.iterations,
                              res.load_steps > 0 ? fmt::format(" ({} load steps)", res.load_steps) : std::string(),
                              res.residual_n);
    if (res.elements_outside_stable_range > 0)  // only computed with check_stability
      res.message += fmt::format("; warning: {} element(s) beyond the volume change at which one element of this "
                                 "model is stable (volume changes {:+.1f}% to {:+.1f}%): the equilibrium may be unstable",
                                 res.elements_outside_stable_range, 100 * res.min_volume_change,
                                 100 * res.max_volume_change);
  }
  log::debug("StaticSolver: {} ({} Krylov iterations, {} factorisations, {} direct solves)", res.message,
             res.krylov_iterations, res.factorizations, res.direct_solves);
  return res;
}

}  // namespace socketsmith::tissue
