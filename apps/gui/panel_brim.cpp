// The Design panel's "Brim and socket": the brim template, its key points and the wall thickness.

#include <string>
#include <vector>

#include <imgui.h>

#include "app_impl.h"
#include "socketsmith/design/case_parameters.h"

namespace socketsmith::gui {

/// The brim template, its key points (angle, height) and the wall thickness.
void App::draw_brim_panel() {
  const design::CaseFile& doc = session_.document();
  const pipeline::DesignSetup& setup = *session_.setup();
  // The templates of this limb's type, as the case file names them (case_parameters.h).
  const design::CaseTextParameter& brim = *design::find_case_text_parameter("brim.template");
  std::vector<design::BrimTemplate> kinds;
  for (std::string_view name : brim.names) {
    const design::BrimTemplate k = design::parse_brim_template(std::string(name));
    if (k != design::BrimTemplate::Custom && design::limb_type_of(k) == setup.model.type) kinds.push_back(k);
  }
  const std::string current = design::to_string(doc.brim.value_or(design::default_brim(setup.model.type))) +
                              (doc.brim_key_points.empty() ? "" : " (edited)");
  if (ImGui::BeginCombo("template", current.c_str())) {
    for (auto k : kinds)
      if (ImGui::Selectable(design::to_string(k).c_str(), k == doc.brim)) session_.set_brim_template(k);
    ImGui::EndCombo();
  }
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", std::string(brim.help).c_str());
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

}  // namespace socketsmith::gui
