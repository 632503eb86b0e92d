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

/// Formats and writes a message at @p at, only when the current level lets it through.
template <class... Args>
void write_at(Level at, fmt::format_string<Args...> f, Args&&... args) {
  if (level() <= at) write(at, fmt::format(f, std::forward<Args>(args)...));
}
template <class... Args> void debug(fmt::format_string<Args...> f, Args&&... a) { write_at(Level::Debug, f, std::forward<Args>(a)...); }
template <class... Args> void info(fmt::format_string<Args...> f, Args&&... a) { write_at(Level::Info, f, std::forward<Args>(a)...); }
template <class... Args> void warn(fmt::format_string<Args...> f, Args&&... a) { write_at(Level::Warn, f, std::forward<Args>(a)...); }
template <class... Args> void error(fmt::format_string<Args...> f, Args&&... a) { write_at(Level::Error, f, std::forward<Args>(a)...); }

}  // namespace socketsmith::log
