#include "socketsmith/report/plot_raster.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "socketsmith/core/errors.h"
#include "socketsmith/report/draw_2d.h"
#include "socketsmith/report/plot_layout.h"

namespace socketsmith::report {
namespace {

using draw2d::Coverage;
using draw2d::fill_box;
using draw2d::fill_disc;
using draw2d::mix;
using draw2d::PixelRect;
using draw2d::pixels_within;

constexpr Rgb kInk{0, 0, 0};
constexpr Rgb kWhite{255, 255, 255};
constexpr Rgb kGridColour{221, 221, 221};    // #dddddd as in the SVG
constexpr Rgb kLegendFrame{153, 153, 153};  // #999999
constexpr float kLegendOpacity = 0.9f;

/// Bitmap font scale of each kind of text (the font is 12 px per line at scale 1).
int font_scale(PlotText kind) { return kind == PlotText::Title ? 2 : 1; }

PlotTextMetrics raster_metrics() {
  PlotTextMetrics m;
  m.tick_px = text_height("0", font_scale(PlotText::Tick));
  m.label_px = text_height("0", font_scale(PlotText::Label));
  m.title_px = text_height("0", font_scale(PlotText::Title));
  m.legend_px = text_height("0", font_scale(PlotText::Legend));
  m.width_px = [](std::string_view text, PlotText kind) {
    return static_cast<double>(text_width(to_ascii(text), font_scale(kind)));
  };
  return m;
}

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return c >= 'a' && c <= 'f' ? c - 'a' + 10 : -1;
}

/// "#rgb", "#rrggbb" or a basic CSS colour name; nullopt for anything else.
std::optional<Rgb> parse_colour(std::string_view text) {
  if (!text.empty() && text[0] == '#' && (text.size() == 4 || text.size() == 7)) {
    const std::size_t digits = text.size() == 4 ? 1 : 2;
    std::array<int, 3> v{};
    for (std::size_t k = 0; k < 3; ++k) {
      int value = 0;
      for (std::size_t j = 0; j < digits; ++j) {
        const int d = hex_digit(text[1 + k * digits + j]);
        if (d < 0) return std::nullopt;
        value = value * 16 + d;
      }
      v[k] = digits == 1 ? value * 17 : value;
    }
    return Rgb{std::uint8_t(v[0]), std::uint8_t(v[1]), std::uint8_t(v[2])};
  }
  static constexpr std::pair<std::string_view, Rgb> kNames[] = {
      {"black", {0, 0, 0}},       {"white", {255, 255, 255}}, {"grey", {128, 128, 128}},
      {"gray", {128, 128, 128}},  {"red", {255, 0, 0}},       {"green", {0, 128, 0}},
      {"blue", {0, 0, 255}},      {"orange", {255, 165, 0}},  {"purple", {128, 0, 128}},
      {"brown", {165, 42, 42}},   {"pink", {255, 192, 203}},  {"cyan", {0, 255, 255}},
      {"magenta", {255, 0, 255}}, {"yellow", {255, 255, 0}},  {"navy", {0, 0, 128}},
      {"teal", {0, 128, 128}},    {"olive", {128, 128, 0}},   {"maroon", {128, 0, 0}},
      {"lime", {0, 255, 0}},      {"silver", {192, 192, 192}}};
  std::string lower(text);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (const auto& [name, rgb] : kNames)
    if (name == lower) return rgb;
  return std::nullopt;
}

/// Clips the segment a→b to the rectangle (Liang–Barsky); the parameters [t0, t1] of the part
/// inside, or nullopt when none is.
std::optional<std::pair<double, double>> clip_segment(double ax, double ay, double bx, double by,
                                                      double x0, double y0, double x1, double y1) {
  double t0 = 0, t1 = 1;
  const double dx = bx - ax, dy = by - ay;
  const std::array<std::pair<double, double>, 4> edges{
      {{-dx, ax - x0}, {dx, x1 - ax}, {-dy, ay - y0}, {dy, y1 - ay}}};
  for (const auto& [p, q] : edges) {
    if (p == 0) {
      if (q < 0) return std::nullopt;
      continue;
    }
    const double t = q / p;
    if (p < 0)
      t0 = std::max(t0, t);
    else
      t1 = std::min(t1, t);
    if (t0 > t1) return std::nullopt;
  }
  return std::pair{t0, t1};
}

/// Strokes one sub-path of a series (finite pixel points) into @p cov; dashes restart at the
/// start of every sub-path, as in SVG.
void stroke_polyline(Coverage& cov, const std::vector<std::pair<double, double>>& pts,
                     const PlotSeries& s, double x0, double y0, double x1, double y1) {
  const double r = 0.5 * s.line_width;
  if (pts.size() == 1) {  // a lone point: a round dot, as the SVG's round cap
    const auto [x, y] = pts[0];
    if (x >= x0 && x <= x1 && y >= y0 && y <= y1) cov.capsule(x, y, x, y, r);
    return;
  }
  const auto [dash, gap] = dash_pattern(s);
  const double period = dash + gap;
  double start = 0;  // arc length at the segment's start [px]
  for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
    const auto [ax, ay] = pts[i];
    const auto [bx, by] = pts[i + 1];
    const double len = std::hypot(bx - ax, by - ay);
    const auto part = clip_segment(ax, ay, bx, by, x0, y0, x1, y1);
    const double seg_start = start;
    start = std::isfinite(start + len) ? start + len : 0.0;
    if (!part || !std::isfinite(len)) continue;
    // Copies of the bindings: clang 14 (the fuzz and sanitizer builds) cannot capture a binding.
    const auto at = [ax = ax, ay = ay, bx = bx, by = by](double t) {
      return std::pair{ax + t * (bx - ax), ay + t * (by - ay)};
    };
    if (!s.dashed || len == 0) {
      const auto [px0, py0] = at(part->first);
      const auto [px1, py1] = at(part->second);
      cov.capsule(px0, py0, px1, py1, r);
      continue;
    }
    // Dashes [k period, k period + dash] of the sub-path's arc length, counted from the
    // visible part's start (local coordinates stay small however far away the data lies).
    const double visible = (part->second - part->first) * len;
    const double phase = std::fmod(seg_start + part->first * len, period);
    for (double d = -phase; d <= visible; d += period) {
      const double d0 = std::max(0.0, d), d1 = std::min(visible, d + dash);
      if (d0 > d1) continue;
      const auto [px0, py0] = at(part->first + d0 / len);
      const auto [px1, py1] = at(part->first + d1 / len);
      cov.capsule(px0, py0, px1, py1, r);
    }
  }
}

