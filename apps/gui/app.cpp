#include "app.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include <GLFW/glfw3.h>
#include <fmt/ranges.h>
#include <imgui.h>

#include "plots.h"
#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/exit_status.h"
#include "socketsmith/design/input_limits.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/geometry/shape_compare.h"
#include "socketsmith/report/html.h"
#include "socketsmith/report/nice_number.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/units.h"
#include "socketsmith/report/raster.h"

namespace socketsmith::gui {

namespace fs = std::filesystem;
constexpr double kDeg = std::numbers::pi / 180.0;
constexpr float kLeftPanel = 390, kRightPanel = 440;

namespace {
/// The colour map of a field: viridis for the thresholds, diverging (blue inside, red outside) for
/// the deviation of a compared shape and the rectification (as the report's), the clinicians'
/// pressure map for the rest.
report::Colormap field_colormap(Field field) {
  return field == Field::Threshold                                   ? report::Colormap::Viridis
         : field == Field::Deviation || field == Field::Rectification ? report::Colormap::Diverging
                                                                      : report::Colormap::Pressure;
}
}  // namespace

const char* to_string(Field field) {
  switch (field) {
    case Field::Pressure: return "pressure";
    case Field::Threshold: return "threshold";
    case Field::Ratio: return "ratio";
    case Field::Displacement: return "displacement";
    case Field::Deviation: return "deviation";
    case Field::Rectification: return "rectification";
  }
  return "pressure";
}

Field parse_field(const std::string& text) {
  for (Field f : {Field::Pressure, Field::Threshold, Field::Ratio, Field::Displacement, Field::Deviation,
                  Field::Rectification})
    if (text == to_string(f)) return f;
  fail("colour field '{}' is not known (use pressure, threshold, ratio, displacement, deviation or rectification)",
       text);
}

void App::set_field(Field field) {
  field_ = field;
  colours_dirty_ = true;
  if (field == Field::Rectification) {
    is_rectification_asked_ = true;
    is_rectification_table_opening_ = true;
  }
}

App::App(GLFWwindow* window, bool is_headless)
    : window_(window), is_headless_(is_headless), renderer_(std::make_unique<MeshRenderer>()) {
  dialog_folder_ = fs::current_path().string();
  // Library messages (limb repairs, estimated bones, optimiser rounds): on stderr as before, and
  // kept for the Log panel.
  log::set_sink([lines = log_](log::Level level, std::string_view message) {
    static const char* names[] = {"debug", "info", "warn", "error", "off"};
    const std::string line = fmt::format("[{}] {}", names[static_cast<int>(level)], message);
    std::fprintf(stderr, "%s\n", line.c_str());
    std::lock_guard lock(lines->mutex);
    lines->lines.push_back(line);
    if (lines->lines.size() > 500) lines->lines.erase(lines->lines.begin(), lines->lines.begin() + 100);
  });
}

App::~App() {
  log::set_sink(nullptr);
  worker_.reset();  // joins the solve thread before the solver goes
  if (job_ && job_->done.valid()) job_->done.wait();
  if (rectification_job_.valid()) rectification_job_.wait();
}

// ------------------------------------------------------------------------------------------------
// Document
// ------------------------------------------------------------------------------------------------

void App::start_job(const std::string& what, std::function<void(const ProgressCallback&)> work) {
  if (job_) {
    show_error(fmt::format("{}: wait until {} has finished", what, job_->what));
    return;
  }
  BackgroundJob job;
  job.what = what;
  auto fraction = job.fraction;
  auto stage_mutex = job.stage_mutex;
  auto stage = job.stage;
  ProgressCallback progress = [fraction, stage_mutex, stage](double f, std::string_view s) {
    fraction->store(f);
    std::lock_guard lock(*stage_mutex);
    *stage = s;
    return true;
  };
  job.done = std::async(std::launch::async, [work = std::move(work), progress] { work(progress); });
  job_ = std::move(job);
}

void App::load(design::CaseFile c, fs::path path, const std::string& what, bool is_rebuild) {
  start_job(what, [this, c = std::move(c), path = std::move(path), is_rebuild](const ProgressCallback& progress) {
    auto setup = pipeline::prepare_design(c, {}, progress);
    std::lock_guard lock(loaded_mutex_);
    loaded_ = std::move(setup);
    loaded_case_ = c;
    loaded_path_ = path;
    loaded_is_rebuild_ = is_rebuild;
  });
}

void App::open_case(const fs::path& path) {
  try {
    load(design::read_case(path), path, "opening " + path.string());
  } catch (const std::exception& e) {
    show_error(exit_status(std::current_exception()).message);
  }
}

void App::open_demo(int target_nodes) { load(pipeline::demo_case(target_nodes), {}, "opening the demo"); }

void App::open_limb(const fs::path& path, int target_nodes) {
  design::CaseFile c;
  c.limb.file = fs::absolute(path).string();
  c.target_nodes = target_nodes;
  load(std::move(c), {}, "opening " + path.string());
}

void App::install_setup(std::unique_ptr<pipeline::DesignSetup> setup, design::CaseFile c, fs::path path) {
  worker_.reset();
  setup_ = std::move(setup);
  case_ = std::move(c);
  // The design as the GUI edits it: explicit spots and brim template (the defaults made concrete),
  // so the saved case replays to the same socket.
  case_.spots = setup_->spots;
  case_path_ = std::move(path);
  if (!case_path_.empty()) case_.folder = fs::absolute(case_path_).parent_path();
  undo_.clear();
  redo_.clear();
  is_dirty_ = false;
  state_.reset();
  template_.reset();  // the last case's reading
  rectification_.reset();  // the last limb's (a chart still computed for it is dropped when done)
  ++setup_serial_;
  selected_spot_ = -1;
  worker_ = std::make_unique<DesignWorker>(*setup_->solver);
  skin_rest_ = setup_->solver->skin().triangles();
  stump_.set_geometry(skin_rest_);
  bones_.clear();
  for (const auto& b : setup_->model.bones) {
    auto m = std::make_unique<GpuMesh>();
    m->set_geometry(b.mesh);
    m->set_colour({0.93f, 0.9f, 0.8f, 1.0f});
    bones_.push_back(std::move(m));
  }
  camera_.up = setup_->model.frame.axis;
  camera_.front = setup_->model.frame.anterior;
  camera_.yaw_rad = 0.5;
  camera_.pitch_rad = 0.2;
  camera_.frame(geometry::bounding_box(setup_->model.skin));
  update_brim();
  info_ = fmt::format("{}: {} nodes, {} skin nodes", case_path_.empty() ? "new case" : case_path_.string(),
                      setup_->solver->model().num_nodes(), setup_->solver->skin().nodes.size());
  request_solve(false);
}

void App::save_case(const fs::path& path) {
  try {
    design::CaseFile out = case_;
    // Limb paths stay valid wherever the case goes.
    if (!out.limb.file.empty()) out.limb.file = fs::absolute(design::resolve(case_, case_.limb.file)).string();
    if (out.limb.bones != "auto" && out.limb.bones != "estimate" && out.limb.bones != "none")
      out.limb.bones = fs::absolute(design::resolve(case_, case_.limb.bones)).string();
    if (path.has_parent_path()) ensure_directory(path.parent_path());
    design::write_case(path, out);
    case_ = out;
    case_path_ = path;
    case_.folder = fs::absolute(path).parent_path();
    is_dirty_ = false;
    info_ = "saved " + path.string();
  } catch (const Error& e) {
    show_error(e.what());
    throw;
  }
}

void App::export_design(const fs::path& dir) {
  if (!setup_) {
    show_error("export: open a case first");
    return;
  }
  design::CaseFile c = case_;
  c.optimise = false;
  start_job("exporting to " + dir.string(), [this, c, dir](const ProgressCallback& progress) {
    const auto summary = pipeline::run_design(c, dir, false, progress);
    std::lock_guard lock(loaded_mutex_);
    job_message_ = summary.value("constraints_met", false)
                ? fmt::format("exported socket.stl and report.html to {}", dir.string())
                : fmt::format("exported the report to {}; no socket: the constraints are not all met{}", dir.string(),
                              summary.value("removed", nlohmann::json::array()).empty()
                                  ? ""
                                  : " (the earlier socket.stl there was removed)");
  });
}

void App::compare_with(const fs::path& path) {
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

void App::push_history() {
  undo_.push_back(case_);
  if (undo_.size() > 200) undo_.erase(undo_.begin());
  redo_.clear();
}

void App::step_history(std::vector<design::CaseFile>& from, std::vector<design::CaseFile>& to) {
  if (from.empty() || !setup_) return;
  to.push_back(case_);
  case_ = from.back();
  from.pop_back();
  is_dirty_ = true;
  request_solve(true);
}

void App::undo() { step_history(undo_, redo_); }

void App::redo() { step_history(redo_, undo_); }

void App::begin_edit() {
  if (edit_start_) return;
  push_history();
  edit_start_ = case_;
}

void App::end_edit() {
  if (!edit_start_) return;
  edit_start_.reset();
  if (worker_ && setup_ && setup_->solver->options().mode != design::DesignSolveMode::Linear) request_solve(false);
}

void App::edit(const std::function<void()>& change, bool brim_changed) {
  if (!setup_) fail("no case is open: open a case, a limb or the demo first");
  if (!edit_start_) push_history();
  change();
  is_dirty_ = true;
  request_solve(brim_changed);
}

void App::request_solve(bool brim_changed) {
  if (!worker_) return;
  DesignRequest r;
  r.spots = case_.spots;
  r.generation = ++generation_;
  r.preview = edit_start_.has_value();  // a slider moves: the tangent answers, the release solves
  if (brim_changed) {
    try {
      const design::BrimTemplate kind = case_.brim.value_or(design::default_brim(setup_->model.type));
      setup_->brim = case_.brim_key_points.empty() ? design::make_brim(kind, setup_->model)
                                                   : design::brim_from_key_points(case_.brim_key_points, kind);
      design::validate_brim(setup_->brim, setup_->model.skin, setup_->model.frame);
    } catch (const Error& e) {
      show_error(e.what());
    }
    r.brim = setup_->brim;
    update_brim();
  }
  worker_->solve(std::move(r));
}

void App::autosave() {
  if (!is_dirty_ || !setup_ || is_headless_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_autosave_ < std::chrono::seconds(60)) return;
  last_autosave_ = now;
  const fs::path p = case_path_.empty() ? fs::path("socketsmith_autosave.json")
                                        : fs::path(case_path_.string() + ".autosave.json");
  try {
    design::write_case(p, case_);
    info_ = "autosaved to " + p.string();
  } catch (const Error& e) {
    show_error(std::string("autosave: ") + e.what());
  }
}

bool App::request_close() {
  if (!is_dirty_ || is_headless_) return true;
  is_close_requested_ = true;
  return false;
}

// ------------------------------------------------------------------------------------------------
// Design edits
// ------------------------------------------------------------------------------------------------

namespace {

design::Spot spot_at(design::SpotType type, double theta, double h, double amplitude_pa, double length_m) {
  design::Spot s;
  s.type = type;
  s.amplitude_pa = amplitude_pa;
  s.theta0 = theta;
  s.r_theta = 20 * kDeg;
  s.h0 = h;
  s.r_h = 0.015;
  s.theta1 = design::wrap_angle(theta - 20 * kDeg);
  s.theta2 = design::wrap_angle(theta + 20 * kDeg);
  s.h1 = std::max(0.0, h - 0.015);
  s.h2 = std::min(length_m, h + 0.015);
  if (type == design::SpotType::Grad) {
    s.h1 = 0.5 * h;
    s.h2 = h;
  }
  s.lambda_h = 8.0 / (0.05 * length_m);
  return s;
}

}  // namespace

void App::add_spot_at(const Vec3& point, design::SpotType type, double amplitude_pa) {
  if (!setup_) fail("add spot: no case is open");
  const auto& frame = setup_->model.frame;
  const auto cyl = frame.to_cylindrical(point);
  const double length = setup_->model.length_m;
  require(cyl.h > 0 && cyl.h < length, "add spot: the point at h = {:.0f} mm is off the limb (0..{:.0f} mm)",
          cyl.h * 1e3, length * 1e3);
  design::Spot s = spot_at(type, cyl.theta, cyl.h, amplitude_pa, length);
  // Named after the nearest landmark within 30 mm, else numbered.
  std::string name = fmt::format("spot {}", case_.spots.size() + 1);
  double best = 0.03;
  for (const auto& l : setup_->model.landmarks)
    if ((l.position - point).norm() < best) {
      best = (l.position - point).norm();
      name = l.code + " " + std::to_string(case_.spots.size() + 1);
    }
  s.name = name;
  design::validate_spot(s, length);
  edit([&] { case_.spots.push_back(s); });
  selected_spot_ = static_cast<int>(case_.spots.size()) - 1;
  scroll_to_selected_ = true;
}

void App::add_spot_at_landmark(const std::string& code, design::SpotType type, double amplitude_pa) {
  if (!setup_) fail("add spot: no case is open");
  for (const auto& l : setup_->model.landmarks)
    if (l.code == code) {
      add_spot_at(l.position, type, amplitude_pa);
      case_.spots.back().name = code + " (added)";
      return;
    }
  std::string codes;
  for (const auto& l : setup_->model.landmarks) codes += (codes.empty() ? "" : ", ") + l.code;
  fail("add spot: landmark '{}' is not on this limb (use one of {})", code, codes);
}

int App::spot_index(const std::string& name) const {
  for (size_t k = 0; k < case_.spots.size(); ++k)
    if (case_.spots[k].name == name) return static_cast<int>(k);
  return -1;
}

void App::set_spot_value(int index, const std::string& field, double value) {
  require(index >= 0 && index < static_cast<int>(case_.spots.size()), "set: spot {} does not exist ({} spots)", index,
          case_.spots.size());
  design::Spot s = case_.spots[index];
  if (field == "amplitude_kpa") s.amplitude_pa = value * 1e3;
  else if (field == "theta0_deg") s.theta0 = value * kDeg;
  else if (field == "r_theta_deg") s.r_theta = value * kDeg;
  else if (field == "h0_mm") s.h0 = value * 1e-3;
  else if (field == "r_h_mm") s.r_h = value * 1e-3;
  else if (field == "theta1_deg") s.theta1 = value * kDeg;
  else if (field == "theta2_deg") s.theta2 = value * kDeg;
  else if (field == "h1_mm") s.h1 = value * 1e-3;
  else if (field == "h2_mm") s.h2 = value * 1e-3;
  else if (field == "enabled") s.enabled = value != 0;
  else
    fail("set: spot field '{}' is not known (amplitude_kpa, theta0_deg, r_theta_deg, h0_mm, r_h_mm, theta1_deg, "
         "theta2_deg, h1_mm, h2_mm, enabled)",
         field);
  design::validate_spot(s, setup_ ? setup_->model.length_m : 1.0);
  edit([&] { case_.spots[index] = s; });
}

void App::remove_spot(int index) {
  if (index < 0 || index >= static_cast<int>(case_.spots.size())) return;
  // A case without spots would be saved as the default layout: keep at least one.
  require(case_.spots.size() > 1, "remove spot: '{}' is the last spot; a design needs at least one: add another "
          "spot first", case_.spots[index].name);
  edit([&] { case_.spots.erase(case_.spots.begin() + index); });
  selected_spot_ = -1;
}

void App::set_brim_template(design::BrimTemplate kind) {
  if (!setup_) return;
  try {
    design::validate_brim(design::make_brim(kind, setup_->model), setup_->model.skin, setup_->model.frame);
  } catch (const Error& e) {
    show_error(e.what());
    return;
  }
  edit(
      [&] {
        case_.brim = kind;
        case_.brim_key_points.clear();
      },
      true);
}

void App::move_brim_key_point(int index, double theta_rad, double h_m) {
  if (!setup_) return;
  design::BrimLine b = setup_->brim;
  try {
    b.move_key_point(index, theta_rad, h_m);
    design::validate_brim(b, setup_->model.skin, setup_->model.frame);
  } catch (const Error& e) {
    show_error(e.what());
    return;
  }
  edit([&] { case_.brim_key_points = b.key_points(); }, true);
}

void App::set_patient(const design::PatientLoad& patient, double youngs_modulus_pa, const design::ThresholdTable& thresholds) {
  // The same checks as the case file's (design/input_limits.h): nothing is silently replaced.
  design::check_patient(patient, "patient: ");
  design::check_input(design::limits::kYoungsModulus, youngs_modulus_pa / 1e3, "patient: tissue.youngs_kpa");
  for (const auto& [code, v] : thresholds)
    design::check_input(design::limits::kPainThreshold, v / 1e3, "patient: patient.thresholds_kpa." + code);
  push_history();
  case_.patient = patient;
  case_.youngs_modulus_pa = youngs_modulus_pa;
  case_.thresholds = thresholds;
  is_dirty_ = true;
}

void App::set_thickness(double thickness_m) {
  design::check_input(design::limits::kThickness, thickness_m * 1e3, "socket: socket.thickness_mm");
  edit([&] { case_.socket.thickness_m = thickness_m; });
}

void App::optimise(double time_limit_s) {
  if (!worker_) return;
  if (time_limit_s > 0) design::check_input(design::limits::kTimeLimit, time_limit_s, "optimise: time limit");
  push_history();
  design::OptimizerOptions o = pipeline::optimizer_options(*setup_, case_);
  o.time_limit_s = time_limit_s;
  DesignRequest r;
  r.spots = case_.spots;
  r.generation = ++generation_;
  worker_->optimise(std::move(r), o);
  is_optimising_ = true;
  optimiser_message_.clear();
}

void App::cancel_optimise() {
  if (worker_) worker_->cancel();
}

void App::show_error(const std::string& message) {
  log::error("{}", message);
  errors_.push_back(message);
  if (errors_.size() > 20) errors_.erase(errors_.begin());
}

bool App::is_idle() const {
  // A rectification chart asked for and not yet of the shown design counts as work to wait for.
  const bool chart_due = is_rectification_asked_ && state_ &&
                         (!rectification_ || rectification_->setup != setup_serial_ || rectification_->state != state_serial_);
  return !job_ && !(worker_ && worker_->is_busy()) && !is_optimising_ && !rectification_job_.valid() && !chart_due;
}

// ------------------------------------------------------------------------------------------------
// Results
// ------------------------------------------------------------------------------------------------

void App::poll_jobs() {
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
  std::unique_ptr<pipeline::DesignSetup> loaded;
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
      field_ = Field::Deviation;
      is_auto_range_ = true;
      colours_dirty_ = true;
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
    const bool dirty = is_dirty_;
    install_setup(std::move(loaded), std::move(c), std::move(p));
    undo_ = std::move(undo);
    redo_ = std::move(redo);
    is_dirty_ = dirty;
  } else {
    install_setup(std::move(loaded), std::move(c), std::move(p));
    deviation_m_.clear();  // another limb: the comparison was of the one before
    comparison_.clear();
    comparison_file_.clear();
    if (field_ == Field::Deviation) field_ = Field::Pressure;
  }
}

void App::poll_worker() {
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
    colours_dirty_ = true;
    update_meshes();
    update_feedback();
  }
}

