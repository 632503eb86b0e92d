#pragma once
/// @file svg_plot.h
/// Dependency-free SVG line and scatter plots for reports and papers: nice axis ticks
/// (1, 2, 5 × 10^k), grid lines, legend, axis labels, several panels in one figure.

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace socketsmith::report {

/// One data series of a plot. Points with a NaN or infinite coordinate are skipped and break
/// the line in two.
struct PlotSeries {
  std::string name;          ///< legend entry; "" = not listed in the legend
  std::vector<double> x, y;  ///< coordinates in data units, same size
  std::string color;         ///< any SVG colour ("#0072B2", "red"); "" = next palette colour
  bool dashed = false;       ///< dashed line
  bool markers = false;      ///< a circle at every point (with line_width = 0: scatter plot)
  double line_width = 2;     ///< [px], >= 0; 0 = no line
};

/// Where the legend box goes inside the plot area. Best = the corner that covers the fewest
/// data points (top right on a tie).
enum class LegendPosition { Best, TopRight, TopLeft, BottomRight, BottomLeft, None };

/// A 2-D plot. Axis limits that are not given are taken from the finite data and widened to
/// the nearest tick; limits that are given are kept exactly and data outside them is clipped.
struct Plot {
  std::string title, x_label, y_label;  ///< "" = omitted
  std::vector<PlotSeries> series;
  std::optional<double> x_min, x_max, y_min, y_max;  ///< axis limits in data units
  int width_px = 720;                                ///< [px], 120..20000
  int height_px = 480;                               ///< [px], 100..20000
  LegendPosition legend = LegendPosition::Best;
  bool show_grid = true;  ///< light grid lines at the ticks
};

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

/// Escapes &, <, >, " and ' for XML text and attribute values; drops characters that XML 1.0
/// does not allow (control characters other than tab, line feed and carriage return).
std::string xml_escape(std::string_view text);

}  // namespace socketsmith::report
