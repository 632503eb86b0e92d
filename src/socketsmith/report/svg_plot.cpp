#include "socketsmith/report/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <iterator>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/report/plot_layout.h"

namespace socketsmith::report {
namespace {

constexpr double kTickFontPx = 12;
constexpr double kLabelFontPx = 14;
constexpr double kTitleFontPx = 16;
constexpr double kLegendFontPx = 12;
constexpr double kCharWidthEm = 0.6;  // average glyph width of Helvetica/Arial, a safe estimate
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

double font_px(PlotText kind) {
  switch (kind) {
    case PlotText::Tick:
      return kTickFontPx;
    case PlotText::Label:
      return kLabelFontPx;
    case PlotText::Title:
      return kTitleFontPx;
    case PlotText::Legend:
      break;
  }
  return kLegendFontPx;
}

/// Text measured with an average glyph width (the viewer's font is not known here).
PlotTextMetrics svg_metrics() {
  PlotTextMetrics m;
  m.tick_px = kTickFontPx;
  m.label_px = kLabelFontPx;
  m.title_px = kTitleFontPx;
  m.legend_px = kLegendFontPx;
  m.width_px = [](std::string_view text, PlotText kind) {
    // Count UTF-8 code points, not bytes.
    std::size_t n = 0;
    for (unsigned char c : text)
      if ((c & 0xC0) != 0x80) ++n;
    return static_cast<double>(n) * font_px(kind) * kCharWidthEm;
  };
  return m;
}

std::string dash_array(const PlotSeries& s) {
  const auto [dash, gap] = dash_pattern(s);
  return px(dash) + "," + px(gap);
}

/// Stroke attributes shared by a series' line and its legend sample.
std::string stroke_attributes(const PlotSeries& s, const std::string& color) {
  std::string a = fmt::format(
      R"(fill="none" stroke="{}" stroke-width="{}" stroke-linejoin="round" stroke-linecap="round")",
      xml_escape(color), px(s.line_width));
  if (s.dashed) a += fmt::format(R"( stroke-dasharray="{}")", dash_array(s));
  return a;
}

/// The background and the plot area's clip path.
void emit_background(Out& out, const PlotLayout& l, const std::string& id) {
  emit(out, R"(<rect x="0" y="0" width="{}" height="{}" fill="white"/>)", px(l.width),
       px(l.height));
  emit(
      out,
      R"(<defs><clipPath id="{}-clip"><rect x="{}" y="{}" width="{}" height="{}"/></clipPath></defs>)",
      id, px(l.clip_x0), px(l.clip_y0), px(l.clip_x1 - l.clip_x0), px(l.clip_y1 - l.clip_y0));
}

/// The grid lines at the ticks.
void emit_grid(Out& out, const PlotLayout& l) {
  const double left = l.left, top = l.top, plot_w = l.plot_w, plot_h = l.plot_h;
  emit(out, R"(<g stroke="#dddddd" stroke-width="1">)");
  for (double t : l.x.ticks)
    emit(out, R"(<line x1="{0}" y1="{1}" x2="{0}" y2="{2}"/>)", px(l.to_px_x(t)), px(top),
         px(top + plot_h));
  for (double t : l.y.ticks)
    emit(out, R"(<line x1="{1}" y1="{0}" x2="{2}" y2="{0}"/>)", px(l.to_px_y(t)), px(left),
         px(left + plot_w));
  emit(out, "</g>");
}

/// A series' path data: a new sub-path after every non-finite point.
std::string series_path(const PlotSeries& s, const PlotLayout& l) {
  std::string d;
  bool pen_down = false;
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!is_finite_point(s.x[i], s.y[i])) {
      pen_down = false;
      continue;
    }
    const std::string p = px(l.to_px_x(s.x[i])) + " " + px(l.to_px_y(s.y[i]));
    if (pen_down) {
      d += " L" + p;
    } else {
      // A lone point shows as a round dot thanks to the round line cap.
      const bool next_finite = i + 1 < s.x.size() && is_finite_point(s.x[i + 1], s.y[i + 1]);
      d += (d.empty() ? "M" : " M") + p + (next_finite ? "" : " h0.01");
      pen_down = true;
    }
  }
  return d;
}

/// Series: one path per series and its markers, clipped to the plot area.
void emit_series(Out& out, const Plot& plot, const PlotLayout& l, const std::string& id) {
  emit(out, R"~(<g clip-path="url(#{}-clip)">)~", id);
  for (std::size_t si = 0; si < plot.series.size(); ++si) {
    const PlotSeries& s = plot.series[si];
    if (s.line_width > 0) {
      const std::string d = series_path(s, l);
      if (!d.empty()) emit(out, R"(<path d="{}" {}/>)", d, stroke_attributes(s, l.colors[si]));
    }
    if (s.markers) {
      emit(out, R"(<g fill="{}">)", xml_escape(l.colors[si]));
      for (std::size_t i = 0; i < s.x.size(); ++i)
        if (is_finite_point(s.x[i], s.y[i]))
          emit(out, R"(<circle cx="{}" cy="{}" r="{}"/>)", px(l.to_px_x(s.x[i])), px(l.to_px_y(s.y[i])),
               px(marker_radius(s)));
      emit(out, "</g>");
    }
  }
  emit(out, "</g>");
}

/// The frame, the ticks and the tick labels.
void emit_axes(Out& out, const PlotLayout& l) {
  const double left = l.left, top = l.top, plot_w = l.plot_w, plot_h = l.plot_h;
  const double tick = l.tick_length_px;
  emit(
      out,
      R"(<rect x="{}" y="{}" width="{}" height="{}" fill="none" stroke="black" stroke-width="1"/>)",
      px(left), px(top), px(plot_w), px(plot_h));
  emit(out, R"(<g stroke="black" stroke-width="1">)");
  for (double t : l.x.ticks)
    emit(out, R"(<line x1="{0}" y1="{1}" x2="{0}" y2="{2}"/>)", px(l.to_px_x(t)), px(top + plot_h),
         px(top + plot_h + tick));
  for (double t : l.y.ticks)
    emit(out, R"(<line x1="{1}" y1="{0}" x2="{2}" y2="{0}"/>)", px(l.to_px_y(t)), px(left - tick),
         px(left));
  emit(out, "</g>");
  emit(out, R"(<g font-size="{}" fill="black">)", px(kTickFontPx));
  for (std::size_t i = 0; i < l.x.ticks.size(); ++i)
    emit(out, R"(<text x="{}" y="{}" text-anchor="middle">{}</text>)", px(l.to_px_x(l.x.ticks[i])),
         px(top + plot_h + tick + 4 + kTickFontPx), xml_escape(l.x.labels[i]));
  for (std::size_t i = 0; i < l.y.ticks.size(); ++i)
    emit(out, R"(<text x="{}" y="{}" dy="0.35em" text-anchor="end">{}</text>)",
         px(left - tick - 4), px(l.to_px_y(l.y.ticks[i])), xml_escape(l.y.labels[i]));
  emit(out, "</g>");
}

/// The axis labels and the title.
void emit_titles(Out& out, const Plot& plot, const PlotLayout& l) {
  const double left = l.left, top = l.top, plot_w = l.plot_w, plot_h = l.plot_h;
  const double tick = l.tick_length_px;
  if (!plot.x_label.empty())
    emit(out, R"(<text x="{}" y="{}" font-size="{}" text-anchor="middle">{}</text>)",
         px(left + 0.5 * plot_w), px(top + plot_h + tick + 6 + kTickFontPx + 8 + kLabelFontPx),
         px(kLabelFontPx), xml_escape(plot.x_label));
  if (!plot.y_label.empty()) {
    const double x = 10 + kLabelFontPx;
    const double y = top + 0.5 * plot_h;
    emit(
        out,
        R"~(<text x="{0}" y="{1}" font-size="{2}" text-anchor="middle" transform="rotate(-90 {0} {1})">{3}</text>)~",
        px(x), px(y), px(kLabelFontPx), xml_escape(plot.y_label));
  }
  if (!plot.title.empty())
    emit(out,
         R"(<text x="{}" y="{}" font-size="{}" font-weight="bold" text-anchor="middle">{}</text>)",
         px(left + 0.5 * plot_w), px(14 + kTitleFontPx), px(kTitleFontPx), xml_escape(plot.title));
}

/// The legend: a box with each named series' sample and name.
void emit_legend(Out& out, const Plot& plot, const PlotLayout& l) {
  emit(out, R"(<g font-size="{}">)", px(kLegendFontPx));
  emit(
      out,
      R"(<rect x="{}" y="{}" width="{}" height="{}" fill="white" fill-opacity="0.9" stroke="#999999" stroke-width="1"/>)",
      px(l.legend_x), px(l.legend_y), px(l.legend_w), px(l.legend_h));
  for (std::size_t row = 0; row < l.legend_entries.size(); ++row) {
    const PlotSeries& s = plot.series[l.legend_entries[row]];
    const std::string& color = l.colors[l.legend_entries[row]];
    const double cy = l.legend_row_y(row);
    const double x0 = l.legend_x + l.legend_pad_px, x1 = x0 + l.legend_sample_px;
    if (s.line_width > 0)
      emit(out, R"(<path d="M{} {} H{}" {}/>)", px(x0), px(cy), px(x1),
           stroke_attributes(s, color));
    if (s.markers)
      emit(out, R"(<circle cx="{}" cy="{}" r="{}" fill="{}"/>)", px(0.5 * (x0 + x1)), px(cy),
           px(marker_radius(s)), xml_escape(color));
    emit(out, R"(<text x="{}" y="{}" dy="0.35em">{}</text>)", px(x1 + l.legend_gap_px), px(cy),
         xml_escape(s.name));
  }
  emit(out, "</g>");
}

/// Writes one plot's elements (no <svg> wrapper) in a local frame [0, width]×[0, height].
/// @p id makes clip-path ids unique within a document.
void render_panel(Out& out, const Plot& plot, const std::string& id) {
  const PlotLayout l = layout_plot(plot, svg_metrics());
  emit_background(out, l, id);
  if (plot.show_grid) emit_grid(out, l);
  emit_series(out, plot, l, id);
  emit_axes(out, l);
  emit_titles(out, plot, l);
  if (!l.legend_entries.empty()) emit_legend(out, plot, l);
}

void open_document(Out& out, double width, double height) {
  emit(out, R"(<?xml version="1.0" encoding="UTF-8" standalone="no"?>)");
  emit(
      out,
      R"(<svg xmlns="http://www.w3.org/2000/svg" version="1.1" width="{0}" height="{1}" viewBox="0 0 {0} {1}" font-family="{2}">)",
      px(width), px(height), kFontFamily);
}

}  // namespace

std::string escape_markup(std::string_view text, std::string_view apostrophe, bool drop_controls) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += apostrophe; break;
      default:
        if (drop_controls && static_cast<unsigned char>(c) < 0x20 && c != '\t' && c != '\n' && c != '\r') break;
        out += c;
    }
  }
  return out;
}

std::string xml_escape(std::string_view text) { return escape_markup(text, "&apos;", true); }

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
  const PlotGrid g = layout_plot_grid(panels, columns, "render_svg_grid");
  const int n = static_cast<int>(panels.size());
  const int cols = g.columns, rows = g.rows, cell_w = g.cell_w, cell_h = g.cell_h;
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
