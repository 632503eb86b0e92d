#pragma once
/// The software rasterizer's shared pieces (inside `report` only; `raster.h` is the interface): the
/// pixel rectangle, the image check, filled rectangles, labels with a halo and tick values, shared by
/// the 3-D rendering and PNG output (`raster.cpp`) and the text, marker labels and colour bars (`raster_text.cpp`),
/// and the scene check (`raster_scene.cpp`).
/// Why apart: drawing text is a responsibility of its own, with its own font; checking a scene's
/// input is another, and kept raster.cpp under the file limit.

#include <string>
#include <utility>
#include <vector>

#include "socketsmith/report/raster.h"

namespace socketsmith::report::raster_detail {

inline constexpr Rgb kInk{30, 30, 30};  // text, outlines
inline constexpr Rgb kWhite{255, 255, 255};
inline constexpr int kUnitLabelRows = 15;  // font rows between a colour bar's unit label and the bar

/// Half-open pixel rectangle [x0, x1) × [y0, y1).
struct Rect {
  int x0, y0, x1, y1;
};

/// One-line error unless the image's size is sane and its pixels match it (@p fn names the caller).
void require_consistent(const Image& img, const char* fn);
/// Fills @p r clipped to @p clip.
void fill_rect(Image& img, Rect r, Rgb colour, const Rect& clip);
/// Dark text with a one-pixel white halo, readable over any mesh colour.
void draw_label(Image& img, int x, int y, const std::string& text, int scale, const Rect& clip);
/// A marker drawn at pixel (x, y).
struct MarkerSpot {
  const Marker* marker;
  double x, y;
};
/// The labels of @p spots' markers: right of each disc at its height, else left when the right
/// leaves @p viewport; where that would cover a disc or a label already drawn (landmarks a few
/// millimetres apart: a transfemoral socket's IS, IR, AL and ST under the medial brim), the
/// nearest free row above or below on the same side, with a thin leader to its disc.
void draw_marker_labels(Image& img, const std::vector<MarkerSpot>& spots, const Rect& viewport);
/// One-line error unless every layer has a mesh with finite vertices and valid triangles, one value
/// per vertex (or none) in a finite range, and an opacity in (0, 1], and every marker a finite
/// position and a radius of 1 to 100 px (@p fn names the caller).
void validate_scene(const char* fn, const std::vector<MeshLayer>& layers, const std::vector<Marker>& markers);
/// Ticks at multiples of the smallest 1, 2, 5 × 10^k step >= range / 5, with their labels.
std::vector<std::pair<double, std::string>> nice_ticks(double vmin, double vmax);

}  // namespace socketsmith::report::raster_detail
