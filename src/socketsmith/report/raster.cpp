#include "socketsmith/report/raster.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <ostream>
#include <span>
#include <string_view>

#include <fmt/format.h>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/report/nice_number.h"
#include "socketsmith/report/raster_detail.h"

// stb is header-only: the PNG writer is compiled here, with static linkage so it cannot clash
// with the copy inside Debian's libstb (which the GUI links for Dear ImGui). stb_easy_font is
// all static functions already.
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#define STBI_WRITE_NO_STDIO
#include <stb/stb_image_write.h>

namespace socketsmith::report {
using namespace raster_detail;
namespace {

using Eigen::Vector3d;
using Eigen::Vector3f;

static_assert(sizeof(Rgb) == 3 && alignof(Rgb) == 1, "Image pixels are handed to stb as bytes");

constexpr double kAmbient = 0.3;  // face-on lighting is ambient + diffuse = 1: true colour
constexpr double kDiffuse = 0.7;
constexpr double kBackFaceDim = 0.6;         // inside of an open surface
constexpr double kCreaseCos = 0.766;         // cos 40°: sharper edges keep the face normal
constexpr std::int64_t kSub = 256;           // sub-pixel steps per pixel (fixed-point vertices)
constexpr double kMaxOffscreenPx = 1 << 20;  // keeps the fixed-point edge products in int64

// Colormap tables, sampled at equal steps.
constexpr std::array<Rgb, 9> kViridis{{{68, 1, 84},
                                       {71, 44, 122},
                                       {59, 81, 139},
                                       {44, 113, 142},
                                       {33, 144, 141},
                                       {39, 173, 129},
                                       {92, 200, 99},
                                       {170, 220, 50},
                                       {253, 231, 37}}};
constexpr std::array<Rgb, 4> kPressure{
    {{35, 75, 205}, {50, 175, 80}, {250, 215, 45}, {205, 35, 35}}};
constexpr std::array<Rgb, 2> kGreys{{{20, 20, 20}, {240, 240, 240}}};
constexpr std::array<Rgb, 9> kDiverging{{{33, 102, 172},
                                         {67, 147, 195},
                                         {146, 197, 222},
                                         {209, 229, 240},
                                         {247, 247, 247},
                                         {253, 219, 199},
                                         {244, 165, 130},
                                         {214, 96, 77},
                                         {178, 24, 43}}};

inline std::uint8_t to_byte(float v) {
  return static_cast<std::uint8_t>(std::clamp(v, 0.0f, 255.0f) + 0.5f);
}

Vector3f to_vec(Rgb c) { return {float(c.r), float(c.g), float(c.b)}; }

inline Rgb to_rgb(const Vector3f& v) { return {to_byte(v.x()), to_byte(v.y()), to_byte(v.z())}; }

/// (1 - a) * dst + a * src.
Rgb blend(Rgb dst, Rgb src, float a) { return to_rgb(to_vec(dst) * (1 - a) + to_vec(src) * a); }



// ---- rasterization ----------------------------------------------------------------------------

/// Supersampled colour and depth of one viewport.
struct Target {
  int width, height;         // [samples]
  std::vector<float> depth;  // [m] along the view direction, +inf = empty
  std::vector<Rgb> colour;
};

/// A triangle corner in fixed-point sample coordinates (1/kSub sample).
struct Corner {
  std::int64_t x, y;
  double depth;     // [m]
  Vector3f colour;  // shaded uniform colour, 0..255
  float t;          // position in the colormap, 0..1
  float intensity;  // shading factor
};

/// Colormap sampled at kLutSize equal steps (0..255 per channel).
constexpr int kLutSize = 256;
using Lut = std::array<Vector3f, kLutSize>;

/// A triangle ready to fill. With a colormap, the value (t) and the shading are interpolated
/// separately and looked up per sample, so a large triangle spanning the range shows the
/// colormap's middle colours rather than a straight blend of its corner colours.
struct ShadedTriangle {
  std::array<Corner, 3> corners;
  const Lut* lut;  // nullptr = interpolate the corners' colours
};

std::int64_t floor_div(std::int64_t a, std::int64_t b) {
  return a >= 0 ? a / b : -((-a + b - 1) / b);
}

/// Fills the samples whose centres lie inside the triangle. Shared edges are owned by exactly
/// one side (exact integer edge functions + a consistent tie rule), so translucent meshes get
/// no double-blended seams. opacity 1 writes depth; below 1 it blends without writing depth.
void rasterize(const ShadedTriangle& tri, Target& target, float opacity) {
  std::array<Corner, 3> c = tri.corners;
  auto edge = [](const Corner& a, const Corner& b, std::int64_t px, std::int64_t py) {
    return (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x);
  };
  std::int64_t area = edge(c[0], c[1], c[2].x, c[2].y);
  if (area == 0) return;
  if (area < 0) {
    std::swap(c[1], c[2]);
    area = -area;
  }
  const auto [xmin, xmax] = std::minmax({c[0].x, c[1].x, c[2].x});
  const auto [ymin, ymax] = std::minmax({c[0].y, c[1].y, c[2].y});
  // Sample (i, j) has its centre at ((i + 1/2) kSub, (j + 1/2) kSub).
  const auto i0 = std::max<std::int64_t>(0, floor_div(xmin - kSub / 2 + kSub - 1, kSub));
  const auto i1 = std::min<std::int64_t>(target.width - 1, floor_div(xmax - kSub / 2, kSub));
  const auto j0 = std::max<std::int64_t>(0, floor_div(ymin - kSub / 2 + kSub - 1, kSub));
  const auto j1 = std::min<std::int64_t>(target.height - 1, floor_div(ymax - kSub / 2, kSub));
  if (i0 > i1 || j0 > j1) return;

  // Edge k runs from corner k+1 to corner k+2: e_k = A x + B y + C, positive inside, and
  // e_k / area is the barycentric weight of corner k.
  std::array<std::int64_t, 3> row{}, dx{}, dy{}, bias{};
  for (int k = 0; k < 3; ++k) {
    const Corner& a = c[(k + 1) % 3];
    const Corner& b = c[(k + 2) % 3];
    const std::int64_t A = -(b.y - a.y), B = b.x - a.x;
    dx[k] = A * kSub;
    dy[k] = B * kSub;
    row[k] = edge(a, b, i0 * kSub + kSub / 2, j0 * kSub + kSub / 2);
    // A sample exactly on the edge belongs to the triangle whose (A, B) is lexicographically
    // positive; the neighbour across the edge has (-A, -B).
    bias[k] = (A > 0 || (A == 0 && B > 0)) ? 0 : 1;
  }
  const double inv_area = 1.0 / double(area);
  const bool is_opaque = opacity >= 1;
  for (auto j = j0; j <= j1; ++j) {
    std::array<std::int64_t, 3> e = row;
    std::size_t idx = std::size_t(j) * target.width + std::size_t(i0);
    for (auto i = i0; i <= i1; ++i, ++idx) {
      if (e[0] >= bias[0] && e[1] >= bias[1] && e[2] >= bias[2]) {
        const double w0 = double(e[0]) * inv_area, w1 = double(e[1]) * inv_area,
                     w2 = double(e[2]) * inv_area;
        const auto depth = float(w0 * c[0].depth + w1 * c[1].depth + w2 * c[2].depth);
        if (depth < target.depth[idx]) {
          const auto f0 = float(w0), f1 = float(w1), f2 = float(w2);
          Vector3f colour;
          if (tri.lut != nullptr) {
            const float t = std::clamp(f0 * c[0].t + f1 * c[1].t + f2 * c[2].t, 0.0f, 1.0f);
            colour = (*tri.lut)[std::size_t(t * (kLutSize - 1) + 0.5f)] *
                     (f0 * c[0].intensity + f1 * c[1].intensity + f2 * c[2].intensity);
          } else {
            colour = f0 * c[0].colour + f1 * c[1].colour + f2 * c[2].colour;
          }
          if (is_opaque) {
            target.depth[idx] = depth;
            target.colour[idx] = to_rgb(colour);
          } else {
            target.colour[idx] =
                to_rgb(to_vec(target.colour[idx]) * (1 - opacity) + colour * opacity);
          }
        }
      }
      for (int k = 0; k < 3; ++k) e[k] += dx[k];
    }
    for (int k = 0; k < 3; ++k) row[k] += dy[k];
  }
}

/// Per-vertex data of one layer in one view.
struct PreparedLayer {
  std::vector<std::array<std::int64_t, 2>> sample;  // fixed-point sample coordinates
  std::vector<double> depth;                        // [m]
  std::vector<bool> is_far;                         // too far outside the viewport to draw
  std::vector<float> t;                             // colormap position 0..1, NaN = no value
  std::vector<Vector3d> normal;                     // area-weighted unit normal (or zero)
  Vector3f colour;                                  // uniform colour, 0..255
  Lut lut;                                          // the layer's colormap
  bool has_values;
};

PreparedLayer prepare(const MeshLayer& layer, const Projection& proj, int x0, int y0, int ss) {
  const auto& mesh = *layer.mesh;
  const std::size_t nv = mesh.vertices.size();
  PreparedLayer p;
  p.sample.resize(nv);
  p.depth.resize(nv);
  p.is_far.resize(nv);
  p.t.assign(nv, std::numeric_limits<float>::quiet_NaN());
  p.normal.assign(nv, Vector3d::Zero());
  p.colour = to_vec(layer.colour);
  p.has_values = !layer.vertex_values.empty();
  if (p.has_values)
    for (int i = 0; i < kLutSize; ++i)
      p.lut[i] = to_vec(colormap_colour(layer.colormap, double(i) / (kLutSize - 1)));
  for (std::size_t v = 0; v < nv; ++v) {
    const Vector3d q = proj.project(mesh.vertices[v]);
    const double sx = (q.x() - x0) * ss, sy = (q.y() - y0) * ss;
    p.is_far[v] = !(std::abs(sx) < kMaxOffscreenPx && std::abs(sy) < kMaxOffscreenPx);
    if (!p.is_far[v]) p.sample[v] = {std::llround(sx * kSub), std::llround(sy * kSub)};
    p.depth[v] = q.z();
    if (p.has_values && std::isfinite(layer.vertex_values[v]))
      p.t[v] = float(std::clamp(
          (layer.vertex_values[v] - layer.value_min) / (layer.value_max - layer.value_min), 0.0,
          1.0));
  }
  for (const auto& tri : mesh.triangles) {
    const Vector3d n = (mesh.vertices[tri[1]] - mesh.vertices[tri[0]])
                           .cross(mesh.vertices[tri[2]] - mesh.vertices[tri[0]]);
    for (int k : tri) p.normal[k] += n;
  }
  for (auto& n : p.normal) n.normalize();  // Eigen leaves a zero vector unchanged
  return p;
}

/// Shaded triangle @p t, or nothing when it is not drawn (degenerate or far away). A triangle
/// with a vertex without a value is drawn in the uniform colour.
std::optional<ShadedTriangle> shade_triangle(const geometry::TriMesh& mesh, const PreparedLayer& p,
                                             int t, const Vector3d& light) {
  const auto& tri = mesh.triangles[t];
  if (p.is_far[tri[0]] || p.is_far[tri[1]] || p.is_far[tri[2]]) return std::nullopt;
  Vector3d fn = (mesh.vertices[tri[1]] - mesh.vertices[tri[0]])
                    .cross(mesh.vertices[tri[2]] - mesh.vertices[tri[0]]);
  const double len = fn.norm();
  if (!(len > 0)) return std::nullopt;
  fn /= len;
  const bool is_back = fn.dot(light) < 0;
  const double dim = is_back ? kBackFaceDim : 1.0;
  ShadedTriangle out{{}, nullptr};
  bool has_all_values = p.has_values;
  for (int k = 0; k < 3; ++k) {
    const int v = tri[k];
    Vector3d n = p.normal[v].dot(fn) >= kCreaseCos ? p.normal[v] : fn;
    if (is_back) n = -n;
    const auto intensity = float(dim * (kAmbient + kDiffuse * std::max(0.0, n.dot(light))));
    out.corners[k] = {p.sample[v][0],       p.sample[v][1], p.depth[v],
                      p.colour * intensity, p.t[v],         intensity};
    has_all_values = has_all_values && !std::isnan(p.t[v]);
  }
  if (has_all_values) out.lut = &p.lut;
  return out;
}

void draw_marker_disc(Image& img, double cx, double cy, double r, Rgb fill, const Rect& clip) {
  const double outline = std::max(1.5, 0.25 * r);
  const int ya = std::max(clip.y0, int(std::floor(cy - r - 1))),
            yb = std::min(clip.y1, int(std::ceil(cy + r + 1)));
  const int xa = std::max(clip.x0, int(std::floor(cx - r - 1))),
            xb = std::min(clip.x1, int(std::ceil(cx + r + 1)));
  for (int y = ya; y < yb; ++y)
    for (int x = xa; x < xb; ++x) {
      const double d = std::hypot(x + 0.5 - cx, y + 0.5 - cy);
      const double coverage = std::clamp(r + 0.5 - d, 0.0, 1.0);
      if (coverage == 0) continue;
      const double inner = std::clamp(r - outline + 0.5 - d, 0.0, 1.0);
      img.at(x, y) = blend(img.at(x, y), blend(kInk, fill, float(inner)), float(coverage));
    }
}

}  // namespace

void raster_detail::require_consistent(const Image& img, const char* fn) {
  require(img.width >= 1 && img.height >= 1 && img.width <= kMaxImageSide &&
              img.height <= kMaxImageSide,
          "{}: image size {}×{} (expected 1..{} per side)", fn, img.width, img.height,
          kMaxImageSide);
  require(img.pixels.size() == static_cast<std::size_t>(img.width) * img.height,
          "{}: image has {} pixels for {}×{} (expected width × height)", fn, img.pixels.size(),
          img.width, img.height);
}

void raster_detail::fill_rect(Image& img, Rect r, Rgb colour, const Rect& clip) {
  r = {std::max(r.x0, clip.x0), std::max(r.y0, clip.y0), std::min(r.x1, clip.x1),
       std::min(r.y1, clip.y1)};
  for (int y = r.y0; y < r.y1; ++y)
    for (int x = r.x0; x < r.x1; ++x) img.at(x, y) = colour;
}

// ---- public API -------------------------------------------------------------------------------

Image::Image(int w, int h, Rgb background) : width(w), height(h) {
  require(w >= 1 && h >= 1 && w <= kMaxImageSide && h <= kMaxImageSide,
          "Image: size {}×{} (expected 1..{} pixels per side)", w, h, kMaxImageSide);
  pixels.assign(std::size_t(w) * std::size_t(h), background);
}

Vector3d Projection::project(const Vector3d& p) const {
  const Vector3d d = p - origin;
  return {origin_px.x() + px_per_m * d.dot(right), origin_px.y() + px_per_m * d.dot(down),
          d.dot(forward)};
}

Projection fit(const Camera& camera, const geometry::Aabb& box, int x0, int y0, int w, int h,
               double margin) {
  const Vector3d& v = camera.view_dir;
  const Vector3d& u = camera.up;
  require(v.allFinite() && v.norm() > 0, "fit: camera view_dir ({}, {}, {}) is not a direction",
          v.x(), v.y(), v.z());
  require(u.allFinite() && u.norm() > 0 && v.normalized().cross(u.normalized()).norm() > 1e-6,
          "fit: camera up ({}, {}, {}) is not a direction across view_dir ({}, {}, {})", u.x(),
          u.y(), u.z(), v.x(), v.y(), v.z());
  require(!box.is_empty() && box.min.allFinite() && box.max.allFinite(),
          "fit: frame box [({}, {}, {}), ({}, {}, {})] is empty or not finite", box.min.x(),
          box.min.y(), box.min.z(), box.max.x(), box.max.y(), box.max.z());
  require(w >= 1 && h >= 1, "fit: viewport size {}×{} (expected at least 1×1)", w, h);
  require(margin >= 0 && margin <= 0.45, "fit: margin {} (expected 0..0.45 of the viewport)",
          margin);

  Projection p;
  p.forward = v.normalized();
  const Vector3d screen_up = (u - u.dot(p.forward) * p.forward).normalized();
  p.right = p.forward.cross(screen_up);
  p.down = -screen_up;
  p.origin = box.center();
  p.origin_px = {x0 + 0.5 * w, y0 + 0.5 * h};
  // Half extents of the box's outline on screen (the box is symmetric about its centre).
  const Vector3d half = 0.5 * box.extent();
  const double half_x = half.dot(p.right.cwiseAbs()), half_y = half.dot(p.down.cwiseAbs());
  const double border = margin * std::min(w, h);
  const double sx =
      half_x > 0 ? (0.5 * w - border) / half_x : std::numeric_limits<double>::infinity();
  const double sy =
      half_y > 0 ? (0.5 * h - border) / half_y : std::numeric_limits<double>::infinity();
  p.px_per_m = std::isfinite(std::min(sx, sy)) ? std::min(sx, sy) : 1.0;
  return p;
}

Rgb colormap_colour(Colormap colormap, double t) {
  std::span<const Rgb> table;
  switch (colormap) {
    case Colormap::Viridis:
      table = kViridis;
      break;
    case Colormap::Pressure:
      table = kPressure;
      break;
    case Colormap::Greys:
      table = kGreys;
      break;
    case Colormap::Diverging:
      table = kDiverging;
      break;
  }
  const double s = (t >= 0 ? std::min(t, 1.0) : 0.0) * double(table.size() - 1);
  const std::size_t i = std::min(std::size_t(s), table.size() - 2);
  return blend(table[i], table[i + 1], float(s - double(i)));
}

namespace {

/// The viewport's supersampled target, starting as its current pixels so that uncovered samples
/// keep them.
Target viewport_target(const Image& img, int x0, int y0, int w, int h, int ss) {
  Target target{w * ss, h * ss, {}, {}};
  target.depth.assign(std::size_t(target.width) * target.height,
                      std::numeric_limits<float>::infinity());
  target.colour.resize(target.depth.size());
  for (int j = 0; j < target.height; ++j) {
    Rgb* row = &target.colour[std::size_t(j) * target.width];
    for (int x = 0; x < w; ++x) std::fill_n(row + x * ss, ss, img.at(x0 + x, y0 + j / ss));
  }
  return target;
}

/// Opaque layers in any order (z-buffer), then translucent triangles far to near.
void draw_layers(Target& target, const std::vector<MeshLayer>& layers,
                 const std::vector<PreparedLayer>& prepared, const Vector3d& light) {
  struct Translucent {
    double depth;
    int layer, triangle;
  };
  std::vector<Translucent> translucent;
  for (std::size_t l = 0; l < layers.size(); ++l) {
    const auto& mesh = *layers[l].mesh;
    for (int t = 0; t < mesh.num_triangles(); ++t) {
      if (layers[l].opacity < 1) {
        const auto& tri = mesh.triangles[t];
        const auto& d = prepared[l].depth;
        translucent.push_back({d[tri[0]] + d[tri[1]] + d[tri[2]], int(l), t});  // 3 × centroid
      } else if (const auto shaded = shade_triangle(mesh, prepared[l], t, light)) {
        rasterize(*shaded, target, 1.0f);
      }
    }
  }
  std::sort(translucent.begin(), translucent.end(),
            [](const Translucent& a, const Translucent& b) { return a.depth > b.depth; });
  for (const auto& tr : translucent)
    if (const auto shaded =
            shade_triangle(*layers[tr.layer].mesh, prepared[tr.layer], tr.triangle, light))
      rasterize(*shaded, target, float(layers[tr.layer].opacity));
}

/// Resolve: each pixel of the viewport at (x0, y0) is the rounded mean of its ss × ss samples.
void resolve_target(Image& img, const Target& target, int x0, int y0, int w, int h, int ss) {
  const int n = ss * ss;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      int r = n / 2, g = n / 2, b = n / 2;
      for (int j = 0; j < ss; ++j) {
        const Rgb* sample =
            &target.colour[std::size_t(y * ss + j) * target.width + std::size_t(x * ss)];
        for (int i = 0; i < ss; ++i) {
          r += sample[i].r;
          g += sample[i].g;
          b += sample[i].b;
        }
      }
      img.at(x0 + x, y0 + y) = {std::uint8_t(r / n), std::uint8_t(g / n), std::uint8_t(b / n)};
    }
}

/// Whether a marker projected to @p q is in front of the nearest opaque surface over its centre
/// pixel's samples (always, when it is flagged so or its centre is outside the viewport).
bool is_marker_visible(const Marker& marker, const Vector3d& q, const Projection& proj,
                       const Target& target, const Rect& viewport, int ss) {
  const int x0 = viewport.x0, y0 = viewport.y0, w = viewport.x1 - x0, h = viewport.y1 - y0;
  const double px = std::floor(q.x() - x0), py = std::floor(q.y() - y0);
  if (marker.is_always_visible || !(px >= 0 && px < w && py >= 0 && py < h)) return true;
  float nearest = std::numeric_limits<float>::infinity();
  for (int j = 0; j < ss; ++j)
    for (int i = 0; i < ss; ++i)
      nearest = std::min(nearest, target.depth[std::size_t(int(py) * ss + j) * target.width +
                                               std::size_t(int(px) * ss + i)]);
  return q.z() - marker.radius_px / proj.px_per_m <= double(nearest);
}

/// The visible markers as discs, then their labels (draw_marker_labels), in @p viewport.
void draw_markers(Image& img, const std::vector<Marker>& markers, const Projection& proj,
                  const Target& target, const Rect& viewport, int ss) {
  std::vector<MarkerSpot> shown;
  for (const auto& marker : markers) {
    const Vector3d q = proj.project(marker.position);
    if (!is_marker_visible(marker, q, proj, target, viewport, ss)) continue;
    draw_marker_disc(img, q.x(), q.y(), marker.radius_px, marker.colour, viewport);
    shown.push_back({&marker, q.x(), q.y()});
  }
  draw_marker_labels(img, shown, viewport);
}

}  // namespace

