#pragma once
/// @file draw_2d.h
/// Anti-aliased 2-D drawing on an Image (internal header of `report`): strokes, discs, circles,
/// polygons and boxes, with the coverage of each pixel taken at its centre. Shared by the plots'
/// PNG renderer (plot_raster.cpp) and the design report's pictures (design_report.cpp), so that
/// both draw a line or a marker the same way. Pixel (x, y) covers [x, x+1) × [y, y+1).

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/report/raster.h"

namespace socketsmith::report::draw2d {

/// @p dst blended towards @p src by @p a in [0, 1] (rounded to the nearest level).
Rgb mix(Rgb dst, Rgb src, float a);

/// Pixel rectangle [x0, x1) × [y0, y1).
struct PixelRect {
  int x0, y0, x1, y1;
};

/// Every pixel of @p img.
inline PixelRect whole(const Image& img) { return {0, 0, img.width, img.height}; }

/// Pixels of @p img whose centres lie in [x0, x1] × [y0, y1] (pixel coordinates).
PixelRect pixels_within(const Image& img, double x0, double y0, double x1, double y1);

/// Calls f(x, y) for the pixels of @p clip that overlap the box [lo_x, hi_x] × [lo_y, hi_y]
/// grown by one pixel (room for the anti-aliased edge).
template <class F>
void for_pixels_near(const PixelRect& clip, double lo_x, double lo_y, double hi_x, double hi_y, F&& f) {
  const int x0 = std::max(clip.x0, static_cast<int>(std::floor(lo_x - 1)));
  const int x1 = std::min(clip.x1, static_cast<int>(std::ceil(hi_x + 1)));
  const int y0 = std::max(clip.y0, static_cast<int>(std::floor(lo_y - 1)));
  const int y1 = std::min(clip.y1, static_cast<int>(std::ceil(hi_y + 1)));
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) f(x, y);
}

/// Coverage in [0, 1] of the pixel centred at (@p px, @p py) by a stroke of radius @p r [px]
/// from (@p ax, @p ay) to (@p bx, @p by) with round ends.
double stroke_coverage(double px, double py, double ax, double ay, double bx, double by, double r);

/// Per-pixel coverage of several strokes of one colour (the maximum over its pieces, so that
/// joins and overlapping dashes are not darker), blended once.
struct Coverage {
  PixelRect clip;
  int width;
  std::vector<float> cover;
  PixelRect dirty{0, 0, 0, 0};

  Coverage(const Image& img, PixelRect c)
      : clip(c), width(img.width), cover(img.pixels.size(), 0.0f), dirty{c.x1, c.y1, c.x0, c.y0} {}

  /// A stroke of radius @p r [px] from a to b with round ends.
  void capsule(double ax, double ay, double bx, double by, double r);
  void blend_into(Image& img, Rgb colour) const;
};

/// One stroke of width @p width [px] from a to b with round ends, blended at @p alpha.
void stroke_segment(Image& img, Eigen::Vector2d a, Eigen::Vector2d b, double width, Rgb colour, float alpha = 1);

/// Anti-aliased filled disc of radius @p r [px], clipped to @p clip.
void fill_disc(Image& img, double cx, double cy, double r, Rgb colour, const PixelRect& clip);

/// A circle of @p radius [px] drawn with a line of @p width [px].
void stroke_circle(Image& img, Eigen::Vector2d centre, double radius, double width, Rgb colour);

/// Fills a simple polygon (even-odd rule at pixel centres) blended at @p alpha.
void fill_polygon(Image& img, const std::vector<Eigen::Vector2d>& points, Rgb colour, float alpha);

/// Fills the pixel rectangle [x0, x1) × [y0, y1), clipped to the image, blending at @p alpha.
void fill_box(Image& img, int x0, int y0, int x1, int y1, Rgb colour, float alpha = 1);

}  // namespace socketsmith::report::draw2d
