// DesignSession: the background jobs (prepare a case, export, compare), the solve and optimiser
// results, the feedback derived from a shown state and the rectification chart.
#include <cmath>
#include <thread>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/geometry/shape_compare.h"
#include "socketsmith/pipeline/design_session.h"

namespace socketsmith::pipeline {

namespace fs = std::filesystem;

std::string SessionJob::stage_text() const {
  std::lock_guard lock(*stage_mutex);
  return *stage;
}

ProgressCallback SessionJob::reporter(std::shared_ptr<std::atomic<bool>> cancel) const {
  return [fraction = fraction, stage_mutex = stage_mutex, stage = stage, cancel = std::move(cancel)](
             double f, std::string_view s) {
    fraction->store(f);
    std::lock_guard lock(*stage_mutex);
    *stage = s;
    return !cancel || !cancel->load();
  };
}

// ------------------------------------------------------------------------------------------------
// Jobs
// ------------------------------------------------------------------------------------------------

bool DesignSession::start_job(const std::string& what, std::function<void(const ProgressCallback&)> work) {
  if (job_) {
    show_error(fmt::format("{}: wait until {} has finished", what, job_->what));
    return false;
  }
  SessionJob job;
  job.what = what;
  ProgressCallback progress = job.reporter();
  job.done = std::async(std::launch::async, [work = std::move(work), progress] { work(progress); });
  job_ = std::move(job);
  return true;
}

bool DesignSession::load(design::CaseFile c, fs::path path, const std::string& what, bool is_rebuild) {
  return start_job(what, [this, c = std::move(c), path = std::move(path), is_rebuild](const ProgressCallback& progress) {
    auto setup = prepare_design(c, {}, progress);
    std::lock_guard lock(loaded_mutex_);
    loaded_ = std::move(setup);
    loaded_case_ = c;
    loaded_path_ = path;
    loaded_is_rebuild_ = is_rebuild;
  });
}

void DesignSession::export_design(const fs::path& dir) {
  if (!setup_) {
    show_error("export: open a case first");
    return;
  }
  design::CaseFile c = case_;
  c.optimise = false;
  start_job("exporting to " + dir.string(), [this, c, dir](const ProgressCallback& progress) {
    const auto summary = run_design(c, dir, false, progress);
    std::lock_guard lock(loaded_mutex_);
    job_message_ = summary.value("constraints_met", false)
                       ? fmt::format("exported socket.stl and report.html to {}", dir.string())
                       : fmt::format("exported the report to {}; no socket: the constraints are not all met{}",
                                     dir.string(),
                                     summary.value("removed", nlohmann::json::array()).empty()
                                         ? ""
                                         : " (the earlier socket.stl there was removed)");
  });
}

void DesignSession::compare_with(const fs::path& path) {
  if (!setup_) {
    show_error("compare: open a case first (the limb to compare with)");
    return;
  }
  // Copies: the job must not read the setup, which a load may replace meanwhile.
  start_job("comparing with " + path.string(),
            [this, path, limb = setup_->limb, skin = skin_rest_](const ProgressCallback& progress) {
              report_progress(progress, 0.1, "compare: reading the second shape");
              const geometry::TriMesh b = geometry::read_mesh(path);
              report_progress(progress, 0.3, "compare: aligning it onto the limb");
              const geometry::ShapeComparison cmp = geometry::compare_shapes(limb, b);
              report_progress(progress, 0.9, "compare: deviation on the stump's skin");
              // The deviation at the stump's skin nodes (on the limb's surface), to B as aligned.
              std::vector<double> dev = geometry::signed_deviation(skin, cmp.b, 0.05);
              std::lock_guard lock(loaded_mutex_);
              compared_label_ = fmt::format(
                  "{} ({}) aligned by {}, ICP residual {:.2f} mm: deviation mean {:+.2f} mm, 5th-95th percentile "
                  "{:+.2f} ... {:+.2f} mm below {:.0f} mm; volume change {:+.1f} %",
                  path.filename().string(), geometry::to_string(cmp.b_kind), cmp.seed, cmp.icp.rms_m * 1e3,
                  cmp.stats.mean_m * 1e3, cmp.stats.p05_m * 1e3, cmp.stats.p95_m * 1e3, cmp.crop_height_m * 1e3,
                  cmp.volume_a_m3 > 0 ? 100 * (cmp.volume_b_m3 / cmp.volume_a_m3 - 1) : 0.0);
              compared_file_ = path.filename().string();
              compared_ = std::move(dev);
            });
}

// ------------------------------------------------------------------------------------------------
// Results
// ------------------------------------------------------------------------------------------------

void DesignSession::poll() {
  poll_jobs();
  poll_worker();
  poll_rectification();
  poll_delivery();
}

bool DesignSession::is_idle() const {
  // A rectification chart asked for and not yet of the shown design counts as work to wait for.
  const bool chart_due = is_rectification_asked_ && state_ &&
                         (!rectification_ || rectification_->setup != setup_serial_ || rectification_->state != state_serial_);
  // So does a delivery check asked for and not yet of the shown design (when it has a socket).
  const bool check_due = is_delivery_asked_ && state_ && state_->status.all_ok() && !is_delivery_current();
  return !job_ && !is_solving() && !is_optimising_ && !rectification_job_.valid() && !chart_due &&
         !delivery_job_ && !check_due;
}

bool DesignSession::wait_idle(std::chrono::steady_clock::duration timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    poll();
    if (is_idle()) return true;
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

void DesignSession::poll_jobs() {
  if (!job_) return;
  if (job_->done.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
  try {
    job_->done.get();
  } catch (const Error& e) {
    show_error(e.what());
  } catch (const std::exception& e) {
    show_error(fmt::format("{}: unexpected error: {}", job_->what, e.what()));
  }
  job_.reset();
  std::unique_ptr<DesignSetup> loaded;
  design::CaseFile c;
  fs::path p;
  bool is_rebuild = false;
  {
    std::lock_guard lock(loaded_mutex_);
    if (compared_) {
      deviation_m_ = std::move(*compared_);
      compared_.reset();
      comparison_ = compared_label_;
      comparison_file_ = compared_file_;
      info_ = "compared with " + comparison_;
      ++comparison_serial_;
    }
    loaded = std::move(loaded_);
    c = loaded_case_;
    p = loaded_path_;
    is_rebuild = loaded_is_rebuild_;
    if (!job_message_.empty()) info_ = std::move(job_message_);
    job_message_.clear();
  }
  if (!loaded) return;
  if (is_rebuild) {  // the same case with new patient data: the edits and their history stay
    auto undo = std::move(undo_), redo = std::move(redo_);
    auto journal = std::move(journal_);
    const bool dirty = is_dirty_;
    install(std::move(loaded), std::move(c), std::move(p));
    undo_ = std::move(undo);
    redo_ = std::move(redo);
    journal_ = std::move(journal);
    is_dirty_ = dirty;
  } else {
    install(std::move(loaded), std::move(c), std::move(p));
    if (!deviation_m_.empty() || !comparison_.empty()) ++comparison_serial_;
    deviation_m_.clear();  // another limb: the comparison was of the one before
    comparison_.clear();
    comparison_file_.clear();
  }
}

void DesignSession::poll_worker() {
  if (!worker_) return;
  for (auto& r : worker_->take_results()) {
    if (r.kind == DesignOutcome::Kind::Optimise) {
      is_optimising_ = false;
      if (r.is_cancelled) {
        optimiser_message_ = "optimisation cancelled; the spots are as before";
        if (!undo_.empty()) undo_.pop_back();
      } else if (r.optimiser) {
        optimiser_message_ = r.optimiser->message;
        case_.spots = r.spots;
        is_dirty_ = true;
      }
    }
    if (!r.error.empty()) {
      show_error(r.error);
      solve_status_ = "last solve failed: the view shows the previous result";
      continue;
    }
    if (!r.state) continue;
    // An older generation is shown too while a newer edit is solved: the radar follows the drag.
    state_ = std::move(r.state);
    ++state_serial_;
    solve_status_ = fmt::format("{} ({:.0f} ms)", state_->message, r.seconds * 1e3);
    update_feedback();
  }
}

void DesignSession::update_feedback() {
  if (!setup_ || !state_) return;
  const auto& st = *state_;
  try {
    radar_ = radar_axes(*setup_, st);
    profiles_ = pressure_profiles(*setup_, st);
    template_ = pipeline::template_check(*setup_, st);
  } catch (const Error& e) {
    show_error(e.what());
  }
}

std::pair<double, std::string> DesignSession::optimiser_progress() const {
  return worker_ ? worker_->progress() : std::pair<double, std::string>{0, ""};
}

geometry::TriMesh DesignSession::socket_preview() const {
  geometry::TriMesh s;
  if (!setup_ || !state_) return s;
  s.vertices = state_->skin_positions;
  for (size_t i = 0; i < s.vertices.size(); ++i) s.vertices[i] += case_.socket.thickness_m * state_->skin_normals[i];
  const auto& above = setup_->solver->above_brim();
  for (const auto& t : skin_rest_.triangles)
    if (!above[t[0]] && !above[t[1]] && !above[t[2]]) s.triangles.push_back(t);
  return s;
}

// ------------------------------------------------------------------------------------------------
// Rectification chart
// ------------------------------------------------------------------------------------------------

const RectificationChart* DesignSession::rectification() const {
  return rectification_ && rectification_->setup == setup_serial_ && rectification_->error.empty() ? &*rectification_
                                                                                                   : nullptr;
}

std::string DesignSession::rectification_error() const {
  return rectification_ && rectification_->setup == setup_serial_ ? rectification_->error : std::string();
}

std::vector<RectificationRow> DesignSession::rectification_rows() const {
  std::vector<RectificationRow> rows;
  const RectificationChart* c = rectification();
  if (!c) return rows;
  for (const auto& l : c->rectification.landmarks) {
    const double mm = l.rectification_m * 1e3;
    rows.push_back({l.code, l.name, mm, std::isfinite(mm) ? fmt::format("{:+.2f}", mm) : "-",
                    rectification_kind(l.rectification_m), l.is_axial ? "along the axis" : "radially"});
  }
  return rows;
}

void DesignSession::poll_rectification() {
  if (rectification_job_.valid()) {
    if (rectification_job_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
    RectificationChart c = rectification_job_.get();  // the job keeps its errors in c.error
    if (c.setup == setup_serial_) {  // else it was of the limb before
      if (!c.error.empty()) show_error("rectification chart: " + c.error);
      rectification_ = std::move(c);
      ++rectification_serial_;
    }
  }
  if (!is_rectification_asked_ || !setup_ || !state_) return;
  if (rectification_ && rectification_->setup == setup_serial_ && rectification_->state == state_serial_) return;
  // Once the shown design has settled: no solve waiting, no slider held, no optimisation running
  // (then the state is a full solve under the current brim).
  if (is_solving() || edit_start_ || is_optimising_) return;
  start_rectification();
}

void DesignSession::start_rectification() {
  // Copies: the solver and the setup's brim go on changing on other threads meanwhile.
  geometry::TriMesh designed = skin_rest_;
  designed.vertices = state_->skin_positions;
  rectification_job_ = std::async(
      std::launch::async, [rest = skin_rest_, designed = std::move(designed), met = state_->status.all_ok(),
                           frame = setup_->model.frame, brim = setup_->brim, landmarks = setup_->model.landmarks,
                           socket = case_.socket, setup = setup_serial_, state = state_serial_] {
        const auto t0 = std::chrono::steady_clock::now();
        RectificationChart c;
        c.setup = setup;
        c.state = state;
        try {
          const ChecksWall wall = designed_wall(rest, designed, met, frame, brim, socket);
          c.wall_source = wall.source;
          c.rectification = compute_rectification(rest, wall.wall, frame, brim, landmarks);
        } catch (const std::exception& e) {
          c.error = e.what();
        }
        c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        return c;
      });
}

}  // namespace socketsmith::pipeline
