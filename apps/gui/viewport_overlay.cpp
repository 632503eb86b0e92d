// What is drawn over the 3D view: the colour bar, the landmarks, the selected spot, the help line
// and the small window of the field, its range and the view's toggles.

#include <string>
#include <vector>

#include <imgui.h>

#include "app_impl.h"
#include "plots.h"

namespace socketsmith::gui {

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
                      : field_ == Field::Delivered                              ? "delivered [kPa]"
                      : field_ == Field::DeliveryError                          ? "delivered - designed [kPa]"
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
                                              "1-8: field";
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
                          "deviation of the compared shape [mm]", "rectification [mm]",
                          "delivered pressure [kPa]", "delivered - designed [kPa]"};
  // The deviation is offered once a second shape was compared (File > Compare with a second shape),
  // the rectification and the delivered pressures once a design is shown.
  std::vector<Field> offered{Field::Pressure, Field::Threshold, Field::Ratio, Field::Displacement};
  if (!session_.deviation_m().empty()) offered.push_back(Field::Deviation);
  if (session_.state()) offered.insert(offered.end(), {Field::Rectification, Field::Delivered, Field::DeliveryError});
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
  if (field_ == Field::Delivered || field_ == Field::DeliveryError)  // the table is in the feedback panel
    ImGui::TextDisabled(session_.delivery() ? "donned and stood on; grey above the brim"
                                            : "grey until the delivery check has run (feedback panel)");
  if (ImGui::Checkbox("auto range", &is_auto_range_)) colours_dirty_ = true;
  if (!is_auto_range_) {
    ImGui::SetNextItemWidth(200);
    if (ImGui::DragFloatRange2("range", &range_min_, &range_max_, 0.1f, is_signed(field_) ? -100.0f : 0.0f, 1000.0f))
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

}  // namespace socketsmith::gui
