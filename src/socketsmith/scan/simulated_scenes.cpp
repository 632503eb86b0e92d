// The scenes of simulated_sensor.h: the thesis's targets (a cylinder, the calibration box, a flat
// chessboard) and the scenes with printed chessboards on them (a calibration board, the box with a
// board on each side). Building a scene needs nothing of the sensor, which simulated_sensor.cpp
// renders.
#include "socketsmith/scan/simulated_sensor.h"

#include <cmath>

#include "socketsmith/core/errors.h"

namespace socketsmith::scan {
namespace {

/// Adds a grid of n1 × n2 quads spanning origin + [0,1]·e1 + [0,1]·e2 (normal e1 × e2).
void add_grid_face(geometry::TriMesh& m, const Vec3& origin, const Vec3& e1, const Vec3& e2, int n1, int n2) {
  const int base = m.num_vertices();
  for (int j = 0; j <= n2; ++j)
    for (int i = 0; i <= n1; ++i) m.vertices.push_back(origin + e1 * (double(i) / n1) + e2 * (double(j) / n2));
  auto id = [&](int i, int j) { return base + j * (n1 + 1) + i; };
  for (int j = 0; j < n2; ++j)
    for (int i = 0; i < n1; ++i) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
}

geometry::TriMesh make_box_cells(const Vec3& size, const Vec3& center, const Eigen::Vector3i& cells) {
  const Vec3 lo = center - 0.5 * size;
  const Vec3 X = Vec3::UnitX() * size.x(), Y = Vec3::UnitY() * size.y(), Z = Vec3::UnitZ() * size.z();
  geometry::TriMesh m;
  add_grid_face(m, lo + X, Y, Z, cells.y(), cells.z());  // +x
  add_grid_face(m, lo, Z, Y, cells.z(), cells.y());      // -x
  add_grid_face(m, lo + Y, Z, X, cells.z(), cells.x());  // +y
  add_grid_face(m, lo, X, Z, cells.x(), cells.z());      // -y
  add_grid_face(m, lo + Z, X, Y, cells.x(), cells.y());  // +z
  add_grid_face(m, lo, Y, X, cells.y(), cells.x());      // -z
  return geometry::weld_vertices(m, 1e-9);
}

}  // namespace

geometry::TriMesh make_cylinder(double diameter_m, double height_m, const Vec3& center, int segments, int rings) {
  require(std::isfinite(diameter_m) && diameter_m > 0.0 && std::isfinite(height_m) && height_m > 0.0,
          "make_cylinder: diameter {} m and height {} m must be positive", diameter_m, height_m);
  require(segments >= 8 && rings >= 1, "make_cylinder: need at least 8 segments and 1 ring");
  const double r = diameter_m / 2;
  geometry::TriMesh m;
  for (int j = 0; j <= rings; ++j)
    for (int i = 0; i < segments; ++i) {
      const double a = 2.0 * M_PI * i / segments;
      m.vertices.push_back(center + Vec3(r * std::cos(a), r * std::sin(a), -height_m / 2 + height_m * j / rings));
    }
  auto id = [&](int i, int j) { return j * segments + (i % segments); };
  for (int j = 0; j < rings; ++j)
    for (int i = 0; i < segments; ++i) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  const int cb = m.num_vertices();
  m.vertices.push_back(center - Vec3(0, 0, height_m / 2));
  const int ct = m.num_vertices();
  m.vertices.push_back(center + Vec3(0, 0, height_m / 2));
  for (int i = 0; i < segments; ++i) {
    m.triangles.push_back({cb, id(i + 1, 0), id(i, 0)});
    m.triangles.push_back({ct, id(i, rings), id(i + 1, rings)});
  }
  return m;
}

geometry::TriMesh make_box(const Vec3& size, const Vec3& center) {
  require(size.allFinite() && (size.array() > 0.0).all(), "make_box: sizes must be positive");
  const double cell = 0.02;
  const Eigen::Vector3i cells((size / cell).array().ceil().cast<int>().cwiseMax(1).matrix());
  return make_box_cells(size, center, cells);
}

geometry::TriMesh make_chessboard(int cols, int rows, double square_m, const Vec3& center, double thickness_m) {
  require(cols >= 2 && rows >= 2 && cols <= 100 && rows <= 100,
          "make_chessboard: {}x{} squares (expected 2 to 100 each way)", cols, rows);
  require(std::isfinite(square_m) && square_m > 0.0 && thickness_m > 0.0,
          "make_chessboard: square {} m and thickness {} m must be positive", square_m, thickness_m);
  const Vec3 size(cols * square_m, thickness_m, rows * square_m);
  return make_box_cells(size, center + Vec3(0, thickness_m / 2, 0), Eigen::Vector3i(cols, 1, rows));
}

ChessboardPatch calibration_chessboard(const Eigen::Isometry3d& world_from_board) {
  ChessboardPatch b;
  b.pattern = ChessboardPattern{9, 6, 0.06};
  b.margin_m = 0.06;
  b.world_from_board = world_from_board;
  return b;
}

Scene make_chessboard_scene(const ChessboardPatch& board, double thickness_m) {
  validate_pattern(board.pattern, "make_chessboard_scene");
  require(std::isfinite(board.margin_m) && board.margin_m >= 0.0 && std::isfinite(thickness_m) && thickness_m > 0.0,
          "make_chessboard_scene: margin {} m must be >= 0 and thickness {} m positive", board.margin_m, thickness_m);
  const Eigen::Vector2d h = board.half_size();
  Scene scene;
  // Board frame: the printed face at z = 0 faces −z; the slab extends to +z.
  scene.mesh = make_box_cells(Vec3(2 * h.x(), 2 * h.y(), thickness_m), Vec3(0, 0, thickness_m / 2),
                              Eigen::Vector3i(board.pattern.inner_cols + 1, board.pattern.inner_rows + 1, 1));
  for (Vec3& v : scene.mesh.vertices) v = board.world_from_board * v;
  scene.chessboards.push_back(board);
  return scene;
}

Scene make_box_scene(const Vec3& size, const Eigen::Isometry3d& world_from_box, const ChessboardPattern& pattern,
                     double margin_m) {
  validate_pattern(pattern, "make_box_scene");
  Scene scene;
  scene.mesh = make_box(size);
  for (Vec3& v : scene.mesh.vertices) v = world_from_box * v;
  const Vec3 normals[4] = {Vec3::UnitX(), Vec3::UnitY(), -Vec3::UnitX(), -Vec3::UnitY()};
  for (const Vec3& out : normals) {
    ChessboardPatch b;
    b.pattern = pattern;
    b.margin_m = margin_m;
    const Eigen::Vector2d h = b.half_size();
    const double face_width = std::abs(out.x()) > 0.5 ? size.y() : size.x();
    require(2 * h.x() <= face_width + 1e-9 && 2 * h.y() <= size.z() + 1e-9,
            "make_box_scene: a {:.0f} x {:.0f} mm board does not fit a {:.0f} x {:.0f} mm face (smaller squares or "
            "margin)",
            2e3 * h.x(), 2e3 * h.y(), face_width * 1e3, size.z() * 1e3);
    // Board axes: z into the box, y down the face, x = y × z (rows read left to right from outside).
    const Vec3 z = -out, y = -Vec3::UnitZ(), x = y.cross(z);
    Eigen::Isometry3d box_from_board = Eigen::Isometry3d::Identity();
    box_from_board.linear().col(0) = x;
    box_from_board.linear().col(1) = y;
    box_from_board.linear().col(2) = z;
    box_from_board.translation() = out * (0.5 * out.cwiseAbs().dot(size));
    b.world_from_board = world_from_box * box_from_board;
    scene.chessboards.push_back(b);
  }
  return scene;
}

}  // namespace socketsmith::scan
