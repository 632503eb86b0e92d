#pragma once
// Internal to design/: the case file's JSON readers shared by case_file.cpp (the hand-written
// keys) and case_parameters.cpp (the table's). Each throws InvalidInputError with one line naming
// '<where>.<key>'.

#include <set>
#include <string>

#include <nlohmann/json.hpp>

namespace socketsmith::design::detail {

/// @throws unless @p j is an object whose keys are all in @p known ("unknown key 'x' in 'where' (known: ...)").
void check_keys(const nlohmann::json& j, const std::string& where, const std::set<std::string>& known);

/// j[key] as a finite number, or @p fallback when the key is absent.
double number(const nlohmann::json& j, const std::string& key, const std::string& where, double fallback);

/// j[key] as a string, or @p fallback when the key is absent.
std::string text(const nlohmann::json& j, const std::string& key, const std::string& where, const std::string& fallback);

/// j[key] as true / false, or @p fallback when the key is absent.
bool flag(const nlohmann::json& j, const std::string& key, const std::string& where, bool fallback);

}  // namespace socketsmith::design::detail
