#pragma once
/// The mesh readers' shared pieces (inside `geometry` only; `mesh_io.h` is the interface): text and
/// binary scanning helpers, the source a parser names in its messages, and the parser of each
/// format — STL (`mesh_io_stl.cpp`), OBJ (`mesh_io_obj.cpp`), PLY (`mesh_io_ply.cpp`). Why apart:
/// `mesh_io.cpp` picks the format and checks and writes meshes; each format's grammar and its
/// one-line errors are a room of their own.

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


#include "socketsmith/geometry/mesh_io.h"

namespace socketsmith::geometry::mesh_io_detail {
namespace fs = std::filesystem;

inline std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

inline bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }
inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

inline bool is_finite(const Vec3& p) { return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z()); }

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
inline std::string shown(std::string_view tok) {
  if (tok.size() > 40) return std::string(tok.substr(0, 40)) + "...";
  return std::string(tok);
}

/// Reads the whole file; IoError when it cannot be opened or read.
inline std::string read_file(const fs::path& path) {
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
inline bool looks_like_text(std::string_view d) {
  const std::size_t n = std::min<std::size_t>(d.size(), 512);
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<unsigned char>(d[i]);
    if ((c < 0x20 && !is_space(static_cast<char>(c))) || c == 0x7f) return false;
  }
  return true;
}

/// Parses a floating-point number at @p p (accepting a leading '+'); nullptr on failure.
/// The number must be followed by whitespace or the end of the data.
inline const char* parse_double(const char* p, const char* end, double& out) {
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

inline const char* skip_blanks(const char* p, const char* end) {
  while (p < end && is_blank(*p)) ++p;
  return p;
}
inline const char* skip_space(const char* p, const char* end) {
  while (p < end && is_space(*p)) ++p;
  return p;
}
inline const char* token_end(const char* p, const char* end) {
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

/// STL, binary or ASCII (told apart by the size the header announces and by the first bytes);
/// @p format receives "stl-binary" or "stl-ascii".
TriMesh parse_stl(const Source& src, std::string& format);
/// Wavefront OBJ: vertices and faces (polygons fanned), other records ignored.
TriMesh parse_obj(const Source& src);
/// PLY, ASCII or binary (either endianness): the vertex and face elements; @p format receives
/// "ply-ascii" or "ply-binary".
TriMesh parse_ply(const Source& src, std::string& format);

}  // namespace socketsmith::geometry::mesh_io_detail
