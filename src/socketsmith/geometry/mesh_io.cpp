#include "socketsmith/geometry/mesh_io.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <ostream>
#include <string_view>
#include <system_error>

#include <fmt/format.h>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/geometry/aaop.h"

#include "socketsmith/geometry/mesh_io_detail.h"

namespace socketsmith::geometry {
using namespace mesh_io_detail;
namespace {

// ---------------------------------------------------------------------------------------------
// Writers

Vec3 scaled_vertex(const TriMesh& mesh, int v, double s) { return mesh.vertices[v] * s; }

std::string stl_binary(const TriMesh& mesh, double s, units::LengthUnit unit) {
  std::string buf(84 + 50 * mesh.triangles.size(), '\0');
  std::string header = fmt::format("socketsmith binary STL, unit: {}", units::to_string(unit));
  header.resize(80, ' ');
  std::memcpy(buf.data(), header.data(), 80);
  char* p = buf.data() + 80;
  store_le(p, static_cast<std::uint32_t>(mesh.triangles.size()));
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    const Vec3 n = triangle_normal(mesh, t);
    for (int k = 0; k < 3; ++k) store_le(p, static_cast<float>(n[k]));
    for (int c = 0; c < 3; ++c) {
      const Vec3 v = scaled_vertex(mesh, mesh.triangles[t][c], s);
      for (int k = 0; k < 3; ++k) store_le(p, static_cast<float>(v[k]));
    }
    store_le(p, std::uint16_t{0});
  }
  return buf;
}

void stl_ascii(fmt::memory_buffer& b, const TriMesh& mesh, double s) {
  auto out = std::back_inserter(b);
  fmt::format_to(out, "solid socketsmith\n");
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    const Vec3 n = triangle_normal(mesh, t);
    fmt::format_to(out, "  facet normal {} {} {}\n    outer loop\n", n.x(), n.y(), n.z());
    for (int c = 0; c < 3; ++c) {
      const Vec3 v = scaled_vertex(mesh, mesh.triangles[t][c], s);
      fmt::format_to(out, "      vertex {} {} {}\n", v.x(), v.y(), v.z());
    }
    fmt::format_to(out, "    endloop\n  endfacet\n");
  }
  fmt::format_to(out, "endsolid socketsmith\n");
}

