#pragma once
/// @file plots.h
/// The live feedback widgets of socketsmith-gui, drawn with ImGui's draw lists: the radar chart
/// of the seven constraint values against their targets, a pressure profile along a path (with
/// the pain threshold) and a vertical colour bar.

#include <string>
#include <vector>

#include <imgui.h>

#include "socketsmith/report/design_report.h"
#include "socketsmith/report/raster.h"

namespace socketsmith::gui {

/// Draws @p axes (report::seven_radar_axes with is_ok set) as a radar chart filling a square of
/// side @p size at the cursor: rings at 0.5, 1.5, 2, the target circle r = 1, the value polygon,
/// one point per axis (green met, red not met, hollow when clamped) and labels with the values.
void radar_chart(const std::vector<report::RadarAxis>& axes, float size);

/// Draws @p profile (pressure solid blue, threshold dashed red, kPa) in a box of @p size at the
/// cursor, with its name, y range and x range.
void profile_plot(const report::PathProfile& profile, ImVec2 size);

/// A vertical colour bar at @p pos (screen) of @p size on @p draw_list, vmax at the top, with
/// five labelled ticks and @p unit above it.
void colour_bar(ImDrawList* draw_list, ImVec2 pos, ImVec2 size, report::Colormap colormap, double vmin, double vmax,
                const std::string& unit);

/// report::colormap_colour as an ImGui colour.
ImU32 colormap_u32(report::Colormap colormap, double t, float alpha = 1.0f);

/// @p text of the library (report lines, verdicts) as the window's font can draw it: unchanged with
/// DejaVu Sans (fonts.h); with ImGui's built-in font (Latin-1) → ≤ ≥ − in ASCII ("->", "<=", ">=",
/// "-"), which it would draw as "?".
std::string shown_text(std::string text);

}  // namespace socketsmith::gui
