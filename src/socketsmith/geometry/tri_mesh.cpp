#include "socketsmith/geometry/tri_mesh.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "socketsmith/core/errors.h"

namespace socketsmith::geometry {
namespace {

bool is_finite(const Vec3& p) { return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z()); }

void require_valid_indices(const TriMesh& mesh, const char* function) {
  const int nv = mesh.num_vertices();
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const int v = mesh.triangles[t][k];
      if (v < 0 || v >= nv)
        fail("{}: triangle {} refers to vertex {} but the mesh has {} vertices (valid: 0..{})",
             function, t, v, nv, nv - 1);
    }
  }
}

/// Integer cell coordinates of a hash grid, or the bit pattern of a position (exact mode).
struct CellKey {
  std::int64_t x, y, z;
  bool operator==(const CellKey&) const = default;
};

std::uint64_t hash_key(const CellKey& k) {
  // Multiply-xorshift mix of the three coordinates (splitmix64 finaliser).
  std::uint64_t h = static_cast<std::uint64_t>(k.x) * 0x9E3779B97F4A7C15ull;
  h ^= static_cast<std::uint64_t>(k.y) * 0xC2B2AE3D27D4EB4Full;
  h ^= static_cast<std::uint64_t>(k.z) * 0x165667B19E3779F9ull;
  h ^= h >> 31;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 29;
  return h;
}

/// Open-addressing map CellKey -> dense cell id. Slots hold only the cell id (4 bytes), the key
/// lives once per cell, so the table stays small and cache friendly for millions of vertices.
class CellTable {
 public:
  explicit CellTable(std::size_t expected_cells) {
    std::size_t cap = 16;
    while (cap < 2 * expected_cells) cap *= 2;
    slots_.assign(cap, -1);
    mask_ = cap - 1;
  }

  /// Cell id of @p key or -1.
  int find(const CellKey& key) const {
    for (std::size_t i = hash_key(key) & mask_;; i = (i + 1) & mask_) {
      const int c = slots_[i];
      if (c < 0) return -1;
      if (keys_[c] == key) return c;
    }
  }

  /// Adds @p key (which must not be present) and returns its new cell id.
  int insert(const CellKey& key) {
    if (2 * (keys_.size() + 1) > slots_.size()) grow();
    const int c = static_cast<int>(keys_.size());
    keys_.push_back(key);
    place(c);
    return c;
  }

 private:
  void place(int c) {
    std::size_t i = hash_key(keys_[c]) & mask_;
    while (slots_[i] >= 0) i = (i + 1) & mask_;
    slots_[i] = c;
  }
  void grow() {
    slots_.assign(slots_.size() * 2, -1);
    mask_ = slots_.size() - 1;
    for (int c = 0; c < static_cast<int>(keys_.size()); ++c) place(c);
  }

  std::vector<int> slots_;
  std::vector<CellKey> keys_;
  std::size_t mask_ = 0;
};

std::int64_t cell_coordinate(double f) {
  constexpr double kLimit = 4e18;  // keeps the cast defined for absurd coordinate / tolerance ratios
  return static_cast<std::int64_t>(std::clamp(std::floor(f), -kLimit, kLimit));
}

std::int64_t bits_of(double x) {
  return std::bit_cast<std::int64_t>(x + 0.0);  // + 0.0 maps -0.0 to +0.0
}


/// The welded vertices ("representatives") in a hash grid: the cells they fall in, and the chain
/// of representatives sharing each cell.
struct WeldGrid {
  std::vector<Vec3>& representatives;
  CellTable table;
  std::vector<int> cell_head;     // first representative vertex (output index) per cell
  std::vector<int> next_in_cell;  // chain of representatives sharing a cell

  WeldGrid(std::vector<Vec3>& out, std::size_t expected) : representatives(out), table(expected) {}

  /// Adds @p p as a new representative in cell @p cell_id (−1: in none); returns its index.
  int add_representative(const Vec3& p, int cell_id) {
    const int r = static_cast<int>(representatives.size());
    representatives.push_back(p);
    next_in_cell.push_back(-1);
    if (cell_id >= 0) {
      if (cell_id >= static_cast<int>(cell_head.size())) cell_head.resize(cell_id + 1, -1);
      next_in_cell[r] = cell_head[cell_id];
      cell_head[cell_id] = r;
    }
    return r;
  }

  /// The representative at exactly @p p's position (bit for bit), added if there is none.
  int weld_exact(const Vec3& p) {
    const CellKey key{bits_of(p.x()), bits_of(p.y()), bits_of(p.z())};
    int c = table.find(key);
    if (c >= 0) return cell_head[c];
    c = table.insert(key);
    return add_representative(p, c);
  }

  /// The first representative within tol of @p p (tol2 = tol² [m²], cells of 2 tol, @p inv_cell
  /// = 1 / cell [1/m]), added if there is none.
  int weld_within(const Vec3& p, double inv_cell, double tol2) {
    const Vec3 f = p * inv_cell;
    const CellKey own{cell_coordinate(f.x()), cell_coordinate(f.y()), cell_coordinate(f.z())};
    const std::int64_t dx = (f.x() - std::floor(f.x()) < 0.5) ? -1 : 1;
    const std::int64_t dy = (f.y() - std::floor(f.y()) < 0.5) ? -1 : 1;
    const std::int64_t dz = (f.z() - std::floor(f.z()) < 0.5) ? -1 : 1;
    int own_cell = -1;
    for (int k = 0; k < 8; ++k) {
      const CellKey key{own.x + ((k & 1) ? dx : 0), own.y + ((k & 2) ? dy : 0),
                        own.z + ((k & 4) ? dz : 0)};
      const int c = table.find(key);
      if (k == 0) own_cell = c;
      if (c < 0) continue;
      for (int r = cell_head[c]; r >= 0; r = next_in_cell[r])
        if ((representatives[r] - p).squaredNorm() <= tol2) return r;
    }
    if (own_cell < 0) own_cell = table.insert(own);
    return add_representative(p, own_cell);
  }
};

}  // namespace

