#include "fonts.h"

#include <cstdlib>
#include <filesystem>

#include <imgui.h>

namespace socketsmith::gui {

namespace {

/// The code points of UTF-8 @p text (the library writes only well-formed UTF-8).
std::u32string code_points(const std::string& text) {
  std::u32string out;
  for (size_t k = 0; k < text.size();) {
    const auto c = static_cast<unsigned char>(text[k]);
    const int len = c < 0x80 ? 1 : c < 0xE0 ? 2 : c < 0xF0 ? 3 : 4;
    char32_t cp = len == 1 ? c : len == 2 ? (c & 0x1F) : len == 3 ? (c & 0x0F) : (c & 0x07);
    for (int b = 1; b < len && k + b < text.size(); ++b) cp = (cp << 6) | (static_cast<unsigned char>(text[k + b]) & 0x3F);
    out.push_back(cp);
    k += len;
  }
  return out;
}

}  // namespace

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
  const std::string all = kLibrarySymbols;
  size_t k = 0;
  for (char32_t cp : code_points(all)) {
    const size_t len = cp < 0x80 ? 1 : cp < 0x800 ? 2 : cp < 0x10000 ? 3 : 4;
    if (!draws(cp)) out += all.substr(k, len);
    k += len;
  }
  return out;
}

}  // namespace socketsmith::gui
