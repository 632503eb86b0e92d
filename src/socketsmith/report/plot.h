#pragma once
/// @file plot.h
/// A 2-D line and scatter plot as plain data: its series, axis limits, labels, size and legend.
/// Rendered to SVG by svg_plot.h and to PNG by plot_raster.h, both from one layout
/// (plot_layout.h).

#include <optional>
#include <string>
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

}  // namespace socketsmith::report
