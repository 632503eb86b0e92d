#pragma once
/// @file plot_raster.h
/// The report::Plot of plot.h rendered to pixels (PNG) instead of SVG (svg_plot.h): the same
/// layout (plot_layout.h: limits, ticks, clipping, legend), anti-aliased lines with round caps
/// and joins, dashes, circle markers, grid, frame, tick labels, title, axis labels (the y label
/// turned 90°) and legend, text in raster.h's bitmap font. Text goes through to_ascii() first
/// ("±" → "+/-", "²" → "^2", "ν" → "nu"; other non-ASCII characters → '?').

#include <filesystem>
#include <vector>

#include "socketsmith/report/plot.h"
#include "socketsmith/report/plot_layout.h"
#include "socketsmith/report/raster.h"

namespace socketsmith::report {

/// Renders @p plot as an image of plot.width_px × plot.height_px pixels.
/// Series colours may be "#rgb", "#rrggbb" or one of the basic CSS names (black, white, grey,
/// gray, red, green, blue, orange, purple, brown, pink, cyan, magenta, yellow, navy, teal,
/// olive, maroon, lime, silver).
/// @throws InvalidInputError as render_svg (the same checks and messages, naming
///         render_plot_image), when a side exceeds kMaxImageSide, or a colour is not one of
///         the above.
Image render_plot_image(const Plot& plot);

/// Where render_plot_image puts everything of @p plot (plot area, ticks, legend), in pixels of
/// its image (pixel (i, j) covers [i, i+1) × [j, j+1)).
/// @throws InvalidInputError as render_plot_image.
PlotLayout plot_image_layout(const Plot& plot);

/// Writes render_plot_image(@p plot) to @p path as PNG, atomically.
/// @throws as render_plot_image; IoError when the file cannot be written.
void write_plot_png(const std::filesystem::path& path, const Plot& plot);

/// Renders several panels into one image, row by row, @p columns panels per row, as
/// render_svg_grid: every cell is as large as the largest panel (image columns × cell width
/// by rows × cell height), each panel keeps its own size at the top left of its cell.
/// @throws InvalidInputError as render_svg_grid or render_plot_image.
Image render_plot_grid_image(const std::vector<Plot>& panels, int columns);

/// Writes render_plot_grid_image(@p panels, @p columns) to @p path as PNG, atomically.
void write_plot_grid_png(const std::filesystem::path& path, const std::vector<Plot>& panels,
                         int columns);

}  // namespace socketsmith::report
