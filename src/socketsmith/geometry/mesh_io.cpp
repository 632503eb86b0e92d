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

namespace socketsmith::geometry {
namespace {
namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Small helpers

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }
bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

bool is_finite(const Vec3& p) { return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z()); }

/// Everything a parser needs to name the file and the line in its messages.
struct Source {
  std::string name;       ///< the path as the user gave it
  std::string_view data;  ///< whole file

  int line_of(const char* p) const {
    const char* b = data.data();
    p = std::clamp(p, b, b + data.size());
    return 1 + static_cast<int>(std::count(b, p, '\n'));
  }
};

/// Shortens a token for an error message.
std::string shown(std::string_view tok) {
  if (tok.size() > 40) return std::string(tok.substr(0, 40)) + "...";
  return std::string(tok);
}

/// Reads the whole file; IoError when it cannot be opened or read.
std::string read_file(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec))
    fail<IoError>("read_mesh: cannot open '{}': it is a directory (expected a mesh file)", path.string());
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f)
    fail<IoError>("read_mesh: cannot open '{}': {} (check the path and permissions)", path.string(),
                  std::strerror(errno));
  std::string data;
  if (std::fseek(f, 0, SEEK_END) == 0) {
    const long size = std::ftell(f);
    if (size > 0) data.resize(static_cast<std::size_t>(size));
    std::fseek(f, 0, SEEK_SET);
  }
  std::size_t got = data.empty() ? 0 : std::fread(data.data(), 1, data.size(), f);
  // Non-seekable files (pipes): read in chunks.
  if (data.empty()) {
    char buf[1 << 16];
    std::size_t k;
    while ((k = std::fread(buf, 1, sizeof buf, f)) > 0) data.append(buf, k);
    got = data.size();
  }
  const bool bad = std::ferror(f) != 0;
  std::fclose(f);
  if (bad || got != data.size())
    fail<IoError>("read_mesh: cannot read '{}' (read {} of {} bytes)", path.string(), got, data.size());
  return data;
}

/// True when the first bytes look like text (no NUL or other control bytes).
bool looks_like_text(std::string_view d) {
  const std::size_t n = std::min<std::size_t>(d.size(), 512);
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<unsigned char>(d[i]);
    if ((c < 0x20 && !is_space(static_cast<char>(c))) || c == 0x7f) return false;
  }
  return true;
}

/// Parses a floating-point number at @p p (accepting a leading '+'); nullptr on failure.
/// The number must be followed by whitespace or the end of the data.
const char* parse_double(const char* p, const char* end, double& out) {
  const char* q = (p < end && *p == '+') ? p + 1 : p;
  auto [ptr, ec] = std::from_chars(q, end, out);
  if (ec == std::errc::result_out_of_range) {
    // Too large for a double: a non-finite coordinate. Keep the sign.
    out = (q < end && *q == '-') ? -HUGE_VAL : HUGE_VAL;
    if (ptr == q) return nullptr;
  } else if (ec != std::errc()) {
    return nullptr;
  }
  if (ptr < end && !is_space(*ptr)) return nullptr;
  return ptr;
}

const char* skip_blanks(const char* p, const char* end) {
  while (p < end && is_blank(*p)) ++p;
  return p;
}
const char* skip_space(const char* p, const char* end) {
  while (p < end && is_space(*p)) ++p;
  return p;
}
const char* token_end(const char* p, const char* end) {
  while (p < end && !is_space(*p)) ++p;
  return p;
}

template <class T>
T load_le(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) {
    auto* b = reinterpret_cast<unsigned char*>(&v);
    std::reverse(b, b + sizeof(T));
  }
  return v;
}

template <class T>
void store_le(char*& p, T v) {
  if constexpr (std::endian::native == std::endian::big) {
    auto* b = reinterpret_cast<unsigned char*>(&v);
    std::reverse(b, b + sizeof(T));
  }
  std::memcpy(p, &v, sizeof(T));
  p += sizeof(T);
}

// ---------------------------------------------------------------------------------------------
// STL

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

// ---------------------------------------------------------------------------------------------
// OBJ

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

// ---------------------------------------------------------------------------------------------
// PLY

enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

