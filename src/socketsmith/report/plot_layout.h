#pragma once
/// @file plot_layout.h
/// The geometry of a report::Plot that every renderer shares (SVG in svg_plot.cpp, PNG in
/// plot_raster.cpp): input checks, data limits widened to nice ticks (1, 2, 5 × 10^k), margins,
/// plot area, clip rectangle, series colours, dash pattern, marker size and legend placement.
/// Renderers only differ in how they measure and draw text, which they describe with
/// PlotTextMetrics.

#include <cmath>
#include <cstddef>
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "socketsmith/report/plot.h"

namespace socketsmith::report {

/// The four kinds of text in a plot.
enum class PlotText { Tick, Label, Title, Legend };

/// How a renderer's text measures: heights [px] of each kind, and the width [px] of a string.
struct PlotTextMetrics {
  double tick_px = 12;    ///< tick label height [px]
  double label_px = 14;   ///< axis label height [px]
  double title_px = 16;   ///< title height [px]
  double legend_px = 12;  ///< legend entry height [px]
  /// Width [px] of @p text drawn as @p kind.
  std::function<double(std::string_view text, PlotText kind)> width_px;
};

/// One axis: limits in data units, the tick values and their labels.
struct PlotAxis {
  double lo = 0, hi = 1;  ///< axis limits in data units, lo < hi
  double step = 0.2;      ///< tick spacing in data units
  bool fixed_lo = false, fixed_hi = false;  ///< limit given by the user (kept exactly)
  std::vector<double> ticks;
  std::vector<std::string> labels;  ///< one per tick

  /// Position of @p v along the axis: 0 at lo, 1 at hi.
  double fraction(double v) const { return (v - lo) / (hi - lo); }
};

/// Where everything of one plot goes, in pixels of a frame [0, width] × [0, height], y down.
struct PlotLayout {
  double width = 0, height = 0;              ///< [px] the whole plot
  double left = 0, top = 0;                  ///< [px] top-left corner of the plot area
  double plot_w = 0, plot_h = 0;             ///< [px] size of the plot area
  double clip_x0 = 0, clip_y0 = 0;           ///< [px] data clip rectangle, top-left
  double clip_x1 = 0, clip_y1 = 0;           ///< [px] data clip rectangle, bottom-right
  double tick_length_px = 5;                 ///< [px] tick marks outside the plot area
  PlotAxis x, y;                             ///< the axes
  std::vector<std::string> colors;           ///< one per series: its own or the palette's
  std::vector<std::size_t> legend_entries;   ///< series listed in the legend (empty = none)
  double legend_x = 0, legend_y = 0;         ///< [px] legend box, top-left
  double legend_w = 0, legend_h = 0;         ///< [px] legend box size
  double legend_pad_px = 8;                  ///< [px] inner padding of the legend box
  double legend_row_px = 18;                 ///< [px] height of one legend row
  double legend_sample_px = 28;              ///< [px] length of a legend's line sample
  double legend_gap_px = 6;                  ///< [px] between the sample and the name

  /// Pixel x of data value @p x.
  double to_px_x(double v) const { return left + x.fraction(v) * plot_w; }
  /// Pixel y of data value @p y.
  double to_px_y(double v) const { return top + plot_h - y.fraction(v) * plot_h; }
  /// Vertical centre [px] of legend row @p row.
  double legend_row_y(std::size_t row) const {
    return legend_y + legend_pad_px / 2 + legend_row_px * (static_cast<double>(row) + 0.5);
  }
};

/// Checks @p plot as every renderer does; @p where starts each message ("render_svg").
/// @throws InvalidInputError when a series has x and y of different sizes or a negative or
///         non-finite line width, an axis limit is not finite, x_min >= x_max or
///         y_min >= y_max, or the size is out of range.
void validate_plot(const Plot& plot, std::string_view where);

/// Lays out @p plot (assumed valid) for text measuring as @p metrics.
PlotLayout layout_plot(const Plot& plot, const PlotTextMetrics& metrics);

/// Cells of a figure of several panels, row by row: every cell as large as the largest panel.
struct PlotGrid {
  int columns = 1, rows = 1;       ///< cells across and down (columns <= number of panels)
  int cell_w = 0, cell_h = 0;      ///< [px] size of one cell
};

/// Checks @p panels and @p columns as every grid renderer does and sizes the grid; @p where
/// starts each message ("render_svg_grid").
/// @throws InvalidInputError when @p panels is empty or @p columns < 1, or as validate_plot
///         (the message then names the panel).
PlotGrid layout_plot_grid(const std::vector<Plot>& panels, int columns, std::string_view where);

/// True when both coordinates are finite (other points are skipped and break the line).
inline bool is_finite_point(double x, double y) {
  return std::isfinite(x) && std::isfinite(y);
}

/// Radius [px] of a series' circle markers.
double marker_radius(const PlotSeries& series);

/// Dash pattern of a dashed series: (dash length, gap length) [px] along the line.
std::pair<double, double> dash_pattern(const PlotSeries& series);

}  // namespace socketsmith::report
