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
#include "socketsmith/report/nice_number.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/case_parameters.h"
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
    session_.ask_rectification();
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
  log::set_sink(nullptr);  // the session's threads end with it, after this
}


// ------------------------------------------------------------------------------------------------
// The session: what the window adds to its edits, and the view following it
// ------------------------------------------------------------------------------------------------

void App::apply(const nlohmann::json& action) {
  const size_t spots = session_.document().spots.size();
  session_.apply(action);
  const size_t now = session_.document().spots.size();
  if (now > spots) select_spot(static_cast<int>(now) - 1);
  if (now < spots) selected_spot_ = -1;
}

void App::add_spot_at(const Vec3& point, design::SpotType type, double amplitude_pa) {
  session_.add_spot_at(point, type, amplitude_pa);
  select_spot(static_cast<int>(session_.document().spots.size()) - 1);
}

void App::remove_spot(int index) {
  const size_t spots = session_.document().spots.size();
  session_.remove_spot(index);
  if (session_.document().spots.size() < spots) selected_spot_ = -1;
}

void App::save() {
  if (session_.path().empty()) dialog_ = Dialog::SaveAs;
  else try {
      session_.save_case(session_.path());
    } catch (const Error&) {  // shown by the session
    }
}

bool App::request_close() {
  if (!session_.is_dirty() || is_headless_) return true;
  is_close_requested_ = true;
  return false;
}

void App::follow_session() {
  if (session_.setup_serial() != seen_setup_) {
    seen_setup_ = session_.setup_serial();
    install_scene();
  }
  if (session_.brim_serial() != seen_brim_) {
    seen_brim_ = session_.brim_serial();
    update_brim();
  }
  if (session_.comparison_serial() != seen_comparison_) {
    seen_comparison_ = session_.comparison_serial();
    if (!session_.deviation_m().empty()) {  // a comparison done: the stump shows it
      field_ = Field::Deviation;
      is_auto_range_ = true;
    } else if (field_ == Field::Deviation) {  // another limb: the comparison was of the one before
      field_ = Field::Pressure;
    }
    colours_dirty_ = true;
  }
  if (session_.state_serial() != seen_state_) {
    seen_state_ = session_.state_serial();
    colours_dirty_ = true;
    update_meshes();
  }
  if (session_.rectification_serial() != seen_rectification_) {
    seen_rectification_ = session_.rectification_serial();
    if (field_ == Field::Rectification) colours_dirty_ = true;
  }
}

void App::install_scene() {
  const pipeline::DesignSetup& setup = *session_.setup();
  selected_spot_ = -1;
  stump_.set_geometry(session_.skin_rest());
  bones_.clear();
  for (const auto& b : setup.model.bones) {
    auto m = std::make_unique<GpuMesh>();
    m->set_geometry(b.mesh);
    m->set_colour({0.93f, 0.9f, 0.8f, 1.0f});
    bones_.push_back(std::move(m));
  }
  camera_.up = setup.model.frame.axis;
  camera_.front = setup.model.frame.anterior;
  camera_.yaw_rad = 0.5;
  camera_.pitch_rad = 0.2;
  camera_.frame(geometry::bounding_box(setup.model.skin));
  ++scene_version_;
}

void App::update_brim() {
  const pipeline::DesignSetup* setup = session_.setup();
  if (!setup) return;
  const auto& frame = setup->model.frame;
  // Brim line on the skin, 1 mm outside it so the stump does not hide it.
  std::vector<Vec3> brim = pipeline::brim_on_skin(*setup, 120);
  for (auto& p : brim) p += 0.001 * frame.radial(frame.to_cylindrical(p).theta);
  brim_lines_.set_points(brim, true);
  ++scene_version_;
}

void App::update_meshes() {
  if (!session_.has_design()) return;
  // Socket: the deformed skin below the brim, moved out by the wall thickness (its outer wall).
  if (session_.state()) {
    socket_.set_geometry(session_.socket_preview());
    socket_.set_colour({0.55f, 0.75f, 0.95f, 1.0f});
  }
  ++scene_version_;
}

