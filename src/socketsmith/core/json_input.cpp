#include "socketsmith/core/json_input.h"

#include <vector>

#include "socketsmith/core/errors.h"

namespace socketsmith {
namespace {

/// nlohmann's messages start with "[json.exception.parse_error.101] ": the user needs the rest.
std::string without_prefix(std::string_view what) {
  if (!what.empty() && what.front() == '[') {
    const auto end = what.find("] ");
    if (end != std::string_view::npos) what.remove_prefix(end + 2);
  }
  return std::string(what);
}

}  // namespace

std::string json_error_path(std::string_view text) {
  // Re-parse with a callback that follows the keys and array positions; it stops at the error,
  // where the stack holds the path of the value being read.
  struct Frame {
    bool is_array = false;
    std::string key;
    int index = -1;
  };
  std::vector<Frame> stack;
  using nlohmann::json;
  const json::parser_callback_t follow = [&stack](int, json::parse_event_t event, json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start:
      case json::parse_event_t::array_start:
        if (!stack.empty() && stack.back().is_array) ++stack.back().index;
        stack.push_back({event == json::parse_event_t::array_start, {}, -1});
        break;
      case json::parse_event_t::key:
        if (!stack.empty() && parsed.is_string()) stack.back().key = parsed.get<std::string>();
        break;
      case json::parse_event_t::value:
        if (!stack.empty() && stack.back().is_array) ++stack.back().index;
        break;
      case json::parse_event_t::object_end:
      case json::parse_event_t::array_end:
        if (!stack.empty()) stack.pop_back();
        break;
    }
    return true;  // kept: a discarded container would hide its values' and end events
  };
  const json discarded = json::parse(text.begin(), text.end(), follow, /*allow_exceptions=*/false);
  (void)discarded;
  std::string path;
  for (size_t k = 0; k < stack.size(); ++k) {
    const Frame& f = stack[k];
    if (f.is_array) {
      // A container element was counted when it opened; a number that failed was not.
      const bool failed_here = k + 1 == stack.size();
      path += '[';
      path += std::to_string(failed_here ? f.index + 1 : f.index);
      path += ']';
    } else if (!f.key.empty()) {
      if (!path.empty()) path += '.';
      path += f.key;
    }
  }
  return path;
}

nlohmann::json parse_json_input(std::string_view text, std::string_view label) {
  try {
    return nlohmann::json::parse(text.begin(), text.end());
  } catch (const nlohmann::json::out_of_range& e) {
    // 406: a number too large for a double ("number overflow parsing '1e400'").
    const std::string what = without_prefix(e.what());
    const auto open = what.find('\'');
    const auto close = what.rfind('\'');
    const std::string number = open != std::string::npos && close > open ? what.substr(open + 1, close - open - 1) : what;
    const std::string path = json_error_path(text);
    fail("{}: the number {} at '{}' is out of range (numbers must be finite, at most about 1.8e308)", label, number,
         path.empty() ? std::string("the top level") : path);
  } catch (const nlohmann::json::exception& e) {
    const std::string path = json_error_path(text);
    fail("{} is not valid JSON{}: {}", label, path.empty() ? std::string() : " (at '" + path + "')",
         without_prefix(e.what()));
  }
}

nlohmann::json parse_json_stream(std::istream& in, const std::string& path, std::string_view who) {
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    fail("{}: '{}' is not valid JSON ({})", who, path, e.what());
  }
}

}  // namespace socketsmith