int ply_size(PlyType t) {
  switch (t) {
    case PlyType::Int8:
    case PlyType::UInt8: return 1;
    case PlyType::Int16:
    case PlyType::UInt16: return 2;
    case PlyType::Int32:
    case PlyType::UInt32:
    case PlyType::Float32: return 4;
    case PlyType::Float64: return 8;
  }
  return 0;
}

bool parse_ply_type(std::string_view s, PlyType& t) {
  if (s == "char" || s == "int8") t = PlyType::Int8;
  else if (s == "uchar" || s == "uint8") t = PlyType::UInt8;
  else if (s == "short" || s == "int16") t = PlyType::Int16;
  else if (s == "ushort" || s == "uint16") t = PlyType::UInt16;
  else if (s == "int" || s == "int32") t = PlyType::Int32;
  else if (s == "uint" || s == "uint32") t = PlyType::UInt32;
  else if (s == "float" || s == "float32") t = PlyType::Float32;
  else if (s == "double" || s == "float64") t = PlyType::Float64;
  else return false;
  return true;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::Float32;
  bool is_list = false;
  PlyType count_type = PlyType::UInt8;
};

struct PlyElement {
  std::string name;
  long long count = 0;
  std::vector<PlyProperty> props;
};

/// Thrown by the body readers; converted to InvalidInputError with context by parse_ply.
struct PlyTruncated {};
struct PlyBadToken {
  const char* where;
};
/// A list count or an index stored as a float that is not a whole number of a sane size.
struct PlyBadInteger {
  double value;
};

/// A float read where an integer is meant (some writers store list counts or indices as floats):
/// whole and below 2^53, else PlyBadInteger (casting 1.8e22 to long long is undefined behaviour).
long long whole_number(double d) {
  if (!std::isfinite(d) || d != std::floor(d) || std::abs(d) >= 9e15) throw PlyBadInteger{d};
  return static_cast<long long>(d);
}

/// Binary body reader (little or big endian).
struct PlyBinaryReader {
  const char* p;
  const char* end;
  bool swap;

  template <class T>
  T get() {
    if (end - p < static_cast<std::ptrdiff_t>(sizeof(T))) throw PlyTruncated{};
    T v;
    std::memcpy(&v, p, sizeof(T));
    if (swap) {
      auto* b = reinterpret_cast<unsigned char*>(&v);
      std::reverse(b, b + sizeof(T));
    }
    p += sizeof(T);
    return v;
  }
  double real(PlyType t) {
    switch (t) {
      case PlyType::Float32: return get<float>();
      case PlyType::Float64: return get<double>();
      default: return static_cast<double>(integer(t));
    }
  }
  long long integer(PlyType t) {
    switch (t) {
      case PlyType::Int8: return get<std::int8_t>();
      case PlyType::UInt8: return get<std::uint8_t>();
      case PlyType::Int16: return get<std::int16_t>();
      case PlyType::UInt16: return get<std::uint16_t>();
      case PlyType::Int32: return get<std::int32_t>();
      case PlyType::UInt32: return get<std::uint32_t>();
      case PlyType::Float32: return whole_number(get<float>());
      case PlyType::Float64: return whole_number(get<double>());
    }
    return 0;
  }
  void skip(PlyType t) {
    const int n = ply_size(t);
    if (end - p < n) throw PlyTruncated{};
    p += n;
  }
};

/// ASCII body reader: whitespace-separated numbers.
struct PlyAsciiReader {
  const char* p;
  const char* end;

  std::string_view token() {
    p = skip_space(p, end);
    if (p == end) throw PlyTruncated{};
    const char* b = p;
    p = token_end(p, end);
    return {b, static_cast<std::size_t>(p - b)};
  }
  double real(PlyType) {
    const std::string_view tok = token();
    double v;
    if (!parse_double(tok.data(), tok.data() + tok.size(), v)) throw PlyBadToken{tok.data()};
    return v;
  }
  long long integer(PlyType) {
    const std::string_view tok = token();
    const char* b = tok.data();
    const char* e = b + tok.size();
    if (b < e && *b == '+') ++b;
    long long v;
    auto [r, ec] = std::from_chars(b, e, v);
    if (ec == std::errc() && r == e) return v;
    double d;  // some writers print integers as "3.0"
    if (!parse_double(tok.data(), e, d)) throw PlyBadToken{tok.data()};
    try {
      return whole_number(d);
    } catch (const PlyBadInteger&) {
      throw PlyBadToken{tok.data()};
    }
  }
  void skip(PlyType) { token(); }
};

