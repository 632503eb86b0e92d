#include "socketsmith/report/draw_2d.h"

#include <cstdint>

namespace socketsmith::report::draw2d {

Rgb mix(Rgb dst, Rgb src, float a) {
  const auto ch = [a](std::uint8_t d, std::uint8_t s) {
    return static_cast<std::uint8_t>(std::lround((1 - a) * d + a * s));
  };
  return {ch(dst.r, src.r), ch(dst.g, src.g), ch(dst.b, src.b)};
}

PixelRect pixels_within(const Image& img, double x0, double y0, double x1, double y1) {
  const auto lo = [](double v, int n) {
    return static_cast<int>(std::clamp(std::ceil(v - 0.5), 0.0, double(n)));
  };
  const auto hi = [](double v, int n) {
    return static_cast<int>(std::clamp(std::floor(v - 0.5) + 1, 0.0, double(n)));
  };
  return {lo(x0, img.width), lo(y0, img.height), hi(x1, img.width), hi(y1, img.height)};
}

double stroke_coverage(double px, double py, double ax, double ay, double bx, double by, double r) {
  const double vx = px - ax, vy = py - ay;
  const double dx = bx - ax, dy = by - ay, len2 = dx * dx + dy * dy;
  const double t = len2 > 0 ? std::clamp((vx * dx + vy * dy) / len2, 0.0, 1.0) : 0.0;
  return std::clamp(r + 0.5 - std::hypot(vx - t * dx, vy - t * dy), 0.0, 1.0);
}

void Coverage::capsule(double ax, double ay, double bx, double by, double r) {
  for_pixels_near(clip, std::min(ax, bx) - r, std::min(ay, by) - r, std::max(ax, bx) + r, std::max(ay, by) + r,
                  [&](int x, int y) {
                    const auto c = static_cast<float>(stroke_coverage(x + 0.5, y + 0.5, ax, ay, bx, by, r));
                    if (c <= 0) return;
                    float& cell = cover[static_cast<std::size_t>(y) * width + x];
                    cell = std::max(cell, c);
                    dirty = {std::min(dirty.x0, x), std::min(dirty.y0, y), std::max(dirty.x1, x + 1),
                             std::max(dirty.y1, y + 1)};
                  });
}

void Coverage::blend_into(Image& img, Rgb colour) const {
  for (int y = dirty.y0; y < dirty.y1; ++y)
    for (int x = dirty.x0; x < dirty.x1; ++x) {
      const float c = cover[static_cast<std::size_t>(y) * width + x];
      if (c > 0) img.at(x, y) = mix(img.at(x, y), colour, c);
    }
}

void stroke_segment(Image& img, Eigen::Vector2d a, Eigen::Vector2d b, double width, Rgb colour, float alpha) {
  const double r = 0.5 * width;
  for_pixels_near(whole(img), std::min(a.x(), b.x()) - r, std::min(a.y(), b.y()) - r, std::max(a.x(), b.x()) + r,
                  std::max(a.y(), b.y()) + r, [&](int x, int y) {
                    const double c = alpha * stroke_coverage(x + 0.5, y + 0.5, a.x(), a.y(), b.x(), b.y(), r);
                    if (c > 0) img.at(x, y) = mix(img.at(x, y), colour, static_cast<float>(c));
                  });
}

void fill_disc(Image& img, double cx, double cy, double r, Rgb colour, const PixelRect& clip) {
  for_pixels_near(clip, cx - r, cy - r, cx + r, cy + r, [&](int x, int y) {
    const double c = std::clamp(r + 0.5 - std::hypot(x + 0.5 - cx, y + 0.5 - cy), 0.0, 1.0);
    if (c > 0) img.at(x, y) = mix(img.at(x, y), colour, static_cast<float>(c));
  });
}

void stroke_circle(Image& img, Eigen::Vector2d centre, double radius, double width, Rgb colour) {
  const double r = radius + 0.5 * width;
  for_pixels_near(whole(img), centre.x() - r, centre.y() - r, centre.x() + r, centre.y() + r, [&](int x, int y) {
    const double dist = std::abs(std::hypot(x + 0.5 - centre.x(), y + 0.5 - centre.y()) - radius);
    const double c = std::clamp(0.5 * width + 0.5 - dist, 0.0, 1.0);
    if (c > 0) img.at(x, y) = mix(img.at(x, y), colour, static_cast<float>(c));
  });
}

void fill_polygon(Image& img, const std::vector<Eigen::Vector2d>& pts, Rgb colour, float alpha) {
  if (pts.size() < 3) return;
  Eigen::Vector2d lo = pts[0], hi = pts[0];
  for (const auto& p : pts) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  for_pixels_near(whole(img), lo.x(), lo.y(), hi.x(), hi.y(), [&](int x, int y) {
    const double px = x + 0.5, py = y + 0.5;
    bool inside = false;
    for (std::size_t i = 0, j = pts.size() - 1; i < pts.size(); j = i++) {
      const Eigen::Vector2d& a = pts[i];
      const Eigen::Vector2d& b = pts[j];
      if ((a.y() > py) != (b.y() > py) && px < (b.x() - a.x()) * (py - a.y()) / (b.y() - a.y()) + a.x())
        inside = !inside;
    }
    if (inside) img.at(x, y) = alpha >= 1 ? colour : mix(img.at(x, y), colour, alpha);
  });
}

void fill_box(Image& img, int x0, int y0, int x1, int y1, Rgb colour, float alpha) {
  for (int y = std::max(y0, 0); y < std::min(y1, img.height); ++y)
    for (int x = std::max(x0, 0); x < std::min(x1, img.width); ++x)
      img.at(x, y) = alpha >= 1 ? colour : mix(img.at(x, y), colour, alpha);
}

}  // namespace socketsmith::report::draw2d
