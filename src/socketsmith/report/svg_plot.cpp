#include "socketsmith/report/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"

namespace socketsmith::report {
namespace {

// Okabe–Ito palette (distinguishable with colour-vision deficiencies), yellow left out because
// it is too light on white.
constexpr const char* kPalette[] = {"#0072B2", "#D55E00", "#009E73", "#CC79A7",
                                    "#E69F00", "#56B4E9", "#000000"};
constexpr int kPaletteSize = static_cast<int>(std::size(kPalette));

constexpr double kTickFontPx = 12;
constexpr double kLabelFontPx = 14;
constexpr double kTitleFontPx = 16;
constexpr double kLegendFontPx = 12;
constexpr double kTickLengthPx = 5;
constexpr double kCharWidthEm = 0.6;  // average glyph width of Helvetica/Arial, a safe estimate
constexpr double kEdgePadPx = 6;      // room for strokes and markers at automatic axis limits
constexpr double kMaxPx = 1e6;        // pixel coordinates are clamped to ±this

constexpr const char* kFontFamily = "Helvetica, Arial, sans-serif";

using Out = std::string;

/// Appends one formatted line to @p out.
template <class... Args>
void emit(Out& out, fmt::format_string<Args...> f, Args&&... args) {
  fmt::format_to(std::back_inserter(out), f, std::forward<Args>(args)...);
  out += '\n';
}

/// Pixel coordinate: two decimals at most, trailing zeros removed, never "-0".
std::string px(double v) {
  v = std::isnan(v) ? 0.0 : std::clamp(v, -kMaxPx, kMaxPx);  // NaN only from overflowing data
  std::string s = fmt::format("{:.2f}", v);
  while (s.back() == '0') s.pop_back();
  if (s.back() == '.') s.pop_back();
  if (s == "-0") s = "0";
  return s;
}

double text_width_px(std::string_view text, double font_px) {
  // Count UTF-8 code points, not bytes.
  std::size_t n = 0;
  for (unsigned char c : text)
    if ((c & 0xC0) != 0x80) ++n;
  return static_cast<double>(n) * font_px * kCharWidthEm;
}

/// 1, 2 or 5 × 10^k closest above @p raw.
double nice_step(double raw) {
  if (!(raw > 0) || !std::isfinite(raw)) return 1.0;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / magnitude;
  const double nice = f <= 1.0 + 1e-9 ? 1.0 : f <= 2.0 + 1e-9 ? 2.0 : f <= 5.0 + 1e-9 ? 5.0 : 10.0;
  return nice * magnitude;
}

struct Axis {
  double lo = 0, hi = 1, step = 0.2;
  bool fixed_lo = false, fixed_hi = false;
  std::vector<double> ticks;
  std::vector<std::string> labels;