/// Column (row) of the 1-px line that an SVG stroke of width 1 at @p v mostly covers.
int pixel_line(double v) { return static_cast<int>(std::floor(v)); }

/// @p text turned 90° counter-clockwise (reading upward), centred at (@p cx, @p cy).
void draw_text_upward(Image& img, double cx, double cy, const std::string& text, int scale) {
  const int w = text_width(text, scale), h = text_height(text, scale);
  if (w < 1 || h < 1) return;
  Image glyphs(w, h, kWhite);
  draw_text(glyphs, 0, 0, text, kInk, scale);
  const int x0 = static_cast<int>(std::lround(cx - 0.5 * h));
  const int y0 = static_cast<int>(std::lround(cy - 0.5 * w));
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const int x = x0 + v, y = y0 + (w - 1 - u);
      if (glyphs.at(u, v) == kInk && x >= 0 && y >= 0 && x < img.width && y < img.height)
        img.at(x, y) = kInk;
    }
}

/// Text of @p kind, its top at @p y, horizontally anchored at @p x: 0 = left, 0.5 = centre,
/// 1 = right.
void draw_plot_text(Image& img, double x, double y, const std::string& text, PlotText kind,
                    double anchor) {
  const std::string ascii = to_ascii(text);
  const int scale = font_scale(kind);
  const double w = text_width(ascii, scale);
  draw_text(img, static_cast<int>(std::lround(x - anchor * w)), static_cast<int>(std::lround(y)),
            ascii, kInk, scale);
}