Aabb bounding_box(const TriMesh& mesh) {
  Aabb box;
  for (const Vec3& p : mesh.vertices) box.extend(p);
  return box;
}

Vec3 triangle_normal(const TriMesh& mesh, int t) {
  const auto& tri = mesh.triangles.at(static_cast<std::size_t>(t));
  const Vec3& a = mesh.vertices.at(static_cast<std::size_t>(tri[0]));
  const Vec3& b = mesh.vertices.at(static_cast<std::size_t>(tri[1]));
  const Vec3& c = mesh.vertices.at(static_cast<std::size_t>(tri[2]));
  const Vec3 n = (b - a).cross(c - a);
  const double len = n.norm();
  if (!(len > 0.0) || !std::isfinite(len)) return Vec3::Zero();
  return n / len;
}

double triangle_area(const TriMesh& mesh, int t) {
  const auto& tri = mesh.triangles.at(static_cast<std::size_t>(t));
  const Vec3& a = mesh.vertices.at(static_cast<std::size_t>(tri[0]));
  const Vec3& b = mesh.vertices.at(static_cast<std::size_t>(tri[1]));
  const Vec3& c = mesh.vertices.at(static_cast<std::size_t>(tri[2]));
  return 0.5 * (b - a).cross(c - a).norm();
}

std::optional<Vec3> area_centroid(const TriMesh& mesh) {
  double total = 0.0;
  Vec3 mean = Vec3::Zero();
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    const auto& tri = mesh.triangles[static_cast<std::size_t>(t)];
    const double a = triangle_area(mesh, t);
    mean += a * (mesh.vertices[tri[0]] + mesh.vertices[tri[1]] + mesh.vertices[tri[2]]) / 3.0;
    total += a;
  }
  if (!(total > 0.0)) return std::nullopt;
  return mean / total;
}

double surface_area(const TriMesh& mesh) {
  require_valid_indices(mesh, "surface_area");
  double area = 0.0;
  for (const auto& t : mesh.triangles) {
    const Vec3& a = mesh.vertices[t[0]];
    area += 0.5 * (mesh.vertices[t[1]] - a).cross(mesh.vertices[t[2]] - a).norm();
  }
  return area;
}

double signed_volume(const TriMesh& mesh) {
  require_valid_indices(mesh, "signed_volume");
  if (mesh.triangles.empty()) return 0.0;
  // Tetrahedra from a point near the mesh (the box centre) to every triangle: the sum is
  // independent of that point for a closed surface, and a nearby point avoids cancellation.
  const Vec3 o = bounding_box(mesh).center();
  double six_v = 0.0;
  for (const auto& t : mesh.triangles) {
    const Vec3 a = mesh.vertices[t[0]] - o;
    const Vec3 b = mesh.vertices[t[1]] - o;
    const Vec3 c = mesh.vertices[t[2]] - o;
    six_v += a.dot(b.cross(c));
  }
  return six_v / 6.0;
}

void scale(TriMesh& mesh, double factor) {
  require(std::isfinite(factor) && factor != 0.0,
          "scale: factor is {} (expected a finite, non-zero number)", factor);
  for (Vec3& p : mesh.vertices) p *= factor;
}

void flip_orientation(TriMesh& mesh) {
  for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
}

TriMesh weld_vertices(const TriMesh& mesh, double abs_tol_m) {
  require(std::isfinite(abs_tol_m) && abs_tol_m >= 0.0,
          "weld_vertices: abs_tol_m is {} (expected a finite value >= 0; 0 merges only identical "
          "positions)",
          abs_tol_m);
  require_valid_indices(mesh, "weld_vertices");

  const std::size_t n = mesh.vertices.size();
  TriMesh out;
  std::vector<int> remap(n);
  // STL soups repeat each vertex ~6 times: start small and let the table grow.
  WeldGrid grid(out.vertices, n / 4 + 16);
  out.vertices.reserve(n / 4 + 16);

  const bool exact = abs_tol_m == 0.0;
  // Grid with cells of 2*tol: a neighbour within tol lies in the own cell or in the one adjacent
  // cell on the near side in each axis, so 8 cells are searched instead of 27 with cells of tol.
  const double cell = 2.0 * abs_tol_m;
  const double inv_cell = exact ? 0.0 : 1.0 / cell;
  const double tol2 = abs_tol_m * abs_tol_m;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3& p = mesh.vertices[i];
    if (!is_finite(p)) remap[i] = grid.add_representative(p, -1);  // never merge NaN/inf: callers report them
    else if (exact) remap[i] = grid.weld_exact(p);
    else remap[i] = grid.weld_within(p, inv_cell, tol2);
  }

  out.triangles.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) {
    const std::array<int, 3> m{remap[t[0]], remap[t[1]], remap[t[2]]};
    if (m[0] == m[1] || m[1] == m[2] || m[0] == m[2]) continue;
    out.triangles.push_back(m);
  }
  return out;
}

}  // namespace socketsmith::geometry
