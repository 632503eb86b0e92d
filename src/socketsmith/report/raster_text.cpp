// Text on the software-rendered images (stb_easy_font, scaled, clipped, with a halo for labels),
// tick values and the colour bar (raster_detail.h says why this is apart from raster.cpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <string_view>

#include <fmt/format.h>
#include <stb/stb_easy_font.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/report/draw_2d.h"
#include "socketsmith/report/nice_number.h"
#include "socketsmith/report/raster.h"
#include "socketsmith/report/raster_detail.h"

namespace socketsmith::report {
using namespace raster_detail;
namespace {

constexpr int kBytesPerGlyph = 11 * 64;  // stb_easy_font: at most 11 quads of 64 bytes

/// stb_easy_font indexes its glyph table with (char - 32): anything outside printable ASCII
/// (UTF-8 bytes, tabs) would read outside the table, so it becomes '?'.
std::string printable(const std::string& text) {
  std::string out = text;
  for (char& c : out)
    if (c != '\n' && (c < 32 || c > 126)) c = '?';
  return out;
}

void draw_text_clipped(Image& img, int x, int y, const std::string& text, Rgb colour, int scale,
                       const Rect& clip) {
  std::string chars = printable(text);
  std::vector<unsigned char> quads(chars.size() * kBytesPerGlyph + 64);
  const int n = stb_easy_font_print(0, 0, chars.data(), nullptr, quads.data(), int(quads.size()));
  for (int q = 0; q < n; ++q) {
    // Each quad is an axis-aligned rectangle; vertex 0 and 2 are opposite corners.
    std::array<float, 2> a{}, b{};
    std::memcpy(a.data(), quads.data() + q * 64, sizeof(a));
    std::memcpy(b.data(), quads.data() + q * 64 + 32, sizeof(b));
    fill_rect(img,
              {x + scale * int(std::lround(a[0])), y + scale * int(std::lround(a[1])),
               x + scale * int(std::lround(b[0])), y + scale * int(std::lround(b[1]))},
              colour, clip);
  }
}

bool overlaps(const Rect& a, const Rect& b) { return a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1; }

/// Where a marker's label goes: right of its disc at its height, else left (when the right
/// leaves @p viewport); where that covers a disc or a label already placed (@p placed) — landmarks a few
/// millimetres apart, such as a transfemoral socket's ischial tuberosity, ramus, adductor longus
/// and Scarpa's triangle under the medial brim — the first free row above or below, on the same
/// side; the first choice when no row within six is free.
Rect label_place(double qx, double qy, double radius_px, int width, int height, const Rect& viewport,
                 const std::vector<Rect>& placed) {
  const int gap = int(std::lround(radius_px)) + 4, cx = int(std::lround(qx));
  const int x = cx + gap + width <= viewport.x1 ? cx + gap : cx - gap - width;
  const int y = int(std::lround(qy)) - height / 2, row = height + 2;
  const Rect first{x, y, x + width, y + height};
  for (int k = 0; k <= 12; ++k) {
    const int dy = (k % 2 == 1 ? 1 : -1) * ((k + 1) / 2) * row;  // 0, +1, −1, +2, −2, … rows
    const Rect r{x, y + dy, x + width, y + dy + height};
    if (r.y0 < viewport.y0 || r.y1 > viewport.y1) continue;
    if (std::none_of(placed.begin(), placed.end(), [&](const Rect& p) { return overlaps(p, r); })) return r;
  }
  return first;
}

}  // namespace

void raster_detail::draw_label(Image& img, int x, int y, const std::string& text, int scale, const Rect& clip) {
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
      if (dx != 0 || dy != 0) draw_text_clipped(img, x + dx, y + dy, text, kWhite, scale, clip);
  draw_text_clipped(img, x, y, text, kInk, scale, clip);
}

void raster_detail::draw_marker_labels(Image& img, const std::vector<MarkerSpot>& spots, const Rect& viewport) {
  constexpr int kScale = 2;
  std::vector<Rect> placed;  // the discs, then each label drawn
  for (const auto& s : spots) {
    const int r = int(std::ceil(s.marker->radius_px));
    const int x = int(std::lround(s.x)), y = int(std::lround(s.y));
    placed.push_back({x - r, y - r, x + r + 1, y + r + 1});
  }
  for (const auto& s : spots) {
    if (s.marker->label.empty()) continue;
    const int width = text_width(s.marker->label, kScale), height = 8 * kScale;
    const Rect r = label_place(s.x, s.y, s.marker->radius_px, width, height, viewport, placed);
    placed.push_back(r);
    const double mid = 0.5 * (r.y0 + r.y1);
    if (std::abs(mid - s.y) > 0.5 * height) {  // moved off its disc's height: a leader to it
      const double side = r.x0 > s.x ? r.x0 - 1.0 : r.x1 + 1.0;
      draw2d::stroke_segment(img, {s.x, s.y}, {side, mid}, 1.0, kInk);
    }
    draw_label(img, r.x0, r.y0, s.marker->label, kScale, viewport);
  }
}

std::vector<std::pair<double, std::string>> raster_detail::nice_ticks(double vmin, double vmax) {
  const double step = nice_ceil((vmax - vmin) / 5, NiceMantissas::OneTwoFive);
  const int decimals = std::max(0, -int(std::floor(std::log10(step) + 1e-9)));
  std::vector<std::pair<double, std::string>> ticks;
  for (auto k = static_cast<long long>(std::ceil(vmin / step - 1e-9));
       k * step <= vmax + 1e-9 * step; ++k) {
    const double v = double(k) * step;
    ticks.emplace_back(v, fmt::format("{:.{}f}", v, decimals));
  }
  return ticks;
}

std::string to_ascii(std::string_view text) {
  static const std::pair<std::string_view, std::string_view> kMap[] = {
      {"·", "."}, {"μ", "u"}, {"µ", "u"}, {"θ", "theta"}, {"°", "deg"}, {"≥", ">="},
      {"≤", "<="}, {"²", "^2"}, {"³", "^3"}, {"×", "x"}, {"−", "-"}, {"Δ", "d"},
      {"ρ", "rho"}, {"λ", "lambda"}, {"±", "+/-"}, {"…", "..."}, {"–", "-"}, {"—", "-"}, {"ν", "nu"}, {"ε", "eps"},
      {"σ", "sigma"}, {"≈", "~"}};
  std::string out;
  for (std::size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c < 0x80) {
      out += text[i++];
      continue;
    }
    bool mapped = false;
    for (const auto& [from, to] : kMap)
      if (text.substr(i, from.size()) == from) {
        out += to;
        i += from.size();
        mapped = true;
        break;
      }
    if (mapped) continue;
    // Skip one UTF-8 sequence (lead byte + continuation bytes).
    ++i;
    while (i < text.size() && (static_cast<unsigned char>(text[i]) & 0xC0) == 0x80) ++i;
    out += '?';
  }
  return out;
}

