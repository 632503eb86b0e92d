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

/// Throws E with a fmt-formatted message.
template <class E = InvalidInputError, class... Args>
[[noreturn]] void fail(fmt::format_string<Args...> format, Args&&... args) {
  throw E(fmt::format(format, std::forward<Args>(args)...));
}

/// Precondition check active in every build type (public API contracts).
template <class E = InvalidInputError, class... Args>
void require(bool condition, fmt::format_string<Args...> format, Args&&... args) {
  if (!condition) throw E(fmt::format(format, std::forward<Args>(args)...));
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