/// Vertical offset [px] from a text's top to the middle of its capitals.
double cap_middle(PlotText kind) { return 4.0 * font_scale(kind); }

std::vector<Rgb> series_rgb(const Plot& plot, const PlotLayout& l, std::string_view where) {
  std::vector<Rgb> out;
  for (std::size_t i = 0; i < plot.series.size(); ++i) {
    const auto c = parse_colour(l.colors[i]);
    require(c.has_value(),
            "{}: series {} ('{}') has colour '{}' (expected #rgb, #rrggbb or a basic colour name "
            "such as black, red, blue, grey)",
            where, i, plot.series[i].name, l.colors[i]);
    out.push_back(*c);
  }
  return out;
}

/// The plot area's edges as the columns and rows of their 1-px lines.
struct PlotAreaPixels {
  int left, top, right, bottom;

  explicit PlotAreaPixels(const PlotLayout& l)
      : left(pixel_line(l.left)), top(pixel_line(l.top)), right(pixel_line(l.left + l.plot_w)),
        bottom(pixel_line(l.top + l.plot_h)) {}
};

/// Grid lines at the ticks, across the plot area.
void draw_grid(Image& img, const PlotLayout& l) {
  const PlotAreaPixels px(l);
  for (double t : l.x.ticks) {
    const int x = pixel_line(l.to_px_x(t));
    fill_box(img, x, px.top, x + 1, px.bottom + 1, kGridColour);
  }
  for (double t : l.y.ticks) {
    const int y = pixel_line(l.to_px_y(t));
    fill_box(img, px.left, y, px.right + 1, y + 1, kGridColour);
  }
}

/// A series' line: one stroked sub-path per run of finite points, clipped to @p clip.
void draw_series_line(Image& img, const PlotSeries& s, const PlotLayout& l, const PixelRect& clip,
                      const Rgb& rgb) {
  Coverage cov(img, clip);
  // Segments are cut to the clip rectangle grown by the stroke (so that caps at its edge
  // are whole); the pixels are clipped exactly.
  const double grow = s.line_width + 2;
  std::vector<std::pair<double, double>> path;
  const auto flush = [&] {
    if (!path.empty())
      stroke_polyline(cov, path, s, l.clip_x0 - grow, l.clip_y0 - grow, l.clip_x1 + grow,
                      l.clip_y1 + grow);
    path.clear();
  };
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    const double x = is_finite_point(s.x[i], s.y[i]) ? l.to_px_x(s.x[i]) : NAN;
    const double y = is_finite_point(s.x[i], s.y[i]) ? l.to_px_y(s.y[i]) : NAN;
    if (std::isfinite(x) && std::isfinite(y))
      path.emplace_back(x, y);
    else
      flush();
  }
  flush();
  cov.blend_into(img, rgb);
}

/// A series' markers at its finite points, clipped to @p clip.
void draw_series_markers(Image& img, const PlotSeries& s, const PlotLayout& l, const PixelRect& clip,
                         const Rgb& rgb) {
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!is_finite_point(s.x[i], s.y[i])) continue;
    const double x = l.to_px_x(s.x[i]), y = l.to_px_y(s.y[i]);
    if (std::isfinite(x) && std::isfinite(y) && std::abs(x) < 1e7 && std::abs(y) < 1e7)
      fill_disc(img, x, y, marker_radius(s), rgb, clip);
  }
}