void App::update_colours() {
  if (!session_.has_design() || !colours_dirty_) return;
  colours_dirty_ = false;
  const size_t n = session_.skin_rest().vertices.size();
  const auto& thr = session_.setup()->solver->thresholds();
  const auto& above = session_.setup()->solver->above_brim();
  const auto& state = session_.state();
  const auto& deviation_m = session_.deviation_m();
  std::vector<double> v(n, std::numeric_limits<double>::quiet_NaN());
  for (size_t i = 0; i < n; ++i) {
    switch (field_) {
      case Field::Threshold: v[i] = thr[i] / 1e3; break;
      case Field::Pressure:
        if (state && !above[i]) v[i] = state->pressure_pa[i] / 1e3;
        break;
      case Field::Ratio:
        if (state && !above[i]) v[i] = state->requested_pa[i] / thr[i];
        break;
      case Field::Displacement:
        if (state) v[i] = state->displacement_m[i] * 1e3;
        break;
      case Field::Deviation:
        if (i < deviation_m.size()) v[i] = deviation_m[i] * 1e3;
        break;
      case Field::Rectification:
        if (const RectificationChart* c = session_.rectification(); c && i < c->rectification.vertex_m.size())
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
    if (const RectificationChart* c = session_.rectification(); field_ == Field::Rectification && c) {  // the report's bar
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


// ------------------------------------------------------------------------------------------------
// Frame
// ------------------------------------------------------------------------------------------------

void App::frame(int width, int height) {
  session_.poll();
  follow_session();
  if (!is_headless_) session_.autosave();
  update_colours();

  ImGuiIO& io = ImGui::GetIO();
  if (!io.WantTextInput) {
    if (io.KeyCtrl && ImGui::IsKeyPressed(GLFW_KEY_Z)) session_.undo();
    if (io.KeyCtrl && ImGui::IsKeyPressed(GLFW_KEY_Y)) session_.redo();
    if (io.KeyCtrl && ImGui::IsKeyPressed(GLFW_KEY_S)) save();
    if (!io.KeyCtrl) {
      if (ImGui::IsKeyPressed(GLFW_KEY_1)) set_field(Field::Pressure);
      if (ImGui::IsKeyPressed(GLFW_KEY_2)) set_field(Field::Threshold);
      if (ImGui::IsKeyPressed(GLFW_KEY_3)) set_field(Field::Ratio);
      if (ImGui::IsKeyPressed(GLFW_KEY_4)) set_field(Field::Displacement);
      if (ImGui::IsKeyPressed(GLFW_KEY_5) && !session_.deviation_m().empty()) set_field(Field::Deviation);
      if (ImGui::IsKeyPressed(GLFW_KEY_6)) set_field(Field::Rectification);
      if (ImGui::IsKeyPressed(GLFW_KEY_F) && session_.has_design())
        camera_.frame(geometry::bounding_box(session_.setup()->model.skin));
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

  follow_session();  // an edit made this frame may have moved the brim line
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
                                   socket_alpha_,      stump_alpha_,       static_cast<double>(session_.has_design()),
                                   static_cast<double>(session_.state().has_value())};
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
  if (session_.has_design()) {
    // Opaque stump first: the bones inside it then fail the depth test before shading (llvmpipe
    // shades in software, so overdraw costs frame rate); x-ray: bones first, stump blended over.
    const bool is_xray = stump_alpha_ < 1.0f;
    if (!is_xray) renderer_->draw_opaque(stump_);
    if (show_bones_)
      for (const auto& b : bones_) renderer_->draw_opaque(*b);
    if (is_xray) renderer_->draw_translucent(stump_, stump_alpha_);
    if (show_brim_) renderer_->draw_lines(brim_lines_, {0.1f, 0.1f, 0.1f, 1.0f}, false);
    if (show_socket_ && session_.state()) renderer_->draw_translucent(socket_, socket_alpha_);
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
        if (ImGui::MenuItem(fmt::format("{} nodes", n).c_str())) session_.open_demo(n);
      ImGui::EndMenu();
    }
    ImGui::Separator();
    const bool open = session_.has_design();
    if (ImGui::MenuItem("Save", "Ctrl+S", false, open)) save();
    if (ImGui::MenuItem("Save as...", nullptr, false, open)) dialog_ = Dialog::SaveAs;
    if (ImGui::MenuItem("Export socket and report...", nullptr, false, open)) dialog_ = Dialog::Export;
    if (ImGui::MenuItem("Compare with a second shape...", nullptr, false, open)) dialog_ = Dialog::Compare;
    ImGui::Separator();
    if (ImGui::MenuItem("Quit")) glfwSetWindowShouldClose(window_, 1);
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Edit")) {
    if (ImGui::MenuItem("Undo", "Ctrl+Z", false, session_.can_undo())) session_.undo();
    if (ImGui::MenuItem("Redo", "Ctrl+Y", false, session_.can_redo())) session_.redo();
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("View")) {
    ImGui::MenuItem("Bones", nullptr, &show_bones_);
    ImGui::MenuItem("Landmarks", nullptr, &show_landmarks_);
    ImGui::MenuItem("Socket", nullptr, &show_socket_);
    ImGui::MenuItem("Brim line", nullptr, &show_brim_);
    if (ImGui::MenuItem("Frame the limb", "F") && session_.has_design())
      camera_.frame(geometry::bounding_box(session_.setup()->model.skin));
    ImGui::EndMenu();
  }
  const fs::path& path = session_.path();
  ImGui::TextDisabled("%s%s", path.empty() ? "(unsaved case)" : path.filename().string().c_str(),
                      session_.is_dirty() ? " *" : "");
  ImGui::EndMainMenuBar();
}

void App::draw_design_panel() {
  if (!session_.has_design()) {
    ImGui::TextWrapped("No case open. File > Open case, Open limb scan, or Open demo.");
    if (ImGui::Button("Open the demo (8000 nodes)")) session_.open_demo(8000);
    return;
  }
  if (ImGui::CollapsingHeader("Spots", ImGuiTreeNodeFlags_DefaultOpen)) {
    ImGui::BeginDisabled(session_.is_optimising());  // the optimiser's result replaces the spots
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
    for (int k = 0; k < static_cast<int>(session_.document().spots.size()); ++k) draw_spot(k);
    ImGui::EndChild();
    ImGui::EndDisabled();
    const auto [fraction, stage] = session_.optimiser_progress();
    if (session_.is_optimising()) {
      ImGui::ProgressBar(static_cast<float>(fraction), ImVec2(-80, 0), stage.c_str());
      ImGui::SameLine();
      if (ImGui::Button("Cancel")) session_.cancel_optimise();
    } else {
      if (ImGui::Button("Optimise", ImVec2(-170, 0))) session_.optimise(optimise_time_limit_s_);
      ImGui::SameLine();
      ImGui::SetNextItemWidth(100);
      ImGui::InputFloat("s max", &optimise_time_limit_s_, 10, 60, "%.0f");
      if (ImGui::IsItemHovered()) ImGui::SetTooltip("Time limit of the optimiser in seconds (0: none)");
      optimise_time_limit_s_ = std::max(0.0f, optimise_time_limit_s_);
    }
    if (!session_.optimiser_message().empty()) ImGui::TextWrapped("%s", session_.optimiser_message().c_str());
  }
  if (ImGui::CollapsingHeader("Brim and socket", ImGuiTreeNodeFlags_DefaultOpen)) draw_brim_panel();
}

/// Spot @p k of the list: its check box and label; when selected, its sliders in clinical units.
void App::draw_spot(int k) {
  const design::Spot& s = session_.document().spots[k];
  ImGui::PushID(k);
  bool enabled = s.enabled;
  if (ImGui::Checkbox("##on", &enabled)) session_.set_spot_value(k, "enabled", enabled ? 1 : 0);
  ImGui::SameLine();
  const std::string label = fmt::format("{} [{}] {:.1f} kPa", s.name, design::to_string(s.type), s.amplitude_pa / 1e3);
  if (ImGui::Selectable(label.c_str(), selected_spot_ == k)) selected_spot_ = k;
  if (selected_spot_ == k && scroll_to_selected_) {
    ImGui::SetScrollHereY(0.2f);
    scroll_to_selected_ = false;
  }
  if (selected_spot_ != k) {
    ImGui::PopID();
    return;
  }
  ImGui::Indent();
  // A spot field through the case file's table (case_parameters.h): value in file units, help as tooltip.
  const auto slider = [&](const char* name, const char* field, float lo, float hi, const char* fmt_) {
    const design::SpotParameter& p = *design::find_spot_parameter(field);
    float v = static_cast<float>(design::file_value(p, s));
    const bool changed = ImGui::SliderFloat(name, &v, lo, hi, fmt_);
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", std::string(p.limit.hint).c_str());
    if (ImGui::IsItemActivated()) session_.begin_edit();
    if (changed) {
      try {
        session_.set_spot_value(k, field, v);
      } catch (const Error& e) {
        session_.show_error(e.what());
      }
    }
    if (ImGui::IsItemDeactivated()) session_.end_edit();
  };
  struct Slider { const char *name, *field; float lo, hi; const char* format; };  // shown if the type uses it
  const float L = static_cast<float>(session_.setup()->model.length_m * 1e3);
  for (const Slider& f : {Slider{"A [kPa]", "amplitude_kpa", 0, 300, "%.1f"},
                          Slider{"theta0 [deg]", "theta0_deg", -180, 180, "%.0f"},
                          Slider{"R_theta [deg]", "r_theta_deg", 1, 180, "%.0f"},
                          Slider{"theta1 [deg]", "theta1_deg", -180, 180, "%.0f"},
                          Slider{"theta2 [deg]", "theta2_deg", -180, 180, "%.0f"}, Slider{"h0 [mm]", "h0_mm", 0, L, "%.0f"},
                          Slider{"R_h [mm]", "r_h_mm", 1, L, "%.0f"}, Slider{"h1 [mm]", "h1_mm", 0, L, "%.0f"},
                          Slider{"h2 [mm]", "h2_mm", 0, L, "%.0f"}})
    if (design::spot_type_uses(s.type, f.field)) slider(f.name, f.field, f.lo, f.hi, f.format);
  bool amplitude = s.optimise_amplitude, position = s.optimise_position;
  const bool freedom_changed = ImGui::Checkbox("optimiser may change A", &amplitude) |
                               ImGui::Checkbox("optimiser may move it", &position);
  if (freedom_changed) session_.set_spot_freedom(k, amplitude, position);
  if (ImGui::Button("Remove spot")) {
    try {
      remove_spot(k);
    } catch (const Error& e) {
      session_.show_error(e.what());
    }
  }
  ImGui::Unindent();
  ImGui::PopID();
}

/// The brim template, its key points (angle, height) and the wall thickness.
void App::draw_brim_panel() {
  const design::CaseFile& doc = session_.document();
  const pipeline::DesignSetup& setup = *session_.setup();
  const bool tt = setup.model.type == geometry::LimbType::Transtibial;
  const std::vector<design::BrimTemplate> kinds =
      tt ? std::vector<design::BrimTemplate>{design::BrimTemplate::Ptb, design::BrimTemplate::PtbSc,
                                             design::BrimTemplate::PtbScsp, design::BrimTemplate::Kbm,
                                             design::BrimTemplate::Tsb}
         : std::vector<design::BrimTemplate>{design::BrimTemplate::Quad, design::BrimTemplate::Ics};
  const std::string current = design::to_string(doc.brim.value_or(design::default_brim(setup.model.type))) +
                              (doc.brim_key_points.empty() ? "" : " (edited)");
  if (ImGui::BeginCombo("template", current.c_str())) {
    for (auto k : kinds)
      if (ImGui::Selectable(design::to_string(k).c_str(), k == doc.brim)) session_.set_brim_template(k);
    ImGui::EndCombo();
  }
  const auto key_points = setup.brim.key_points();  // a copy: a move replaces the setup's brim
  for (int i = 0; i < static_cast<int>(key_points.size()); ++i) {
    ImGui::PushID(1000 + i);
    float th = static_cast<float>(key_points[i].theta / kDeg), h = static_cast<float>(key_points[i].h * 1e3);
    const auto one_drag_one_step = [&] {
      if (ImGui::IsItemActivated()) {
        selected_key_point_ = i;
        session_.begin_edit();  // one drag, one undo step
      }
      if (ImGui::IsItemDeactivated()) session_.end_edit();
    };
    ImGui::SetNextItemWidth(150);
    bool changed = ImGui::DragFloat("##th", &th, 0.5f, -180, 180, "%.0f deg");
    one_drag_one_step();
    ImGui::SameLine();
    ImGui::SetNextItemWidth(150);
    changed |= ImGui::DragFloat("##h", &h, 0.5f, 0, static_cast<float>(setup.model.length_m * 1e3), "%.0f mm");
    one_drag_one_step();
    if (changed) session_.move_brim_key_point(i, th * kDeg, h * 1e-3);
    ImGui::PopID();
  }
  ImGui::TextDisabled("Drag a key point's values, or Shift+drag it on the stump.");
  float thk = static_cast<float>(doc.socket.thickness_m * 1e3);
  const bool thk_changed = ImGui::SliderFloat("wall [mm]", &thk, 1, 15, "%.1f");
  if (ImGui::IsItemActivated()) session_.begin_edit();  // before the change: one drag, one undo step
  if (thk_changed) session_.set_thickness(thk * 1e-3);
  if (ImGui::IsItemDeactivated()) session_.end_edit();
}

void App::draw_patient_panel() {
  if (!session_.has_design() || !ImGui::CollapsingHeader("Patient")) return;
  const design::CaseFile& doc = session_.document();
  ImGui::TextWrapped("Changes here rebuild the stump model (a few seconds) when applied.");
  float mass = static_cast<float>(doc.patient.body_mass_kg);
  float pmass = static_cast<float>(doc.patient.prosthesis_mass_kg);
  float mu = static_cast<float>(doc.patient.friction);
  float e = static_cast<float>(doc.youngs_modulus_pa / 1e3);
  bool changed = false;
  changed |= ImGui::InputFloat("body mass [kg]", &mass, 1, 5, "%.1f");
  changed |= ImGui::InputFloat("prosthesis [kg]", &pmass, 0.1f, 1, "%.2f");
  changed |= ImGui::InputFloat("friction [-]", &mu, 0.05f, 0.1f, "%.2f");
  changed |= ImGui::InputFloat("tissue E [kPa]", &e, 5, 20, "%.0f");
  auto table = doc.thresholds.empty() ? design::default_thresholds(session_.setup()->model.type) : doc.thresholds;
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
    design::PatientLoad p = doc.patient;
    p.body_mass_kg = mass;
    p.prosthesis_mass_kg = pmass;
    p.friction = mu;
    try {
      session_.set_patient(p, e * 1e3, thr_changed ? table : doc.thresholds);
    } catch (const Error& err) {
      session_.show_error(err.what());
    }
  }
  if (ImGui::Button("Apply (rebuild the stump model)")) session_.rebuild();
}

/// What the design means against its brim template: per region the mean and peak pressure and the
/// share of the axial load, and the template's criteria (green when they hold).
void App::draw_template_check() {
  const auto& check = session_.template_check();
  if (!check || !ImGui::CollapsingHeader("Template regions", ImGuiTreeNodeFlags_DefaultOpen)) return;
  const design::TemplateCheck& t = *check;
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
  if (!session_.state()) return;
  if (is_rectification_table_opening_) ImGui::SetNextItemOpen(true);
  is_rectification_table_opening_ = false;
  if (!ImGui::CollapsingHeader("Rectification chart")) return;
  if (!session_.is_rectification_asked() || field_ != Field::Rectification) {
    if (ImGui::SmallButton("Colour the stump by socket - limb")) set_field(Field::Rectification);
    if (!session_.is_rectification_asked()) return;
  }
  if (const std::string error = session_.rectification_error(); !error.empty()) {
    ImGui::PushStyleColor(ImGuiCol_Text, IM_COL32(255, 110, 100, 255));
    ImGui::TextWrapped("Not computed: %s", error.c_str());
    ImGui::PopStyleColor();
    return;
  }
  const RectificationChart* c = session_.rectification();
  if (!c) {
    ImGui::TextDisabled("computing the rectification...");
    return;
  }
  const pipeline::Rectification& r = c->rectification;
  ImGui::TextWrapped("Socket minus limb [mm]: %s against the skin at rest, radially (along the axis at the distal "
                     "end); < 0 indentation, > 0 relief. Below the brim %+.2f ... %+.2f mm, mean %+.2f mm (%.1f s).",
                     c->wall_source.c_str(), r.min_m * 1e3, r.max_m * 1e3, r.mean_m * 1e3, c->seconds);
  if (c->state != session_.state_serial()) ImGui::TextDisabled("(of the design before: updating)");
  if (ImGui::BeginTable("rectification", 4, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingStretchProp)) {
    for (const char* h : {"landmark", "socket - limb [mm]", "", "measured"}) ImGui::TableSetupColumn(h);
    ImGui::TableHeadersRow();
    for (const RectificationRow& row : session_.rectification_rows()) {
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
  if (const auto& job = session_.job()) {
    const std::string stage = job->stage_text();
    ImGui::TextWrapped("%s", job->what.c_str());
    ImGui::ProgressBar(static_cast<float>(job->fraction->load()), ImVec2(-1, 0), stage.c_str());
  }
  const std::vector<std::string>& errors = session_.errors();
  for (size_t k = 0; k < errors.size(); ++k) {
    ImGui::PushID(static_cast<int>(5000 + k));
    ImGui::PushStyleColor(ImGuiCol_Text, IM_COL32(255, 110, 100, 255));
    ImGui::TextWrapped("Error: %s", errors[k].c_str());
    ImGui::PopStyleColor();
    ImGui::PopID();
  }
  if (!errors.empty() && ImGui::SmallButton("Dismiss errors")) session_.clear_errors();
  if (!session_.info().empty()) ImGui::TextWrapped("%s", session_.info().c_str());
  if (!session_.has_design()) return;
  const pipeline::DesignSetup& setup = *session_.setup();
  const auto& state = session_.state();
  const bool met = state && state->status.all_ok();
  ImGui::PushStyleColor(ImGuiCol_Text, met ? IM_COL32(90, 220, 110, 255) : IM_COL32(255, 120, 100, 255));
  ImGui::Text("%s", !state ? "solving..." : met ? "All constraints met" : ("Not met: " + state->status.failing()).c_str());
  ImGui::PopStyleColor();
  if (session_.is_solving()) {
    ImGui::SameLine();
    ImGui::TextDisabled("(updating)");
  }
  std::vector<std::string> estimated;
  if (setup.model.bones_estimated) estimated.push_back("the bones");
  if (setup.model.frame.anterior_estimated) estimated.push_back("the front direction");
  if (setup.model.frame.side_estimated) estimated.push_back("the side");
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
    ImGui::TextWrapped("%s", setup.limb_label.c_str());
    for (const auto& n : setup.model.notes) ImGui::BulletText("%s", n.c_str());
  }
  radar_chart(session_.radar(), kRightPanel - 20);
  if (state)
    ImGui::TextWrapped("peak p/T %.0f %%, max displacement %.1f mm; %s", 100 * state->max_requested_ratio,
                       state->max_displacement_m * 1e3, session_.solve_status().c_str());
  for (const auto& p : session_.profiles()) profile_plot(p, ImVec2(kRightPanel - 20, 120));
}

void App::draw_viewport_overlay(int x, int y, int width, int height) {
  ImDrawList* dl = ImGui::GetBackgroundDrawList();
  if (!session_.has_design()) {
    dl->AddText(ImVec2(x + 20.0f, y + 20.0f), IM_COL32(230, 230, 230, 255),
                session_.job() ? "preparing the stump model..." : "no case open");
    return;
  }
  const pipeline::DesignSetup& setup = *session_.setup();
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
    for (const auto& l : setup.model.landmarks) {
      const auto q = camera_.project(l.position, width, height);
      if (!q) continue;
      // Visible when the skin there faces the eye (the landmark's radial direction).
      const Vec3 radial = setup.model.frame.radial(l.cylindrical.theta);
      const bool front = radial.dot(eye - l.position) > 0;
      const ImVec2 p(x + static_cast<float>(q->x()), y + static_cast<float>(q->y()));
      dl->AddCircleFilled(p, 5, front ? IM_COL32(230, 40, 200, 255) : IM_COL32(230, 40, 200, 90));
      dl->AddText(ImVec2(p.x + 7, p.y - 7), front ? IM_COL32(20, 20, 20, 255) : IM_COL32(20, 20, 20, 90),
                  l.code.c_str());
    }
  }
  if (const auto& spots = session_.document().spots; selected_spot_ >= 0 && selected_spot_ < static_cast<int>(spots.size())) {
    double th = 0, h = 0;
    design::spot_centre(spots[selected_spot_], th, h);
    if (const auto q = camera_.project(pipeline::skin_point(setup, th, h), width, height))
      dl->AddCircle(ImVec2(x + static_cast<float>(q->x()), y + static_cast<float>(q->y())), 10,
                    IM_COL32(255, 255, 255, 255), 24, 3);
  }
  const std::string help = is_placing_spot_ ? "click on the stump to place the spot (Esc: stop)"
                                            : "left drag: orbit   right/middle drag: pan   wheel: zoom   F: frame   "
                                              "1-6: field";
  dl->AddText(ImVec2(x + 10.0f, y + height - 22.0f), IM_COL32(60, 60, 60, 255), help.c_str());
  draw_view_controls(x, y);
}

/// The field, its range and the view's toggles, in a small window on the view.
void App::draw_view_controls(int x, int y) {
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
  if (!session_.deviation_m().empty()) offered.push_back(Field::Deviation);
  if (session_.state()) offered.push_back(Field::Rectification);
  ImGui::SetNextItemWidth(200);
  if (ImGui::BeginCombo("colour", fields[static_cast<int>(field_)])) {
    for (Field f : offered)
      if (ImGui::Selectable(fields[static_cast<int>(f)], f == field_)) set_field(f);
    ImGui::EndCombo();
  }
  if (field_ == Field::Deviation && !session_.comparison_file().empty())  // the whole line: feedback panel
    ImGui::TextDisabled("vs %s (> 0: it lies outside the limb)", session_.comparison_file().c_str());
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
  if (session_.has_design() && !ImGui::IsAnyMouseDown()) show_hover(x, y, width, height);
  const geometry::TriMesh& skin = session_.skin_rest();
  if (ImGui::IsMouseClicked(ImGuiMouseButton_Left)) {
    is_dragging_view_ = true;
    drag_distance_px_ = 0;
  }
  if (io.MouseWheel != 0) camera_.zoom(io.MouseWheel);
  const ImVec2 d = io.MouseDelta;
  if (ImGui::IsMouseDown(ImGuiMouseButton_Left) && is_dragging_view_) {
    drag_distance_px_ += std::abs(d.x) + std::abs(d.y);
    if (io.KeyShift && session_.has_design() && selected_key_point_ >= 0) {
      // Shift+drag: the selected brim key point follows the mouse on the skin.
      const auto [o, dir] = camera_.ray(m.x - x, m.y - y, width, height);
      if (const auto hit = pick(skin, o, dir)) {
        const auto c = session_.setup()->model.frame.to_cylindrical(hit->point);
        if (drag_distance_px_ > 3) {
          session_.begin_edit();  // ended when the button is released
          session_.move_brim_key_point(selected_key_point_, c.theta, c.h);
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
    session_.end_edit();
    if (is_placing_spot_ && drag_distance_px_ < 4 && session_.has_design()) {
      const auto [o, dir] = camera_.ray(m.x - x, m.y - y, width, height);
      if (const auto hit = pick(skin, o, dir)) {
        const design::SpotType types[] = {design::SpotType::Cos2, design::SpotType::Sig2, design::SpotType::CosSig,
                                          design::SpotType::Grad};
        try {
          add_spot_at(hit->point, types[new_spot_type_], new_spot_amplitude_kpa_ * 1e3);
        } catch (const Error& e) {
          session_.show_error(e.what());
        }
      }
    }
  }
}

/// Hover: the values under the cursor (the nearest skin node of the triangle hit).
void App::show_hover(int x, int y, int width, int height) {
  const ImVec2 m = ImGui::GetIO().MousePos;
  const geometry::TriMesh& skin = session_.skin_rest();
  const auto [o, dir] = camera_.ray(m.x - x, m.y - y, width, height);
  const auto hit = pick(skin, o, dir);
  if (!hit) return;
  int node = -1;
  double best = 1e9;
  for (int k : skin.triangles[hit->triangle])
    if ((skin.vertices[k] - hit->point).norm() < best) {
      best = (skin.vertices[k] - hit->point).norm();
      node = k;
    }
  const pipeline::DesignSetup& setup = *session_.setup();
  const auto& state = session_.state();
  const auto c = setup.model.frame.to_cylindrical(hit->point);
  std::string text = fmt::format("theta {:.0f} deg, h {:.0f} mm\nthreshold {:.1f} kPa", c.theta / kDeg, c.h * 1e3,
                                 setup.solver->thresholds()[node] / 1e3);
  if (state && setup.solver->above_brim()[node]) text += "\nabove the brim";
  else if (state)
    text += fmt::format("\npressure {:.1f} kPa (p/T {:.2f})\ndisplacement {:.2f} mm", state->pressure_pa[node] / 1e3,
                        state->requested_pa[node] / setup.solver->thresholds()[node], state->displacement_m[node] * 1e3);
  if (const RectificationChart* rc = session_.rectification();
      field_ == Field::Rectification && rc && node < static_cast<int>(rc->rectification.vertex_m.size()) &&
      std::isfinite(rc->rectification.vertex_m[node]))
    text += fmt::format("\nsocket - limb {:+.2f} mm", rc->rectification.vertex_m[node] * 1e3);
  ImGui::SetTooltip("%s", text.c_str());
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
                     : dialog_ == Dialog::SaveAs && !session_.path().empty() ? session_.path().string()
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
      case Dialog::OpenCase: session_.open_case(p); break;
      case Dialog::OpenLimb: session_.open_limb(p, std::clamp(dialog_target_nodes_, 500, 100000)); break;
      case Dialog::SaveAs:
        try {
          session_.save_case(p);
        } catch (const Error&) {
        }
        break;
      case Dialog::Export: session_.export_design(p); break;
      case Dialog::Compare: session_.compare_with(p); break;
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
    if (session_.path().empty()) dialog_ = Dialog::SaveAs;
    else try {
        session_.save_case(session_.path());
        glfwSetWindowShouldClose(window_, 1);
      } catch (const Error&) {
      }
  }
  ImGui::SameLine();
  if (ImGui::Button("Quit without saving")) {
    session_.discard_changes();
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