template <class Reader>
void read_ply_body(Reader& in, const std::vector<PlyElement>& elements, TriMesh& mesh,
                   const Source& src, bool binary) {
  std::vector<int> poly;
  long long num_vertices = -1;
  long long max_index = -1;
  long long max_index_face = -1;
  for (const PlyElement& e : elements) {
    long long item = 0;
    // Items without properties carry no data: nothing to read, whatever the count (the header's
    // size check cannot bound their count, and 8e14 of them were looped over for ever).
    if (e.props.empty() && e.name != "vertex" && e.name != "face") continue;
    try {
      if (e.name == "vertex") {
        int ix = -1, iy = -1, iz = -1;
        for (int j = 0; j < static_cast<int>(e.props.size()); ++j) {
          const PlyProperty& pr = e.props[j];
          if (pr.is_list) continue;
          if (pr.name == "x") ix = j;
          if (pr.name == "y") iy = j;
          if (pr.name == "z") iz = j;
        }
        if (ix < 0 || iy < 0 || iz < 0)
          fail("read_mesh: '{}' has a vertex element without scalar x, y and z properties", src.name);
        if (e.count > INT_MAX)
          fail("read_mesh: '{}' declares {} vertices, more than this reader supports", src.name, e.count);
        const std::size_t first = mesh.vertices.size();
        mesh.vertices.resize(first + static_cast<std::size_t>(e.count));
        for (; item < e.count; ++item) {
          Vec3 v = Vec3::Zero();
          for (int j = 0; j < static_cast<int>(e.props.size()); ++j) {
            const PlyProperty& pr = e.props[j];
            if (pr.is_list) {
              const long long n = in.integer(pr.count_type);
              for (long long k = 0; k < n; ++k) in.skip(pr.type);
            } else if (j == ix) {
              v.x() = in.real(pr.type);
            } else if (j == iy) {
              v.y() = in.real(pr.type);
            } else if (j == iz) {
              v.z() = in.real(pr.type);
            } else {
              in.skip(pr.type);
            }
          }
          if (!is_finite(v))
            fail("read_mesh: '{}' vertex {} has a non-finite coordinate ({}, {}, {}) (expected finite "
                 "numbers)",
                 src.name, item, v.x(), v.y(), v.z());
          mesh.vertices[first + static_cast<std::size_t>(item)] = v;
        }
        num_vertices = static_cast<long long>(mesh.vertices.size());
      } else if (e.name == "face") {
        int il = -1;
        for (int j = 0; j < static_cast<int>(e.props.size()); ++j) {
          const PlyProperty& pr = e.props[j];
          if (pr.is_list && (pr.name == "vertex_indices" || pr.name == "vertex_index")) il = j;
        }
        for (int j = 0; j < static_cast<int>(e.props.size()) && il < 0; ++j)
          if (e.props[j].is_list) il = j;
        if (il < 0)
          fail("read_mesh: '{}' has a face element without a 'vertex_indices' list property", src.name);
        for (; item < e.count; ++item) {
          for (int j = 0; j < static_cast<int>(e.props.size()); ++j) {
            const PlyProperty& pr = e.props[j];
            if (!pr.is_list) {
              in.skip(pr.type);
              continue;
            }
            const long long n = in.integer(pr.count_type);
            if (j != il) {
              for (long long k = 0; k < n; ++k) in.skip(pr.type);
              continue;
            }
            if (n < 3)
              fail("read_mesh: '{}' face {} has {} vertices (expected at least 3)", src.name, item, n);
            poly.clear();
            for (long long k = 0; k < n; ++k) {
              const long long idx = in.integer(pr.type);
              if (idx < 0 || idx >= INT_MAX)
                fail("read_mesh: '{}' face {} refers to vertex {}, which is out of range", src.name,
                     item, idx);
              if (idx > max_index) {
                max_index = idx;
                max_index_face = item;
              }
              poly.push_back(static_cast<int>(idx));
            }
            for (std::size_t k = 1; k + 1 < poly.size(); ++k)
              mesh.triangles.push_back({poly[0], poly[k], poly[k + 1]});
          }
        }
      } else {
        for (; item < e.count; ++item) {
          for (const PlyProperty& pr : e.props) {
            if (pr.is_list) {
              const long long n = in.integer(pr.count_type);
              for (long long k = 0; k < n; ++k) in.skip(pr.type);
            } else {
              in.skip(pr.type);
            }
          }
        }
      }
    } catch (const PlyTruncated&) {
      fail("read_mesh: '{}' ends inside element '{}' at item {} of {} (truncated {} PLY?)", src.name,
           e.name, item, e.count, binary ? "binary" : "ASCII");
    } catch (const PlyBadInteger& bad) {
      fail("read_mesh: '{}': element '{}' item {} has a count or index of {} stored as a float (expected a whole "
           "number below 2^53)", src.name, e.name, item, bad.value);
    } catch (const PlyBadToken& bad) {
      fail("read_mesh: '{}' line {}: expected a number in element '{}', got '{}'", src.name,
           src.line_of(bad.where), e.name,
           shown(std::string_view(bad.where, static_cast<std::size_t>(
                                                 token_end(bad.where, src.data.data() + src.data.size()) -
                                                 bad.where))));
    }
  }
  if (num_vertices < 0) fail("read_mesh: '{}' has no 'vertex' element", src.name);
  if (max_index >= num_vertices)
    fail("read_mesh: '{}' face {} refers to vertex {} but the file has {} vertices (valid: 0..{})",
         src.name, max_index_face, max_index, num_vertices, num_vertices - 1);
}