void App::update_brim() {
  if (!setup_) return;
  const auto& frame = setup_->model.frame;
  // Brim line on the skin, 1 mm outside it so the stump does not hide it.
  std::vector<Vec3> brim = pipeline::brim_on_skin(*setup_, 120);
  for (auto& p : brim) p += 0.001 * frame.radial(frame.to_cylindrical(p).theta);
  brim_lines_.set_points(brim, true);
  ++scene_version_;
}

void App::update_meshes() {
  if (!setup_) return;
  // Socket: the deformed skin below the brim, moved out by the wall thickness (its outer wall).
  if (state_) {
    geometry::TriMesh s;
    s.vertices = state_->skin_positions;
    for (size_t i = 0; i < s.vertices.size(); ++i) s.vertices[i] += case_.socket.thickness_m * state_->skin_normals[i];
    const auto& above = setup_->solver->above_brim();
    for (const auto& t : skin_rest_.triangles)
      if (!above[t[0]] && !above[t[1]] && !above[t[2]]) s.triangles.push_back(t);
    socket_.set_geometry(s);
    socket_.set_colour({0.55f, 0.75f, 0.95f, 1.0f});
  }
  ++scene_version_;
}

void App::update_colours() {
  if (!setup_ || !colours_dirty_) return;
  colours_dirty_ = false;
  const size_t n = skin_rest_.vertices.size();
  const auto& thr = setup_->solver->thresholds();
  const auto& above = setup_->solver->above_brim();
  std::vector<double> v(n, std::numeric_limits<double>::quiet_NaN());
  for (size_t i = 0; i < n; ++i) {
    switch (field_) {
      case Field::Threshold: v[i] = thr[i] / 1e3; break;
      case Field::Pressure:
        if (state_ && !above[i]) v[i] = state_->pressure_pa[i] / 1e3;
        break;
      case Field::Ratio:
        if (state_ && !above[i]) v[i] = state_->requested_pa[i] / thr[i];
        break;
      case Field::Displacement:
        if (state_) v[i] = state_->displacement_m[i] * 1e3;
        break;
      case Field::Deviation:
        if (i < deviation_m_.size()) v[i] = deviation_m_[i] * 1e3;
        break;
      case Field::Rectification:
        if (const RectificationChart* c = rectification(); c && i < c->rectification.vertex_m.size())
          v[i] = c->rectification.vertex_m[i] * 1e3;
        break;
    }
  }
  if (is_auto_range_) {
    double hi = 0;
    for (double x : v)
      if (std::isfinite(x)) hi = std::max(hi, field_ == Field::Deviation ? std::abs(x) : x);
    range_min_ = 0;
    range_max_ = field_ == Field::Ratio ? 1.2f : static_cast<float>(hi > 0 ? hi : 1.0);
    if (field_ == Field::Deviation) {  // symmetric about 0: blue inside, red outside
      range_max_ = static_cast<float>(report::nice_ceil(hi > 0 ? hi : 1.0));
      range_min_ = -range_max_;
    }
    if (const RectificationChart* c = rectification(); field_ == Field::Rectification && c) {  // the report's bar
      range_max_ = static_cast<float>(pipeline::rectification_span_mm(c->rectification));
      range_min_ = -range_max_;
    }
  }
  const report::Colormap cm = field_colormap(field_);
  std::vector<Rgba> colours(n);
  const double span = std::max(1e-12, static_cast<double>(range_max_ - range_min_));
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(v[i])) {
      colours[i] = {0.78f, 0.76f, 0.74f, 1.0f};  // no data (above the brim, or no solve yet)
      continue;
    }
    const auto c = report::colormap_colour(cm, (v[i] - range_min_) / span);
    colours[i] = {c.r / 255.0f, c.g / 255.0f, c.b / 255.0f, 1.0f};
  }
  stump_.set_colours(colours);
  ++scene_version_;
}