/// The frame round the plot area, its ticks and the tick labels.
void draw_frame_and_ticks(Image& img, const PlotLayout& l) {
  const PlotAreaPixels px(l);
  const double left = l.left, bottom = l.top + l.plot_h;
  fill_box(img, px.left, px.top, px.right + 1, px.top + 1, kInk);
  fill_box(img, px.left, px.bottom, px.right + 1, px.bottom + 1, kInk);
  fill_box(img, px.left, px.top, px.left + 1, px.bottom + 1, kInk);
  fill_box(img, px.right, px.top, px.right + 1, px.bottom + 1, kInk);
  const int tick = static_cast<int>(std::lround(l.tick_length_px));
  for (std::size_t i = 0; i < l.x.ticks.size(); ++i) {
    const double x = l.to_px_x(l.x.ticks[i]);
    fill_box(img, pixel_line(x), px.bottom, pixel_line(x) + 1, px.bottom + tick + 1, kInk);
    draw_plot_text(img, x, bottom + l.tick_length_px + 4, l.x.labels[i], PlotText::Tick, 0.5);
  }
  for (std::size_t i = 0; i < l.y.ticks.size(); ++i) {
    const double y = l.to_px_y(l.y.ticks[i]);
    fill_box(img, px.left - tick, pixel_line(y), px.left, pixel_line(y) + 1, kInk);
    draw_plot_text(img, left - l.tick_length_px - 4, y - cap_middle(PlotText::Tick), l.y.labels[i],
                   PlotText::Tick, 1.0);
  }
}

/// The axis labels and the title.
void draw_labels_and_title(Image& img, const Plot& plot, const PlotLayout& l) {
  const double left = l.left, top = l.top, bottom = l.top + l.plot_h;
  const PlotTextMetrics metrics = raster_metrics();
  if (!plot.x_label.empty())
    draw_plot_text(img, left + 0.5 * l.plot_w, bottom + l.tick_length_px + 6 + metrics.tick_px + 8,
                   plot.x_label, PlotText::Label, 0.5);
  if (!plot.y_label.empty())
    draw_text_upward(img, 10 + 0.5 * metrics.label_px, top + 0.5 * l.plot_h,
                     to_ascii(plot.y_label), font_scale(PlotText::Label));
  if (!plot.title.empty()) {
    // Centred over the plot area; a title wider than that area is kept inside the image: centred
    // on the image, and at the small font when even the image is too narrow for the large one.
    const std::string ascii = to_ascii(plot.title);
    const int big = font_scale(PlotText::Title);
    const int scale = text_width(ascii, big) <= img.width - 8 ? big : font_scale(PlotText::Tick);
    const double w = text_width(ascii, scale);
    double x = left + 0.5 * l.plot_w - 0.5 * w;
    if (x < 4 || x + w > img.width - 4) x = std::max(4.0, 0.5 * (img.width - w));
    draw_text(img, static_cast<int>(std::lround(x)), 14, ascii, kInk, scale);
  }
}

/// The legend box: a sample of each entry's line and marker, and its name.
void draw_legend(Image& img, const Plot& plot, const PlotLayout& l, const std::vector<Rgb>& rgb) {
  const int bx0 = pixel_line(l.legend_x), by0 = pixel_line(l.legend_y);
  const int bx1 = pixel_line(l.legend_x + l.legend_w), by1 = pixel_line(l.legend_y + l.legend_h);
  fill_box(img, bx0, by0, bx1 + 1, by1 + 1, kWhite, kLegendOpacity);
  fill_box(img, bx0, by0, bx1 + 1, by0 + 1, kLegendFrame);
  fill_box(img, bx0, by1, bx1 + 1, by1 + 1, kLegendFrame);
  fill_box(img, bx0, by0, bx0 + 1, by1 + 1, kLegendFrame);
  fill_box(img, bx1, by0, bx1 + 1, by1 + 1, kLegendFrame);
  const PixelRect all{0, 0, img.width, img.height};
  for (std::size_t row = 0; row < l.legend_entries.size(); ++row) {
    const std::size_t si = l.legend_entries[row];
    const PlotSeries& s = plot.series[si];
    const double cy = l.legend_row_y(row);
    const double x0 = l.legend_x + l.legend_pad_px, x1 = x0 + l.legend_sample_px;
    if (s.line_width > 0) {
      Coverage cov(img, all);
      stroke_polyline(cov, {{x0, cy}, {x1, cy}}, s, 0, 0, img.width, img.height);
      cov.blend_into(img, rgb[si]);
    }
    if (s.markers) fill_disc(img, 0.5 * (x0 + x1), cy, marker_radius(s), rgb[si], all);
    draw_plot_text(img, x1 + l.legend_gap_px, cy - cap_middle(PlotText::Legend), s.name,
                   PlotText::Legend, 0.0);
  }
}

