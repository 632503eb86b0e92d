#pragma once
/// @file atomic_file.h
/// Files the user cares about are written atomically: to a temporary file beside the target,
/// then renamed over it. A failure leaves the previous file untouched.

#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string_view>

namespace socketsmith {

/// Writes @p path through @p writer into "<path>.tmp-XXXX" and renames it into place.
/// @throws IoError when the directory is not writable or the writer's stream fails;
///         any exception from @p writer propagates after the temporary file is removed.
void write_file_atomically(const std::filesystem::path& path,
                           const std::function<void(std::ostream&)>& writer, bool binary = false);

/// Convenience: writes a whole string atomically.
void write_text_atomically(const std::filesystem::path& path, std::string_view text);

/// Creates @p dir (and parents) or throws IoError naming it.
void ensure_directory(const std::filesystem::path& dir);

}  // namespace socketsmith