  double fraction(double v) const { return (v - lo) / (hi - lo); }
};

/// Axis limits and ticks from the finite data range [data_lo, data_hi] (empty when
/// data_lo > data_hi) and the optional user limits.
Axis make_axis(double data_lo, double data_hi, std::optional<double> user_lo,
               std::optional<double> user_hi, int target_ticks) {
  Axis a;
  a.fixed_lo = user_lo.has_value();
  a.fixed_hi = user_hi.has_value();
  const bool has_data = data_lo <= data_hi;
  double lo = user_lo.value_or(has_data ? data_lo : 0.0);
  double hi = user_hi.value_or(has_data ? data_hi : 1.0);
  if (!has_data && a.fixed_lo && !a.fixed_hi) hi = lo + 1.0;
  if (!has_data && a.fixed_hi && !a.fixed_lo) lo = hi - 1.0;

  // A single value, a one-sided limit beyond the data, or a span too small for doubles to
  // resolve: widen the free side(s).
  const double scale = std::max(std::abs(lo), std::abs(hi));
  if (!(hi - lo > 1e-9 * scale)) {
    const double ref = a.fixed_lo ? lo : hi;
    const double d = ref == 0.0 ? 1.0 : 0.1 * std::abs(ref);
    if (a.fixed_lo)
      hi = lo + d;
    else if (a.fixed_hi)
      lo = hi - d;
    else {
      lo = ref - d;
      hi = ref + d;
    }
  }

  a.step = nice_step((hi - lo) / std::max(target_ticks, 1));
  if (!a.fixed_lo) lo = std::floor(lo / a.step + 1e-9) * a.step;
  if (!a.fixed_hi) hi = std::ceil(hi / a.step - 1e-9) * a.step;
  a.lo = lo;
  a.hi = hi;

  const double k0 = std::ceil(lo / a.step - 1e-9);
  const double k1 = std::floor(hi / a.step + 1e-9);
  if (std::isfinite(k0) && std::isfinite(k1) && k1 - k0 <= 100 && std::abs(k0) < 1e15) {
    for (auto k = static_cast<std::int64_t>(k0); k <= static_cast<std::int64_t>(k1); ++k) {
      double t = static_cast<double>(k) * a.step;
      if (std::abs(t) < 1e-9 * a.step) t = 0.0;
      a.ticks.push_back(t);
    }
  } else if (std::isfinite(lo) && std::isfinite(hi)) {
    a.ticks = {lo, hi};  // data near the limits of double: just label the ends
  }

  // Fixed-point labels with as many decimals as the step needs; %g beyond a sensible range.
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(a.step) + 1e-9)));
  const double largest = std::max(std::abs(a.lo), std::abs(a.hi));
  const bool scientific = largest >= 1e6 || decimals > 4;
  for (double t : a.ticks) {
    std::string s = scientific ? fmt::format("{:g}", t) : fmt::format("{:.{}f}", t, decimals);
    if (s.size() > 1 && s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos)
      s.erase(0, 1);  // "-0.0" -> "0.0"
    a.labels.push_back(std::move(s));
  }
  return a;
}

bool is_finite_point(double x, double y) { return std::isfinite(x) && std::isfinite(y); }

void validate_plot(const Plot& plot, std::string_view where) {
  require(plot.width_px >= 120 && plot.width_px <= 20000, "{}: width_px = {} (expected 120..20000)",
          where, plot.width_px);
  require(plot.height_px >= 100 && plot.height_px <= 20000,
          "{}: height_px = {} (expected 100..20000)", where, plot.height_px);
  const auto check_limit = [&](const std::optional<double>& v, const char* name) {
    require(!v || std::isfinite(*v), "{}: {} = {} (expected a finite number or none)", where, name,
            v.value_or(0.0));
  };
  check_limit(plot.x_min, "x_min");
  check_limit(plot.x_max, "x_max");
  check_limit(plot.y_min, "y_min");
  check_limit(plot.y_max, "y_max");
  require(!(plot.x_min && plot.x_max) || *plot.x_min < *plot.x_max,
          "{}: x_min = {} is not below x_max = {}", where, plot.x_min.value_or(0.0),
          plot.x_max.value_or(0.0));
  require(!(plot.y_min && plot.y_max) || *plot.y_min < *plot.y_max,
          "{}: y_min = {} is not below y_max = {}", where, plot.y_min.value_or(0.0),
          plot.y_max.value_or(0.0));
  for (std::size_t i = 0; i < plot.series.size(); ++i) {
    const PlotSeries& s = plot.series[i];
    require(s.x.size() == s.y.size(),
            "{}: series {} ('{}') has {} x values and {} y values (expected the same number)",
            where, i, s.name, s.x.size(), s.y.size());
    require(std::isfinite(s.line_width) && s.line_width >= 0,
            "{}: series {} ('{}') has line_width = {} (expected >= 0 px)", where, i, s.name,
            s.line_width);
  }
}

std::vector<std::string> series_colors(const Plot& plot) {
  std::vector<std::string> colors;
  int next = 0;
  for (const auto& s : plot.series)
    colors.push_back(!s.color.empty() ? s.color : kPalette[next++ % kPaletteSize]);
  return colors;
}

