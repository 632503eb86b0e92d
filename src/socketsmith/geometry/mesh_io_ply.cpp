// The PLY reader (ASCII, binary little and big endian): header, element bodies, and one-line
// errors that name the file and the line (mesh_io_detail.h says why the readers are apart).
#include "socketsmith/geometry/mesh_io_detail.h"

namespace socketsmith::geometry::mesh_io_detail {
namespace {

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

/// Where the vertex element keeps its scalar x, y and z (the indices into its properties).
struct VertexXyz {
  int ix = -1, iy = -1, iz = -1;
};

VertexXyz find_vertex_xyz(const PlyElement& e, const Source& src) {
  VertexXyz at;
  for (int j = 0; j < static_cast<int>(e.props.size()); ++j) {
    const PlyProperty& pr = e.props[j];
    if (pr.is_list) continue;
    if (pr.name == "x") at.ix = j;
    if (pr.name == "y") at.iy = j;
    if (pr.name == "z") at.iz = j;
  }
  if (at.ix < 0 || at.iy < 0 || at.iz < 0)
    fail("read_mesh: '{}' has a vertex element without scalar x, y and z properties", src.name);
  return at;
}

/// Skips one list property's items after reading its count.
template <class Reader>
void skip_ply_list(Reader& in, const PlyProperty& pr) {
  const long long n = in.integer(pr.count_type);
  for (long long k = 0; k < n; ++k) in.skip(pr.type);
}

/// Reads the vertex element into mesh.vertices; @p item counts the items read (for the errors).
template <class Reader>
void read_ply_vertices(Reader& in, const PlyElement& e, TriMesh& mesh, const Source& src,
                       long long& item) {
  const VertexXyz at = find_vertex_xyz(e, src);
  if (e.count > INT_MAX)
    fail("read_mesh: '{}' declares {} vertices, more than this reader supports", src.name, e.count);
  const std::size_t first = mesh.vertices.size();
  mesh.vertices.resize(first + static_cast<std::size_t>(e.count));
  for (; item < e.count; ++item) {
    Vec3 v = Vec3::Zero();
    for (int j = 0; j < static_cast<int>(e.props.size()); ++j) {
      const PlyProperty& pr = e.props[j];
      if (pr.is_list) skip_ply_list(in, pr);
      else if (j == at.ix) v.x() = in.real(pr.type);
      else if (j == at.iy) v.y() = in.real(pr.type);
      else if (j == at.iz) v.z() = in.real(pr.type);
      else in.skip(pr.type);
    }
    if (!is_finite(v))
      fail("read_mesh: '{}' vertex {} has a non-finite coordinate ({}, {}, {}) (expected finite "
           "numbers)",
           src.name, item, v.x(), v.y(), v.z());
    mesh.vertices[first + static_cast<std::size_t>(item)] = v;
  }
}

/// The face element's vertex-index list: 'vertex_indices' (or 'vertex_index'), else its first list.
int find_face_index_list(const PlyElement& e, const Source& src) {
  int il = -1;
  for (int j = 0; j < static_cast<int>(e.props.size()); ++j) {
    const PlyProperty& pr = e.props[j];
    if (pr.is_list && (pr.name == "vertex_indices" || pr.name == "vertex_index")) il = j;
  }
  for (int j = 0; j < static_cast<int>(e.props.size()) && il < 0; ++j)
    if (e.props[j].is_list) il = j;
  if (il < 0)
    fail("read_mesh: '{}' has a face element without a 'vertex_indices' list property", src.name);
  return il;
}

/// The largest vertex index the faces use and the first face using it, checked against the
/// vertex count once the whole body is read (the vertex element may come after the faces).
struct MaxFaceIndex {
  long long index = -1;
  long long face = -1;
};

/// Reads one face's index list (@p n indices) and fans it into triangles.
template <class Reader>
void read_ply_polygon(Reader& in, const PlyProperty& pr, long long n, long long item, TriMesh& mesh,
                      const Source& src, std::vector<int>& poly, MaxFaceIndex& max_index) {
  if (n < 3) fail("read_mesh: '{}' face {} has {} vertices (expected at least 3)", src.name, item, n);
  poly.clear();
  for (long long k = 0; k < n; ++k) {
    const long long idx = in.integer(pr.type);
    if (idx < 0 || idx >= INT_MAX)
      fail("read_mesh: '{}' face {} refers to vertex {}, which is out of range", src.name, item, idx);
    if (idx > max_index.index) {
      max_index.index = idx;
      max_index.face = item;
    }
    poly.push_back(static_cast<int>(idx));
  }
  for (std::size_t k = 1; k + 1 < poly.size(); ++k)
    mesh.triangles.push_back({poly[0], poly[k], poly[k + 1]});
}

/// Reads the face element into mesh.triangles (polygons fanned); @p item counts the items read.
template <class Reader>
void read_ply_faces(Reader& in, const PlyElement& e, TriMesh& mesh, const Source& src,
                    long long& item, MaxFaceIndex& max_index) {
  const int il = find_face_index_list(e, src);
  std::vector<int> poly;
  for (; item < e.count; ++item) {
    for (int j = 0; j < static_cast<int>(e.props.size()); ++j) {
      const PlyProperty& pr = e.props[j];
      if (!pr.is_list) {
        in.skip(pr.type);
        continue;
      }
      if (j != il) {
        skip_ply_list(in, pr);
        continue;
      }
      const long long n = in.integer(pr.count_type);
      read_ply_polygon(in, pr, n, item, mesh, src, poly, max_index);
    }
  }
}

/// Skips an element this reader does not use; @p item counts the items skipped.
template <class Reader>
void skip_ply_element(Reader& in, const PlyElement& e, long long& item) {
  for (; item < e.count; ++item) {
    for (const PlyProperty& pr : e.props) {
      if (pr.is_list) skip_ply_list(in, pr);
      else in.skip(pr.type);
    }
  }
}

template <class Reader>
void read_ply_body(Reader& in, const std::vector<PlyElement>& elements, TriMesh& mesh,
                   const Source& src, bool binary) {
  long long num_vertices = -1;
  MaxFaceIndex max_index;
  for (const PlyElement& e : elements) {
    long long item = 0;
    // Items without properties carry no data: nothing to read, whatever the count (the header's
    // size check cannot bound their count, and 8e14 of them were looped over for ever).
    if (e.props.empty() && e.name != "vertex" && e.name != "face") continue;
    try {
      if (e.name == "vertex") {
        read_ply_vertices(in, e, mesh, src, item);
        num_vertices = static_cast<long long>(mesh.vertices.size());
      } else if (e.name == "face") {
        read_ply_faces(in, e, mesh, src, item, max_index);
      } else {
        skip_ply_element(in, e, item);
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
  if (max_index.index >= num_vertices)
    fail("read_mesh: '{}' face {} refers to vertex {} but the file has {} vertices (valid: 0..{})",
         src.name, max_index.face, max_index.index, num_vertices, num_vertices - 1);
}

/// The header's lines one at a time (a trailing '\r' dropped), numbered for the errors.
struct PlyHeaderLines {
  std::string_view d;
  std::size_t pos = 0;
  int line = 0;

  bool next(std::string_view& out) {
    if (pos >= d.size()) return false;
    std::size_t eol = d.find('\n', pos);
    if (eol == std::string_view::npos) eol = d.size();
    out = d.substr(pos, eol - pos);
    if (!out.empty() && out.back() == '\r') out.remove_suffix(1);
    pos = eol + 1;
    ++line;
    return true;
  }
};

std::vector<std::string_view> split_words(std::string_view s) {
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
}

/// Fails on one header line, naming the file, the line and what is wrong with it.
struct PlyHeaderError {
  const Source& src;
  int line;
  std::string_view text;

  [[noreturn]] void operator()(std::string_view what) const {
    fail("read_mesh: '{}' line {}: {} in PLY header: '{}'", src.name, line, what, shown(text));
  }
};

enum class PlyEncoding { None, Ascii, Little, Big };

struct PlyHeader {
  PlyEncoding enc = PlyEncoding::None;
  std::vector<PlyElement> elements;
  std::size_t body_offset = 0;  ///< just past the 'end_header' line
};

PlyElement parse_element_line(const std::vector<std::string_view>& toks, const PlyHeaderError& bad) {
  if (toks.size() != 3) bad("expected 'element <name> <count>'");
  PlyElement e;
  e.name = std::string(toks[1]);
  auto [r, ec] = std::from_chars(toks[2].data(), toks[2].data() + toks[2].size(), e.count);
  if (ec != std::errc() || r != toks[2].data() + toks[2].size() || e.count < 0)
    bad("bad element count");
  return e;
}

PlyProperty parse_property_line(const std::vector<std::string_view>& toks, const PlyHeaderError& bad) {
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
  return pr;
}

/// Reads the header from 'ply' to 'end_header': the encoding and the elements with their
/// properties.
PlyHeader parse_ply_header(const Source& src) {
  PlyHeaderLines lines{src.data};
  std::string_view l;
  if (!lines.next(l) || l != "ply")
    fail("read_mesh: '{}' is not a PLY file (its first line is not 'ply')", src.name);
  PlyHeader h;
  bool ended = false;
  while (lines.next(l)) {
    const auto toks = split_words(l);
    if (toks.empty()) continue;
    const std::string_view kw = toks[0];
    const PlyHeaderError bad{src, lines.line, l};
    if (kw == "end_header") {
      ended = true;
      break;
    } else if (kw == "comment" || kw == "obj_info") {
      continue;
    } else if (kw == "format") {
      if (toks.size() < 2) bad("missing encoding");
      if (toks[1] == "ascii") h.enc = PlyEncoding::Ascii;
      else if (toks[1] == "binary_little_endian") h.enc = PlyEncoding::Little;
      else if (toks[1] == "binary_big_endian") h.enc = PlyEncoding::Big;
      else bad("unknown format (expected ascii, binary_little_endian or binary_big_endian)");
    } else if (kw == "element") {
      h.elements.push_back(parse_element_line(toks, bad));
    } else if (kw == "property") {
      if (h.elements.empty()) bad("property before any element");
      h.elements.back().props.push_back(parse_property_line(toks, bad));
    } else {
      bad("unknown keyword");
    }
  }
  if (!ended) fail("read_mesh: '{}' has no 'end_header' line (truncated or not a PLY file)", src.name);
  if (h.enc == PlyEncoding::None) fail("read_mesh: '{}' has no 'format' line in its PLY header", src.name);
  h.body_offset = lines.pos;
  return h;
}

/// Rejects absurd counts before allocating: every item needs at least its fixed-size bytes
/// (binary) or a character and a separator per property (ASCII).
void check_ply_body_size(const Source& src, const std::vector<PlyElement>& elements, bool binary,
                         std::ptrdiff_t body_bytes) {
  long double min_bytes = 0;
  for (const PlyElement& e : elements) {
    long double item = 0;
    for (const PlyProperty& pr : e.props) item += binary ? ply_size(pr.is_list ? pr.count_type : pr.type) : 2;
    min_bytes += item * static_cast<long double>(e.count);
  }
  if (!binary && min_bytes > 0) min_bytes -= 1;  // the last number needs no separator
  if (min_bytes > static_cast<long double>(body_bytes))
    fail("read_mesh: '{}' is a truncated {} PLY: its header declares data of at least {:.0f} bytes "
         "but the file has {} after the header",
         src.name, binary ? "binary" : "ASCII", static_cast<double>(min_bytes), body_bytes);
}

}  // namespace

TriMesh parse_ply(const Source& src, std::string& format) {
  const std::string_view d = src.data;
  const PlyHeader header = parse_ply_header(src);
  TriMesh mesh;
  const char* body = d.data() + std::min(header.body_offset, d.size());
  const char* end = d.data() + d.size();
  const bool binary = header.enc != PlyEncoding::Ascii;
  check_ply_body_size(src, header.elements, binary, end - body);
  if (!binary) {
    format = "ply-ascii";
    PlyAsciiReader in{body, end};
    read_ply_body(in, header.elements, mesh, src, false);
  } else {
    format = "ply-binary";
    const bool swap = (header.enc == PlyEncoding::Big) != (std::endian::native == std::endian::big);
    PlyBinaryReader in{body, end, swap};
    read_ply_body(in, header.elements, mesh, src, true);
  }
  return mesh;
}

}  // namespace socketsmith::geometry::mesh_io_detail
