#include "socketsmith/report/plot_raster.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "socketsmith/core/errors.h"
#include "socketsmith/report/svg_plot.h"

// The reader is only needed here, to check what write_plot_png wrote (static: raster_test.cpp
// has its own copy).
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#include <stb/stb_image.h>

namespace fs = std::filesystem;
using socketsmith::InvalidInputError;
using namespace socketsmith::report;

namespace {

constexpr Rgb kWhite{255, 255, 255};
constexpr Rgb kRed{255, 0, 0};
constexpr Rgb kGreen{0, 160, 0};

/// A plot with the axes fixed to [0, 10] × [0, 10], no grid, legend, title or labels: the
/// plot area is white except for what the series draw.
Plot bare_plot(PlotSeries series) {
  Plot p;
  p.x_min = 0;
  p.x_max = 10;
  p.y_min = 0;
  p.y_max = 10;
  p.show_grid = false;
  p.legend = LegendPosition::None;
  p.series = {std::move(series)};
  return p;
}

/// Pixel (column, row) whose centre is nearest to data point (x, y), computed from the plot
/// area and the fixed limits [0, 10] of bare_plot.
std::pair<int, int> data_pixel(const PlotLayout& l, double x, double y) {
  const double u = l.left + x / 10.0 * l.plot_w;
  const double v = l.top + l.plot_h - y / 10.0 * l.plot_h;
  return {static_cast<int>(std::floor(u)), static_cast<int>(std::floor(v))};
}

int count_colour(const Image& img, Rgb c, const std::function<bool(int, int)>& where) {
  int n = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      if (where(x, y) && img.at(x, y) == c) ++n;
  return n;
}

/// The message of the InvalidInputError that @p f throws, without its "function: " prefix.
std::string message_after_prefix(const std::function<void()>& f) {
  try {
    f();
  } catch (const InvalidInputError& e) {
    const std::string m = e.what();
    const auto colon = m.find(": ");
    return colon == std::string::npos ? m : m.substr(colon + 2);
  }
  return "(nothing thrown)";
}

}  // namespace

TEST(PlotRaster, series_colour_is_at_its_data_pixels_and_background_elsewhere) {
  const Plot plot = bare_plot({"", {0, 10}, {5, 5}, "#FF0000", false, false, 3});
  const Image img = render_plot_image(plot);
  EXPECT_EQ(img.width, plot.width_px);
  EXPECT_EQ(img.height, plot.height_px);
  const PlotLayout l = plot_image_layout(plot);
  for (double x : {1.0, 2.5, 5.0, 7.5, 9.0}) {
    const auto [u, v] = data_pixel(l, x, 5);
    EXPECT_EQ(img.at(u, v), kRed) << "x = " << x;
    const auto [u2, v2] = data_pixel(l, x, 2);
    EXPECT_EQ(img.at(u2, v2), kWhite) << "x = " << x;
    const auto [u8, v8] = data_pixel(l, x, 8);
    EXPECT_EQ(img.at(u8, v8), kWhite) << "x = " << x;
  }
  // The frame is where the layout says, black.
  EXPECT_EQ(img.at(static_cast<int>(l.left), static_cast<int>(l.top + 0.3 * l.plot_h)),
            (Rgb{0, 0, 0}));
  // The 3 px line is 3 px thick (anti-aliased edges aside): rows 2 px away are white.
  const auto [u, v] = data_pixel(l, 5, 5);
  EXPECT_EQ(img.at(u, v - 3), kWhite);
  EXPECT_EQ(img.at(u, v + 3), kWhite);
}

TEST(PlotRaster, a_sloped_line_passes_through_its_points) {
  const Plot plot = bare_plot({"", {0, 10}, {0, 10}, "#FF0000", false, false, 2});
  const Image img = render_plot_image(plot);
  const PlotLayout l = plot_image_layout(plot);
  for (double t : {2.0, 4.0, 6.5, 8.0}) {
    const auto [u, v] = data_pixel(l, t, t);
    // Anti-aliased: the pixel on the line is (nearly) pure red, one 6 px away white.
    EXPECT_GE(img.at(u, v).r, 250);
    EXPECT_LE(img.at(u, v).g, 60);
    EXPECT_EQ(img.at(u + 6, v), kWhite);
  }
}