void obj_text(fmt::memory_buffer& b, const TriMesh& mesh, double s, units::LengthUnit unit) {
  auto out = std::back_inserter(b);
  fmt::format_to(out, "# socketsmith OBJ, unit: {}\n", units::to_string(unit));
  for (const Vec3& p : mesh.vertices) {
    const Vec3 v = p * s;
    fmt::format_to(out, "v {} {} {}\n", v.x(), v.y(), v.z());
  }
  for (const auto& t : mesh.triangles) fmt::format_to(out, "f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
}

std::string ply_header(const TriMesh& mesh, units::LengthUnit unit, bool binary) {
  return fmt::format(
      "ply\nformat {} 1.0\ncomment socketsmith, unit: {}\nelement vertex {}\nproperty double x\n"
      "property double y\nproperty double z\nelement face {}\nproperty list uchar int "
      "vertex_indices\nend_header\n",
      binary ? "binary_little_endian" : "ascii", units::to_string(unit), mesh.vertices.size(),
      mesh.triangles.size());
}

void ply_ascii(fmt::memory_buffer& b, const TriMesh& mesh, double s, units::LengthUnit unit) {
  auto out = std::back_inserter(b);
  fmt::format_to(out, "{}", ply_header(mesh, unit, false));
  for (const Vec3& p : mesh.vertices) {
    const Vec3 v = p * s;
    fmt::format_to(out, "{} {} {}\n", v.x(), v.y(), v.z());
  }
  for (const auto& t : mesh.triangles) fmt::format_to(out, "3 {} {} {}\n", t[0], t[1], t[2]);
}

std::string ply_binary(const TriMesh& mesh, double s, units::LengthUnit unit) {
  const std::string header = ply_header(mesh, unit, true);
  std::string buf(header.size() + 24 * mesh.vertices.size() + 13 * mesh.triangles.size(), '\0');
  std::memcpy(buf.data(), header.data(), header.size());
  char* p = buf.data() + header.size();
  for (const Vec3& q : mesh.vertices)
    for (int k = 0; k < 3; ++k) store_le(p, q[k] * s);
  for (const auto& t : mesh.triangles) {
    store_le(p, std::uint8_t{3});
    for (int k = 0; k < 3; ++k) store_le(p, static_cast<std::int32_t>(t[k]));
  }
  return buf;
}

/// An AAOP shape as a surface in the file's numbers (mm), its landmarks into @p inf (in metres, or
/// in the unit the caller declared).
TriMesh read_aaop_mesh(std::string_view data, const std::string& name, const MeshReadOptions& options,
                       MeshReadInfo& inf) {
  TriMesh mesh;
  // The format's unit is the millimetre: nothing to guess.
  inf.format = "aaop";
  const AaopShape shape = parse_aaop(data, name);
  if (const std::string side = lower(shape.side); side == "left" || side == "right") inf.side = side;
  bool distal_closed = false, proximal_closed = false;
  mesh = aaop_surface(shape, &distal_closed, &proximal_closed);
  const double f = options.unit ? units::to_metres(*options.unit) / units::mm : 1.0;
  for (const AaopLandmark& lm : shape.landmarks) {
    MeshLandmark out{lm.name, {}};
    for (const Vec3& p : lm.points_mm) out.points.push_back(aaop_point_m(p) * f);
    inf.landmarks.push_back(std::move(out));
  }
  // Back to the file's numbers: the unit conversion below applies to every format alike.
  for (Vec3& p : mesh.vertices) p /= units::mm;
  log::info("read_mesh: '{}': AAOP shape, {} spokes × {} slices, {} landmark(s); distal end {}, "
            "proximal end {}",
            name, shape.num_spokes(), shape.num_slices(), shape.landmarks.size(),
            distal_closed ? "closed" : "open", proximal_closed ? "closed" : "open");
  return mesh;
}

/// The warning for a surface whose size fits no body part in its unit (likely mm read as m or m as
/// mm), or nothing.
std::string implausible_size_warning(const std::string& name, double diagonal_m, const MeshReadInfo& inf) {
  const bool too_large = diagonal_m > kMaxPlausibleSize_m;
  if (!too_large && diagonal_m >= kMinPlausibleSize_m) return {};
  const std::string how = inf.unit_was_guessed ? "guessed" : "declared";
  const std::string unit = units::to_string(inf.unit);
  // Too large in metres: millimetres read as metres, and the other way round.
  const units::LengthUnit mistaken = too_large ? units::LengthUnit::Metre : units::LengthUnit::Millimetre;
  if (inf.unit == mistaken)
    return fmt::format("read_mesh: '{}' is {:.3g} m across in the {} unit '{}'; is it in {}? (give the unit: "
                       "limb.units \"{}\" in a case file, --units {} on the command line)",
                       name, diagonal_m, how, unit, too_large ? "millimetres" : "metres", too_large ? "mm" : "m",
                       too_large ? "mm" : "m");
  return fmt::format("read_mesh: '{}' is {:.3g} m across in the {} unit '{}', {} than any body part; check the "
                     "file's unit and scale",
                     name, diagonal_m, how, unit, too_large ? "larger" : "smaller");
}

/// One-line errors for a mesh no file should hold: an index out of range, a non-finite vertex.
void check_writable(const fs::path& path, const TriMesh& mesh, MeshFormat format) {
  const int nv = mesh.num_vertices();
  for (int t = 0; t < mesh.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k) {
      const int v = mesh.triangles[t][k];
      if (v < 0 || v >= nv)
        fail("write_mesh: '{}': triangle {} refers to vertex {} but the mesh has {} vertices",
             path.string(), t, v, nv);
    }
  for (int v = 0; v < nv; ++v)
    if (!is_finite(mesh.vertices[v]))
      fail("write_mesh: '{}': vertex {} has a non-finite coordinate (expected finite numbers)",
           path.string(), v);
  if (format == MeshFormat::PlyBinary || format == MeshFormat::PlyAscii) {
    require(mesh.vertices.size() <= static_cast<std::size_t>(INT_MAX), "write_mesh: too many vertices");
  }
}

}  // namespace

units::LengthUnit guess_length_unit(double raw_diagonal) {
  return raw_diagonal > 5.0 ? units::LengthUnit::Millimetre : units::LengthUnit::Metre;
}

TriMesh read_mesh(const fs::path& path, const MeshReadOptions& options, MeshReadInfo* info) {
  // Read first: a folder given as a mesh is "a directory", not "an unsupported extension ''".
  return read_mesh_data(read_file(path), path.string(), options, info);
}