double marker_radius(const PlotSeries& s) { return std::max(2.5, 1.5 * s.line_width); }

std::string dash_array(const PlotSeries& s) {
  const double w = std::max(s.line_width, 1.0);
  return px(3.0 * w + 2.0) + "," + px(2.0 * w + 2.0);
}

/// Stroke attributes shared by a series' line and its legend sample.
std::string stroke_attributes(const PlotSeries& s, const std::string& color) {
  std::string a = fmt::format(
      R"(fill="none" stroke="{}" stroke-width="{}" stroke-linejoin="round" stroke-linecap="round")",
      xml_escape(color), px(s.line_width));
  if (s.dashed) a += fmt::format(R"( stroke-dasharray="{}")", dash_array(s));
  return a;
}

/// Writes one plot's elements (no <svg> wrapper) in a local frame [0, width]×[0, height].
/// @p id makes clip-path ids unique within a document.
void render_panel(Out& out, const Plot& plot, const std::string& id) {
  const double width = plot.width_px;
  const double height = plot.height_px;
  const bool has_title = !plot.title.empty();
  const bool has_x_label = !plot.x_label.empty();
  const bool has_y_label = !plot.y_label.empty();

  // Finite data ranges; with user x limits the y range only looks at points inside them.
  double x_lo = std::numeric_limits<double>::infinity(), x_hi = -x_lo;
  double y_lo = x_lo, y_hi = -x_lo;
  for (const auto& s : plot.series)
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      const double x = s.x[i], y = s.y[i];
      if (!is_finite_point(x, y)) continue;
      x_lo = std::min(x_lo, x);
      x_hi = std::max(x_hi, x);
      if ((plot.x_min && x < *plot.x_min) || (plot.x_max && x > *plot.x_max)) continue;
      y_lo = std::min(y_lo, y);
      y_hi = std::max(y_hi, y);
    }

  // Vertical layout first: the y ticks decide the width of the left margin.
  const double top = has_title ? 14 + kTitleFontPx + 12 : 16;
  const double bottom =
      kTickLengthPx + 6 + kTickFontPx + (has_x_label ? 10 + kLabelFontPx : 0) + 12;
  const double plot_h = std::max(20.0, height - top - bottom);
  const Axis ya = make_axis(y_lo, y_hi, plot.y_min, plot.y_max,
                            std::clamp(static_cast<int>(plot_h / 55), 2, 10));
  double widest_y_label = 0;
  for (const auto& l : ya.labels)
    widest_y_label = std::max(widest_y_label, text_width_px(l, kTickFontPx));
  const double left =
      10 + (has_y_label ? kLabelFontPx + 10 : 0) + widest_y_label + 6 + kTickLengthPx;
  const double right = 24;
  const double plot_w = std::max(20.0, width - left - right);
  const Axis xa = make_axis(x_lo, x_hi, plot.x_min, plot.x_max,
                            std::clamp(static_cast<int>(plot_w / 90), 2, 10));

  const auto sx = [&](double x) { return left + xa.fraction(x) * plot_w; };
  const auto sy = [&](double y) { return top + plot_h - ya.fraction(y) * plot_h; };

  emit(out, R"(<rect x="0" y="0" width="{}" height="{}" fill="white"/>)", px(width), px(height));

  // Clip the data to the plot area; automatic sides get a little room so that strokes and
  // markers on the outermost tick are drawn whole.
  const double clip_x0 = left - (xa.fixed_lo ? 0 : kEdgePadPx);
  const double clip_x1 = left + plot_w + (xa.fixed_hi ? 0 : kEdgePadPx);
  const double clip_y0 = top - (ya.fixed_hi ? 0 : kEdgePadPx);
  const double clip_y1 = top + plot_h + (ya.fixed_lo ? 0 : kEdgePadPx);
  emit(
      out,
      R"(<defs><clipPath id="{}-clip"><rect x="{}" y="{}" width="{}" height="{}"/></clipPath></defs>)",
      id, px(clip_x0), px(clip_y0), px(clip_x1 - clip_x0), px(clip_y1 - clip_y0));

  // Grid.
  if (plot.show_grid) {
    emit(out, R"(<g stroke="#dddddd" stroke-width="1">)");
    for (double t : xa.ticks)
      emit(out, R"(<line x1="{0}" y1="{1}" x2="{0}" y2="{2}"/>)", px(sx(t)), px(top),
           px(top + plot_h));
    for (double t : ya.ticks)
      emit(out, R"(<line x1="{1}" y1="{0}" x2="{2}" y2="{0}"/>)", px(sy(t)), px(left),
           px(left + plot_w));
    emit(out, "</g>");
  }

  // Series: one path per series, a new sub-path after every non-finite point.
  const std::vector<std::string> colors = series_colors(plot);
  emit(out, R"~(<g clip-path="url(#{}-clip)">)~", id);
  for (std::size_t si = 0; si < plot.series.size(); ++si) {
    const PlotSeries& s = plot.series[si];
    if (s.line_width > 0) {
      std::string d;
      bool pen_down = false;
      for (std::size_t i = 0; i < s.x.size(); ++i) {
        if (!is_finite_point(s.x[i], s.y[i])) {
          pen_down = false;
          continue;
        }
        const std::string p = px(sx(s.x[i])) + " " + px(sy(s.y[i]));
        if (pen_down) {
          d += " L" + p;
        } else {
          // A lone point shows as a round dot thanks to the round line cap.
          const bool next_finite = i + 1 < s.x.size() && is_finite_point(s.x[i + 1], s.y[i + 1]);
          d += (d.empty() ? "M" : " M") + p + (next_finite ? "" : " h0.01");
          pen_down = true;
        }
      }
      if (!d.empty()) emit(out, R"(<path d="{}" {}/>)", d, stroke_attributes(s, colors[si]));
    }
    if (s.markers) {
      emit(out, R"(<g fill="{}">)", xml_escape(colors[si]));
      for (std::size_t i = 0; i < s.x.size(); ++i)
        if (is_finite_point(s.x[i], s.y[i]))
          emit(out, R"(<circle cx="{}" cy="{}" r="{}"/>)", px(sx(s.x[i])), px(sy(s.y[i])),
               px(marker_radius(s)));
      emit(out, "</g>");
    }
  }
  emit(out, "</g>");

  // Frame, ticks, tick labels.
  emit(
      out,
      R"(<rect x="{}" y="{}" width="{}" height="{}" fill="none" stroke="black" stroke-width="1"/>)",
      px(left), px(top), px(plot_w), px(plot_h));
  emit(out, R"(<g stroke="black" stroke-width="1">)");
  for (double t : xa.ticks)
    emit(out, R"(<line x1="{0}" y1="{1}" x2="{0}" y2="{2}"/>)", px(sx(t)), px(top + plot_h),
         px(top + plot_h + kTickLengthPx));
  for (double t : ya.ticks)
    emit(out, R"(<line x1="{1}" y1="{0}" x2="{2}" y2="{0}"/>)", px(sy(t)), px(left - kTickLengthPx),
         px(left));
  emit(out, "</g>");
  emit(out, R"(<g font-size="{}" fill="black">)", px(kTickFontPx));
  for (std::size_t i = 0; i < xa.ticks.size(); ++i)
    emit(out, R"(<text x="{}" y="{}" text-anchor="middle">{}</text>)", px(sx(xa.ticks[i])),
         px(top + plot_h + kTickLengthPx + 4 + kTickFontPx), xml_escape(xa.labels[i]));
  for (std::size_t i = 0; i < ya.ticks.size(); ++i)
    emit(out, R"(<text x="{}" y="{}" dy="0.35em" text-anchor="end">{}</text>)",
         px(left - kTickLengthPx - 4), px(sy(ya.ticks[i])), xml_escape(ya.labels[i]));
  emit(out, "</g>");

  // Axis labels and title.
  if (has_x_label)
    emit(out, R"(<text x="{}" y="{}" font-size="{}" text-anchor="middle">{}</text>)",
         px(left + 0.5 * plot_w),
         px(top + plot_h + kTickLengthPx + 6 + kTickFontPx + 8 + kLabelFontPx), px(kLabelFontPx),
         xml_escape(plot.x_label));
  if (has_y_label) {
    const double x = 10 + kLabelFontPx;
    const double y = top + 0.5 * plot_h;
    emit(
        out,
        R"~(<text x="{0}" y="{1}" font-size="{2}" text-anchor="middle" transform="rotate(-90 {0} {1})">{3}</text>)~",
        px(x), px(y), px(kLabelFontPx), xml_escape(plot.y_label));
  }
  if (has_title)
    emit(out,
         R"(<text x="{}" y="{}" font-size="{}" font-weight="bold" text-anchor="middle">{}</text>)",
         px(left + 0.5 * plot_w), px(14 + kTitleFontPx), px(kTitleFontPx), xml_escape(plot.title));

  // Legend.
  std::vector<std::size_t> entries;
  for (std::size_t i = 0; i < plot.series.size(); ++i)
    if (!plot.series[i].name.empty()) entries.push_back(i);
  if (entries.empty() || plot.legend == LegendPosition::None) return;
  constexpr double kPad = 8, kRowPx = 18, kSamplePx = 28, kGapPx = 6, kInsetPx = 8;
  double widest = 0;
  for (auto i : entries)
    widest = std::max(widest, text_width_px(plot.series[i].name, kLegendFontPx));
  const double box_w = kPad + kSamplePx + kGapPx + widest + kPad;
  const double box_h = 2 * (kPad / 2) + kRowPx * static_cast<double>(entries.size());
  const auto box_x = [&](LegendPosition pos) {
    const bool at_right = pos == LegendPosition::TopRight || pos == LegendPosition::BottomRight;
    return at_right ? left + plot_w - kInsetPx - box_w : left + kInsetPx;
  };
  const auto box_y = [&](LegendPosition pos) {
    const bool at_top = pos == LegendPosition::TopRight || pos == LegendPosition::TopLeft;
    return at_top ? top + kInsetPx : top + plot_h - kInsetPx - box_h;
  };
  LegendPosition position = plot.legend;
  if (position == LegendPosition::Best) {
    // Count the points, and samples every ~10 px along line segments, that each corner
    // would hide.
    constexpr LegendPosition kCorners[] = {LegendPosition::TopRight, LegendPosition::TopLeft,
                                           LegendPosition::BottomRight, LegendPosition::BottomLeft};
    std::size_t fewest = std::numeric_limits<std::size_t>::max();
    for (LegendPosition corner : kCorners) {
      const double x0 = box_x(corner), y0 = box_y(corner);
      const auto inside = [&](double u, double v) {
        return u >= x0 && u <= x0 + box_w && v >= y0 && v <= y0 + box_h;
      };
      std::size_t hidden = 0;
      for (const auto& s : plot.series)
        for (std::size_t i = 0; i < s.x.size(); ++i) {
          if (!is_finite_point(s.x[i], s.y[i])) continue;
          const double u0 = sx(s.x[i]), v0 = sy(s.y[i]);
          hidden += inside(u0, v0) ? 1 : 0;
          if (s.line_width <= 0 || i + 1 == s.x.size() || !is_finite_point(s.x[i + 1], s.y[i + 1]))
            continue;
          const double u1 = sx(s.x[i + 1]), v1 = sy(s.y[i + 1]);
          const double length = std::min(std::hypot(u1 - u0, v1 - v0), 4.0 * (plot_w + plot_h));
          const int samples = std::clamp(static_cast<int>(length / 10.0), 0, 200);
          for (int k = 1; k <= samples; ++k) {
            const double t = static_cast<double>(k) / (samples + 1);
            hidden += inside(u0 + t * (u1 - u0), v0 + t * (v1 - v0)) ? 1 : 0;
          }
        }
      if (hidden < fewest) {
        fewest = hidden;
        position = corner;
      }
    }
  }
  const double bx = box_x(position);
  const double by = box_y(position);
  emit(out, R"(<g font-size="{}">)", px(kLegendFontPx));
  emit(
      out,
      R"(<rect x="{}" y="{}" width="{}" height="{}" fill="white" fill-opacity="0.9" stroke="#999999" stroke-width="1"/>)",
      px(bx), px(by), px(box_w), px(box_h));
  for (std::size_t row = 0; row < entries.size(); ++row) {
    const PlotSeries& s = plot.series[entries[row]];
    const std::string& color = colors[entries[row]];
    const double cy = by + kPad / 2 + kRowPx * (static_cast<double>(row) + 0.5);
    const double x0 = bx + kPad, x1 = x0 + kSamplePx;
    if (s.line_width > 0)
      emit(out, R"(<path d="M{} {} H{}" {}/>)", px(x0), px(cy), px(x1),
           stroke_attributes(s, color));
    if (s.markers)
      emit(out, R"(<circle cx="{}" cy="{}" r="{}" fill="{}"/>)", px(0.5 * (x0 + x1)), px(cy),
           px(marker_radius(s)), xml_escape(color));
    emit(out, R"(<text x="{}" y="{}" dy="0.35em">{}</text>)", px(x1 + kGapPx), px(cy),
         xml_escape(s.name));
  }
  emit(out, "</g>");
}

void open_document(Out& out, double width, double height) {
  emit(out, R"(<?xml version="1.0" encoding="UTF-8" standalone="no"?>)");
  emit(
      out,
      R"(<svg xmlns="http://www.w3.org/2000/svg" version="1.1" width="{0}" height="{1}" viewBox="0 0 {0} {1}" font-family="{2}">)",
      px(width), px(height), kFontFamily);
}

}  // namespace

std::string xml_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20 && c != '\t' && c != '\n' && c != '\r') break;
        out += c;
    }
  }
  return out;
}

