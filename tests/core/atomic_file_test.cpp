#include "socketsmith/core/atomic_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "socketsmith/core/errors.h"

namespace socketsmith {
namespace {
namespace fs = std::filesystem;

fs::path temp_dir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("socketsmith_core_" + name + std::to_string(::getpid()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(AtomicFile, a_failing_writer_leaves_the_previous_file_intact_and_no_temporary) {
  const fs::path dir = temp_dir("atomic");
  const fs::path f = dir / "case.json";
  write_text_atomically(f, "version 1");
  EXPECT_THROW(write_file_atomically(f, [](std::ostream& out) {
    out << "half written";
    throw IoError("disk full");
  }), IoError);
  EXPECT_EQ(slurp(f), "version 1");
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 1);
  write_text_atomically(f, "version 2");
  EXPECT_EQ(slurp(f), "version 2");
  fs::remove_all(dir);
}

TEST(AtomicFile, creates_missing_folders_and_reports_unwritable_ones) {
  const fs::path dir = temp_dir("mk");
  write_text_atomically(dir / "a" / "b" / "c.txt", "x");
  EXPECT_EQ(slurp(dir / "a" / "b" / "c.txt"), "x");
  write_text_atomically(dir / "plain", "file");
  EXPECT_THROW(write_text_atomically(dir / "plain" / "inside.txt", "y"), IoError);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace socketsmith
