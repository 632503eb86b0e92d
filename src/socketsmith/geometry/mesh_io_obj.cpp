// The Wavefront OBJ reader, with one-line errors that name the file and the line (mesh_io_detail.h
// says why the readers are apart).
#include "socketsmith/geometry/mesh_io_detail.h"

namespace socketsmith::geometry::mesh_io_detail {

TriMesh parse_obj(const Source& src) {
  const char* p = src.data.data();
  const char* const end = p + src.data.size();
  if (!looks_like_text(src.data))
    fail("read_mesh: '{}' is binary, not a text OBJ file", src.name);
  TriMesh mesh;
  mesh.vertices.reserve(src.data.size() / 60);
  mesh.triangles.reserve(src.data.size() / 30);
  std::vector<int> poly;
  long long max_index = -1;  // positive indices may only be checked once all vertices are read
  int max_index_line = 0;
  int line = 0;
  int faces = 0;

  while (p < end) {
    ++line;
    const char* eol = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)));
    if (!eol) eol = end;
    const char* q = skip_blanks(p, eol);
    const char* kw_end = q;
    while (kw_end < eol && !is_space(*kw_end)) ++kw_end;
    const std::string_view kw(q, static_cast<std::size_t>(kw_end - q));
    q = kw_end;
    if (kw == "v") {
      Vec3 v;
      for (int k = 0; k < 3; ++k) {
        q = skip_blanks(q, eol);
        const char* r = parse_double(q, eol, v[k]);
        if (!r || q == eol)
          fail("read_mesh: '{}' line {}: expected 3 numbers after 'v', got '{}'", src.name, line,
               shown(std::string_view(p, static_cast<std::size_t>(eol - p))));
        q = r;
      }
      if (!is_finite(v))
        fail("read_mesh: '{}' line {}: vertex {} has a non-finite coordinate ({}, {}, {}) (expected "
             "finite numbers)",
             src.name, line, mesh.vertices.size() + 1, v.x(), v.y(), v.z());
      mesh.vertices.push_back(v);
    } else if (kw == "f") {
      ++faces;
      poly.clear();
      const long long nv = static_cast<long long>(mesh.vertices.size());
      for (;;) {
        q = skip_blanks(q, eol);
        if (q == eol || *q == '#') break;  // end of line or a trailing comment
        long long idx = 0;
        auto [r, ec] = std::from_chars(q, eol, idx);
        if (ec != std::errc() || (r < eol && !is_space(*r) && *r != '/'))
          fail("read_mesh: '{}' line {}: bad vertex index '{}' in face (expected v, v/vt, v/vt/vn "
               "or v//vn)",
               src.name, line, shown(std::string_view(q, static_cast<std::size_t>(token_end(q, eol) - q))));
        if (idx == 0)
          fail("read_mesh: '{}' line {}: vertex index 0 in face (OBJ indices start at 1)", src.name, line);
        if (idx < 0) {
          idx += nv;  // relative to the vertices read so far
          if (idx < 0)
            fail("read_mesh: '{}' line {}: relative index {} is out of range: only {} vertices "
                 "precede this face",
                 src.name, line, idx - nv, nv);
        } else {
          idx -= 1;
          if (idx > max_index) {
            max_index = idx;
            max_index_line = line;
          }
          if (idx >= INT_MAX)
            fail("read_mesh: '{}' line {}: vertex index {} is out of range", src.name, line, idx + 1);
        }
        poly.push_back(static_cast<int>(idx));
        q = token_end(r, eol);
      }
      if (poly.size() < 3)
        fail("read_mesh: '{}' line {}: face has {} vertices (expected at least 3)", src.name, line,
             poly.size());
      for (std::size_t j = 1; j + 1 < poly.size(); ++j) mesh.triangles.push_back({poly[0], poly[j], poly[j + 1]});
    }
    // Other statements (vt, vn, g, o, s, usemtl, mtllib, l, comments...) carry no surface.
    p = eol + (eol < end ? 1 : 0);
  }
  if (mesh.vertices.empty() && faces == 0)
    fail("read_mesh: '{}' is not an OBJ mesh: it has no 'v' or 'f' lines", src.name);
  if (max_index >= static_cast<long long>(mesh.vertices.size()))
    fail("read_mesh: '{}' line {}: face refers to vertex {} but the file has {} vertices", src.name,
         max_index_line, max_index + 1, mesh.vertices.size());
  return mesh;
}

}  // namespace socketsmith::geometry::mesh_io_detail