TEST(PlotRaster, dashed_series_has_gaps_and_solid_series_has_none) {
  PlotSeries line{"", {0, 10}, {5, 5}, "#FF0000", false, false, 2};
  const auto transitions_along_the_line = [](const Plot& plot) {
    const Image img = render_plot_image(plot);
    const PlotLayout l = plot_image_layout(plot);
    const int v = data_pixel(l, 5, 5).second;
    int red = 0, white = 0, changes = 0;
    bool was_red = true;
    for (int u = data_pixel(l, 1, 5).first; u < data_pixel(l, 9, 5).first; ++u) {
      const bool is_red = img.at(u, v) == kRed;
      red += is_red ? 1 : 0;
      white += img.at(u, v) == kWhite ? 1 : 0;
      changes += is_red != was_red ? 1 : 0;
      was_red = is_red;
    }
    return std::tuple{red, white, changes};
  };
  const auto [solid_red, solid_white, solid_changes] = transitions_along_the_line(bare_plot(line));
  EXPECT_EQ(solid_white, 0);
  EXPECT_EQ(solid_changes, 0);
  line.dashed = true;
  const auto [red, white, changes] = transitions_along_the_line(bare_plot(line));
  EXPECT_GT(white, 50);   // gaps of 2 w + 2 = 6 px less the round caps, every 14 px
  EXPECT_GT(red, 100);
  EXPECT_GE(changes, 20);  // ~550 px of line: dozens of dashes
  EXPECT_GT(solid_red, red);
}

TEST(PlotRaster, markers_are_drawn_at_the_points_without_a_line_between) {
  const Plot plot = bare_plot({"", {2, 8}, {2, 8}, "#00A000", false, true, 0});
  const Image img = render_plot_image(plot);
  const PlotLayout l = plot_image_layout(plot);
  for (double t : {2.0, 8.0}) {
    const auto [u, v] = data_pixel(l, t, t);
    EXPECT_EQ(img.at(u, v), kGreen);
    EXPECT_EQ(img.at(u + 1, v + 1), kGreen);  // a disc of radius 2.5 px, not a dot
    EXPECT_EQ(img.at(u + 6, v), kWhite);
  }
  const auto [u, v] = data_pixel(l, 5, 5);
  EXPECT_EQ(img.at(u, v), kWhite);
  // Radius max(2.5, 1.5 w): two discs of ~20 px each.
  const int n = count_colour(img, kGreen, [](int, int) { return true; });
  EXPECT_GE(n, 2 * 12);
  EXPECT_LE(n, 2 * 30);
}

TEST(PlotRaster, data_outside_given_limits_is_clipped_to_the_plot_area) {
  // A line from far left to far right at y = 5, a point above the top, a marker far right.
  Plot plot = bare_plot({"", {-50, 60}, {5, 5}, "#00A000", false, false, 4});
  plot.series.push_back({"", {5, 5}, {8, 30}, "#00A000", false, true, 2});
  plot.series.push_back({"", {40}, {5}, "#00A000", false, true, 0});
  const Image img = render_plot_image(plot);
  const PlotLayout l = plot_image_layout(plot);
  const auto outside = [&](int x, int y) {
    return x + 0.5 < l.left || x + 0.5 > l.left + l.plot_w || y + 0.5 < l.top ||
           y + 0.5 > l.top + l.plot_h;
  };
  const auto inside = [&](int x, int y) { return !outside(x, y); };
  EXPECT_EQ(count_colour(img, kGreen, outside), 0);
  EXPECT_GT(count_colour(img, kGreen, inside), 500);
  // The line reaches both sides of the plot area.
  EXPECT_EQ(img.at(static_cast<int>(l.left) + 2, data_pixel(l, 5, 5).second), kGreen);
  EXPECT_EQ(img.at(static_cast<int>(l.left + l.plot_w) - 2, data_pixel(l, 5, 5).second), kGreen);
  // The vertical segment runs up to the top edge.
  EXPECT_EQ(img.at(data_pixel(l, 5, 5).first, static_cast<int>(l.top) + 2), kGreen);
}

TEST(PlotRaster, nan_points_break_the_line) {
  const Plot plot = bare_plot({"", {0, 4, 5, 6, 10}, {5, 5, std::nan(""), 5, 5}, "#FF0000",
                               false, false, 2});
  const Image img = render_plot_image(plot);
  const PlotLayout l = plot_image_layout(plot);
  EXPECT_EQ(img.at(data_pixel(l, 2, 5).first, data_pixel(l, 2, 5).second), kRed);
  EXPECT_EQ(img.at(data_pixel(l, 5, 5).first, data_pixel(l, 5, 5).second), kWhite);
  EXPECT_EQ(img.at(data_pixel(l, 8, 5).first, data_pixel(l, 8, 5).second), kRed);
}