void App::update_feedback() {
  if (!setup_ || !state_) return;
  const auto& st = *state_;
  try {
    radar_ = pipeline::radar_axes(*setup_, st);
    profiles_ = pipeline::pressure_profiles(*setup_, st);
    template_ = pipeline::template_check(*setup_, st);
  } catch (const Error& e) {
    show_error(e.what());
  }
}

const RectificationChart* App::rectification() const {
  return rectification_ && rectification_->setup == setup_serial_ && rectification_->error.empty() ? &*rectification_
                                                                                                   : nullptr;
}

std::vector<RectificationRow> App::rectification_rows() const {
  std::vector<RectificationRow> rows;
  const RectificationChart* c = rectification();
  if (!c) return rows;
  for (const auto& l : c->rectification.landmarks) {
    const double mm = l.rectification_m * 1e3;
    rows.push_back({l.code, l.name, mm, std::isfinite(mm) ? fmt::format("{:+.2f}", mm) : "-",
                    pipeline::rectification_kind(l.rectification_m), l.is_axial ? "along the axis" : "radially"});
  }
  return rows;
}

void App::poll_rectification() {
  if (rectification_job_.valid()) {
    if (rectification_job_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
    RectificationChart c = rectification_job_.get();  // the job keeps its errors in c.error
    if (c.setup == setup_serial_) {  // else it was of the limb before
      if (!c.error.empty()) show_error("rectification chart: " + c.error);
      rectification_ = std::move(c);
      if (field_ == Field::Rectification) colours_dirty_ = true;
    }
  }
  if (!is_rectification_asked_ || !setup_ || !state_) return;
  if (rectification_ && rectification_->setup == setup_serial_ && rectification_->state == state_serial_) return;
  // Once the shown design has settled: no solve waiting, no slider held, no optimisation running
  // (then the state is a full solve under the current brim).
  if ((worker_ && worker_->is_busy()) || edit_start_ || is_optimising_) return;
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
          const pipeline::ChecksWall wall = pipeline::designed_wall(rest, designed, met, frame, brim, socket);
          c.wall_source = wall.source;
          c.rectification = pipeline::compute_rectification(rest, wall.wall, frame, brim, landmarks);
        } catch (const std::exception& e) {
          c.error = e.what();
        }
        c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        return c;
      });
}