TriMesh parse_ply(const Source& src, std::string& format) {
  const std::string_view d = src.data;
  std::size_t pos = 0;
  int line = 0;
  auto next_line = [&](std::string_view& out) {
    if (pos >= d.size()) return false;
    std::size_t eol = d.find('\n', pos);
    if (eol == std::string_view::npos) eol = d.size();
    out = d.substr(pos, eol - pos);
    if (!out.empty() && out.back() == '\r') out.remove_suffix(1);
    pos = eol + 1;
    ++line;
    return true;
  };
  auto split = [](std::string_view s) {
    std::vector<std::string_view> toks;
    const char* p = s.data();
    const char* end = p + s.size();
    for (;;) {
      p = skip_space(p, end);
      if (p == end) break;
      const char* b = p;
      p = token_end(p, end);
      toks.emplace_back(b, static_cast<std::size_t>(p - b));
    }
    return toks;
  };

  std::string_view l;
  if (!next_line(l) || l != "ply")
    fail("read_mesh: '{}' is not a PLY file (its first line is not 'ply')", src.name);
  enum class Enc { None, Ascii, Little, Big } enc = Enc::None;
  std::vector<PlyElement> elements;
  bool ended = false;
  while (next_line(l)) {
    const auto toks = split(l);
    if (toks.empty()) continue;
    const std::string_view kw = toks[0];
    auto bad = [&](std::string_view what) {
      fail("read_mesh: '{}' line {}: {} in PLY header: '{}'", src.name, line, what, shown(l));
    };
    if (kw == "end_header") {
      ended = true;
      break;
    } else if (kw == "comment" || kw == "obj_info") {
      continue;
    } else if (kw == "format") {
      if (toks.size() < 2) bad("missing encoding");
      if (toks[1] == "ascii") enc = Enc::Ascii;
      else if (toks[1] == "binary_little_endian") enc = Enc::Little;
      else if (toks[1] == "binary_big_endian") enc = Enc::Big;
      else bad("unknown format (expected ascii, binary_little_endian or binary_big_endian)");
    } else if (kw == "element") {
      if (toks.size() != 3) bad("expected 'element <name> <count>'");
      PlyElement e;
      e.name = std::string(toks[1]);
      auto [r, ec] = std::from_chars(toks[2].data(), toks[2].data() + toks[2].size(), e.count);
      if (ec != std::errc() || r != toks[2].data() + toks[2].size() || e.count < 0)
        bad("bad element count");
      elements.push_back(std::move(e));
    } else if (kw == "property") {
      if (elements.empty()) bad("property before any element");
      PlyProperty pr;
      if (toks.size() == 5 && toks[1] == "list") {
        pr.is_list = true;
        if (!parse_ply_type(toks[2], pr.count_type) || !parse_ply_type(toks[3], pr.type))
          bad("unknown property type");
        pr.name = std::string(toks[4]);
      } else if (toks.size() == 3) {
        if (!parse_ply_type(toks[1], pr.type)) bad("unknown property type");
        pr.name = std::string(toks[2]);
      } else {
        bad("expected 'property <type> <name>' or 'property list <type> <type> <name>'");
      }
      elements.back().props.push_back(std::move(pr));
    } else {
      bad("unknown keyword");
    }
  }
  if (!ended) fail("read_mesh: '{}' has no 'end_header' line (truncated or not a PLY file)", src.name);
  if (enc == Enc::None) fail("read_mesh: '{}' has no 'format' line in its PLY header", src.name);

  TriMesh mesh;
  const char* body = d.data() + std::min(pos, d.size());
  const char* end = d.data() + d.size();
  const bool binary = enc != Enc::Ascii;
  // Reject absurd counts before allocating: every item needs at least its fixed-size bytes
  // (binary) or a character and a separator per property (ASCII).
  long double min_bytes = 0;
  for (const PlyElement& e : elements) {
    long double item = 0;
    for (const PlyProperty& pr : e.props) item += binary ? ply_size(pr.is_list ? pr.count_type : pr.type) : 2;
    min_bytes += item * static_cast<long double>(e.count);
  }
  if (!binary && min_bytes > 0) min_bytes -= 1;  // the last number needs no separator
  if (min_bytes > static_cast<long double>(end - body))
    fail("read_mesh: '{}' is a truncated {} PLY: its header declares data of at least {:.0f} bytes "
         "but the file has {} after the header",
         src.name, binary ? "binary" : "ASCII", static_cast<double>(min_bytes), end - body);
  if (!binary) {
    format = "ply-ascii";
    PlyAsciiReader in{body, end};
    read_ply_body(in, elements, mesh, src, false);
  } else {
    format = "ply-binary";
    const bool swap = (enc == Enc::Big) != (std::endian::native == std::endian::big);
    PlyBinaryReader in{body, end, swap};
    read_ply_body(in, elements, mesh, src, true);
  }
  return mesh;
}

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
    // The format's unit is the millimetre: nothing to guess.
    inf.format = "aaop";
    const AaopShape shape = parse_aaop(data, src.name);
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
              src.name, shape.num_spokes(), shape.num_slices(), shape.landmarks.size(),
              distal_closed ? "closed" : "open", proximal_closed ? "closed" : "open");
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
    const double diagonal_m = raw_diagonal * factor;
    const std::string how = inf.unit_was_guessed ? "guessed" : "declared";
    const std::string unit = units::to_string(inf.unit);
    if (diagonal_m > kMaxPlausibleSize_m) {
      inf.warning = inf.unit == units::LengthUnit::Metre
                        ? fmt::format("read_mesh: '{}' is {:.3g} m across in the {} unit '{}'; is it "
                                      "in millimetres? (give the unit: limb.units \"mm\" in a case file, --units mm on the command line)",
                                      src.name, diagonal_m, how, unit)
                        : fmt::format("read_mesh: '{}' is {:.3g} m across in the {} unit '{}', larger "
                                      "than any body part; check the file's unit and scale",
                                      src.name, diagonal_m, how, unit);
    } else if (diagonal_m < kMinPlausibleSize_m) {
      inf.warning = inf.unit == units::LengthUnit::Millimetre
                        ? fmt::format("read_mesh: '{}' is {:.3g} m across in the {} unit '{}'; is it "
                                      "in metres? (give the unit: limb.units \"m\" in a case file, --units m on the command line)",
                                      src.name, diagonal_m, how, unit)
                        : fmt::format("read_mesh: '{}' is {:.3g} m across in the {} unit '{}', smaller "
                                      "than any body part; check the file's unit and scale",
                                      src.name, diagonal_m, how, unit);
    }
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
      auto out = std::back_inserter(b);
      fmt::format_to(out, "{}", ply_header(mesh, unit, false));
      for (const Vec3& p : mesh.vertices) {
        const Vec3 v = p * s;
        fmt::format_to(out, "{} {} {}\n", v.x(), v.y(), v.z());
      }
      for (const auto& t : mesh.triangles) fmt::format_to(out, "3 {} {} {}\n", t[0], t[1], t[2]);
      write_bytes({b.data(), b.size()});
      break;
    }
    case MeshFormat::PlyBinary: {
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
      write_bytes(buf);
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