std::string render_svg(const Plot& plot) {
  validate_plot(plot, "render_svg");
  Out out;
  open_document(out, plot.width_px, plot.height_px);
  render_panel(out, plot, "p0");
  emit(out, "</svg>");
  return out;
}

void write_svg(const std::filesystem::path& path, const Plot& plot) {
  write_text_atomically(path, render_svg(plot));
}

std::string render_svg_grid(const std::vector<Plot>& panels, int columns) {
  require(!panels.empty(), "render_svg_grid: no panels (expected at least one plot)");
  require(columns >= 1, "render_svg_grid: columns = {} (expected >= 1)", columns);
  for (std::size_t i = 0; i < panels.size(); ++i)
    validate_plot(panels[i], fmt::format("render_svg_grid: panel {} ('{}')", i, panels[i].title));
  const int n = static_cast<int>(panels.size());
  const int cols = std::min(columns, n);
  const int rows = (n + cols - 1) / cols;
  int cell_w = 0, cell_h = 0;
  for (const auto& p : panels) {
    cell_w = std::max(cell_w, p.width_px);
    cell_h = std::max(cell_h, p.height_px);
  }
  Out out;
  open_document(out, static_cast<double>(cols) * cell_w, static_cast<double>(rows) * cell_h);
  emit(out, R"(<rect x="0" y="0" width="100%" height="100%" fill="white"/>)");
  for (int i = 0; i < n; ++i) {
    emit(out, R"~(<g transform="translate({} {})">)~", (i % cols) * cell_w, (i / cols) * cell_h);
    render_panel(out, panels[static_cast<std::size_t>(i)], fmt::format("p{}", i));
    emit(out, "</g>");
  }
  emit(out, "</svg>");
  return out;
}

void write_svg_grid(const std::filesystem::path& path, const std::vector<Plot>& panels,
                    int columns) {
  write_text_atomically(path, render_svg_grid(panels, columns));
}

}  // namespace socketsmith::report