int text_width(const std::string& text, int scale) {
  std::string chars = printable(text);
  return scale * stb_easy_font_width(chars.data());
}

int text_height(const std::string& text, int scale) {
  std::string chars = printable(text);
  return scale * stb_easy_font_height(chars.data());
}

void draw_text(Image& img, int x, int y, const std::string& text, Rgb colour, int scale) {
  require_consistent(img, "draw_text");
  require(scale >= 1 && scale <= 16, "draw_text: scale {} (expected 1..16)", scale);
  draw_text_clipped(img, x, y, text, colour, scale, {0, 0, img.width, img.height});
}

void draw_colour_bar(Image& img, int x, int y, int w, int h, Colormap colormap, double vmin,
                     double vmax, const std::string& unit_label) {
  require_consistent(img, "draw_colour_bar");
  require(x >= 0 && y >= 0 && w >= 2 && h >= 8 && x + w <= img.width && y + h <= img.height,
          "draw_colour_bar: bar at ({}, {}) of {}×{} px is not inside the {}×{} image (or is "
          "smaller than 2×8)",
          x, y, w, h, img.width, img.height);
  require(std::isfinite(vmin) && std::isfinite(vmax) && vmin < vmax,
          "draw_colour_bar: value range [{}, {}] (expected finite vmin < vmax)", vmin, vmax);
  const Rect all{0, 0, img.width, img.height};
  fill_rect(img, {x - 1, y - 1, x + w + 1, y + h + 1}, kInk, all);
  for (int j = 0; j < h; ++j)
    fill_rect(img, {x, y + j, x + w, y + j + 1}, colormap_colour(colormap, 1 - (j + 0.5) / h), all);
  constexpr int kScale = 2;
  for (const auto& [value, label] : nice_ticks(vmin, vmax)) {
    const int ty = y + int(std::lround((1 - (value - vmin) / (vmax - vmin)) * (h - 1)));
    fill_rect(img, {x + w, ty, x + w + 5, ty + 1}, kInk, all);
    draw_text_clipped(img, x + w + 8, ty - 4 * kScale, label, kInk, kScale, all);
  }
  draw_text_clipped(img, x, y - kUnitLabelRows * kScale, unit_label, kInk, kScale, all);
}

}  // namespace socketsmith::report
