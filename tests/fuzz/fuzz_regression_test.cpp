// Every file of tests/fuzz/corpus/<target>/ — the fuzzers' seeds and every input that ever made
// one fail — through the same entry points as the fuzzers (compiled here with the normal
// compiler, no libFuzzer): no crash, only documented one-line errors.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "fuzz_entry_points.h"

namespace socketsmith::fuzz {
namespace {
namespace fs = std::filesystem;

const fs::path kCorpus = fs::path(SOCKETSMITH_SOURCE_DIR) / "tests" / "fuzz" / "corpus";

class FuzzRegression : public ::testing::TestWithParam<std::string> {};

TEST_P(FuzzRegression, every_corpus_file_ends_in_success_or_a_documented_error) {
  const std::string target = GetParam();
  const fs::path dir = kCorpus / target;
  ASSERT_TRUE(fs::is_directory(dir)) << dir;
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    std::ifstream in(entry.path(), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_NO_THROW(run(target, reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()))
        << entry.path().filename();
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_LT(s, 20.0) << entry.path().filename() << " took " << s << " s";
    ++files;
  }
  EXPECT_GT(files, 0) << "no corpus files in " << dir;
}

INSTANTIATE_TEST_SUITE_P(Corpus, FuzzRegression, ::testing::Values("stl", "obj", "ply", "limb", "case_file", "design"),
                         [](const ::testing::TestParamInfo<std::string>& p) { return p.param; });

}  // namespace
}  // namespace socketsmith::fuzz
