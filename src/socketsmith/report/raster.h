#pragma once
/// @file raster.h
/// A small software renderer for pictures a person would rather look at than read: limb
/// meshes with landmarks, value fields (pressure maps) with a colour bar, several views side
/// by side, written as PNG. No OpenGL: orthographic projection, z-buffer, Gouraud-interpolated
/// colours, headlight Lambert + ambient shading, back faces darker (open meshes read right),
/// translucent layers blended back to front over opaque ones, supersampled edges. Text is the
/// stb_easy_font bitmap font (printable ASCII; other bytes are drawn as '?').

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::report {

/// An 8-bit sRGB colour.
struct Rgb {
  std::uint8_t r = 0, g = 0, b = 0;
  friend bool operator==(const Rgb&, const Rgb&) = default;
};

/// Largest accepted image side [px].
inline constexpr int kMaxImageSide = 16384;

/// An RGB raster image, row-major, top row first.
struct Image {
  int width = 0;            ///< [px]
  int height = 0;           ///< [px]
  std::vector<Rgb> pixels;  ///< width × height colours; pixel (x, y) at index y * width + x

  /// An image of @p w × @p h pixels filled with @p background.
  /// @throws InvalidInputError when a side is outside 1..kMaxImageSide.
  Image(int w, int h, Rgb background);

  /// Pixel at column @p x, row @p y (0-based, unchecked).
  Rgb& at(int x, int y) { return pixels[static_cast<std::size_t>(y) * width + x]; }
  /// Pixel at column @p x, row @p y (0-based, unchecked).
  const Rgb& at(int x, int y) const { return pixels[static_cast<std::size_t>(y) * width + x]; }
};

/// Orthographic camera: only a direction and an up vector; fit() places and scales the view.
struct Camera {
  /// Direction the camera looks in, from the eye into the scene (any length > 0):
  /// {0, 0, -1} shows the scene as seen from +z.
  Eigen::Vector3d view_dir = Eigen::Vector3d(0, 0, -1);
  /// World direction that appears upward on screen; must not be parallel to view_dir.
  Eigen::Vector3d up = Eigen::Vector3d(0, 1, 0);
};

/// Orthographic map from world coordinates [m] to image pixels, made by fit(). Image x grows
/// to the right, y downward; pixel (i, j) covers [i, i+1) × [j, j+1).
struct Projection {
  Eigen::Vector3d right;      ///< unit world direction of image +x
  Eigen::Vector3d down;       ///< unit world direction of image +y
  Eigen::Vector3d forward;    ///< unit viewing direction (depth grows along it)
  Eigen::Vector3d origin;     ///< world point [m] that maps to origin_px at depth 0
  Eigen::Vector2d origin_px;  ///< image position [px] of origin
  double px_per_m = 1;        ///< scale [px/m], > 0

  /// (x [px], y [px], depth [m]) of world point @p p; larger depth = farther from the eye.
  Eigen::Vector3d project(const Eigen::Vector3d& p) const;
};

/// Frames @p box in the viewport (@p x0, @p y0, @p w, @p h) of an image: the box's projected
/// outline is centred and scaled to fit inside the viewport less a border of
/// @p margin × min(w, h) on each side. A box of zero extent is centred at 1 px/m.
/// @throws InvalidInputError when the camera's view_dir is zero or not finite, up is parallel
///         to it, the box is empty or not finite, w or h < 1, or margin is outside [0, 0.45].
Projection fit(const Camera& camera, const geometry::Aabb& box, int x0, int y0, int w, int h,
               double margin = 0.05);

/// Colour maps for value fields, from small built-in tables interpolated linearly in RGB.
enum class Colormap {
  Viridis,   ///< perceptually uniform dark purple → blue → green → yellow
  Pressure,  ///< blue → green → yellow → red (Jet-like, the clinicians' pressure map)
  Greys,     ///< near black → near white
  Diverging, ///< blue → white → red (ColorBrewer RdBu): signed fields centred on 0, e.g. deviations
};

/// Colour of @p colormap at @p t in [0, 1] (clamped; NaN gives the colour at 0).
Rgb colormap_colour(Colormap colormap, double t);

/// One mesh to draw, with a uniform colour or a per-vertex value field.
struct MeshLayer {
  const geometry::TriMesh* mesh = nullptr;  ///< not owned; must outlive the render call
  /// One value per vertex (#V), any unit; empty = uniform @ref colour. Values are
  /// interpolated across each triangle and mapped per pixel (so a large triangle spanning the
  /// range shows the colormap's middle too). A triangle with a non-finite value at any
  /// corner is drawn in @ref colour (e.g. "no data").
  std::vector<double> vertex_values;
  Rgb colour{200, 200, 200};  ///< uniform colour; also for triangles without values
  double value_min = 0;       ///< value mapped to the colormap's start (lower values clamp)
  double value_max = 1;       ///< value mapped to the colormap's end, > value_min
  Colormap colormap = Colormap::Viridis;
  std::string value_label;  ///< unit or name shown above the colour bar, e.g. "kPa"
  double opacity = 1.0;     ///< (0, 1]; below 1 the layer is blended over the opaque ones
};

/// A landmark: a filled disc with a dark outline, its label beside it.
struct Marker {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< [m]
  std::string label;                                   ///< "" = no label
  Rgb colour{230, 60, 40};
  double radius_px = 6;  ///< disc radius [px], 1..100
  /// Draw even when an opaque surface hides it. Otherwise the marker, seen as a sphere of
  /// radius_px, is drawn only when its front point is not behind the opaque surface at its
  /// centre pixel (translucent layers never hide markers).
  bool is_always_visible = false;
};

/// Framing and quality settings of render().
struct RenderOptions {
  double margin = 0.05;   ///< free border, fraction of the viewport's smaller side, [0, 0.45]
  int supersampling = 2;  ///< samples per pixel along each axis (edge anti-aliasing), 1..4
  /// [px/m] fixed scale (views to compare at the same size), centred on the frame box;
  /// 0 = the largest scale at which the frame box fits (fit()). >= 0, finite.
  double scale_px_per_m = 0;
};

/// Rasterizes @p layers and @p markers into the viewport (@p x0, @p y0, @p w, @p h) of @p img,
/// framing @p frame_box with fit() (or at options.scale_px_per_m). Pixels the meshes do not
/// cover keep their colour. Marker labels go right of the disc, or left when they would leave
/// the viewport, a row up or down (with a leader) where they would cover another marker's disc
/// or label; they are clipped to it.
/// Opaque layers (opacity 1) are z-buffered; translucent layers are then blended back to front
/// (by triangle centroid) without writing depth; markers are drawn last, on top.
/// Shading: colour × (0.3 + 0.7 max(0, n·l)) with a headlight l = −view_dir and smooth vertex
/// normals (face normals across creases sharper than 40°); back faces × 0.6.
/// Triangles reaching more than 2^20 px outside the viewport are not drawn.
/// @throws InvalidInputError when the image's pixel count is not width × height, the viewport
///         is not inside the image, a layer has no mesh, a vertex index out of range, a
///         non-finite vertex, a value count other than #V, a value range that is not finite
///         and increasing, or an opacity outside (0, 1], a marker is not finite or its radius
///         outside 1..100 px, options are out of range, or as fit(). Nothing is drawn then.
void render(Image& img, const Camera& cam, const std::vector<MeshLayer>& layers,
            const std::vector<Marker>& markers, int x0, int y0, int w, int h,
            const geometry::Aabb& frame_box, const RenderOptions& options = {});

/// @p text with common UTF-8 symbols spelled in ASCII for the raster font ("·" → ".",
/// "μ" → "u", "θ" → "theta", "°" → "deg", "≥" → ">=", "≤" → "<=", "²" → "^2", "×" → "x",
/// "−" → "-", "±" → "+/-", "ν" → "nu", "ε" → "eps", …); any other non-ASCII character becomes
/// one '?'.
std::string to_ascii(std::string_view text);

/// Width [px] of @p text drawn with draw_text() at @p scale (the longest line).
int text_width(const std::string& text, int scale = 2);

/// Height [px] of @p text drawn with draw_text() at @p scale: 12 × scale per line.
int text_height(const std::string& text, int scale = 2);

/// Draws @p text (printable ASCII, '\n' starts a line) with its top-left corner at (@p x, @p y),
/// each font pixel a @p scale × @p scale block; clipped to the image.
/// @throws InvalidInputError when scale is outside 1..16.
void draw_text(Image& img, int x, int y, const std::string& text, Rgb colour, int scale = 2);

/// Draws a vertical colour bar in the rectangle (@p x, @p y, @p w, @p h), @p vmax at the top,
/// with a dark frame, 3–6 "nice" ticks (1, 2, 5 × 10^k) labelled to its right and
/// @p unit_label above it (text at scale 2: leave 30 px above and ~100 px to the right).
/// @throws InvalidInputError when the rectangle is not inside the image, w < 2, h < 8, or
///         vmin, vmax are not finite with vmin < vmax.
void draw_colour_bar(Image& img, int x, int y, int w, int h, Colormap colormap, double vmin,
                     double vmax, const std::string& unit_label);

/// The PNG encoding of @p img (8-bit RGB), e.g. for a data URI.
/// @throws InvalidInputError when the pixel count is not width × height or a side is outside
///         1..kMaxImageSide.
std::string encode_png(const Image& img);

/// Writes @p img as an 8-bit RGB PNG, atomically (temporary file + rename).
/// @throws InvalidInputError when the pixel count is not width × height or a side is outside
///         1..kMaxImageSide; IoError when the file cannot be written.
void write_png(const std::filesystem::path& path, const Image& img);

/// The images one below the other, left-aligned on @p background (e.g. two colour maps on the
/// same scale for a side-by-side comparison).
/// @throws InvalidInputError when there is no image or the result exceeds kMaxImageSide.
Image stack_images(const std::vector<Image>& images, Rgb background = {255, 255, 255});

/// Lays out one view per entry of @p views, each @p view_px square, side by side on white:
/// @p title on top, the view's caption under each, and, when a layer has values, one colour
/// bar at the right for the first such layer. Every view is centred on the bounding box of all
/// meshes and markers, at one common scale: the largest at which the box fits every view.
/// @throws InvalidInputError when views is empty, view_px is outside 32..4096, there is
///         nothing to frame (no vertices, no markers), or as render().
Image render_views(const std::vector<MeshLayer>& layers, const std::vector<Marker>& markers,
                   const std::vector<std::pair<Camera, std::string>>& views, int view_px,
                   const std::string& title);

}  // namespace socketsmith::report