void render(Image& img, const Camera& cam, const std::vector<MeshLayer>& layers,
            const std::vector<Marker>& markers, int x0, int y0, int w, int h,
            const geometry::Aabb& frame_box, const RenderOptions& options) {
  require_consistent(img, "render");
  require(x0 >= 0 && y0 >= 0 && w >= 1 && h >= 1 && x0 + w <= img.width && y0 + h <= img.height,
          "render: viewport at ({}, {}) of {}×{} px is not inside the {}×{} image", x0, y0, w, h,
          img.width, img.height);
  require(options.supersampling >= 1 && options.supersampling <= 4,
          "render: supersampling {} (expected 1..4)", options.supersampling);
  require(std::isfinite(options.scale_px_per_m) && options.scale_px_per_m >= 0,
          "render: scale {} px/m (expected >= 0, 0 = fit the frame box)", options.scale_px_per_m);
  validate_scene("render", layers, markers);
  Projection proj = fit(cam, frame_box, x0, y0, w, h, options.margin);
  if (options.scale_px_per_m > 0) proj.px_per_m = options.scale_px_per_m;
  const Vector3d light = -proj.forward;
  const int ss = options.supersampling;
  Target target = viewport_target(img, x0, y0, w, h, ss);
  std::vector<PreparedLayer> prepared;
  prepared.reserve(layers.size());
  for (const auto& layer : layers) prepared.push_back(prepare(layer, proj, x0, y0, ss));
  draw_layers(target, layers, prepared, light);
  resolve_target(img, target, x0, y0, w, h, ss);
  draw_markers(img, markers, proj, target, Rect{x0, y0, x0 + w, y0 + h}, ss);
}

