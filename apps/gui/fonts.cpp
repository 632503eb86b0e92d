#include "fonts.h"

#include <cstdlib>
#include <cstring>
#include <filesystem>

#include <imgui.h>
#include <imgui_internal.h>  // ImTextCharFromUtf8

namespace socketsmith::gui {

std::string window_font_file() {
  if (const char* env = std::getenv("SOCKETSMITH_GUI_FONT"); env && *env) return env;
  return "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
}

bool load_window_font(const std::string& file, float pixels) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) return false;
  // Latin-1, Greek, general punctuation (dashes, ·, …), super- and subscripts, arrows, mathematical
  // operators; ImGui keeps a pointer to this array until the atlas is built.
  static const ImWchar kRanges[] = {0x0020, 0x00FF, 0x0370, 0x03FF, 0x2010, 0x205E, 0x2070, 0x209F,
                                    0x2190, 0x21FF, 0x2200, 0x22FF, 0};
  ImGuiIO& io = ImGui::GetIO();
  ImFont* font = io.Fonts->AddFontFromFileTTF(file.c_str(), pixels, nullptr, kRanges);
  if (!font) return false;
  io.FontDefault = font;
  return true;
}

const ImFont* window_font() {
  const ImGuiIO& io = ImGui::GetIO();
  if (!io.Fonts->IsBuilt()) return nullptr;
  return io.FontDefault ? io.FontDefault : io.Fonts->Fonts.empty() ? nullptr : io.Fonts->Fonts[0];
}

bool draws(char32_t code_point) {
  const ImFont* font = window_font();
  return font && font->FindGlyphNoFallback(static_cast<ImWchar>(code_point));
}

std::string missing_symbols() {
  std::string out;
  for (const char *k = kLibrarySymbols, *end = k + std::strlen(k); k < end;) {
    unsigned int cp = 0;
    const int len = ImTextCharFromUtf8(&cp, k, end);
    if (!draws(cp)) out.append(k, static_cast<size_t>(len));
    k += len;
  }
  return out;
}

}  // namespace socketsmith::gui
