#include "plots.h"
#include "fonts.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string_view>
#include <tuple>
#include <utility>

#include <fmt/format.h>

namespace socketsmith::gui {

ImU32 colormap_u32(report::Colormap colormap, double t, float alpha) {
  const auto c = report::colormap_colour(colormap, t);
  return IM_COL32(c.r, c.g, c.b, static_cast<int>(255 * alpha));
}

namespace {
ImU32 rgb_u32(report::Rgb c) { return IM_COL32(c.r, c.g, c.b, 255); }
}  // namespace

void radar_chart(const std::vector<report::RadarAxis>& axes, float size) {
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 p0 = ImGui::GetCursorScreenPos();
  ImGui::InvisibleButton("##radar", ImVec2(size, size));
  dl->AddRectFilled(p0, ImVec2(p0.x + size, p0.y + size), IM_COL32(255, 255, 255, 255));
  if (axes.empty()) return;
  const ImVec2 c(p0.x + 0.5f * size, p0.y + 0.5f * size);
  const float unit = 0.33f * size / static_cast<float>(report::kRadarMaxRadius);  // px per normalised radius
  const int n = static_cast<int>(axes.size());
  const auto dir = [&](int k) {
    const double a = -std::numbers::pi / 2 + 2 * std::numbers::pi * k / n;  // clockwise from the top
    return ImVec2(static_cast<float>(std::cos(a)), static_cast<float>(std::sin(a)));
  };
  for (double r : {0.5, 1.5, 2.0})
    dl->AddCircle(c, unit * static_cast<float>(r), IM_COL32(200, 200, 200, 255), 64, 1.0f);
  dl->AddCircle(c, unit, IM_COL32(30, 50, 150, 255), 64, 2.5f);
  std::vector<ImVec2> pts;
  std::vector<bool> clamped;
  for (int k = 0; k < n; ++k) {
    const auto& a = axes[k];
    const ImVec2 d = dir(k);
    const float rmax = unit * static_cast<float>(report::kRadarMaxRadius);
    dl->AddLine(c, ImVec2(c.x + d.x * rmax, c.y + d.y * rmax), IM_COL32(170, 170, 170, 255), 1.0f);
    // Tolerance band ticks across the axis.
    const auto tick = [&](double value) {
      const float r = unit * static_cast<float>(std::clamp(1 + (value - a.target) / a.scale, 0.0, report::kRadarMaxRadius));
      const ImVec2 q(c.x + d.x * r, c.y + d.y * r), perp(-d.y * 4, d.x * 4);
      dl->AddLine(ImVec2(q.x - perp.x, q.y - perp.y), ImVec2(q.x + perp.x, q.y + perp.y), IM_COL32(90, 90, 90, 255), 1.5f);
    };
    tick(a.is_lower_bound ? a.target : a.target - a.tolerance);
    if (!a.is_lower_bound) tick(a.target + a.tolerance);
    const double r = 1 + (a.value - a.target) / a.scale;
    clamped.push_back(r < 0 || r > report::kRadarMaxRadius || !std::isfinite(r));
    const float rc = unit * static_cast<float>(std::isfinite(r) ? std::clamp(r, 0.0, report::kRadarMaxRadius) : 0.0);
    pts.push_back(ImVec2(c.x + d.x * rc, c.y + d.y * rc));
  }
  for (int k = 0; k < n; ++k)  // the polygon is star-shaped about the centre: a fan fills it
    dl->AddTriangleFilled(c, pts[k], pts[(k + 1) % n], IM_COL32(70, 110, 200, 50));
  dl->AddPolyline(pts.data(), n, IM_COL32(50, 80, 170, 255), ImDrawFlags_Closed, 2.0f);
  for (int k = 0; k < n; ++k) {
    const auto& a = axes[k];
    const ImU32 col = rgb_u32(a.is_ok ? report::kRadarOkColour : report::kRadarFailColour);
    if (clamped[k]) dl->AddCircle(pts[k], 5.0f, col, 12, 2.0f);
    else dl->AddCircleFilled(pts[k], 5.0f, col);
    const ImVec2 d = dir(k);
    const float rl = unit * static_cast<float>(report::kRadarMaxRadius) + 10;
    const std::string text = fmt::format("{}\n{:.1f} {}", a.name, a.value, a.unit);
    const ImVec2 ts = ImGui::CalcTextSize(text.c_str());
    ImVec2 q(c.x + d.x * rl, c.y + d.y * rl);
    q.x -= ts.x * 0.5f * (1 - d.x);
    q.y -= ts.y * 0.5f * (1 - d.y);
    dl->AddText(q, col, text.c_str());
  }
}

void profile_plot(const report::PathProfile& profile, ImVec2 size) {
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 p0 = ImGui::GetCursorScreenPos();
  ImGui::InvisibleButton(("##" + profile.name).c_str(), size);
  dl->AddRectFilled(p0, ImVec2(p0.x + size.x, p0.y + size.y), IM_COL32(255, 255, 255, 255));
  dl->AddRect(p0, ImVec2(p0.x + size.x, p0.y + size.y), IM_COL32(160, 160, 160, 255));
  double smin = profile.s_min, smax = profile.s_max, ymax = 1;
  if (smax <= smin && !profile.s.empty()) {
    smin = *std::min_element(profile.s.begin(), profile.s.end());
    smax = *std::max_element(profile.s.begin(), profile.s.end());
  }
  if (smax <= smin) smax = smin + 1;
  for (double v : profile.pressure_kpa)
    if (std::isfinite(v)) ymax = std::max(ymax, v);
  for (double v : profile.threshold_kpa)
    if (std::isfinite(v)) ymax = std::max(ymax, v);
  ymax *= 1.1;
  const float left = 34, bottom = 16, top = 16;
  const auto map = [&](double s, double v) {
    return ImVec2(p0.x + left + static_cast<float>((s - smin) / (smax - smin)) * (size.x - left - 4),
                  p0.y + size.y - bottom - static_cast<float>(v / ymax) * (size.y - bottom - top));
  };
  const auto series = [&](const std::vector<double>& v, ImU32 col, bool dashed) {
    std::vector<ImVec2> run;
    const auto flush = [&] {
      if (run.size() >= 2) {
        if (!dashed) dl->AddPolyline(run.data(), static_cast<int>(run.size()), col, 0, 2.0f);
        else
          for (size_t k = 0; k + 1 < run.size(); k += 2) dl->AddLine(run[k], run[k + 1], col, 1.5f);
      }
      run.clear();
    };
    for (size_t k = 0; k < v.size() && k < profile.s.size(); ++k) {
      if (std::isfinite(v[k])) run.push_back(map(profile.s[k], v[k]));
      else flush();
    }
    flush();
  };
  series(profile.threshold_kpa, IM_COL32(210, 40, 40, 255), true);
  series(profile.pressure_kpa, IM_COL32(40, 80, 200, 255), false);
  dl->AddText(ImVec2(p0.x + 4, p0.y + 1), IM_COL32(30, 30, 30, 255), profile.name.c_str());
  dl->AddText(ImVec2(p0.x + 2, p0.y + top), IM_COL32(90, 90, 90, 255), fmt::format("{:.0f}", ymax).c_str());
  dl->AddText(ImVec2(p0.x + 2, p0.y + size.y - bottom - 14), IM_COL32(90, 90, 90, 255), "kPa");
  const std::string xr = fmt::format("{:.0f} .. {:.0f} {}", smin, smax,
                                     profile.s_label.find("deg") != std::string::npos ? "deg" : "mm");
  dl->AddText(ImVec2(p0.x + left, p0.y + size.y - bottom + 1), IM_COL32(90, 90, 90, 255), xr.c_str());
}

void colour_bar(ImDrawList* dl, ImVec2 pos, ImVec2 size, report::Colormap colormap, double vmin, double vmax,
                const std::string& unit) {
  const int steps = 32;
  for (int k = 0; k < steps; ++k) {
    const float y0 = pos.y + size.y * (1 - static_cast<float>(k + 1) / steps);
    const float y1 = pos.y + size.y * (1 - static_cast<float>(k) / steps);
    const ImU32 lo = colormap_u32(colormap, static_cast<double>(k) / steps);
    const ImU32 hi = colormap_u32(colormap, static_cast<double>(k + 1) / steps);
    dl->AddRectFilledMultiColor(ImVec2(pos.x, y0), ImVec2(pos.x + size.x, y1), hi, hi, lo, lo);
  }
  dl->AddRect(pos, ImVec2(pos.x + size.x, pos.y + size.y), IM_COL32(40, 40, 40, 255));
  for (int k = 0; k <= 4; ++k) {
    const double v = vmin + (vmax - vmin) * k / 4.0;
    const float y = pos.y + size.y * (1 - static_cast<float>(k) / 4);
    dl->AddLine(ImVec2(pos.x + size.x, y), ImVec2(pos.x + size.x + 4, y), IM_COL32(40, 40, 40, 255));
    const std::string t = std::abs(vmax - vmin) < 10 ? fmt::format("{:.2f}", v) : fmt::format("{:.0f}", v);
    dl->AddText(ImVec2(pos.x + size.x + 6, y - 7), IM_COL32(20, 20, 20, 255), t.c_str());
  }
  dl->AddText(ImVec2(pos.x - 4, pos.y - 20), IM_COL32(20, 20, 20, 255), unit.c_str());
}

std::string shown_text(std::string text) {
  static const std::tuple<char32_t, std::string_view, std::string_view> kAscii[] = {
      {U'→', "→", "->"}, {U'≤', "≤", "<="}, {U'≥', "≥", ">="}, {U'−', "−", "-"}};
  for (const auto& [code_point, symbol, ascii] : kAscii)
    if (!draws(code_point))
      for (size_t k = text.find(symbol); k != std::string::npos; k = text.find(symbol, k + ascii.size()))
        text.replace(k, symbol.size(), ascii);
  return text;
}

}  // namespace socketsmith::gui