TEST(PlotRaster, full_plot_has_grid_ticks_text_and_legend) {
  Plot plot;
  plot.title = "front: MAE 1.2 ± 0.3 kPa";
  plot.x_label = "height [mm]";
  plot.y_label = "pressure [kPa]";
  plot.legend = LegendPosition::TopLeft;
  plot.series = {{"designed", {0, 50, 100}, {1, 9, 4}, "#CC79A7", false, true, 2},
                 {"CalculiX", {0, 50, 100}, {2, 7, 5}, "", true, false, 2}};
  const Image img = render_plot_image(plot);
  const PlotLayout l = plot_image_layout(plot);
  ASSERT_GE(l.x.ticks.size(), 3u);
  // Grid line at an inner x tick, away from the data.
  const int gx = static_cast<int>(std::floor(l.to_px_x(l.x.ticks[1])));
  EXPECT_EQ(img.at(gx, static_cast<int>(l.top + l.plot_h) - 3), (Rgb{221, 221, 221}));
  // Ink in the title band, left margin (tick labels, y label) and below the plot.
  const auto ink_in = [&](int x0, int y0, int x1, int y1) {
    return count_colour(img, Rgb{0, 0, 0},
                        [&](int x, int y) { return x >= x0 && x < x1 && y >= y0 && y < y1; });
  };
  EXPECT_GT(ink_in(0, 0, img.width, static_cast<int>(l.top) - 2), 100);  // title
  EXPECT_GT(ink_in(0, static_cast<int>(l.top), 30, static_cast<int>(l.top + l.plot_h)), 30);
  EXPECT_GT(ink_in(0, static_cast<int>(l.top + l.plot_h) + 2, img.width, img.height), 100);
  // Legend box at the top left with the first palette colour (#0072B2, the second series has
  // no colour of its own) in it.
  EXPECT_LT(l.legend_x, l.left + 0.5 * l.plot_w);
  const int legend_blue = count_colour(img, Rgb{0x00, 0x72, 0xB2}, [&](int x, int y) {
    return x >= l.legend_x && x <= l.legend_x + l.legend_w && y >= l.legend_y &&
           y <= l.legend_y + l.legend_h;
  });
  EXPECT_GT(legend_blue, 5);
}

TEST(PlotRaster, a_title_wider_than_the_plot_stays_inside_the_image) {
  // validate's front-line title ("front line (through the patellar tendon): MAE … R …") is wider
  // than its 720 px panel at the large font; it was cut at the left edge.
  Plot plot;
  plot.width_px = 360;
  plot.title = "front line (through the patellar tendon): MAE 2.05 +/- 1.40 kPa, R 0.73";
  plot.series = {{"a", {0, 1}, {0, 1}, "#ff0000", false, false, 2}};
  const Image img = render_plot_image(plot);
  const PlotLayout l = plot_image_layout(plot);
  int inside = 0, outside = 0;
  for (int y = 0; y < static_cast<int>(l.top) - 2; ++y)
    for (int x = 0; x < img.width; ++x)
      if (img.at(x, y) == (Rgb{0, 0, 0})) ++(x < 4 || x >= img.width - 4 ? outside : inside);
  EXPECT_GT(inside, 100);
  EXPECT_EQ(outside, 0);
}

TEST(PlotRaster, grid_image_is_columns_by_rows_cells_with_each_panel_at_its_cell) {
  Plot a = bare_plot({"", {0, 10}, {5, 5}, "#FF0000", false, false, 3});
  Plot b = a;
  b.width_px = 400;
  b.height_px = 300;
  Plot c = a;
  c.height_px = 520;
  const Image grid = render_plot_grid_image({a, b, c}, 2);
  EXPECT_EQ(grid.width, 2 * 720);
  EXPECT_EQ(grid.height, 2 * 520);
  const Image one = render_plot_image(b);
  for (int y = 0; y < one.height; y += 7)
    for (int x = 0; x < one.width; x += 5) ASSERT_EQ(grid.at(720 + x, y), one.at(x, y));
  // Below the smaller panel b: background.
  EXPECT_EQ(grid.at(720 + 200, 400), kWhite);
  // Panel c in the second row.
  const Image third = render_plot_image(c);
  const PlotLayout l = plot_image_layout(c);
  const auto [u, v] = data_pixel(l, 5, 5);
  EXPECT_EQ(third.at(u, v), kRed);
  EXPECT_EQ(grid.at(u, 520 + v), kRed);
  // More columns than panels: one row.
  const Image row = render_plot_grid_image({a, b}, 5);
  EXPECT_EQ(row.width, 2 * 720);
  EXPECT_EQ(row.height, 480);
}

