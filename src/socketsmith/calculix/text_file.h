#pragma once
/// @file text_file.h
/// Whole-file text reading for the result readers (internal to fe).

#include <filesystem>
#include <string>

namespace socketsmith::calculix {

/// The whole file as text. @throws IoError naming the file when it cannot be opened.
std::string read_text_file(const std::filesystem::path& path);

}  // namespace socketsmith::calculix
