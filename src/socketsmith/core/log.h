#pragma once
/// @file log.h
/// Logging sink. Libraries never print: they log through this sink, which the application
/// configures (console, file, GUI panel, or silence in tests).

#include <functional>
#include <string>
#include <string_view>

#include <fmt/format.h>

namespace socketsmith::log {

enum class Level { Debug = 0, Info = 1, Warn = 2, Error = 3, Off = 4 };

/// A sink receives every message at or above the current level.
using Sink = std::function<void(Level, std::string_view)>;

/// Replaces the sink (default: spdlog to stderr). Pass nullptr to restore the default.
void set_sink(Sink sink);
/// Messages below @p level are dropped.
void set_level(Level level);
Level level();
/// Parses "debug|info|warn|error|off".
Level parse_level(std::string_view text);

void write(Level level, std::string_view message);

template <class... Args>
void debug(fmt::format_string<Args...> f, Args&&... args) {
  if (level() <= Level::Debug) write(Level::Debug, fmt::format(f, std::forward<Args>(args)...));
}
template <class... Args>
void info(fmt::format_string<Args...> f, Args&&... args) {
  if (level() <= Level::Info) write(Level::Info, fmt::format(f, std::forward<Args>(args)...));
}
template <class... Args>
void warn(fmt::format_string<Args...> f, Args&&... args) {
  if (level() <= Level::Warn) write(Level::Warn, fmt::format(f, std::forward<Args>(args)...));
}
template <class... Args>
void error(fmt::format_string<Args...> f, Args&&... args) {
  if (level() <= Level::Error) write(Level::Error, fmt::format(f, std::forward<Args>(args)...));
}

}  // namespace socketsmith::log
