#pragma once
/// @file json_input.h
/// JSON written by a user (case files, GUI scripts): parse errors become one InvalidInputError
/// line that names the file, the place and — for a number too large for a double, such as
/// 1e400 — the key that holds it.

#include <istream>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace socketsmith {

/// Parses @p text. @p label names the document in messages ("case file 'x.json'").
/// @throws InvalidInputError, one line:
///   "case file 'x.json' is not valid JSON: syntax error while parsing value ... at line 1, column 12"
///   "case file 'x.json': the number 1e400 at 'patient.body_mass_kg' is out of range (numbers must be finite, at
///    most about 1.8e308)"
nlohmann::json parse_json_input(std::string_view text, std::string_view label);

/// Parses a JSON file the caller opened as @p in from @p path (a file the program wrote: a rig,
/// a model); @p who starts the message.
/// @throws InvalidInputError, one line: "read_recording: 'rig.json' is not valid JSON (<the parser's message>)"
nlohmann::json parse_json_stream(std::istream& in, const std::string& path, std::string_view who);

/// The key path ("patient.body_mass_kg", "design.spots[2].h0_mm") of the value being read at
/// the first error of @p text; "" when the error is outside any object or array.
std::string json_error_path(std::string_view text);

}  // namespace socketsmith
