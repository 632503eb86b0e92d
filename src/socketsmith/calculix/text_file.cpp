#include "socketsmith/calculix/text_file.h"

#include <fstream>
#include <sstream>

#include "socketsmith/core/errors.h"

namespace socketsmith::calculix {

std::string read_text_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail<IoError>("cannot open '{}' (does CalculiX's job directory still exist?)", path.string());
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace socketsmith::calculix