/// Draws @p plot, laid out as @p l, into @p img at offset (0, 0) (img is exactly the plot).
void draw_plot(Image& img, const Plot& plot, const PlotLayout& l, const std::vector<Rgb>& rgb) {
  if (plot.show_grid) draw_grid(img, l);
  // Series, clipped to the layout's clip rectangle.
  const PixelRect clip = pixels_within(img, l.clip_x0, l.clip_y0, l.clip_x1, l.clip_y1);
  for (std::size_t si = 0; si < plot.series.size(); ++si) {
    const PlotSeries& s = plot.series[si];
    if (s.line_width > 0) draw_series_line(img, s, l, clip, rgb[si]);
    if (s.markers) draw_series_markers(img, s, l, clip, rgb[si]);
  }
  draw_frame_and_ticks(img, l);
  draw_labels_and_title(img, plot, l);
  if (!l.legend_entries.empty()) draw_legend(img, plot, l, rgb);
}

/// Checks, lays out and draws @p plot into a new image; @p where names the caller in errors.
Image render_checked(const Plot& plot, std::string_view where) {
  require(plot.width_px <= kMaxImageSide && plot.height_px <= kMaxImageSide,
          "{}: {}×{} px (expected at most {} px per side for an image)", where, plot.width_px,
          plot.height_px, kMaxImageSide);
  const PlotLayout l = layout_plot(plot, raster_metrics());
  const std::vector<Rgb> rgb = series_rgb(plot, l, where);
  Image img(plot.width_px, plot.height_px, kWhite);
  draw_plot(img, plot, l, rgb);
  return img;
}

}  // namespace

Image render_plot_image(const Plot& plot) {
  validate_plot(plot, "render_plot_image");
  return render_checked(plot, "render_plot_image");
}

PlotLayout plot_image_layout(const Plot& plot) {
  validate_plot(plot, "plot_image_layout");
  return layout_plot(plot, raster_metrics());
}

void write_plot_png(const std::filesystem::path& path, const Plot& plot) {
  write_png(path, render_plot_image(plot));
}

Image render_plot_grid_image(const std::vector<Plot>& panels, int columns) {
  constexpr std::string_view kWhere = "render_plot_grid_image";
  const PlotGrid g = layout_plot_grid(panels, columns, kWhere);
  require(static_cast<long long>(g.columns) * g.cell_w <= kMaxImageSide &&
              static_cast<long long>(g.rows) * g.cell_h <= kMaxImageSide,
          "{}: the grid is {}×{} px (expected at most {} px per side)", kWhere,
          static_cast<long long>(g.columns) * g.cell_w, static_cast<long long>(g.rows) * g.cell_h,
          kMaxImageSide);
  Image out(g.columns * g.cell_w, g.rows * g.cell_h, kWhite);
  for (std::size_t i = 0; i < panels.size(); ++i) {
    const Image panel =
        render_checked(panels[i], fmt::format("{}: panel {} ('{}')", kWhere, i, panels[i].title));
    const int ox = static_cast<int>(i) % g.columns * g.cell_w;
    const int oy = static_cast<int>(i) / g.columns * g.cell_h;
    for (int y = 0; y < panel.height; ++y)
      std::copy_n(panel.pixels.begin() + static_cast<std::ptrdiff_t>(y) * panel.width, panel.width,
                  out.pixels.begin() + static_cast<std::ptrdiff_t>(oy + y) * out.width + ox);
  }
  return out;
}

void write_plot_grid_png(const std::filesystem::path& path, const std::vector<Plot>& panels,
                         int columns) {
  write_png(path, render_plot_grid_image(panels, columns));
}

}  // namespace socketsmith::report
