#include "socketsmith/core/log.h"

#include <atomic>
#include <mutex>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "socketsmith/core/enum_names.h"
#include "socketsmith/core/errors.h"

namespace socketsmith::log {
namespace {
std::mutex g_mutex;
Sink g_sink;  // empty: default spdlog sink
std::atomic<Level> g_level{Level::Info};

spdlog::logger& default_logger() {
  static auto logger = [] {
    auto l = spdlog::stderr_color_mt("socketsmith");
    l->set_pattern("%^[%l]%$ %v");
    l->set_level(spdlog::level::trace);
    return l;
  }();
  return *logger;
}
}  // namespace

void set_sink(Sink sink) {
  std::lock_guard lock(g_mutex);
  g_sink = std::move(sink);
}

void set_level(Level lvl) { g_level = lvl; }
Level level() { return g_level; }

Level parse_level(std::string_view text) {
  static constexpr EnumName<Level> kLevels[] = {
      {Level::Debug, "debug"}, {Level::Info, "info"}, {Level::Warn, "warn"}, {Level::Error, "error"}, {Level::Off, "off"}};
  return parse_named(kLevels, text, "log::parse_level: unknown level '{}' (expected debug|info|warn|error|off)");
}

void write(Level lvl, std::string_view message) {
  if (lvl < g_level || lvl == Level::Off) return;
  std::lock_guard lock(g_mutex);
  if (g_sink) {
    g_sink(lvl, message);
    return;
  }
  switch (lvl) {
    case Level::Debug: default_logger().debug("{}", message); break;
    case Level::Info: default_logger().info("{}", message); break;
    case Level::Warn: default_logger().warn("{}", message); break;
    default: default_logger().error("{}", message); break;
  }
}

}  // namespace socketsmith::log
