#pragma once
/// @file design_worker.h
/// Runs the design solves and the optimiser of one stump on a worker thread, so the caller (the
/// window's thread, through DesignSession) never waits. Solve requests coalesce: while a solve
/// runs, newer requests replace the pending one (latest wins), so a dragged slider costs one solve
/// per solve time, not one per frame.
/// The worker is the only thread that touches the DesignSolver after construction.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "socketsmith/design/brim.h"
#include "socketsmith/design/design_solver.h"
#include "socketsmith/design/optimizer.h"

namespace socketsmith::pipeline {

/// What to solve: the spots and, when it changed, the brim.
struct DesignRequest {
  std::vector<design::Spot> spots;
  std::optional<design::BrimLine> brim;  ///< set: the solver's brim is replaced first
  std::uint64_t generation = 0;          ///< the caller's edit counter, returned with the result
  /// A slider is moving: the tangent's quick answer (DesignSolver::preview) serves it; the full
  /// solve comes with the request made on release.
  bool preview = false;
};

/// A finished job.
struct DesignOutcome {
  enum class Kind { Solve, Optimise } kind = Kind::Solve;
  std::uint64_t generation = 0;
  std::vector<design::Spot> spots;               ///< the spots solved (optimised ones for Optimise)
  std::optional<design::DesignState> state;      ///< empty on error or cancel
  std::optional<design::OptimizerResult> optimiser;
  std::string error;                             ///< one line; empty on success
  bool is_cancelled = false;
  double seconds = 0;
};

class DesignWorker {
 public:
  /// @p solver must outlive the worker; its brim must be set.
  explicit DesignWorker(design::DesignSolver& solver);
  ~DesignWorker();
  DesignWorker(const DesignWorker&) = delete;
  DesignWorker& operator=(const DesignWorker&) = delete;

  /// Queues a solve; replaces a solve still waiting (latest wins).
  void solve(DesignRequest request);
  /// Queues an optimisation (replaces a waiting solve; runs after the current job).
  void optimise(DesignRequest request, design::OptimizerOptions options);
  /// Asks a running optimisation to stop at its next progress report.
  void cancel();
  /// The finished jobs since the last call, oldest first.
  std::vector<DesignOutcome> take_results();
  /// A job runs or waits, or a result waits to be taken.
  bool is_busy() const;
  /// Progress of the running optimisation: fraction [0, 1] and stage.
  std::pair<double, std::string> progress() const;
  /// Solves finished so far (for the refresh-rate measurement).
  long solves_done() const { return solves_done_.load(); }

 private:
  struct Job {
    DesignOutcome::Kind kind = DesignOutcome::Kind::Solve;
    DesignRequest request;
    design::OptimizerOptions options;
  };
  void run();
  DesignOutcome execute(Job& job);
  /// Removes the waiting solve (if any), moving its brim change into @p request. Lock held.
  void drop_waiting_solve(DesignRequest& request);

  design::DesignSolver& solver_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::vector<Job> queue_;  // at most one solve (the newest) and the optimisations
  std::vector<DesignOutcome> results_;
  bool running_job_ = false;
  bool stop_ = false;
  std::atomic<bool> cancel_{false};
  std::atomic<long> solves_done_{0};
  double progress_ = 0;
  std::string stage_;
  std::thread thread_;
};

}  // namespace socketsmith::pipeline