TEST(PlotRaster, bad_input_throws_the_svg_renderers_messages) {
  const Plot good = bare_plot({"MSS-CS model", {0, 1}, {0, 1}, "", false, false, 2});
  std::vector<Plot> bad;
  bad.push_back(good);
  bad.back().series[0].y.pop_back();
  bad.push_back(good);
  bad.back().x_min = 10;
  bad.back().x_max = 10;
  bad.push_back(good);
  bad.back().y_max = std::numeric_limits<double>::infinity();
  bad.push_back(good);
  bad.back().x_min = std::numeric_limits<double>::quiet_NaN();
  bad.push_back(good);
  bad.back().height_px = 50;
  bad.push_back(good);
  bad.back().series[0].line_width = -1;
  for (const Plot& p : bad) {
    const std::string svg = message_after_prefix([&] { render_svg(p); });
    const std::string png = message_after_prefix([&] { render_plot_image(p); });
    EXPECT_NE(svg, "(nothing thrown)");
    EXPECT_EQ(png, svg);
    EXPECT_EQ(message_after_prefix([&] { write_plot_png("/nonexistent/never.png", p); }), svg);
    // In a grid the message names the function and the panel.
    try {
      render_plot_grid_image({good, p}, 2);
      ADD_FAILURE() << "expected InvalidInputError for " << svg;
    } catch (const InvalidInputError& e) {
      EXPECT_NE(std::string(e.what()).find("render_plot_grid_image: panel 1"), std::string::npos)
          << e.what();
    }
  }
  EXPECT_NE(message_after_prefix([&] { render_plot_image(bad[0]); }).find("MSS-CS model"),
            std::string::npos);
  EXPECT_EQ(message_after_prefix([] { render_plot_grid_image({}, 2); }),
            message_after_prefix([] { render_svg_grid({}, 2); }));
  EXPECT_EQ(message_after_prefix([&] { render_plot_grid_image({good}, 0); }),
            message_after_prefix([&] { render_svg_grid({good}, 0); }));
  // Colours the raster renderer cannot read are named.
  Plot odd = good;
  odd.series[0].color = "hsl(10, 20%, 30%)";
  EXPECT_NE(message_after_prefix([&] { render_plot_image(odd); }).find("hsl(10, 20%, 30%)"),
            std::string::npos);
}

TEST(PlotRaster, colour_names_and_short_hex_are_read) {
  for (const auto& [name, rgb] : std::vector<std::pair<std::string, Rgb>>{
           {"red", kRed}, {"#f00", kRed}, {"#FF0000", kRed}, {"Blue", Rgb{0, 0, 255}}}) {
    const Plot plot = bare_plot({"", {0, 10}, {5, 5}, name, false, false, 3});
    const auto [u, v] = data_pixel(plot_image_layout(plot), 5, 5);
    EXPECT_EQ(render_plot_image(plot).at(u, v), rgb) << name;
  }
}

TEST(PlotRaster, write_plot_png_writes_a_readable_png) {
  const fs::path dir =
      fs::temp_directory_path() / ("socketsmith_plot_png_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  Plot plot = bare_plot({"line", {0, 10}, {0, 10}, "#0072B2", true, true, 2});
  plot.title = "title";
  write_plot_png(dir / "one.png", plot);
  write_plot_grid_png(dir / "grid.png", {plot, plot, plot}, 2);

  std::ifstream in(dir / "one.png", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GE(bytes.size(), 24u);
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(bytes.substr(12, 4), "IHDR");
  const auto be32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    for (std::size_t k = 0; k < 4; ++k) v = v << 8 | static_cast<unsigned char>(bytes[at + k]);
    return v;
  };
  EXPECT_EQ(be32(16), 720u);
  EXPECT_EQ(be32(20), 480u);

  const Image expected = render_plot_image(plot);
  int w = 0, h = 0, comp = 0;
  unsigned char* data = stbi_load((dir / "one.png").string().c_str(), &w, &h, &comp, 3);
  ASSERT_NE(data, nullptr);
  ASSERT_EQ(w, 720);
  ASSERT_EQ(h, 480);
  EXPECT_EQ(std::memcmp(data, expected.pixels.data(), expected.pixels.size() * 3), 0);
  stbi_image_free(data);
  data = stbi_load((dir / "grid.png").string().c_str(), &w, &h, &comp, 3);
  ASSERT_NE(data, nullptr);
  EXPECT_EQ(w, 2 * 720);
  EXPECT_EQ(h, 2 * 480);
  stbi_image_free(data);
  fs::remove_all(dir);
}

TEST(PlotRaster, far_away_and_huge_data_is_clipped_without_stalling) {
  // Dashed lines from far outside the limits (pixel coordinates ~1e17 and overflowing) into
  // the plot area: drawn inside, nothing outside.
  Plot plot = bare_plot({"", {-1e16, 5, 1e300}, {5, 5, 1e300}, "#00A000", true, true, 2});
  plot.series.push_back({"", {-1e308, 1e308}, {2, 2}, "#00A000", true, false, 2});
  const Image img = render_plot_image(plot);
  const PlotLayout l = plot_image_layout(plot);
  const auto outside = [&](int x, int y) {
    return x + 0.5 < l.left || x + 0.5 > l.left + l.plot_w || y + 0.5 < l.top ||
           y + 0.5 > l.top + l.plot_h;
  };
  EXPECT_EQ(count_colour(img, kGreen, outside), 0);
  EXPECT_GT(count_colour(img, kGreen, [&](int x, int y) { return !outside(x, y); }), 100);
}
