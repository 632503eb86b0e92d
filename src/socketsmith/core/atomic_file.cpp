#include "socketsmith/core/atomic_file.h"

#include <fstream>
#include <random>
#include <system_error>

#include "socketsmith/core/errors.h"

namespace socketsmith {
namespace fs = std::filesystem;

void ensure_directory(const fs::path& dir) {
  if (dir.empty()) return;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    fail<IoError>("cannot create directory '{}': {}", dir.string(),
                  ec ? ec.message() : "a file of that name exists");
}

void write_file_atomically(const fs::path& path, const std::function<void(std::ostream&)>& writer,
                           bool binary) {
  ensure_directory(path.parent_path());
  std::random_device rd;
  const fs::path tmp = path.string() + fmt::format(".tmp-{:08x}", rd());
  try {
    {
      std::ofstream out(tmp, binary ? std::ios::binary | std::ios::trunc : std::ios::trunc);
      if (!out) fail<IoError>("cannot write '{}' (check the folder exists and is writable)", path.string());
      writer(out);
      out.flush();
      if (!out) fail<IoError>("writing '{}' failed (disk full?)", path.string());
    }
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) fail<IoError>("cannot move '{}' into place: {}", path.string(), ec.message());
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
}

void write_text_atomically(const fs::path& path, std::string_view text) {
  write_file_atomically(path, [&](std::ostream& out) { out << text; });
}

}  // namespace socketsmith
