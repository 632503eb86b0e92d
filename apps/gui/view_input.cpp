// The mouse on the 3D view: orbit, pan, zoom, placing a spot, Shift+drag of a brim key point, and
// the values under the cursor.

#include <cmath>
#include <string>

#include <fmt/format.h>
#include <imgui.h>

#include "app_impl.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/design/case_parameters.h"

namespace socketsmith::gui {

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
        const std::string_view type = design::find_spot_text_parameter("type")->names[new_spot_type_];
        try {
          add_spot_at(hit->point, design::parse_spot_type(std::string(type)), new_spot_amplitude_kpa_ * 1e3);
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
  if (const pipeline::DeliveryCheck* d = session_.delivery();
      (field_ == Field::Delivered || field_ == Field::DeliveryError) && d &&
      node < static_cast<int>(d->below_brim.size()) && d->below_brim[node])
    text += fmt::format("\ndelivered {:.1f} kPa (designed {:.1f}, open-loop socket {:.1f})",
                        d->closed_loop_pa[node] / 1e3, d->target_pa[node] / 1e3, d->open_loop_pa[node] / 1e3);
  ImGui::SetTooltip("%s", text.c_str());
}

}  // namespace socketsmith::gui
