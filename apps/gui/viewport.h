#pragma once
/// @file viewport.h
/// The 3D view of socketsmith-gui: an orbit camera and an OpenGL 3.3 core renderer of triangle
/// meshes with per-vertex colours (the stump coloured by a field, the bones, the translucent
/// socket) and line strips (the brim). World units are metres; the camera orbits a target point.

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/geometry/tri_mesh.h"

namespace socketsmith::gui {

using Vec3 = Eigen::Vector3d;

/// An RGBA colour, components in [0, 1].
using Rgba = std::array<float, 4>;

/// Orbit camera: looks at `target` from `distance` along the direction given by yaw and pitch
/// about the world axis `up` (the limb axis). Perspective projection.
struct OrbitCamera {
  Vec3 target = Vec3::Zero();      ///< [m]
  Vec3 up = Vec3::UnitZ();         ///< world up (unit)
  Vec3 front = Vec3::UnitX();      ///< world direction seen at yaw 0 (unit, ⟂ up)
  double yaw_rad = 0.6;            ///< about up, from front
  double pitch_rad = 0.25;         ///< above the horizontal, (−π/2, π/2)
  double distance_m = 0.6;         ///< eye to target [m], > 0
  double fov_y_rad = 0.6;          ///< vertical field of view

  Vec3 eye() const;
  /// 4×4 view matrix (world → eye).
  Eigen::Matrix4f view() const;
  /// 4×4 projection for an aspect ratio width/height.
  Eigen::Matrix4f projection(double aspect) const;
  /// Frames a bounding box (target at its centre, distance to see it whole).
  void frame(const geometry::Aabb& box);
  /// Mouse drag of (dx, dy) pixels: orbit (rotate) or pan in the view plane.
  void orbit(double dx_px, double dy_px);
  void pan(double dx_px, double dy_px, double viewport_height_px);
  /// Wheel: zoom by a factor per notch.
  void zoom(double notches);
  /// The ray through viewport pixel (x, y) (origin, unit direction), y downward.
  std::pair<Vec3, Vec3> ray(double x_px, double y_px, double width_px, double height_px) const;
  /// Screen position (x, y in pixels, y downward) of a world point; nullopt behind the eye.
  std::optional<Eigen::Vector2d> project(const Vec3& p, double width_px, double height_px) const;
};

/// The first hit of a ray on a triangle mesh: triangle index and world point; nullopt on a miss.
struct RayHit {
  int triangle = -1;
  Vec3 point = Vec3::Zero();
  double distance_m = 0;
};
std::optional<RayHit> pick(const geometry::TriMesh& mesh, const Vec3& origin, const Vec3& direction);

/// A triangle mesh on the GPU (positions, smooth normals, per-vertex colours).
class GpuMesh {
 public:
  GpuMesh() = default;
  ~GpuMesh();
  GpuMesh(const GpuMesh&) = delete;
  GpuMesh& operator=(const GpuMesh&) = delete;

  /// Uploads geometry (smooth vertex normals computed here) with per-vertex colours (#V) or one
  /// colour for all vertices.
  void set_geometry(const geometry::TriMesh& mesh);
  void set_colours(const std::vector<Rgba>& colours);
  void set_colour(const Rgba& colour);
  bool empty() const { return index_count_ == 0; }
  void draw() const;

 private:
  void ensure_buffers();
  unsigned vao_ = 0, vbo_pos_ = 0, vbo_nrm_ = 0, vbo_col_ = 0, ebo_ = 0;
  int index_count_ = 0;
  int vertex_count_ = 0;
};

/// A line strip on the GPU (e.g. the brim), one colour.
class GpuLines {
 public:
  GpuLines() = default;
  ~GpuLines();
  GpuLines(const GpuLines&) = delete;
  GpuLines& operator=(const GpuLines&) = delete;
  void set_points(const std::vector<Vec3>& points, bool closed);
  void draw() const;

 private:
  unsigned vao_ = 0, vbo_ = 0;
  int count_ = 0;
  bool closed_ = false;
};

/// The shader program shared by meshes and lines: headlight Lambert + ambient, alpha.
class MeshRenderer {
 public:
  MeshRenderer();
  ~MeshRenderer();
  MeshRenderer(const MeshRenderer&) = delete;
  MeshRenderer& operator=(const MeshRenderer&) = delete;

  /// Starts drawing into the bound framebuffer (width × height pixels) with the camera.
  void begin(const OrbitCamera& camera, int width, int height);
  /// Draws an opaque mesh (depth written).
  void draw_opaque(const GpuMesh& mesh);
  /// Draws a translucent mesh (after the opaque ones; depth tested, not written; back faces
  /// culled: the mesh's outward, counter-clockwise faces are seen).
  void draw_translucent(const GpuMesh& mesh, float alpha);
  /// Draws a line strip in one colour, unlit, always on top when @p on_top.
  void draw_lines(const GpuLines& lines, const Rgba& colour, bool on_top);
  void end();

 private:
  unsigned program_ = 0;
  int loc_mvp_ = -1, loc_view_ = -1, loc_alpha_ = -1, loc_lit_ = -1, loc_colour_ = -1, loc_use_colour_ = -1;
};

/// An offscreen framebuffer the 3D view is rendered into (multisampled when samples > 1), blitted
/// into the window every frame: the scene is redrawn only when it changed, the panels every frame
/// (with software OpenGL the scene's shading is the costly part of a frame).
class SceneTarget {
 public:
  SceneTarget() = default;
  ~SceneTarget();
  SceneTarget(const SceneTarget&) = delete;
  SceneTarget& operator=(const SceneTarget&) = delete;
  /// (Re)creates the buffers when the size or sample count changed; true when it did.
  bool resize(int width, int height, int samples);
  /// Binds it for drawing (viewport set to its size).
  void bind() const;
  /// Copies (resolves) it into the window's framebuffer at (x, y) from the bottom-left.
  void blit_to_window(int x, int y) const;
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  unsigned fbo_ = 0, colour_ = 0, depth_ = 0;
  int width_ = 0, height_ = 0, samples_ = 0;
};

/// Reads the back buffer's pixels (RGB, top row first) of a width × height framebuffer.
std::vector<std::uint8_t> read_pixels(int width, int height);

}  // namespace socketsmith::gui