// ------------------------------------------------------------------------------------------------
// Frame
// ------------------------------------------------------------------------------------------------

void App::frame(int width, int height) {
  poll_jobs();
  poll_worker();
  poll_rectification();
  autosave();
  update_colours();

  ImGuiIO& io = ImGui::GetIO();
  if (!io.WantTextInput) {
    if (io.KeyCtrl && ImGui::IsKeyPressed(GLFW_KEY_Z)) undo();
    if (io.KeyCtrl && ImGui::IsKeyPressed(GLFW_KEY_Y)) redo();
    if (io.KeyCtrl && ImGui::IsKeyPressed(GLFW_KEY_S)) {
      if (case_path_.empty()) dialog_ = Dialog::SaveAs;
      else try {
          save_case(case_path_);
        } catch (const Error&) {
        }
    }
    if (!io.KeyCtrl) {
      if (ImGui::IsKeyPressed(GLFW_KEY_1)) set_field(Field::Pressure);
      if (ImGui::IsKeyPressed(GLFW_KEY_2)) set_field(Field::Threshold);
      if (ImGui::IsKeyPressed(GLFW_KEY_3)) set_field(Field::Ratio);
      if (ImGui::IsKeyPressed(GLFW_KEY_4)) set_field(Field::Displacement);
      if (ImGui::IsKeyPressed(GLFW_KEY_5) && !deviation_m_.empty()) set_field(Field::Deviation);
      if (ImGui::IsKeyPressed(GLFW_KEY_6)) set_field(Field::Rectification);
      if (ImGui::IsKeyPressed(GLFW_KEY_F) && setup_) camera_.frame(geometry::bounding_box(setup_->model.skin));
      if (ImGui::IsKeyPressed(GLFW_KEY_ESCAPE)) is_placing_spot_ = false;
    }
  }

  draw_menu();
  const float menu_h = ImGui::GetFrameHeight();
  ImGui::SetNextWindowPos(ImVec2(0, menu_h));
  ImGui::SetNextWindowSize(ImVec2(kLeftPanel, static_cast<float>(height) - menu_h));
  ImGui::Begin("Design", nullptr, ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  draw_design_panel();
  draw_patient_panel();
  ImGui::End();
  ImGui::SetNextWindowPos(ImVec2(static_cast<float>(width) - kRightPanel, menu_h));
  ImGui::SetNextWindowSize(ImVec2(kRightPanel, static_cast<float>(height) - menu_h));
  ImGui::Begin("Feedback", nullptr, ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  draw_feedback_panel();
  ImGui::End();
  draw_file_dialog();
  draw_close_dialog();

  const int vx = static_cast<int>(kLeftPanel), vy = static_cast<int>(menu_h);
  const int vw = std::max(1, width - static_cast<int>(kLeftPanel + kRightPanel)), vh = std::max(1, height - vy);
  handle_view_input(vx, vy, vw, vh);
  draw_viewport_overlay(vx, vy, vw, vh);

  ImGui::Render();
  // The panels cover the window but the view, which render_scene clears: no full-window clear.
  render_scene(vx, vy, vw, vh, height);
  glViewport(0, 0, width, height);
}

void App::render_scene(int x, int y, int width, int height, int framebuffer_height) {
  // Redrawn only when something in it changed (camera, data, toggles, size).
  const std::array<double, 12> key{camera_.target.x(), camera_.target.y(), camera_.target.z(), camera_.yaw_rad,
                                   camera_.pitch_rad,  camera_.distance_m, static_cast<double>(scene_version_),
                                   static_cast<double>(show_bones_ + 2 * show_socket_ + 4 * show_brim_),
                                   socket_alpha_,      stump_alpha_,       static_cast<double>(setup_ != nullptr),
                                   static_cast<double>(state_.has_value())};
  const bool resized = scene_target_.resize(width, height, is_headless_ ? 0 : 4);
  if (resized || key != scene_key_) {
    scene_key_ = key;
    scene_target_.bind();
    draw_scene(width, height);
  }
  scene_target_.blit_to_window(x, framebuffer_height - y - height);
}

void App::draw_scene(int width, int height) {
  renderer_->begin(camera_, width, height);
  if (setup_) {
    // Opaque stump first: the bones inside it then fail the depth test before shading (llvmpipe
    // shades in software, so overdraw costs frame rate); x-ray: bones first, stump blended over.
    const bool is_xray = stump_alpha_ < 1.0f;
    if (!is_xray) renderer_->draw_opaque(stump_);
    if (show_bones_)
      for (const auto& b : bones_) renderer_->draw_opaque(*b);
    if (is_xray) renderer_->draw_translucent(stump_, stump_alpha_);
    if (show_brim_) renderer_->draw_lines(brim_lines_, {0.1f, 0.1f, 0.1f, 1.0f}, false);
    if (show_socket_ && state_) renderer_->draw_translucent(socket_, socket_alpha_);
  }
  renderer_->end();
}

void App::screenshot(const fs::path& path, int width, int height) const {
  const auto rgb = read_pixels(width, height);
  report::Image img(width, height, {0, 0, 0});
  for (size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = {rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]};
  if (path.has_parent_path()) ensure_directory(path.parent_path());
  report::write_png(path, img);
}

// ------------------------------------------------------------------------------------------------
// Panels
// ------------------------------------------------------------------------------------------------

void App::draw_menu() {
  if (!ImGui::BeginMainMenuBar()) return;
  if (ImGui::BeginMenu("File")) {
    if (ImGui::MenuItem("Open case...")) dialog_ = Dialog::OpenCase;
    if (ImGui::MenuItem("Open limb scan...")) dialog_ = Dialog::OpenLimb;
    if (ImGui::BeginMenu("Open demo")) {
      for (int n : {2500, 8000, 20000})
        if (ImGui::MenuItem(fmt::format("{} nodes", n).c_str())) open_demo(n);
      ImGui::EndMenu();
    }
    ImGui::Separator();
    if (ImGui::MenuItem("Save", "Ctrl+S", false, setup_ != nullptr)) {
      if (case_path_.empty()) dialog_ = Dialog::SaveAs;
      else try {
          save_case(case_path_);
        } catch (const Error&) {
        }
    }
    if (ImGui::MenuItem("Save as...", nullptr, false, setup_ != nullptr)) dialog_ = Dialog::SaveAs;
    if (ImGui::MenuItem("Export socket and report...", nullptr, false, setup_ != nullptr)) dialog_ = Dialog::Export;
    if (ImGui::MenuItem("Compare with a second shape...", nullptr, false, setup_ != nullptr)) dialog_ = Dialog::Compare;
    ImGui::Separator();
    if (ImGui::MenuItem("Quit")) glfwSetWindowShouldClose(window_, 1);
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Edit")) {
    if (ImGui::MenuItem("Undo", "Ctrl+Z", false, !undo_.empty())) undo();
    if (ImGui::MenuItem("Redo", "Ctrl+Y", false, !redo_.empty())) redo();
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("View")) {
    ImGui::MenuItem("Bones", nullptr, &show_bones_);
    ImGui::MenuItem("Landmarks", nullptr, &show_landmarks_);
    ImGui::MenuItem("Socket", nullptr, &show_socket_);
    ImGui::MenuItem("Brim line", nullptr, &show_brim_);
    if (ImGui::MenuItem("Frame the limb", "F") && setup_) camera_.frame(geometry::bounding_box(setup_->model.skin));
    ImGui::EndMenu();
  }
  ImGui::TextDisabled("%s%s", case_path_.empty() ? "(unsaved case)" : case_path_.filename().string().c_str(),
                      is_dirty_ ? " *" : "");
  ImGui::EndMainMenuBar();
}

void App::draw_design_panel() {
  if (!setup_) {
    ImGui::TextWrapped("No case open. File > Open case, Open limb scan, or Open demo.");
    if (ImGui::Button("Open the demo (8000 nodes)")) open_demo(8000);
    return;
  }
  if (ImGui::CollapsingHeader("Spots", ImGuiTreeNodeFlags_DefaultOpen)) {
    ImGui::BeginDisabled(is_optimising_);  // the optimiser's result replaces the spots
    const char* types[] = {"cos2", "sig2", "cos-sig", "grad"};
    ImGui::SetNextItemWidth(90);
    ImGui::Combo("type", &new_spot_type_, types, 4);
    ImGui::SameLine();
    ImGui::SetNextItemWidth(90);
    ImGui::DragFloat("kPa", &new_spot_amplitude_kpa_, 0.5f, 0.0f, 500.0f, "%.1f");
    ImGui::SameLine();
    if (ImGui::Checkbox("place", &is_placing_spot_)) {
    }
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("Click on the stump to place a spot of this type (Esc: stop)");
    ImGui::BeginChild("spots", ImVec2(0, 300), true);
    const double L = setup_->model.length_m * 1e3;
    for (int k = 0; k < static_cast<int>(case_.spots.size()); ++k) {
      design::Spot& s = case_.spots[k];
      ImGui::PushID(k);
      bool enabled = s.enabled;
      if (ImGui::Checkbox("##on", &enabled)) set_spot_value(k, "enabled", enabled ? 1 : 0);
      ImGui::SameLine();
      const std::string label =
          fmt::format("{} [{}] {:.1f} kPa", s.name, design::to_string(s.type), s.amplitude_pa / 1e3);
      if (ImGui::Selectable(label.c_str(), selected_spot_ == k)) selected_spot_ = k;
      if (selected_spot_ == k && scroll_to_selected_) {
        ImGui::SetScrollHereY(0.2f);
        scroll_to_selected_ = false;
      }
      if (selected_spot_ == k) {
        ImGui::Indent();
        const auto slider = [&](const char* name, const char* field, double value, float lo, float hi, const char* fmt_) {
          float v = static_cast<float>(value);
          const bool changed = ImGui::SliderFloat(name, &v, lo, hi, fmt_);
          if (ImGui::IsItemActivated()) begin_edit();
          if (changed) {
            try {
              set_spot_value(k, field, v);
            } catch (const Error& e) {
              show_error(e.what());
            }
          }
          if (ImGui::IsItemDeactivated()) end_edit();
        };
        slider("A [kPa]", "amplitude_kpa", s.amplitude_pa / 1e3, 0, 300, "%.1f");
        if (s.type == design::SpotType::Cos2 || s.type == design::SpotType::CosSig) {
          slider("theta0 [deg]", "theta0_deg", s.theta0 / kDeg, -180, 180, "%.0f");
          slider("R_theta [deg]", "r_theta_deg", s.r_theta / kDeg, 1, 180, "%.0f");
        }
        if (s.type == design::SpotType::Sig2) {
          slider("theta1 [deg]", "theta1_deg", s.theta1 / kDeg, -180, 180, "%.0f");
          slider("theta2 [deg]", "theta2_deg", s.theta2 / kDeg, -180, 180, "%.0f");
        }
        if (s.type == design::SpotType::Cos2) {
          slider("h0 [mm]", "h0_mm", s.h0 * 1e3, 0, static_cast<float>(L), "%.0f");
          slider("R_h [mm]", "r_h_mm", s.r_h * 1e3, 1, static_cast<float>(L), "%.0f");
        } else {
          slider("h1 [mm]", "h1_mm", s.h1 * 1e3, 0, static_cast<float>(L), "%.0f");
          slider("h2 [mm]", "h2_mm", s.h2 * 1e3, 0, static_cast<float>(L), "%.0f");
        }
        if (ImGui::Checkbox("optimiser may change A", &s.optimise_amplitude)) is_dirty_ = true;
        if (ImGui::Checkbox("optimiser may move it", &s.optimise_position)) is_dirty_ = true;
        if (ImGui::Button("Remove spot")) {
          try {
            remove_spot(k);
          } catch (const Error& e) {
            show_error(e.what());
          }
        }
        ImGui::Unindent();
      }
      ImGui::PopID();
    }
    ImGui::EndChild();
    ImGui::EndDisabled();
    const auto [fraction, stage] = worker_ ? worker_->progress() : std::pair<double, std::string>{0, ""};
    if (is_optimising_) {
      ImGui::ProgressBar(static_cast<float>(fraction), ImVec2(-80, 0), stage.c_str());
      ImGui::SameLine();
      if (ImGui::Button("Cancel")) cancel_optimise();
    } else {
      if (ImGui::Button("Optimise", ImVec2(-170, 0))) optimise(optimise_time_limit_s_);
      ImGui::SameLine();
      ImGui::SetNextItemWidth(100);
      ImGui::InputFloat("s max", &optimise_time_limit_s_, 10, 60, "%.0f");
      if (ImGui::IsItemHovered()) ImGui::SetTooltip("Time limit of the optimiser in seconds (0: none)");
      optimise_time_limit_s_ = std::max(0.0f, optimise_time_limit_s_);
    }
    if (!optimiser_message_.empty()) ImGui::TextWrapped("%s", optimiser_message_.c_str());
  }
  if (ImGui::CollapsingHeader("Brim and socket", ImGuiTreeNodeFlags_DefaultOpen)) {
    const bool tt = setup_->model.type == geometry::LimbType::Transtibial;
    const std::vector<design::BrimTemplate> kinds =
        tt ? std::vector<design::BrimTemplate>{design::BrimTemplate::Ptb, design::BrimTemplate::PtbSc,
                                               design::BrimTemplate::PtbScsp, design::BrimTemplate::Kbm,
                                               design::BrimTemplate::Tsb}
           : std::vector<design::BrimTemplate>{design::BrimTemplate::Quad, design::BrimTemplate::Ics};
    const std::string current = design::to_string(case_.brim.value_or(design::default_brim(setup_->model.type))) +
                                (case_.brim_key_points.empty() ? "" : " (edited)");
    if (ImGui::BeginCombo("template", current.c_str())) {
      for (auto k : kinds)
        if (ImGui::Selectable(design::to_string(k).c_str(), k == case_.brim)) set_brim_template(k);
      ImGui::EndCombo();
    }
    const auto& kp = setup_->brim.key_points();
    for (int i = 0; i < static_cast<int>(kp.size()); ++i) {
      ImGui::PushID(1000 + i);
      float th = static_cast<float>(kp[i].theta / kDeg), h = static_cast<float>(kp[i].h * 1e3);
      ImGui::SetNextItemWidth(150);
      bool changed = ImGui::DragFloat("##th", &th, 0.5f, -180, 180, "%.0f deg");
      if (ImGui::IsItemActivated()) {
        selected_key_point_ = i;
        begin_edit();  // one drag, one undo step
      }
      if (ImGui::IsItemDeactivated()) end_edit();
      ImGui::SameLine();
      ImGui::SetNextItemWidth(150);
      changed |= ImGui::DragFloat("##h", &h, 0.5f, 0, static_cast<float>(setup_->model.length_m * 1e3), "%.0f mm");
      if (ImGui::IsItemActivated()) {
        selected_key_point_ = i;
        begin_edit();  // one drag, one undo step
      }
      if (ImGui::IsItemDeactivated()) end_edit();
      if (changed) move_brim_key_point(i, th * kDeg, h * 1e-3);
      ImGui::PopID();
    }
    ImGui::TextDisabled("Drag a key point's values, or Shift+drag it on the stump.");
    float thk = static_cast<float>(case_.socket.thickness_m * 1e3);
    const bool thk_changed = ImGui::SliderFloat("wall [mm]", &thk, 1, 15, "%.1f");
    if (ImGui::IsItemActivated()) begin_edit();  // before the change: one drag, one undo step
    if (thk_changed) set_thickness(thk * 1e-3);
    if (ImGui::IsItemDeactivated()) end_edit();
  }
}

void App::draw_patient_panel() {
  if (!setup_ || !ImGui::CollapsingHeader("Patient")) return;
  ImGui::TextWrapped("Changes here rebuild the stump model (a few seconds) when applied.");
  float mass = static_cast<float>(case_.patient.body_mass_kg);
  float pmass = static_cast<float>(case_.patient.prosthesis_mass_kg);
  float mu = static_cast<float>(case_.patient.friction);
  float e = static_cast<float>(case_.youngs_modulus_pa / 1e3);
  bool changed = false;
  changed |= ImGui::InputFloat("body mass [kg]", &mass, 1, 5, "%.1f");
  changed |= ImGui::InputFloat("prosthesis [kg]", &pmass, 0.1f, 1, "%.2f");
  changed |= ImGui::InputFloat("friction [-]", &mu, 0.05f, 0.1f, "%.2f");
  changed |= ImGui::InputFloat("tissue E [kPa]", &e, 5, 20, "%.0f");
  auto table = case_.thresholds.empty() ? design::default_thresholds(setup_->model.type) : case_.thresholds;
  ImGui::Text("Pain thresholds [kPa]");
  bool thr_changed = false;
  for (auto& [code, v] : table) {
    float kpa = static_cast<float>(v / 1e3);
    if (ImGui::InputFloat(code.c_str(), &kpa, 1, 10, "%.1f")) {
      v = kpa * 1e3;
      thr_changed = true;
    }
  }
  if (changed || thr_changed) {
    design::PatientLoad p = case_.patient;
    p.body_mass_kg = mass;
    p.prosthesis_mass_kg = pmass;
    p.friction = mu;
    try {
      set_patient(p, e * 1e3, thr_changed ? table : case_.thresholds);
    } catch (const Error& err) {
      show_error(err.what());
    }
  }
  if (ImGui::Button("Apply (rebuild the stump model)")) {
    load(case_, case_path_, "rebuilding the stump model", true);
  }
}

/// What the design means against its brim template: per region the mean and peak pressure and the
/// share of the axial load, and the template's criteria (green when they hold).
void App::draw_template_check() {
  if (!template_ || !ImGui::CollapsingHeader("Template regions", ImGuiTreeNodeFlags_DefaultOpen)) return;
  const design::TemplateCheck& t = *template_;
  if (t.applies) {
    ImGui::PushStyleColor(ImGuiCol_Text, t.met ? IM_COL32(90, 220, 110, 255) : IM_COL32(255, 120, 100, 255));
    ImGui::TextWrapped("%s: %s", t.template_name.c_str(), t.met ? "means its template" : "does NOT mean its template");
    ImGui::PopStyleColor();
  }
  if (ImGui::BeginTable("regions", 4, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingStretchProp)) {
    for (const char* h : {"region", "mean kPa", "peak kPa", "% of F_z"}) ImGui::TableSetupColumn(h);
    ImGui::TableHeadersRow();
    for (const design::ZoneLoad* r : {&t.tolerant, &t.sensitive, &t.distal_fifth, &t.below_brim}) {
      if (r->nodes == 0) continue;
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(r->codes.empty() ? r->key.c_str() : fmt::format("{}", fmt::join(r->codes, " ")).c_str());
      ImGui::TableNextColumn();
      ImGui::Text("%.1f", r->mean_pa / 1e3);
      ImGui::TableNextColumn();
      ImGui::Text("%.1f", r->peak_pa / 1e3);
      ImGui::TableNextColumn();
      ImGui::Text("%.0f", 100 * r->axial_share);
    }
    ImGui::EndTable();
  }
  if (t.applies) ImGui::TextWrapped("%s", t.summary.c_str());
}

/// The rectification chart: socket minus limb at each landmark (indentation blue, relief red), the
/// range below the brim, and the button that colours the stump by it.
void App::draw_rectification() {
  if (!state_) return;
  if (is_rectification_table_opening_) ImGui::SetNextItemOpen(true);
  is_rectification_table_opening_ = false;
  if (!ImGui::CollapsingHeader("Rectification chart")) return;
  if (!is_rectification_asked_ || field_ != Field::Rectification) {
    if (ImGui::SmallButton("Colour the stump by socket - limb")) set_field(Field::Rectification);
    if (!is_rectification_asked_) return;
  }
  if (rectification_ && rectification_->setup == setup_serial_ && !rectification_->error.empty()) {
    ImGui::PushStyleColor(ImGuiCol_Text, IM_COL32(255, 110, 100, 255));
    ImGui::TextWrapped("Not computed: %s", rectification_->error.c_str());
    ImGui::PopStyleColor();
    return;
  }
  const RectificationChart* c = rectification();
  if (!c) {
    ImGui::TextDisabled("computing the rectification...");
    return;
  }
  const pipeline::Rectification& r = c->rectification;
  ImGui::TextWrapped("Socket minus limb [mm]: %s against the skin at rest, radially (along the axis at the distal "
                     "end); < 0 indentation, > 0 relief. Below the brim %+.2f ... %+.2f mm, mean %+.2f mm (%.1f s).",
                     c->wall_source.c_str(), r.min_m * 1e3, r.max_m * 1e3, r.mean_m * 1e3, c->seconds);
  if (c->state != state_serial_) ImGui::TextDisabled("(of the design before: updating)");
  if (ImGui::BeginTable("rectification", 4, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingStretchProp)) {
    for (const char* h : {"landmark", "socket - limb [mm]", "", "measured"}) ImGui::TableSetupColumn(h);
    ImGui::TableHeadersRow();
    for (const RectificationRow& row : rectification_rows()) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(row.code.c_str());
      if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", row.name.c_str());
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(row.value.c_str());
      ImGui::TableNextColumn();
      const ImU32 colour = !std::isfinite(row.mm) ? IM_COL32(160, 160, 160, 255)
                           : row.mm < 0            ? IM_COL32(110, 160, 255, 255)
                                                   : IM_COL32(255, 120, 100, 255);
      ImGui::PushStyleColor(ImGuiCol_Text, colour);
      ImGui::TextUnformatted(row.kind.c_str());
      ImGui::PopStyleColor();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(row.measured.c_str());
    }
    ImGui::EndTable();
  }
}

void App::draw_feedback_panel() {
  if (job_) {
    std::string stage;
    {
      std::lock_guard lock(*job_->stage_mutex);
      stage = *job_->stage;
    }
    ImGui::TextWrapped("%s", job_->what.c_str());
    ImGui::ProgressBar(static_cast<float>(job_->fraction->load()), ImVec2(-1, 0), stage.c_str());
  }
  for (size_t k = 0; k < errors_.size(); ++k) {
    ImGui::PushID(static_cast<int>(5000 + k));
    ImGui::PushStyleColor(ImGuiCol_Text, IM_COL32(255, 110, 100, 255));
    ImGui::TextWrapped("Error: %s", errors_[k].c_str());
    ImGui::PopStyleColor();
    ImGui::PopID();
  }
  if (!errors_.empty() && ImGui::SmallButton("Dismiss errors")) errors_.clear();
  if (!info_.empty()) ImGui::TextWrapped("%s", info_.c_str());
  if (!setup_) return;
  const bool met = state_ && state_->status.all_ok();
  ImGui::PushStyleColor(ImGuiCol_Text, met ? IM_COL32(90, 220, 110, 255) : IM_COL32(255, 120, 100, 255));
  ImGui::Text("%s", !state_ ? "solving..." : met ? "All constraints met" : ("Not met: " + state_->status.failing()).c_str());
  ImGui::PopStyleColor();
  if (worker_ && worker_->is_busy()) {
    ImGui::SameLine();
    ImGui::TextDisabled("(updating)");
  }
  std::vector<std::string> estimated;
  if (setup_->model.bones_estimated) estimated.push_back("the bones");
  if (setup_->model.frame.anterior_estimated) estimated.push_back("the front direction");
  if (setup_->model.frame.side_estimated) estimated.push_back("the side");
  if (!estimated.empty()) {
    ImGui::PushStyleColor(ImGuiCol_Text, IM_COL32(255, 200, 80, 255));
    ImGui::TextWrapped("Check %s: estimated from the skin", fmt::format("{}", fmt::join(estimated, ", ")).c_str());
    ImGui::PopStyleColor();
  }
  draw_template_check();
  draw_rectification();
  if (ImGui::CollapsingHeader("Log")) {
    ImGui::BeginChild("log", ImVec2(0, 160), true, ImGuiWindowFlags_HorizontalScrollbar);
    std::lock_guard lock(log_->mutex);
    for (const auto& l : log_->lines) ImGui::TextUnformatted(l.c_str());
    if (ImGui::GetScrollY() >= ImGui::GetScrollMaxY()) ImGui::SetScrollHereY(1.0f);
    ImGui::EndChild();
  }
  if (ImGui::CollapsingHeader("Limb notes")) {
    ImGui::TextWrapped("%s", setup_->limb_label.c_str());
    for (const auto& n : setup_->model.notes) ImGui::BulletText("%s", n.c_str());
  }
  radar_chart(radar_, kRightPanel - 20);
  if (state_)
    ImGui::TextWrapped("peak p/T %.0f %%, max displacement %.1f mm; %s", 100 * state_->max_requested_ratio,
                       state_->max_displacement_m * 1e3, solve_status_.c_str());
  for (const auto& p : profiles_) profile_plot(p, ImVec2(kRightPanel - 20, 120));
}

void App::draw_viewport_overlay(int x, int y, int width, int height) {
  ImDrawList* dl = ImGui::GetBackgroundDrawList();
  if (!setup_) {
    dl->AddText(ImVec2(x + 20.0f, y + 20.0f), IM_COL32(230, 230, 230, 255),
                job_ ? "preparing the stump model..." : "no case open");
    return;
  }
  const char* units = field_ == Field::Ratio ? "p/T [-]" : field_ == Field::Displacement ? "displacement [mm]"
                      : field_ == Field::Threshold                              ? "threshold [kPa]"
                      : field_ == Field::Deviation                              ? "deviation [mm]"
                      : field_ == Field::Rectification                          ? "socket - limb [mm]"
                                                                                : "pressure [kPa]";
  colour_bar(dl, ImVec2(x + width - 70.0f, y + 60.0f), ImVec2(18, 240), field_colormap(field_), range_min_, range_max_,
             "");
  dl->AddText(ImVec2(x + width - 160.0f, y + 36.0f), IM_COL32(20, 20, 20, 255), units);
  if (show_landmarks_) {
    const Vec3 eye = camera_.eye();
    for (const auto& l : setup_->model.landmarks) {
      const auto q = camera_.project(l.position, width, height);
      if (!q) continue;
      // Visible when the skin there faces the eye (the landmark's radial direction).
      const Vec3 radial = setup_->model.frame.radial(l.cylindrical.theta);
      const bool front = radial.dot(eye - l.position) > 0;
      const ImVec2 p(x + static_cast<float>(q->x()), y + static_cast<float>(q->y()));
      dl->AddCircleFilled(p, 5, front ? IM_COL32(230, 40, 200, 255) : IM_COL32(230, 40, 200, 90));
      dl->AddText(ImVec2(p.x + 7, p.y - 7), front ? IM_COL32(20, 20, 20, 255) : IM_COL32(20, 20, 20, 90),
                  l.code.c_str());
    }
  }
  if (selected_spot_ >= 0 && selected_spot_ < static_cast<int>(case_.spots.size())) {
    double th = 0, h = 0;
    design::spot_centre(case_.spots[selected_spot_], th, h);
    if (const auto q = camera_.project(pipeline::skin_point(*setup_, th, h), width, height))
      dl->AddCircle(ImVec2(x + static_cast<float>(q->x()), y + static_cast<float>(q->y())), 10,
                    IM_COL32(255, 255, 255, 255), 24, 3);
  }
  const std::string help = is_placing_spot_ ? "click on the stump to place the spot (Esc: stop)"
                                            : "left drag: orbit   right/middle drag: pan   wheel: zoom   F: frame   "
                                              "1-6: field";
  dl->AddText(ImVec2(x + 10.0f, y + height - 22.0f), IM_COL32(60, 60, 60, 255), help.c_str());
  // Field and range controls on the view.
  ImGui::SetNextWindowPos(ImVec2(x + 10.0f, y + 10.0f));
  ImGui::SetNextWindowBgAlpha(0.75f);
  ImGui::Begin("##view", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoMove |
                   ImGuiWindowFlags_NoSavedSettings);
  const char* fields[] = {"applied pressure [kPa]", "pain threshold [kPa]", "pressure / threshold", "displacement [mm]",
                          "deviation of the compared shape [mm]", "rectification [mm]"};
  // The deviation is offered once a second shape was compared (File > Compare with a second shape),
  // the rectification once a design is shown.
  std::vector<Field> offered{Field::Pressure, Field::Threshold, Field::Ratio, Field::Displacement};
  if (!deviation_m_.empty()) offered.push_back(Field::Deviation);
  if (state_) offered.push_back(Field::Rectification);
  ImGui::SetNextItemWidth(200);
  if (ImGui::BeginCombo("colour", fields[static_cast<int>(field_)])) {
    for (Field f : offered)
      if (ImGui::Selectable(fields[static_cast<int>(f)], f == field_)) set_field(f);
    ImGui::EndCombo();
  }
  if (field_ == Field::Deviation && !comparison_file_.empty())  // the whole line is in the feedback panel
    ImGui::TextDisabled("vs %s (> 0: it lies outside the limb)", comparison_file_.c_str());
  if (field_ == Field::Rectification)  // the table is in the feedback panel
    ImGui::TextDisabled("blue: indentation, red: relief; grey above the brim");
  if (ImGui::Checkbox("auto range", &is_auto_range_)) colours_dirty_ = true;
  if (!is_auto_range_) {
    ImGui::SetNextItemWidth(200);
    const bool is_signed = field_ == Field::Deviation || field_ == Field::Rectification;
    if (ImGui::DragFloatRange2("range", &range_min_, &range_max_, 0.1f, is_signed ? -100.0f : 0.0f, 1000.0f))
      colours_dirty_ = true;
  }
  ImGui::SetNextItemWidth(200);
  ImGui::SliderFloat("stump opacity", &stump_alpha_, 0.2f, 1.0f, "%.2f");
  ImGui::Checkbox("bones", &show_bones_);
  ImGui::SameLine();
  ImGui::Checkbox("landmarks", &show_landmarks_);
  ImGui::SameLine();
  ImGui::Checkbox("socket", &show_socket_);
  if (show_socket_) {
    ImGui::SetNextItemWidth(200);
    ImGui::SliderFloat("socket opacity", &socket_alpha_, 0.05f, 0.9f, "%.2f");
  }
  ImGui::End();
}

void App::handle_view_input(int x, int y, int width, int height) {
  ImGuiIO& io = ImGui::GetIO();
  const ImVec2 m = io.MousePos;
  const bool inside = m.x >= x && m.x < x + width && m.y >= y && m.y < y + height;
  if (io.WantCaptureMouse || !inside) {
    if (!ImGui::IsMouseDown(ImGuiMouseButton_Left)) is_dragging_view_ = false;
    if (!is_dragging_view_) return;
  }
  // Hover: the values under the cursor (the nearest skin node of the triangle hit).
  if (setup_ && !ImGui::IsAnyMouseDown()) {
    const auto [o, dir] = camera_.ray(m.x - x, m.y - y, width, height);
    if (const auto hit = pick(skin_rest_, o, dir)) {
      int node = -1;
      double best = 1e9;
      for (int k : skin_rest_.triangles[hit->triangle])
        if ((skin_rest_.vertices[k] - hit->point).norm() < best) {
          best = (skin_rest_.vertices[k] - hit->point).norm();
          node = k;
        }
      const auto c = setup_->model.frame.to_cylindrical(hit->point);
      std::string text = fmt::format("theta {:.0f} deg, h {:.0f} mm\nthreshold {:.1f} kPa", c.theta / kDeg, c.h * 1e3,
                                     setup_->solver->thresholds()[node] / 1e3);
      if (state_ && setup_->solver->above_brim()[node]) text += "\nabove the brim";
      else if (state_)
        text += fmt::format("\npressure {:.1f} kPa (p/T {:.2f})\ndisplacement {:.2f} mm", state_->pressure_pa[node] / 1e3,
                            state_->requested_pa[node] / setup_->solver->thresholds()[node],
                            state_->displacement_m[node] * 1e3);
      if (const RectificationChart* rc = rectification();
          field_ == Field::Rectification && rc && node < static_cast<int>(rc->rectification.vertex_m.size()) &&
          std::isfinite(rc->rectification.vertex_m[node]))
        text += fmt::format("\nsocket - limb {:+.2f} mm", rc->rectification.vertex_m[node] * 1e3);
      ImGui::SetTooltip("%s", text.c_str());
    }
  }
  if (ImGui::IsMouseClicked(ImGuiMouseButton_Left)) {
    is_dragging_view_ = true;
    drag_distance_px_ = 0;
  }
  if (io.MouseWheel != 0) camera_.zoom(io.MouseWheel);
  const ImVec2 d = io.MouseDelta;
  if (ImGui::IsMouseDown(ImGuiMouseButton_Left) && is_dragging_view_) {
    drag_distance_px_ += std::abs(d.x) + std::abs(d.y);
    if (io.KeyShift && setup_ && selected_key_point_ >= 0) {
      // Shift+drag: the selected brim key point follows the mouse on the skin.
      const auto [o, dir] = camera_.ray(m.x - x, m.y - y, width, height);
      if (const auto hit = pick(skin_rest_, o, dir)) {
        const auto c = setup_->model.frame.to_cylindrical(hit->point);
        if (drag_distance_px_ > 3) {
          begin_edit();  // ended when the button is released
          move_brim_key_point(selected_key_point_, c.theta, c.h);
        }
      }
    } else if (!is_placing_spot_) {
      camera_.orbit(d.x, d.y);
    }
  }
  if (ImGui::IsMouseDown(ImGuiMouseButton_Right) || ImGui::IsMouseDown(ImGuiMouseButton_Middle))
    camera_.pan(d.x, d.y, height);
  if (ImGui::IsMouseReleased(ImGuiMouseButton_Left) && is_dragging_view_) {
    is_dragging_view_ = false;
    end_edit();
    if (is_placing_spot_ && drag_distance_px_ < 4 && setup_) {
      const auto [o, dir] = camera_.ray(m.x - x, m.y - y, width, height);
      if (const auto hit = pick(skin_rest_, o, dir)) {
        const design::SpotType types[] = {design::SpotType::Cos2, design::SpotType::Sig2, design::SpotType::CosSig,
                                          design::SpotType::Grad};
        try {
          add_spot_at(hit->point, types[new_spot_type_], new_spot_amplitude_kpa_ * 1e3);
        } catch (const Error& e) {
          show_error(e.what());
        }
      }
    }
  }
}

// ------------------------------------------------------------------------------------------------
// Dialogs
// ------------------------------------------------------------------------------------------------

void App::draw_file_dialog() {
  if (dialog_ == Dialog::None) return;
  const char* titles[] = {"", "Open case", "Open limb scan", "Save case as", "Export to folder",
                          "Compare with a second shape (scan or socket)"};
  const char* title = titles[static_cast<int>(dialog_)];
  if (!ImGui::IsPopupOpen(title)) {
    ImGui::OpenPopup(title);
    if (dialog_path_.empty())
      dialog_path_ = dialog_ == Dialog::Export ? (fs::path(dialog_folder_) / "socketsmith_export").string()
                     : dialog_ == Dialog::SaveAs && !case_path_.empty() ? case_path_.string()
                                                                        : dialog_folder_ + "/";
  }
  ImGui::SetNextWindowSize(ImVec2(640, 460), ImGuiCond_Appearing);
  if (!ImGui::BeginPopupModal(title)) return;
  char buf[1024];
  std::snprintf(buf, sizeof buf, "%s", dialog_path_.c_str());
  ImGui::SetNextItemWidth(-1);
  if (ImGui::InputText("##path", buf, sizeof buf)) dialog_path_ = buf;
  // A small browser of the folder: directories and files of the right kind.
  ImGui::TextDisabled("%s", dialog_folder_.c_str());
  ImGui::BeginChild("files", ImVec2(0, 300), true);
  if (ImGui::Selectable("..")) dialog_folder_ = fs::path(dialog_folder_).parent_path().string();
  std::error_code ec;
  std::vector<fs::directory_entry> entries;
  for (const auto& e : fs::directory_iterator(dialog_folder_, ec)) entries.push_back(e);
  std::sort(entries.begin(), entries.end());
  for (const auto& e : entries) {
    const std::string name = e.path().filename().string();
    if (name.starts_with(".")) continue;
    if (e.is_directory(ec)) {
      if (ImGui::Selectable((name + "/").c_str())) {
        dialog_folder_ = e.path().string();
        if (dialog_ == Dialog::Export) dialog_path_ = e.path().string();
      }
      continue;
    }
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
    const bool wanted = dialog_ == Dialog::OpenLimb || dialog_ == Dialog::Compare
                            ? (ext == ".stl" || ext == ".obj" || ext == ".ply" || ext == ".aop")
                                                    : dialog_ != Dialog::Export && ext == ".json";
    if (wanted && ImGui::Selectable(name.c_str())) dialog_path_ = e.path().string();
  }
  ImGui::EndChild();
  if (dialog_ == Dialog::OpenLimb) ImGui::InputInt("mesh nodes", &dialog_target_nodes_, 1000, 5000);
  const char* ok = dialog_ == Dialog::SaveAs   ? "Save"
                   : dialog_ == Dialog::Export  ? "Export"
                   : dialog_ == Dialog::Compare ? "Compare"
                                                : "Open";
  if (ImGui::Button(ok, ImVec2(120, 0))) {
    const fs::path p = dialog_path_;
    switch (dialog_) {
      case Dialog::OpenCase: open_case(p); break;
      case Dialog::OpenLimb: open_limb(p, std::clamp(dialog_target_nodes_, 500, 100000)); break;
      case Dialog::SaveAs:
        try {
          save_case(p);
        } catch (const Error&) {
        }
        break;
      case Dialog::Export: export_design(p); break;
      case Dialog::Compare: compare_with(p); break;
      case Dialog::None: break;
    }
    dialog_ = Dialog::None;
    dialog_path_.clear();
    ImGui::CloseCurrentPopup();
  }
  ImGui::SameLine();
  if (ImGui::Button("Cancel", ImVec2(120, 0))) {
    dialog_ = Dialog::None;
    dialog_path_.clear();
    ImGui::CloseCurrentPopup();
  }
  ImGui::EndPopup();
}

void App::draw_close_dialog() {
  if (!is_close_requested_) return;
  if (!ImGui::IsPopupOpen("Unsaved changes")) ImGui::OpenPopup("Unsaved changes");
  if (!ImGui::BeginPopupModal("Unsaved changes", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) return;
  ImGui::Text("The case has unsaved changes.");
  if (ImGui::Button("Save and quit")) {
    is_close_requested_ = false;
    ImGui::CloseCurrentPopup();
    if (case_path_.empty()) dialog_ = Dialog::SaveAs;
    else try {
        save_case(case_path_);
        glfwSetWindowShouldClose(window_, 1);
      } catch (const Error&) {
      }
  }
  ImGui::SameLine();
  if (ImGui::Button("Quit without saving")) {
    is_dirty_ = false;
    glfwSetWindowShouldClose(window_, 1);
  }
  ImGui::SameLine();
  if (ImGui::Button("Cancel")) {
    is_close_requested_ = false;
    ImGui::CloseCurrentPopup();
  }
  ImGui::EndPopup();
}

}  // namespace socketsmith::gui
