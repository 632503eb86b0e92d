#include "socketsmith/report/plot_layout.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <optional>
#include <tuple>

#include "socketsmith/core/errors.h"
#include "socketsmith/report/nice_number.h"

namespace socketsmith::report {
namespace {

// Okabe–Ito palette (distinguishable with colour-vision deficiencies), yellow left out because
// it is too light on white.
constexpr const char* kPalette[] = {"#0072B2", "#D55E00", "#009E73", "#CC79A7",
                                    "#E69F00", "#56B4E9", "#000000"};
constexpr int kPaletteSize = static_cast<int>(std::size(kPalette));

constexpr double kTickLengthPx = 5;
constexpr double kEdgePadPx = 6;  // room for strokes and markers at automatic axis limits
constexpr double kLegendInsetPx = 8;

/// 1, 2 or 5 × 10^k closest above @p raw; 1 when there is no finite positive step.
double nice_step(double raw) {
  if (!(raw > 0) || !std::isfinite(raw)) return 1.0;
  return nice_ceil(raw, NiceMantissas::OneTwoFive);
}

/// Axis limits and ticks from the finite data range [data_lo, data_hi] (empty when
/// data_lo > data_hi) and the optional user limits.
PlotAxis make_axis(double data_lo, double data_hi, std::optional<double> user_lo,
                   std::optional<double> user_hi, int target_ticks) {
  PlotAxis a;
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

/// Top-left corner [px] of the legend box at @p corner of the plot area.
std::pair<double, double> legend_origin(const PlotLayout& l, LegendPosition corner) {
  const bool at_right = corner == LegendPosition::TopRight || corner == LegendPosition::BottomRight;
  const bool at_top = corner == LegendPosition::TopRight || corner == LegendPosition::TopLeft;
  return {at_right ? l.left + l.plot_w - kLegendInsetPx - l.legend_w : l.left + kLegendInsetPx,
          at_top ? l.top + kLegendInsetPx : l.top + l.plot_h - kLegendInsetPx - l.legend_h};
}

/// The corner of the plot area whose legend box hides the fewest points, and samples every
/// ~10 px along line segments (top right on a tie).
LegendPosition best_legend_corner(const Plot& plot, const PlotLayout& l) {
  constexpr LegendPosition kCorners[] = {LegendPosition::TopRight, LegendPosition::TopLeft,
                                         LegendPosition::BottomRight, LegendPosition::BottomLeft};
  LegendPosition best = LegendPosition::TopRight;
  std::size_t fewest = std::numeric_limits<std::size_t>::max();
  for (LegendPosition corner : kCorners) {
    // Plain variables, not a structured binding: clang 14 (the fuzz and sanitizer builds) cannot
    // capture a binding in a lambda.
    const auto origin = legend_origin(l, corner);
    const double x0 = origin.first, y0 = origin.second;
    const auto inside = [&](double u, double v) {
      return u >= x0 && u <= x0 + l.legend_w && v >= y0 && v <= y0 + l.legend_h;
    };
    std::size_t hidden = 0;
    for (const auto& s : plot.series)
      for (std::size_t i = 0; i < s.x.size(); ++i) {
        if (!is_finite_point(s.x[i], s.y[i])) continue;
        const double u0 = l.to_px_x(s.x[i]), v0 = l.to_px_y(s.y[i]);
        hidden += inside(u0, v0) ? 1 : 0;
        if (s.line_width <= 0 || i + 1 == s.x.size() || !is_finite_point(s.x[i + 1], s.y[i + 1]))
          continue;
        const double u1 = l.to_px_x(s.x[i + 1]), v1 = l.to_px_y(s.y[i + 1]);
        const double length = std::min(std::hypot(u1 - u0, v1 - v0), 4.0 * (l.plot_w + l.plot_h));
        const int samples = std::clamp(static_cast<int>(length / 10.0), 0, 200);
        for (int k = 1; k <= samples; ++k) {
          const double t = static_cast<double>(k) / (samples + 1);
          hidden += inside(u0 + t * (u1 - u0), v0 + t * (v1 - v0)) ? 1 : 0;
        }
      }
    if (hidden < fewest) {
      fewest = hidden;
      best = corner;
    }
  }
  return best;
}

}  // namespace

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

PlotLayout layout_plot(const Plot& plot, const PlotTextMetrics& metrics) {
  PlotLayout l;
  l.width = plot.width_px;
  l.height = plot.height_px;
  l.tick_length_px = kTickLengthPx;

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
  l.top = !plot.title.empty() ? 14 + metrics.title_px + 12 : 16;
  const double bottom = kTickLengthPx + 6 + metrics.tick_px +
                        (!plot.x_label.empty() ? 10 + metrics.label_px : 0) + 12;
  l.plot_h = std::max(20.0, l.height - l.top - bottom);
  l.y = make_axis(y_lo, y_hi, plot.y_min, plot.y_max,
                  std::clamp(static_cast<int>(l.plot_h / 55), 2, 10));
  double widest_y_label = 0;
  for (const auto& label : l.y.labels)
    widest_y_label = std::max(widest_y_label, metrics.width_px(label, PlotText::Tick));
  l.left = 10 + (!plot.y_label.empty() ? metrics.label_px + 10 : 0) + widest_y_label + 6 +
           kTickLengthPx;
  const double right = 24;
  l.plot_w = std::max(20.0, l.width - l.left - right);
  l.x = make_axis(x_lo, x_hi, plot.x_min, plot.x_max,
                  std::clamp(static_cast<int>(l.plot_w / 90), 2, 10));

  // Clip the data to the plot area; automatic sides get a little room so that strokes and
  // markers on the outermost tick are drawn whole.
  l.clip_x0 = l.left - (l.x.fixed_lo ? 0 : kEdgePadPx);
  l.clip_x1 = l.left + l.plot_w + (l.x.fixed_hi ? 0 : kEdgePadPx);
  l.clip_y0 = l.top - (l.y.fixed_hi ? 0 : kEdgePadPx);
  l.clip_y1 = l.top + l.plot_h + (l.y.fixed_lo ? 0 : kEdgePadPx);

  int next = 0;
  for (const auto& s : plot.series)
    l.colors.push_back(!s.color.empty() ? s.color : kPalette[next++ % kPaletteSize]);

  // Legend.
  if (plot.legend == LegendPosition::None) return l;
  for (std::size_t i = 0; i < plot.series.size(); ++i)
    if (!plot.series[i].name.empty()) l.legend_entries.push_back(i);
  if (l.legend_entries.empty()) return l;
  l.legend_row_px = std::max(18.0, metrics.legend_px + 6);
  double widest = 0;
  for (auto i : l.legend_entries)
    widest = std::max(widest, metrics.width_px(plot.series[i].name, PlotText::Legend));
  l.legend_w = l.legend_pad_px + l.legend_sample_px + l.legend_gap_px + widest + l.legend_pad_px;
  l.legend_h = l.legend_pad_px + l.legend_row_px * static_cast<double>(l.legend_entries.size());
  const LegendPosition position =
      plot.legend == LegendPosition::Best ? best_legend_corner(plot, l) : plot.legend;
  std::tie(l.legend_x, l.legend_y) = legend_origin(l, position);
  return l;
}

PlotGrid layout_plot_grid(const std::vector<Plot>& panels, int columns, std::string_view where) {
  require(!panels.empty(), "{}: no panels (expected at least one plot)", where);
  require(columns >= 1, "{}: columns = {} (expected >= 1)", where, columns);
  for (std::size_t i = 0; i < panels.size(); ++i)
    validate_plot(panels[i], fmt::format("{}: panel {} ('{}')", where, i, panels[i].title));
  const int n = static_cast<int>(panels.size());
  PlotGrid g;
  g.columns = std::min(columns, n);
  g.rows = (n + g.columns - 1) / g.columns;
  for (const auto& p : panels) {
    g.cell_w = std::max(g.cell_w, p.width_px);
    g.cell_h = std::max(g.cell_h, p.height_px);
  }
  return g;
}

double marker_radius(const PlotSeries& series) { return std::max(2.5, 1.5 * series.line_width); }

std::pair<double, double> dash_pattern(const PlotSeries& series) {
  const double w = std::max(series.line_width, 1.0);
  return {3.0 * w + 2.0, 2.0 * w + 2.0};
}

}  // namespace socketsmith::report
