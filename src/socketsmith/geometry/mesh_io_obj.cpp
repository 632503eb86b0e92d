// The Wavefront OBJ reader, with one-line errors that name the file and the line (mesh_io_detail.h
// says why the readers are apart).
#include "socketsmith/geometry/mesh_io_detail.h"

namespace socketsmith::geometry::mesh_io_detail {
namespace {

/// The largest positive face index seen and its line: positive indices may only be checked once
/// all vertices are read.
struct MaxObjIndex {
  long long index = -1;
  int line = 0;
};

/// Reads a 'v' line's three coordinates from @p q (just past the keyword); @p p..eol is the line.
Vec3 parse_obj_vertex(const Source& src, int line, const char* p, const char* q, const char* eol,
                      std::size_t vertex_number) {
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
         src.name, line, vertex_number, v.x(), v.y(), v.z());
  return v;
}

/// Reads an 'f' line's vertex indices from @p q (just past the keyword) into @p poly, 0-based;
/// negative ones are relative to the @p num_vertices read so far.
void parse_obj_face(const Source& src, int line, const char* q, const char* eol,
                    long long num_vertices, std::vector<int>& poly, MaxObjIndex& max_index) {
  const long long nv = num_vertices;
  poly.clear();
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
      if (idx > max_index.index) {
        max_index.index = idx;
        max_index.line = line;
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
}

}  // namespace

TriMesh parse_obj(const Source& src) {
  const char* p = src.data.data();
  const char* const end = p + src.data.size();
  if (!looks_like_text(src.data))
    fail("read_mesh: '{}' is binary, not a text OBJ file", src.name);
  TriMesh mesh;
  mesh.vertices.reserve(src.data.size() / 60);
  mesh.triangles.reserve(src.data.size() / 30);
  std::vector<int> poly;
  MaxObjIndex max_index;
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
      mesh.vertices.push_back(parse_obj_vertex(src, line, p, q, eol, mesh.vertices.size() + 1));
    } else if (kw == "f") {
      ++faces;
      parse_obj_face(src, line, q, eol, static_cast<long long>(mesh.vertices.size()), poly, max_index);
      for (std::size_t j = 1; j + 1 < poly.size(); ++j) mesh.triangles.push_back({poly[0], poly[j], poly[j + 1]});
    }
    // Other statements (vt, vn, g, o, s, usemtl, mtllib, l, comments...) carry no surface.
    p = eol + (eol < end ? 1 : 0);
  }
  if (mesh.vertices.empty() && faces == 0)
    fail("read_mesh: '{}' is not an OBJ mesh: it has no 'v' or 'f' lines", src.name);
  if (max_index.index >= static_cast<long long>(mesh.vertices.size()))
    fail("read_mesh: '{}' line {}: face refers to vertex {} but the file has {} vertices", src.name,
         max_index.line, max_index.index + 1, mesh.vertices.size());
  return mesh;
}

}  // namespace socketsmith::geometry::mesh_io_detail
