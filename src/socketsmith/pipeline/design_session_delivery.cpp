// DesignSession: the delivery check — the closed loop of the shown design on a thread of its own,
// run on release (once the design has settled), stopped by the next edit.
#include <algorithm>
#include <chrono>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/pipeline/design_session.h"

namespace socketsmith::pipeline {

namespace {

/// The check of @p c (the case as edited): prepared and solved afresh, as *Export* does
/// (run_design without optimising), then its socket donned, stood on and corrected
/// (close_design_loop, as `design` runs it). Preparing and solving take the first tenth of
/// @p progress; the loop the rest. Errors are kept in the result, not thrown.
DeliveryCheck check_delivery(design::CaseFile c, const ProgressCallback& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  DeliveryCheck d;
  try {
    ClosedLoopOptions loop_options = closed_loop_options(c);  // the export's loop
    c.optimise = false;
    c.closed_loop = false;  // solve_design builds the open-loop socket; the loop runs below, with its own progress
    const auto part = [&](double lo, double hi) {
      return [&progress, lo, hi](double f, std::string_view stage) {
        return report_progress(progress, lo + (hi - lo) * f, stage);
      };
    };
    std::unique_ptr<DesignSetup> setup = prepare_design(c, {}, part(0.0, 0.06));
    const DesignResult r = solve_design(*setup, false, part(0.06, 0.1));
    require(r.constraints_met, "the constraints are not all met ({}): there is no socket to don",
            r.state.status.failing());
    loop_options.progress = part(0.1, 1.0);
    ClosedLoopResult loop = close_design_loop(*setup, r, loop_options);
    d.summary = summarise_delivery(*setup, loop);
    d.converged = loop.converged;
    d.message = loop.message;
    for (const auto& it : loop.iterations) ++(it.refit ? d.refits : d.donnings);
    d.target_pa = std::move(loop.target_pa);
    d.open_loop_pa = std::move(loop.open_loop_pa);
    d.closed_loop_pa = std::move(loop.closed_loop_pa);
    d.below_brim = std::move(loop.below_brim);
  } catch (const std::exception& e) {
    d.error = e.what();
  }
  d.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return d;
}

}  // namespace

void DesignSession::stop_delivery() {
  is_delivery_asked_ = false;
  if (delivery_job_) delivery_job_->cancel->store(true);
}

const DeliveryCheck* DesignSession::delivery() const {
  return delivery_ && delivery_->setup == setup_serial_ && delivery_->error.empty() ? &*delivery_ : nullptr;
}

std::string DesignSession::delivery_error() const {
  return delivery_ && delivery_->setup == setup_serial_ ? delivery_->error : std::string();
}

std::pair<double, std::string> DesignSession::delivery_progress() const {
  if (!delivery_job_) return {-1.0, {}};
  return {delivery_job_->progress.fraction->load(), delivery_job_->progress.stage_text()};
}

void DesignSession::poll_delivery() {
  if (delivery_job_) {
    // The design moved on (an edit, another limb): the check of the one before stops at its next
    // progress report (a donning step), and is dropped.
    if (delivery_job_->setup != setup_serial_ || delivery_job_->state != state_serial_) delivery_job_->cancel->store(true);
    if (delivery_job_->done.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
    DeliveryCheck d = delivery_job_->done.get();  // the job keeps its errors in d.error
    const bool is_cancelled = delivery_job_->cancel->load();
    delivery_job_.reset();
    if (!is_cancelled) {
      if (!d.error.empty()) show_error("delivery check: " + d.error);
      delivery_ = std::move(d);
      ++delivery_serial_;
    }
  }
  if (!is_delivery_asked_ || !setup_ || !state_ || !state_->status.all_ok()) return;
  if (is_delivery_current()) return;
  // Once the shown design has settled, as the rectification chart.
  if (is_solving() || edit_start_ || is_optimising_ || job_) return;
  start_delivery();
}

void DesignSession::start_delivery() {
  DeliveryJob job;
  job.setup = setup_serial_;
  job.state = state_serial_;
  job.progress.what = "checking what the socket delivers";
  ProgressCallback progress = job.progress.reporter(job.cancel);
  // A copy of the case as edited: the window goes on editing it meanwhile.
  job.done = std::async(std::launch::async, [c = case_, progress, setup = job.setup, state = job.state] {
    DeliveryCheck d = check_delivery(c, progress);
    d.setup = setup;
    d.state = state;
    return d;
  });
  log::info("delivery check: started on the design shown ({} spots)", case_.spots.size());
  delivery_job_ = std::move(job);
}

}  // namespace socketsmith::pipeline
