#include "socketsmith/pipeline/design_worker.h"

#include <dlfcn.h>

#include <chrono>

#include "socketsmith/core/errors.h"

namespace socketsmith::pipeline {

DesignWorker::DesignWorker(design::DesignSolver& solver) : solver_(solver), thread_([this] { run(); }) {}

DesignWorker::~DesignWorker() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
    queue_.clear();
  }
  cancel_ = true;
  wake_.notify_all();
  thread_.join();
}

void DesignWorker::drop_waiting_solve(DesignRequest& request) {
  // Latest wins: a waiting solve is replaced, but a brim change it carried is kept.
  for (auto it = queue_.begin(); it != queue_.end(); ++it)
    if (it->kind == DesignOutcome::Kind::Solve) {
      if (!request.brim && it->request.brim) request.brim = std::move(it->request.brim);
      queue_.erase(it);
      return;
    }
}

void DesignWorker::solve(DesignRequest request) {
  {
    std::lock_guard lock(mutex_);
    drop_waiting_solve(request);
    queue_.push_back({DesignOutcome::Kind::Solve, std::move(request), {}});
  }
  wake_.notify_one();
}

void DesignWorker::optimise(DesignRequest request, design::OptimizerOptions options) {
  {
    std::lock_guard lock(mutex_);
    drop_waiting_solve(request);
    progress_ = 0;
    stage_ = "design: optimising";
    queue_.push_back({DesignOutcome::Kind::Optimise, std::move(request), std::move(options)});
  }
  cancel_ = false;
  wake_.notify_one();
}

void DesignWorker::cancel() { cancel_ = true; }

std::vector<DesignOutcome> DesignWorker::take_results() {
  std::lock_guard lock(mutex_);
  std::vector<DesignOutcome> out;
  out.swap(results_);
  return out;
}

bool DesignWorker::is_busy() const {
  std::lock_guard lock(mutex_);
  return running_job_ || !queue_.empty() || !results_.empty();  // a result not yet taken counts
}

std::pair<double, std::string> DesignWorker::progress() const {
  std::lock_guard lock(mutex_);
  return {progress_, stage_};
}

namespace {

/// The window and the solves share the cores (2 on the reference machine, with llvmpipe drawing
/// in software): the solves run on one thread, so the UI thread is never starved by OpenMP or
/// OpenBLAS threads spinning between parallel regions (measured: 6.5 → 35 frames/s while a
/// slider is dragged at 8k nodes). Looked up at run time: the libraries may be built without them.
void use_one_solver_thread() {
  if (auto* omp = reinterpret_cast<void (*)(int)>(dlsym(RTLD_DEFAULT, "omp_set_num_threads"))) omp(1);  // this thread
  if (auto* blas = reinterpret_cast<void (*)(int)>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) blas(1);
}

}  // namespace

void DesignWorker::run() {
  use_one_solver_thread();
  for (;;) {
    Job job;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      job = std::move(queue_.front());
      queue_.erase(queue_.begin());
      running_job_ = true;
    }
    DesignOutcome outcome = execute(job);
    {
      std::lock_guard lock(mutex_);
      results_.push_back(std::move(outcome));
      running_job_ = false;
    }
  }
}

DesignOutcome DesignWorker::execute(Job& job) {
  const auto t0 = std::chrono::steady_clock::now();
  DesignOutcome out;
  out.kind = job.kind;
  out.generation = job.request.generation;
  out.spots = job.request.spots;
  try {
    if (job.request.brim) {
      const design::BrimLine brim = *job.request.brim;
      solver_.set_brim([brim](double theta) { return brim.height(theta); });
    }
    if (job.kind == DesignOutcome::Kind::Solve) {
      out.state = job.request.preview ? solver_.preview(job.request.spots) : solver_.solve(job.request.spots);
      ++solves_done_;
      // A full nonlinear solve: factorise its tangent now, while nothing waits, so the next
      // drag's first preview does not pay for it.
      if (!job.request.preview) {
        bool idle = false;
        {
          std::lock_guard lock(mutex_);
          idle = queue_.empty();
        }
        if (idle) solver_.prepare_preview();
      }
    } else {
      auto options = job.options;
      options.progress = [this](double f, std::string_view stage) {
        {
          std::lock_guard lock(mutex_);
          progress_ = f;
          stage_ = stage;
        }
        return !cancel_.load();
      };
      auto result = design::optimise_design(solver_, job.request.spots, options);
      if (result.message == "cancelled") {
        out.is_cancelled = true;
      } else {
        out.spots = result.spots;
        out.state = result.state;
      }
      out.optimiser = std::move(result);
    }
  } catch (const Error& e) {
    out.error = e.what();
    out.state.reset();
  } catch (const std::exception& e) {
    out.error = std::string("unexpected error: ") + e.what();
    out.state.reset();
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace socketsmith::pipeline