Image stack_images(const std::vector<Image>& images, Rgb background) {
  require(!images.empty(), "stack_images: no image");
  int w = 0, h = 0;
  for (const auto& im : images) {
    require_consistent(im, "stack_images");
    w = std::max(w, im.width);
    h += im.height;
  }
  Image out(w, h, background);  // checks the sides
  int y0 = 0;
  for (const auto& im : images) {
    for (int y = 0; y < im.height; ++y)
      for (int x = 0; x < im.width; ++x) out.at(x, y0 + y) = im.at(x, y);
    y0 += im.height;
  }
  return out;
}

std::string encode_png(const Image& img) {
  require_consistent(img, "encode_png");
  std::string bytes;
  auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), std::size_t(size));
  };
  if (stbi_write_png_to_func(append, &bytes, img.width, img.height, 3, img.pixels.data(),
                             img.width * 3) == 0)
    fail<Error>("encode_png: cannot encode the {}×{} image", img.width, img.height);
  return bytes;
}

void write_png(const std::filesystem::path& path, const Image& img) {
  require_consistent(img, "write_png");
  const std::string bytes = encode_png(img);
  write_file_atomically(
      path, [&](std::ostream& out) { out.write(bytes.data(), std::streamsize(bytes.size())); },
      true);
}

Image render_views(const std::vector<MeshLayer>& layers, const std::vector<Marker>& markers,
                   const std::vector<std::pair<Camera, std::string>>& views, int view_px,
                   const std::string& title) {
  require(!views.empty(), "render_views: no views (expected at least one camera)");
  require(view_px >= 64 && view_px <= 4096, "render_views: view size {} px (expected 64..4096)",
          view_px);
  validate_scene("render_views", layers, markers);
  geometry::Aabb box;
  for (const auto& layer : layers)
    for (const auto& v : layer.mesh->vertices) box.extend(v);
  for (const auto& marker : markers) box.extend(marker.position);
  require(!box.is_empty(), "render_views: nothing to draw (no vertices and no markers)");

  constexpr int kPad = 10, kTitleScale = 3, kCaptionScale = 2, kBarWidth = 18;
  const MeshLayer* valued = nullptr;
  for (const auto& layer : layers)
    if (!layer.vertex_values.empty()) {
      valued = &layer;
      break;
    }
  int bar_column = 0;
  if (valued != nullptr) {
    int label_w = text_width(valued->value_label, kCaptionScale) - kBarWidth;
    for (const auto& tick : nice_ticks(valued->value_min, valued->value_max))
      label_w = std::max(label_w, 8 + text_width(tick.second, kCaptionScale));
    bar_column = kPad + kBarWidth + label_w + kPad;
  }
  const int title_h = title.empty() ? kPad : kPad + text_height(title, kTitleScale);
  int caption_h = 0;
  for (const auto& view : views)
    caption_h = std::max(caption_h, text_height(view.second, kCaptionScale));
  const int n = int(views.size());
  Image img(n * view_px + bar_column, title_h + view_px + caption_h + kPad, kWhite);

  draw_text(img, (img.width - text_width(title, kTitleScale)) / 2, kPad, title, kInk, kTitleScale);
  RenderOptions options;
  options.scale_px_per_m = std::numeric_limits<double>::infinity();
  for (const auto& view : views)
    options.scale_px_per_m =
        std::min(options.scale_px_per_m,
                 fit(view.first, box, 0, 0, view_px, view_px, options.margin).px_per_m);
  for (int k = 0; k < n; ++k) {
    render(img, views[k].first, layers, markers, k * view_px, title_h, view_px, view_px, box,
           options);
    const std::string& caption = views[k].second;
    draw_text(img, k * view_px + (view_px - text_width(caption, kCaptionScale)) / 2,
              title_h + view_px, caption, kInk, kCaptionScale);
  }
  if (valued != nullptr) {
    const int label_room = kUnitLabelRows * kCaptionScale;
    draw_colour_bar(img, n * view_px + kPad, title_h + view_px / 8 + label_room, kBarWidth,
                    view_px * 3 / 4 - label_room, valued->colormap, valued->value_min,
                    valued->value_max, valued->value_label);
  }
  return img;
}

}  // namespace socketsmith::report
