#pragma once
/// @file newton_loop.h
/// The Newton iteration of every nonlinear solve of socketsmith: the static and design solves
/// (StaticSolver: Newton–BiCGSTAB on the tissue's residual, backtracking on ‖r‖) and donning and
/// standing (contact::ContactSolver: Newton–CHOLMOD on the contact's incremental potential, a line
/// search on it). One loop owns what the solves share — the convergence test, the iteration budget,
/// the residual's stall test, the retry of an iterate with a fresh factorisation (a direction or a
/// line search that failed on a reused one is not an iteration), the acceptance of an iterate short
/// of the tolerance that the problem vouches for, and the one-line diagnosis when it stops short;
/// the problem (NewtonProblem) owns the iterate, its residual, its tangent and factorisation, its
/// direction and its line search. Load stepping (StaticSolver::continue_load) and path refinement
/// (ContactSolver's sub-steps and pushes) call it once per step.

#include <string>

namespace socketsmith::tissue {

/// Why a Newton solve ended.
enum class NewtonStop {
  Converged,         ///< the residual is within the tolerance
  Accepted,          ///< the problem accepted an iterate above the tolerance (e.g. a node on a kink of the wall)
  NotFinite,         ///< the residual is NaN or infinite
  Stalled,           ///< the residual fell by less than stall_reduction over stall_iterations iterations
  NoDirection,       ///< the problem found no Newton direction (e.g. a singular tangent)
  LineSearchFailed,  ///< no step along the direction was accepted, even with a fresh factorisation
  IterationLimit,    ///< max_iterations directions taken
  Stopped,           ///< the problem stopped the solve (NewtonProblem::stop_reason says why)
};

struct NewtonLoopOptions {
  int max_iterations = 80;  ///< Newton directions per solve, ≥ 0 (retries of an iterate not counted)
  /// The stall test: the solve stops when the residual has fallen by less than stall_reduction
  /// over the last stall_iterations iterations (0: no test).
  int stall_iterations = 0;
  double stall_reduction = 1.0 / 3;  ///< in (0, 1)
};

/// What a Newton solve did. `iterations` counts the directions taken (a retry of the same iterate
/// with a fresh factorisation is not one).
struct NewtonOutcome {
  NewtonStop stop = NewtonStop::NotFinite;
  int iterations = 0;
  double residual = 0.0;   ///< ‖r‖ at the last iterate
  double tolerance = 0.0;  ///< the tolerance there
  std::string message;     ///< one line: how it ended, and for a failure why
  bool ok() const { return stop == NewtonStop::Converged || stop == NewtonStop::Accepted; }
};

/// The problem-specific half of a Newton solve. The problem holds the current iterate; the loop
/// asks for its residual, a direction from it and a step along that direction.
class NewtonProblem {
 public:
  virtual ~NewtonProblem() = default;

  /// ‖r‖ at the current iterate and the tolerance it must reach there (both may depend on the
  /// iterate, e.g. the contact forces).
  virtual double residual_norm() const = 0;
  virtual double tolerance() const = 0;

  /// What a direction or a line search reports: done, retry the same iterate with a fresh
  /// factorisation (the problem has discarded its old one; at most once per iterate is the
  /// problem's promise, not the loop's), or failed.
  enum class Result { Done, RetryFresh, Failed };

  /// Called before each direction (iteration @p it from 0): false stops the solve (NewtonStop::Stopped;
  /// e.g. an iteration budget shared by many solves).
  virtual bool proceed(int it) { return it >= 0; }
  /// Computes Newton's direction at the current iterate.
  virtual Result direction() = 0;
  /// Moves the iterate along the last direction (a line search); on Done the iterate, its residual
  /// and tolerance are the accepted point's.
  virtual Result line_search() = 0;
  /// What follows an accepted step: go on, accept the iterate short of the tolerance
  /// (NewtonStop::Accepted), or stop (NewtonStop::Stopped).
  enum class Next { Continue, Accept, Stop };
  virtual Next after_step() { return Next::Continue; }
  /// The loop is about to end with @p why (IterationLimit or LineSearchFailed): true accepts the
  /// current iterate instead (NewtonStop::Accepted).
  virtual bool accept_short(NewtonStop why) { return why == NewtonStop::Accepted; }
  /// Why the problem stopped the solve or found no direction, for the message ("" when it has no
  /// more to say than the stop reason).
  virtual std::string stop_reason() const { return {}; }
};

/// Runs Newton on @p problem from its current iterate. Never throws for a solve that does not
/// converge: the outcome says why, in one line.
NewtonOutcome run_newton(NewtonProblem& problem, const NewtonLoopOptions& options);

}  // namespace socketsmith::tissue
