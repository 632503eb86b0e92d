// The menu bar and the modal dialogs it opens: the file dialog (open, save as, export, compare)
// and the one asking about unsaved changes on close.

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <GLFW/glfw3.h>
#include <fmt/format.h>
#include <imgui.h>

#include "app_impl.h"
#include "socketsmith/core/errors.h"

namespace socketsmith::gui {

namespace fs = std::filesystem;

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
