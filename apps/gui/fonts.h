#pragma once
/// The window's font: DejaVu Sans (Debian's fonts-dejavu-core) with the symbols the library's text
/// uses — Greek (μ, ν, σ), arrows, ≤ ≥ ≈ ±, minus and dashes, super- and subscripts — which Dear
/// ImGui's built-in font (Latin-1 only) draws as "?". Without the file the built-in font stays and
/// shown_text (plots.h) writes those symbols in ASCII.

#include <string>

namespace socketsmith::gui {

/// The symbols of the library's text the window must draw (UTF-8): checked by the headless state.
inline constexpr const char* kLibrarySymbols = "μνσΔ→←≤≥≈±×·−–—…²³⁻¹°";

/// The window's font file: $SOCKETSMITH_GUI_FONT when set, else DejaVu Sans where Debian installs it.
std::string window_font_file();

/// Loads @p file as the window's font into the current ImGui context, before its first frame, at
/// @p pixels. False when it is not a font file (the built-in font is kept).
bool load_window_font(const std::string& file, float pixels = 14.0f);

/// Whether the window's font (built) has a glyph for @p code_point.
bool draws(char32_t code_point);

/// The symbols of kLibrarySymbols the current font has no glyph for (UTF-8); empty when it draws all.
std::string missing_symbols();

}  // namespace socketsmith::gui
