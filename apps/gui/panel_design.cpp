// The Design panel (left): the spots — the new spot's type and amplitude, the list with the
// selected spot's sliders in clinical units, the optimiser — and the brim panel below them.

#include <algorithm>
#include <string>

#include <fmt/format.h>
#include <imgui.h>

#include "app_impl.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/design/case_parameters.h"

namespace socketsmith::gui {

void App::draw_design_panel() {
  if (!session_.has_design()) {
    ImGui::TextWrapped("No case open. File > Open case, Open limb scan, or Open demo.");
    if (ImGui::Button("Open the demo (8000 nodes)")) session_.open_demo(8000);
    return;
  }
  if (ImGui::CollapsingHeader("Spots", ImGuiTreeNodeFlags_DefaultOpen)) {
    ImGui::BeginDisabled(session_.is_optimising());  // the optimiser's result replaces the spots
    // The spot types as the case file names them (case_parameters.h); the view places the chosen one.
    const design::SpotTextParameter& type = *design::find_spot_text_parameter("type");
    ImGui::SetNextItemWidth(90);
    if (ImGui::BeginCombo("type", std::string(type.names[new_spot_type_]).c_str())) {
      for (int i = 0; i < static_cast<int>(type.names.size()); ++i)
        if (ImGui::Selectable(std::string(type.names[i]).c_str(), i == new_spot_type_)) new_spot_type_ = i;
      ImGui::EndCombo();
    }
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", std::string(type.help).c_str());
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

}  // namespace socketsmith::gui
