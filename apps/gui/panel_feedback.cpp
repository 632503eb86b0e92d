// The Feedback panel (right): the job's progress, errors, whether the constraints are met, the
// template's regions, the rectification chart, the log, the limb's notes, the radar and the profiles.

#include <cmath>
#include <mutex>
#include <string>
#include <vector>

#include <fmt/ranges.h>
#include <imgui.h>

#include "app_impl.h"
#include "plots.h"
#include "socketsmith/pipeline/closed_loop.h"
#include "socketsmith/report/delivery_bar.h"

namespace socketsmith::gui {

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

namespace {

/// The delivery check's tables: per region (below the brim, each path) and per landmark, the
/// open-loop socket against the corrected one.
void delivery_tables(const pipeline::DeliveryCheck& d) {
  if (ImGui::BeginTable("delivery", 4, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingStretchProp)) {
    for (const char* h : {"region", "MAE kPa", "p99 kPa", "R"}) ImGui::TableSetupColumn(h);
    ImGui::TableHeadersRow();
    for (const pipeline::RegionDelivery& r : d.summary.regions) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      const std::string shown = r.key == "mid_circumference" ? "mid circ." : r.key.substr(0, r.key.find('_')) + " " +
                                                                             r.key.substr(r.key.find('_') + 1);
      ImGui::TextUnformatted(r.key.find('_') == std::string::npos ? r.key.c_str() : shown.c_str());
      if (ImGui::IsItemHovered())
        ImGui::SetTooltip("%s: mean %.1f kPa delivered by the corrected socket, %.1f kPa designed", r.name.c_str(),
                          r.closed_loop.mean_a / 1e3, r.closed_loop.mean_b / 1e3);
      ImGui::TableNextColumn();
      ImGui::Text("%.2f -> %.2f", r.open_loop.mae / 1e3, r.closed_loop.mae / 1e3);
      ImGui::TableNextColumn();
      ImGui::Text("%.1f -> %.1f", r.open_loop.p99 / 1e3, r.closed_loop.p99 / 1e3);
      ImGui::TableNextColumn();
      ImGui::Text("%.2f -> %.2f", r.open_loop.r, r.closed_loop.r);
    }
    ImGui::EndTable();
  }
  if (ImGui::BeginTable("delivery_landmarks", 4, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingStretchProp)) {
    for (const char* h : {"landmark", "designed p/T", "open loop p/T", "corrected p/T"}) ImGui::TableSetupColumn(h);
    ImGui::TableHeadersRow();
    for (const pipeline::LandmarkDelivery& l : d.summary.landmarks) {
      if (l.threshold_pa <= 0) continue;
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(l.code.c_str());
      for (double p : {l.target_pa, l.open_loop_pa, l.closed_loop_pa}) {
        ImGui::TableNextColumn();
        ImGui::Text("%.2f", p / l.threshold_pa);
      }
    }
    ImGui::EndTable();
  }
}

}  // namespace

/// What the socket delivers (pipeline::DeliveryCheck): the closed loop of the shown design run on
/// release — its progress, then below the brim and on each path the open-loop and the corrected
/// socket against the design, and at each landmark the pressure/threshold ratio.
void App::draw_delivery() {
  const auto& state = session_.state();
  if (!state) return;
  if (is_delivery_table_opening_) ImGui::SetNextItemOpen(true);
  is_delivery_table_opening_ = false;
  if (!ImGui::CollapsingHeader("Delivered (donned and stood on)")) return;
  if (!session_.is_delivery_asked()) {
    ImGui::TextWrapped("Don the socket that Export would write and stand on it (friction, half the body weight), "
                       "correct its wall until it delivers this design, and compare: what Export runs, here after "
                       "every design.");
    if (ImGui::SmallButton("Check what the socket delivers")) set_field(Field::Delivered);
  } else if (ImGui::SmallButton("Stop checking")) {
    session_.stop_delivery();
  }
  if (session_.document().closed_loop == false)
    ImGui::TextColored(ImVec4(1.0f, 0.78f, 0.3f, 1.0f), "The case sets design.closed_loop false: Export writes the "
                                                         "open-loop socket, not the corrected one.");
  if (const auto [f, stage] = session_.delivery_progress(); f >= 0)
    ImGui::ProgressBar(static_cast<float>(f), ImVec2(-1, 0), stage.c_str());
  else if (session_.is_delivery_asked() && !state->status.all_ok())
    ImGui::TextDisabled("No socket to don: the constraints are not all met.");
  if (const std::string error = session_.delivery_error(); !error.empty()) {
    ImGui::PushStyleColor(ImGuiCol_Text, IM_COL32(255, 110, 100, 255));
    ImGui::TextWrapped("Not checked: %s", error.c_str());
    ImGui::PopStyleColor();
  }
  const pipeline::DeliveryCheck* d = session_.delivery();
  if (!d) return;
  ImGui::PushStyleColor(ImGuiCol_Text, d->converged ? IM_COL32(90, 220, 110, 255) : IM_COL32(255, 200, 80, 255));
  ImGui::TextWrapped("Closed loop %s (%d donnings, %d refits, %.0f s).", d->converged ? "converged" : "not converged",
                     d->donnings, d->refits, d->seconds);
  ImGui::PopStyleColor();
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", d->message.c_str());
  // Issue 20's delivery bar for the socket exported: below the brim, on each path, at the landmarks.
  const report::DeliveryVerdict bar = pipeline::delivery_verdicts(d->summary).second;
  ImGui::PushStyleColor(ImGuiCol_Text, bar.met() ? IM_COL32(90, 220, 110, 255) : IM_COL32(255, 200, 80, 255));
  ImGui::TextWrapped("Delivery bar: %s", shown_text(bar.summary()).c_str());
  ImGui::PopStyleColor();
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", shown_text(report::describe()).c_str());
  if (d->state != session_.state_serial()) ImGui::TextDisabled("(of the design before: updating)");
  ImGui::TextWrapped("Against the design, open-loop socket -> corrected socket (the one exported):");
  delivery_tables(*d);
  if (field_ != Field::Delivered && ImGui::SmallButton("Colour by delivered")) set_field(Field::Delivered);
  if (field_ != Field::Delivered && field_ != Field::DeliveryError) ImGui::SameLine();
  if (field_ != Field::DeliveryError && ImGui::SmallButton("Colour by delivered - designed"))
    set_field(Field::DeliveryError);
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
  draw_delivery();
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

}  // namespace socketsmith::gui
