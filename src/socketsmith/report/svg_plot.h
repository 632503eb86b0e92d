#pragma once
/// @file svg_plot.h
/// Dependency-free SVG line and scatter plots (the report::Plot of plot.h) for reports and
/// papers: nice axis ticks (1, 2, 5 × 10^k), grid lines, legend, axis labels, several panels in
/// one figure.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "socketsmith/report/plot.h"

namespace socketsmith::report {

/// Renders @p plot as a standalone SVG document.
/// @throws InvalidInputError when a series has x and y of different sizes or a negative or
///         non-finite line width, an axis limit is not finite, x_min >= x_max or
///         y_min >= y_max, or the size is out of range (each message names the offender).
std::string render_svg(const Plot& plot);

/// Writes render_svg(@p plot) to @p path atomically.
/// @throws as render_svg; IoError when the file cannot be written.
void write_svg(const std::filesystem::path& path, const Plot& plot);

/// Renders several panels into one SVG, row by row, @p columns panels per row. Every cell of
/// the grid is as large as the largest panel; each panel keeps its own size.
/// @throws InvalidInputError when @p panels is empty or @p columns < 1, or as render_svg.
std::string render_svg_grid(const std::vector<Plot>& panels, int columns);

/// Writes render_svg_grid(@p panels, @p columns) to @p path atomically.
void write_svg_grid(const std::filesystem::path& path, const std::vector<Plot>& panels,
                    int columns);

/// Escapes &, <, >, " and ' (as @p apostrophe) for markup text and attribute values; with
/// @p drop_controls, drops the control characters XML 1.0 does not allow (all but tab, line feed
/// and carriage return). xml_escape and html_escape are its two uses.
std::string escape_markup(std::string_view text, std::string_view apostrophe, bool drop_controls);

/// Escapes &, <, >, " and ' for XML text and attribute values; drops characters that XML 1.0
/// does not allow (control characters other than tab, line feed and carriage return).
std::string xml_escape(std::string_view text);

}  // namespace socketsmith::report