TriMesh read_mesh_data(std::string_view data, const std::string& name, const MeshReadOptions& options,
                       MeshReadInfo* info) {
  require(std::isfinite(options.weld_tol_m) && options.weld_tol_m >= 0.0,
          "read_mesh: weld_tol_m is {} (expected a finite value >= 0 metres)", options.weld_tol_m);
  const std::string ext = lower(fs::path(name).extension().string());
  if (ext != ".stl" && ext != ".obj" && ext != ".ply" && ext != ".aop")
    fail("read_mesh: '{}' has an unsupported extension '{}' (expected .stl, .obj, .ply or .aop)", name,
         fs::path(name).extension().string());
  const Source src{name, data};
  if (data.empty()) fail("read_mesh: '{}' is empty (0 bytes); expected a mesh", src.name);
  if (std::all_of(data.begin(), data.end(), [](char c) { return is_space(c); }))
    fail("read_mesh: '{}' contains only whitespace; expected a mesh", src.name);

  MeshReadInfo local;
  MeshReadInfo& inf = info ? *info : local;
  inf = MeshReadInfo{};

  TriMesh mesh;
  const bool is_stl = ext == ".stl";
  const bool is_aaop = ext == ".aop";
  if (is_aaop) {
    mesh = read_aaop_mesh(data, src.name, options, inf);
  } else if (is_stl) {
    mesh = parse_stl(src, inf.format);
  } else if (ext == ".obj") {
    inf.format = "obj";
    mesh = parse_obj(src);
  } else {
    mesh = parse_ply(src, inf.format);
  }
  if (mesh.triangles.empty())
    fail("read_mesh: '{}' has 0 triangles (expected a closed surface){}", src.name,
         mesh.vertices.empty() ? "" : fmt::format("; it has {} vertices only", mesh.vertices.size()));

  // Units: the raw size decides when the caller did not say.
  const double raw_diagonal = bounding_box(mesh).extent().norm();
  inf.unit_was_guessed = !options.unit.has_value() && !is_aaop;
  inf.unit = options.unit ? *options.unit
             : is_aaop    ? units::LengthUnit::Millimetre
                          : guess_length_unit(raw_diagonal);
  if (inf.unit_was_guessed)
    log::info("read_mesh: '{}' has no declared unit; it is {:.4g} units across, so assuming {} "
              "(pass the unit to override)",
              src.name, raw_diagonal,
              inf.unit == units::LengthUnit::Millimetre ? "millimetres" : "metres");
  const double factor = units::to_metres(inf.unit);
  if (factor != 1.0)
    for (Vec3& p : mesh.vertices) p *= factor;

  // Welding: STL repeats every vertex per triangle, so it is always merged (at least exact
  // duplicates); OBJ/PLY vertices are shared already and are welded only when a tolerance is set.
  const std::size_t nv_before = mesh.vertices.size();
  const std::size_t nt_before = mesh.triangles.size();
  if (is_stl || options.weld_tol_m > 0.0) {
    mesh = weld_vertices(mesh, options.weld_tol_m);
  } else {
    std::erase_if(mesh.triangles, [](const std::array<int, 3>& t) {
      return t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
    });
  }
  inf.welded_vertices = static_cast<int>(nv_before - mesh.vertices.size());
  inf.dropped_triangles = static_cast<int>(nt_before - mesh.triangles.size());
  if (mesh.triangles.empty())
    fail("read_mesh: '{}' has 0 usable triangles: all {} are degenerate (repeated vertices)",
         src.name, nt_before);
  if (inf.dropped_triangles > 0)
    log::info("read_mesh: '{}': dropped {} degenerate triangle(s) with repeated vertices", src.name,
              inf.dropped_triangles);

  if (options.warn_on_implausible_size) {
    inf.warning = implausible_size_warning(src.name, raw_diagonal * factor, inf);
    if (!inf.warning.empty()) log::warn("{}", inf.warning);
  }
  log::debug("read_mesh: '{}' ({}): {} vertices, {} triangles, {} welded", src.name, inf.format,
             mesh.num_vertices(), mesh.num_triangles(), inf.welded_vertices);
  return mesh;
}

void write_mesh(const fs::path& path, const TriMesh& mesh, units::LengthUnit unit, MeshFormat format) {
  if (format == MeshFormat::Auto) {
    const std::string ext = lower(path.extension().string());
    if (ext == ".stl") format = MeshFormat::StlBinary;
    else if (ext == ".obj") format = MeshFormat::Obj;
    else if (ext == ".ply") format = MeshFormat::PlyBinary;
    else if (ext == ".aop") format = MeshFormat::Aaop;
    else
      fail("write_mesh: '{}' has an unknown extension '{}' (expected .stl, .obj, .ply or .aop, or pass a "
           "MeshFormat)",
           path.string(), path.extension().string());
  }
  check_writable(path, mesh, format);

  const double s = 1.0 / units::to_metres(unit);
  auto write_bytes = [&](std::string_view bytes) {
    write_file_atomically(path, [&](std::ostream& o) { o.write(bytes.data(), static_cast<std::streamsize>(bytes.size())); },
                          true);
  };

  switch (format) {
    case MeshFormat::StlBinary: {
      write_bytes(stl_binary(mesh, s, unit));
      break;
    }
    case MeshFormat::StlAscii: {
      fmt::memory_buffer b;
      stl_ascii(b, mesh, s);
      write_bytes({b.data(), b.size()});
      break;
    }
    case MeshFormat::Obj: {
      fmt::memory_buffer b;
      obj_text(b, mesh, s, unit);
      write_bytes({b.data(), b.size()});
      break;
    }
    case MeshFormat::PlyAscii: {
      fmt::memory_buffer b;
      ply_ascii(b, mesh, s, unit);
      write_bytes({b.data(), b.size()});
      break;
    }
    case MeshFormat::PlyBinary: {
      write_bytes(ply_binary(mesh, s, unit));
      break;
    }
    case MeshFormat::Aaop: {
      require(unit == units::LengthUnit::Millimetre,
              "write_mesh: '{}': AAOP files are in millimetres (asked for {})", path.string(),
              units::to_string(unit));
      write_aaop(path, sample_aaop(mesh));
      break;
    }
    case MeshFormat::Auto: break;
  }
}

}  // namespace socketsmith::geometry
