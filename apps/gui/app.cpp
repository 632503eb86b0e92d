// App's core: the log sink, the session's edits as the window adds to them, the GPU scene following
// the session, and the frame (keys, the panels' windows, the view). The panels, the view's overlay
// and input, and the dialogs are App's methods in their own files (app_impl.h lists them).

#include "app.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <GLFW/glfw3.h>
#include <fmt/format.h>
#include <imgui.h>

#include "app_impl.h"
#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/report/nice_number.h"
#include "socketsmith/report/raster.h"

namespace socketsmith::gui {

namespace fs = std::filesystem;

const char* to_string(Field field) {
  switch (field) {
    case Field::Pressure: return "pressure";
    case Field::Threshold: return "threshold";
    case Field::Ratio: return "ratio";
    case Field::Displacement: return "displacement";
    case Field::Deviation: return "deviation";
    case Field::Rectification: return "rectification";
    case Field::Delivered: return "delivered";
    case Field::DeliveryError: return "delivery_error";
  }
  return "pressure";
}

Field parse_field(const std::string& text) {
  for (Field f : {Field::Pressure, Field::Threshold, Field::Ratio, Field::Displacement, Field::Deviation,
                  Field::Rectification, Field::Delivered, Field::DeliveryError})
    if (text == to_string(f)) return f;
  fail("colour field '{}' is not known (use pressure, threshold, ratio, displacement, deviation, rectification, "
       "delivered or delivery_error)",
       text);
}

void App::set_field(Field field) {
  field_ = field;
  colours_dirty_ = true;
  if (field == Field::Rectification) {
    session_.ask_rectification();
    is_rectification_table_opening_ = true;
  }
  if (field == Field::Delivered || field == Field::DeliveryError) {
    session_.ask_delivery();
    is_delivery_table_opening_ = true;
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
  if (session_.delivery_serial() != seen_delivery_) {
    seen_delivery_ = session_.delivery_serial();
    if (field_ == Field::Delivered || field_ == Field::DeliveryError) colours_dirty_ = true;
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
  const pipeline::DeliveryCheck* delivered = session_.delivery();
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
      case Field::Delivered:
        if (delivered && i < delivered->below_brim.size() && delivered->below_brim[i])
          v[i] = delivered->closed_loop_pa[i] / 1e3;
        break;
      case Field::DeliveryError:
        if (delivered && i < delivered->below_brim.size() && delivered->below_brim[i])
          v[i] = (delivered->closed_loop_pa[i] - delivered->target_pa[i]) / 1e3;
        break;
    }
  }
  if (is_auto_range_) {
    double hi = 0;
    for (double x : v)
      if (std::isfinite(x)) hi = std::max(hi, is_signed(field_) ? std::abs(x) : x);
    range_min_ = 0;
    range_max_ = field_ == Field::Ratio ? 1.2f : static_cast<float>(hi > 0 ? hi : 1.0);
    if (field_ == Field::Deviation || field_ == Field::DeliveryError) {  // symmetric about 0
      range_max_ = static_cast<float>(report::nice_ceil(hi > 0 ? hi : 1.0));
      range_min_ = -range_max_;
    }
    if (field_ == Field::Delivered && delivered) {  // the designed pressures' range: the two maps compare
      double designed = 0;
      for (size_t i = 0; i < delivered->target_pa.size(); ++i)
        if (delivered->below_brim[i]) designed = std::max(designed, delivered->target_pa[i] / 1e3);
      range_max_ = static_cast<float>(report::nice_ceil(designed > 0 ? designed : 1.0));
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
      if (ImGui::IsKeyPressed(GLFW_KEY_7)) set_field(Field::Delivered);
      if (ImGui::IsKeyPressed(GLFW_KEY_8)) set_field(Field::DeliveryError);
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

}  // namespace socketsmith::gui
