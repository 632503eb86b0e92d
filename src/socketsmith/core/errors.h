#pragma once
/// @file errors.h
/// Error types of socketsmith. Messages name the function, the field and the offending value,
/// and say what would be valid: "read_stl: 'limb.stl' has 0 triangles (expected a closed surface)".

#include <stdexcept>
#include <string>

#include <fmt/format.h>

namespace socketsmith {

/// Base of every socketsmith error.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Bad input from the user: a value out of range, a file that is not a mesh, NaN coordinates...
class InvalidInputError : public Error {
 public:
  using Error::Error;
};

/// A file could not be read or written.
class IoError : public Error {
 public:
  using Error::Error;
};

/// A solver diverged or met an invalid state (inverted element, NaN).
class SolverError : public Error {
 public:
  using Error::Error;
};

/// A mesh has the wrong topology for the operation (open, non-manifold, inverted).
class TopologyError : public Error {
 public:
  using Error::Error;
};

namespace detail {
/// A message is one line: control characters that came in with the user's text (a key, a name, a
/// token read from a file) are shown escaped ("\n", "\x01") instead of breaking it.
inline std::string one_line_message(std::string m) {
  std::string out;
  out.reserve(m.size());
  for (const char c : m) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '\n') out += "\\n";
    else if (c == '\r') out += "\\r";
    else if (c == '\t') out += ' ';
    else if (u < 0x20 || u == 0x7f) out += fmt::format("\\x{:02x}", u);
    else out += c;
  }
  return out;
}
}  // namespace detail

/// Throws E with a fmt-formatted message (on one line, see detail::one_line_message).
template <class E = InvalidInputError, class... Args>
[[noreturn]] void fail(fmt::format_string<Args...> format, Args&&... args) {
  throw E(detail::one_line_message(fmt::format(format, std::forward<Args>(args)...)));
}

/// Precondition check active in every build type (public API contracts).
template <class E = InvalidInputError, class... Args>
void require(bool condition, fmt::format_string<Args...> format, Args&&... args) {
  if (!condition) throw E(detail::one_line_message(fmt::format(format, std::forward<Args>(args)...)));
}

}  // namespace socketsmith

/// Internal invariant: active in Debug and in CI builds, compiled out in Release otherwise.
#if !defined(NDEBUG) || defined(SOCKETSMITH_ENABLE_ASSERTS)
#define SOCKETSMITH_ASSERT(cond)                                                                   \
  do {                                                                                             \
    if (!(cond))                                                                                   \
      throw ::socketsmith::Error(std::string("internal invariant failed: " #cond " at ") +        \
                                 __FILE__ + ":" + std::to_string(__LINE__));                       \
  } while (0)
#else
#define SOCKETSMITH_ASSERT(cond) \
  do {                           \
  } while (0)
#endif
