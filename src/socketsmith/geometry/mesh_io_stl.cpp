// The STL reader, binary and ASCII, with one-line errors that name the file and the line
// (mesh_io_detail.h says why the readers are apart).
#include "socketsmith/geometry/mesh_io_detail.h"

namespace socketsmith::geometry::mesh_io_detail {
namespace {

TriMesh parse_stl_binary(const Source& src) {
  const std::string_view d = src.data;
  const std::uint32_t n = load_le<std::uint32_t>(d.data() + 80);
  TriMesh mesh;
  mesh.vertices.resize(3 * static_cast<std::size_t>(n));
  mesh.triangles.resize(n);
  const char* rec = d.data() + 84;
  for (std::uint32_t t = 0; t < n; ++t, rec += 50) {
    for (int k = 0; k < 3; ++k) {
      const char* v = rec + 12 + 12 * k;
      Vec3 p(load_le<float>(v), load_le<float>(v + 4), load_le<float>(v + 8));
      if (!is_finite(p))
        fail("read_mesh: '{}' triangle {} has a non-finite coordinate ({}, {}, {}) (expected finite "
             "numbers)",
             src.name, t, p.x(), p.y(), p.z());
      mesh.vertices[3 * t + k] = p;
    }
    const int b = 3 * static_cast<int>(t);
    mesh.triangles[t] = {b, b + 1, b + 2};
  }
  return mesh;
}

TriMesh parse_stl_ascii(const Source& src) {
  const char* p = src.data.data();
  const char* const end = p + src.data.size();
  TriMesh mesh;
  mesh.vertices.reserve(src.data.size() / 100);
  mesh.triangles.reserve(src.data.size() / 250);
  std::size_t loop_start = 0;
  bool in_loop = false;
  int facets = 0;

  auto next = [&]() -> std::string_view {
    p = skip_space(p, end);
    const char* b = p;
    p = token_end(p, end);
    return {b, static_cast<std::size_t>(p - b)};
  };
  auto unexpected = [&](std::string_view tok, std::string_view expected) {
    fail("read_mesh: '{}' line {}: expected {} in ASCII STL, got '{}'", src.name,
         src.line_of(tok.data()), expected, tok.empty() ? "end of file" : shown(tok));
  };

  for (;;) {
    const std::string_view tok = next();
    if (tok.empty()) break;
    if (tok == "vertex") {
      if (!in_loop) unexpected(tok, "'outer loop' before 'vertex'");
      Vec3 v;
      for (int k = 0; k < 3; ++k) {
        p = skip_space(p, end);
        const char* q = parse_double(p, end, v[k]);
        if (!q) unexpected({p, static_cast<std::size_t>(token_end(p, end) - p)}, "a number after 'vertex'");
        p = q;
      }
      if (!is_finite(v))
        fail("read_mesh: '{}' line {}: non-finite coordinate ({}, {}, {}) (expected finite numbers)",
             src.name, src.line_of(p), v.x(), v.y(), v.z());
      mesh.vertices.push_back(v);
    } else if (tok == "facet") {
      if (in_loop) unexpected(tok, "'endloop'");
      if (const auto t2 = next(); t2 != "normal") unexpected(t2, "'normal' after 'facet'");
      for (int k = 0; k < 3; ++k) next();  // normals are recomputed from the vertices
      ++facets;
    } else if (tok == "outer") {
      if (const auto t2 = next(); t2 != "loop") unexpected(t2, "'loop' after 'outer'");
      in_loop = true;
      loop_start = mesh.vertices.size();
    } else if (tok == "endloop") {
      if (!in_loop) unexpected(tok, "'outer loop' before 'endloop'");
      const std::size_t k = mesh.vertices.size() - loop_start;
      if (k < 3)
        fail("read_mesh: '{}' line {}: facet {} has {} vertices (expected 3)", src.name,
             src.line_of(tok.data()), facets, k);
      for (std::size_t j = 1; j + 1 < k; ++j)  // polygons (non-standard) are fan-triangulated
        mesh.triangles.push_back({static_cast<int>(loop_start), static_cast<int>(loop_start + j),
                                  static_cast<int>(loop_start + j + 1)});
      in_loop = false;
    } else if (tok == "endfacet") {
      if (in_loop) unexpected(tok, "'endloop'");
    } else if (tok == "solid" || tok == "endsolid") {
      if (in_loop) unexpected(tok, "'endloop'");
      while (p < end && *p != '\n') ++p;  // the solid's name
    } else {
      unexpected(tok, "'facet', 'outer loop', 'vertex', 'endloop', 'endfacet' or 'endsolid'");
    }
  }
  if (in_loop)
    fail("read_mesh: '{}' ends inside facet {} (truncated ASCII STL?)", src.name, facets);
  return mesh;
}

}  // namespace

TriMesh parse_stl(const Source& src, std::string& format) {
  const std::string_view d = src.data;
  const std::string_view head = d.substr(skip_space(d.data(), d.data() + d.size()) - d.data());
  const bool text = looks_like_text(d);
  // A binary STL may start with "solid" too, but its count and float bytes are not text.
  if (text && head.starts_with("solid")) {
    format = "stl-ascii";
    return parse_stl_ascii(src);
  }
  if (text)
    fail("read_mesh: '{}' is not an STL file: it is text that does not start with 'solid', and its "
         "size ({} bytes) does not fit a binary STL",
         src.name, d.size());
  if (d.size() < 84)
    fail("read_mesh: '{}' is truncated: {} bytes, but a binary STL needs at least 84", src.name,
         d.size());
  const std::uint32_t n = load_le<std::uint32_t>(d.data() + 80);
  const std::uint64_t expected = 84 + 50 * static_cast<std::uint64_t>(n);
  if (n == 0)
    fail("read_mesh: '{}' has 0 triangles (expected a closed surface)", src.name);
  if (d.size() < expected)
    fail("read_mesh: '{}' is a truncated binary STL: its header declares {} triangles ({} bytes) "
         "but the file has {} bytes",
         src.name, n, expected, d.size());
  if (n > static_cast<std::uint32_t>(INT_MAX / 3))
    fail("read_mesh: '{}' declares {} triangles, more than this reader supports", src.name, n);
  if (d.size() > expected)
    log::warn("read_mesh: '{}' has {} bytes after the {} triangles its header declares; ignoring them",
              src.name, d.size() - expected, n);
  format = "stl-binary";
  return parse_stl_binary(src);
}

}  // namespace socketsmith::geometry::mesh_io_detail
