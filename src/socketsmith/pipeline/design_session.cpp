// DesignSession: the document, its edits in clinical units, undo/redo, autosave and save. The jobs,
// solve results and charts are in design_session_results.cpp; the script actions and the journal
// in design_session_script.cpp.
#include "socketsmith/pipeline/design_session.h"

#include <algorithm>
#include <numbers>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/exit_status.h"
#include "socketsmith/core/log.h"
#include "socketsmith/design/case_parameters.h"
#include "socketsmith/design/input_limits.h"

namespace socketsmith::pipeline {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

/// A new spot of @p type centred at (theta, h) with the GUI's default widths: ±20 deg, ±15 mm.
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

DesignSession::DesignSession() = default;

DesignSession::~DesignSession() {
  worker_.reset();  // joins the solve thread before the solver goes
  if (job_ && job_->done.valid()) job_->done.wait();
  if (rectification_job_.valid()) rectification_job_.wait();
  if (delivery_job_) {
    delivery_job_->cancel->store(true);  // it stops at its next progress report
    delivery_job_->done.wait();
  }
}

void DesignSession::show_error(const std::string& message) {
  log::error("{}", message);
  errors_.push_back(message);
  if (errors_.size() > 20) errors_.erase(errors_.begin());
}

// ------------------------------------------------------------------------------------------------
// Document
// ------------------------------------------------------------------------------------------------

void DesignSession::open_case(const fs::path& path) {
  try {
    load(design::read_case(path), path, "opening " + path.string());
  } catch (const std::exception& e) {
    show_error(exit_status(std::current_exception()).message);
  }
}

void DesignSession::open_demo(int target_nodes) { load(demo_case(target_nodes), {}, "opening the demo"); }

void DesignSession::open_limb(const fs::path& path, int target_nodes) {
  design::CaseFile c;
  c.limb.file = fs::absolute(path).string();
  c.target_nodes = target_nodes;
  load(std::move(c), {}, "opening " + path.string());
}

void DesignSession::rebuild() {
  if (setup_ && load(case_, case_path_, "rebuilding the stump model", true)) record({{"do", "rebuild"}});
}

void DesignSession::install(std::unique_ptr<DesignSetup> setup, design::CaseFile c, fs::path path) {
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
  journal_ = json::array();
  is_dirty_ = false;
  state_.reset();
  template_.reset();       // the last case's reading
  rectification_.reset();  // the last limb's (a chart still computed for it is dropped when done)
  ++setup_serial_;
  ++brim_serial_;
  worker_ = std::make_unique<DesignWorker>(*setup_->solver);
  skin_rest_ = setup_->solver->skin().triangles();
  info_ = fmt::format("{}: {} nodes, {} skin nodes", case_path_.empty() ? "new case" : case_path_.string(),
                      setup_->solver->model().num_nodes(), setup_->solver->skin().nodes.size());
  request_solve(false);
}

void DesignSession::save_case(const fs::path& path) {
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

fs::path DesignSession::autosave_path() const {
  return case_path_.empty() ? fs::path("socketsmith_autosave.json") : fs::path(case_path_.string() + ".autosave.json");
}

bool DesignSession::autosave(std::chrono::steady_clock::time_point now, std::chrono::steady_clock::duration interval) {
  if (!is_dirty_ || !setup_) return false;
  if (now - last_autosave_ < interval) return false;
  last_autosave_ = now;
  const fs::path p = autosave_path();
  try {
    design::write_case(p, case_);
    info_ = "autosaved to " + p.string();
    return true;
  } catch (const Error& e) {
    show_error(std::string("autosave: ") + e.what());
    return false;
  }
}

// ------------------------------------------------------------------------------------------------
// History
// ------------------------------------------------------------------------------------------------

void DesignSession::push_history() {
  undo_.push_back(case_);
  if (undo_.size() > 200) undo_.erase(undo_.begin());
  redo_.clear();
}

bool DesignSession::step_history(std::vector<design::CaseFile>& from, std::vector<design::CaseFile>& to) {
  if (from.empty() || !setup_) return false;
  to.push_back(case_);
  case_ = from.back();
  from.pop_back();
  is_dirty_ = true;
  request_solve(true);
  return true;
}

void DesignSession::undo() {
  if (step_history(undo_, redo_)) record({{"do", "undo"}});
}

void DesignSession::redo() {
  if (step_history(redo_, undo_)) record({{"do", "redo"}});
}

void DesignSession::begin_edit() {
  if (edit_start_) return;
  push_history();
  edit_start_ = case_;
  record({{"do", "begin_edit"}});
}

void DesignSession::end_edit() {
  if (!edit_start_) return;
  edit_start_.reset();
  record({{"do", "end_edit"}});
  if (worker_ && setup_ && setup_->solver->options().mode != design::DesignSolveMode::Linear) request_solve(false);
}

void DesignSession::edit(const std::function<void()>& change, bool brim_changed) {
  if (!setup_) fail("no case is open: open a case, a limb or the demo first");
  if (!edit_start_) push_history();
  change();
  is_dirty_ = true;
  request_solve(brim_changed);
}

void DesignSession::request_solve(bool brim_changed) {
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
    ++brim_serial_;
  }
  worker_->solve(std::move(r));
}

// ------------------------------------------------------------------------------------------------
// Edits
// ------------------------------------------------------------------------------------------------

void DesignSession::add_spot(const Eigen::Vector3d& point, design::SpotType type, double amplitude_pa, const std::string& name) {
  if (!setup_) fail("add spot: no case is open");
  const auto& frame = setup_->model.frame;
  const auto cyl = frame.to_cylindrical(point);
  const double length = setup_->model.length_m;
  require(cyl.h > 0 && cyl.h < length, "add spot: the point at h = {:.0f} mm is off the limb (0..{:.0f} mm)",
          cyl.h * 1e3, length * 1e3);
  design::Spot s = spot_at(type, cyl.theta, cyl.h, amplitude_pa, length);
  s.name = name;
  if (s.name.empty()) {  // named after the nearest landmark within 30 mm, else numbered
    s.name = fmt::format("spot {}", case_.spots.size() + 1);
    double best = 0.03;
    for (const auto& l : setup_->model.landmarks)
      if ((l.position - point).norm() < best) {
        best = (l.position - point).norm();
        s.name = l.code + " " + std::to_string(case_.spots.size() + 1);
      }
  }
  design::validate_spot(s, length);
  edit([&] { case_.spots.push_back(s); });
}

void DesignSession::add_spot_at(const Eigen::Vector3d& point, design::SpotType type, double amplitude_pa) {
  add_spot(point, type, amplitude_pa, "");
  record({{"do", "add_spot"},
          {"point_mm", {point.x() * 1e3, point.y() * 1e3, point.z() * 1e3}},
          {"type", design::to_string(type)},
          {"amplitude_kpa", amplitude_pa / 1e3}});
}

void DesignSession::add_spot_at_landmark(const std::string& code, design::SpotType type, double amplitude_pa) {
  if (!setup_) fail("add spot: no case is open");
  for (const auto& l : setup_->model.landmarks)
    if (l.code == code) {
      add_spot(l.position, type, amplitude_pa, code + " (added)");
      record({{"do", "add_spot"}, {"landmark", code}, {"type", design::to_string(type)}, {"amplitude_kpa", amplitude_pa / 1e3}});
      return;
    }
  std::string codes;
  for (const auto& l : setup_->model.landmarks) codes += (codes.empty() ? "" : ", ") + l.code;
  fail("add spot: landmark '{}' is not on this limb (use one of {})", code, codes);
}

int DesignSession::spot_index(const std::string& name) const {
  for (size_t k = 0; k < case_.spots.size(); ++k)
    if (case_.spots[k].name == name) return static_cast<int>(k);
  return -1;
}

void DesignSession::set_spot_value(int index, const std::string& field, double value) {
  require(index >= 0 && index < static_cast<int>(case_.spots.size()), "set: spot {} does not exist ({} spots)", index,
          case_.spots.size());
  const design::SpotParameter* p = design::find_spot_parameter(field);
  if (p == nullptr) {
    std::string known;
    for (const auto& q : design::spot_parameters()) known += fmt::format("{}{}", known.empty() ? "" : ", ", q.name());
    fail("set: spot field '{}' is not known ({})", field, known);
  }
  if (field == "optimise_amplitude" || field == "optimise_position") {  // the optimiser's freedom: no solve
    const design::Spot& s = case_.spots[index];
    set_spot_freedom(index, field == "optimise_amplitude" ? value != 0 : s.optimise_amplitude,
                     field == "optimise_position" ? value != 0 : s.optimise_position);
    return;
  }
  design::Spot s = case_.spots[index];
  design::set_file_value(*p, s, value, fmt::format("set: spot {} {}", s.name, field));
  design::validate_spot(s, setup_ ? setup_->model.length_m : 1.0);
  edit([&] { case_.spots[index] = s; });
  record({{"do", "set"}, {"spot", index}, {"field", field}, {"value", value}});
}

void DesignSession::set_spot_freedom(int index, bool amplitude, bool position) {
  require(index >= 0 && index < static_cast<int>(case_.spots.size()), "set: spot {} does not exist ({} spots)", index,
          case_.spots.size());
  design::Spot& s = case_.spots[index];
  if (s.optimise_amplitude != amplitude)
    record({{"do", "set"}, {"spot", index}, {"field", "optimise_amplitude"}, {"value", amplitude ? 1 : 0}});
  if (s.optimise_position != position)
    record({{"do", "set"}, {"spot", index}, {"field", "optimise_position"}, {"value", position ? 1 : 0}});
  s.optimise_amplitude = amplitude;
  s.optimise_position = position;
  is_dirty_ = true;
}

void DesignSession::remove_spot(int index) {
  if (index < 0 || index >= static_cast<int>(case_.spots.size())) return;
  // A case without spots would be saved as the default layout: keep at least one.
  require(case_.spots.size() > 1, "remove spot: '{}' is the last spot; a design needs at least one: add another "
          "spot first", case_.spots[index].name);
  edit([&] { case_.spots.erase(case_.spots.begin() + index); });
  record({{"do", "remove_spot"}, {"spot", index}});
}

void DesignSession::set_brim_template(design::BrimTemplate kind) {
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
  record({{"do", "brim"}, {"template", design::to_string(kind)}});
}

void DesignSession::move_brim_key_point(int index, double theta_rad, double h_m) {
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
  record({{"do", "brim_key_point"}, {"index", index}, {"theta_deg", theta_rad / kDeg}, {"h_mm", h_m * 1e3}});
}

void DesignSession::set_patient(const design::PatientLoad& patient, double youngs_modulus_pa,
                                const design::ThresholdTable& thresholds) {
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
  json thresholds_kpa = json::object();
  for (const auto& [code, v] : thresholds) thresholds_kpa[code] = v / 1e3;
  record({{"do", "patient"},
          {"body_mass_kg", patient.body_mass_kg},
          {"prosthesis_mass_kg", patient.prosthesis_mass_kg},
          {"friction", patient.friction},
          {"youngs_kpa", youngs_modulus_pa / 1e3},
          {"thresholds_kpa", thresholds_kpa}});
}

void DesignSession::set_thickness(double thickness_m) {
  design::check_input(design::limits::kThickness, thickness_m * 1e3, "socket: socket.thickness_mm");
  edit([&] { case_.socket.thickness_m = thickness_m; });
  record({{"do", "thickness"}, {"mm", thickness_m * 1e3}});
}

void DesignSession::optimise(double time_limit_s) {
  if (!worker_) return;
  if (time_limit_s > 0) design::check_input(design::limits::kTimeLimit, time_limit_s, "optimise: time limit");
  push_history();
  design::OptimizerOptions o = optimizer_options(*setup_, case_);
  o.time_limit_s = time_limit_s;
  DesignRequest r;
  r.spots = case_.spots;
  r.generation = ++generation_;
  worker_->optimise(std::move(r), o);
  is_optimising_ = true;
  optimiser_message_.clear();
  record(time_limit_s > 0 ? json{{"do", "optimise"}, {"time_limit_s", time_limit_s}} : json{{"do", "optimise"}});
}

void DesignSession::cancel_optimise() {
  if (!worker_) return;
  worker_->cancel();
  record({{"do", "cancel"}});
}

}  // namespace socketsmith::pipeline
