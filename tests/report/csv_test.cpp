#include "socketsmith/report/csv.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "socketsmith/core/errors.h"

namespace fs = std::filesystem;
using socketsmith::InvalidInputError;
using socketsmith::IoError;
using socketsmith::report::CsvTable;
using socketsmith::report::read_csv;
using socketsmith::report::write_csv;

namespace {

/// A fresh directory per test, removed afterwards.
class CsvTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / (std::string("socketsmith_csv_") + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  void write_text(const fs::path& p, const std::string& text) {
    std::ofstream out(p, std::ios::binary);
    out << text;
  }

  fs::path dir_;
};

}  // namespace

TEST_F(CsvTest, round_trip_keeps_header_and_values) {
  const fs::path p = dir_ / "table.csv";
  const std::vector<std::string> header = {"time_s", "force_n", "pressure, kPa"};
  const std::vector<std::vector<double>> rows = {
      {0.0, -1.5, 1e-7}, {0.1, 2.0 / 3.0, 123456.789}, {1e300, -0.0, 42}};
  write_csv(p, header, rows, 17);
  const CsvTable t = read_csv(p);
  EXPECT_EQ(t.header, header);
  ASSERT_EQ(t.num_rows(), 3);
  ASSERT_EQ(t.num_columns(), 3);
  for (std::size_t r = 0; r < rows.size(); ++r)
    for (std::size_t c = 0; c < 3; ++c) EXPECT_DOUBLE_EQ(t.rows[r][c], rows[r][c]) << r << "," << c;
  EXPECT_EQ(t.column_index("force_n"), 1);
  EXPECT_EQ(t.column_index("nope"), -1);
  EXPECT_EQ(t.column("pressure, kPa"), (std::vector<double>{1e-7, 123456.789, 42}));
  EXPECT_THROW(t.column("nope"), InvalidInputError);
  // No temporary file is left behind.
  int files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_)) ++files;
  EXPECT_EQ(files, 1);
}

TEST_F(CsvTest, significant_digits_round_values) {
  const fs::path p = dir_ / "digits.csv";
  write_csv(p, {"x"}, {{1.0 / 3.0}}, 3);
  std::ifstream in(p);
  std::string header, line;
  std::getline(in, header);
  std::getline(in, line);
  EXPECT_EQ(line, "0.333");
  EXPECT_NEAR(read_csv(p).rows[0][0], 1.0 / 3.0, 1e-3);
  EXPECT_THROW(write_csv(p, {"x"}, {{1.0}}, 0), InvalidInputError);
  EXPECT_THROW(write_csv(p, {"x"}, {{1.0}}, 18), InvalidInputError);
}

TEST_F(CsvTest, non_finite_values_round_trip) {
  const fs::path p = dir_ / "nan.csv";
  const double inf = std::numeric_limits<double>::infinity();
  write_csv(p, {"a", "b", "c"}, {{std::nan(""), inf, -inf}});
  const CsvTable t = read_csv(p);
  ASSERT_EQ(t.num_rows(), 1);
  EXPECT_TRUE(std::isnan(t.rows[0][0]));
  EXPECT_EQ(t.rows[0][1], inf);
  EXPECT_EQ(t.rows[0][2], -inf);
}

TEST_F(CsvTest, row_of_wrong_width_throws_and_keeps_old_file) {
  const fs::path p = dir_ / "bad.csv";
  write_csv(p, {"a", "b"}, {{1, 2}});
  try {
    write_csv(p, {"a", "b"}, {{1, 2}, {3}});
    FAIL() << "expected InvalidInputError";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("row 1"), std::string::npos) << e.what();
  }
  // The previous file is untouched.
  EXPECT_EQ(read_csv(p).rows, (std::vector<std::vector<double>>{{1, 2}}));
  // Without a header every row must match the first one.
  EXPECT_THROW(write_csv(dir_ / "nohdr.csv", {}, {{1, 2}, {3, 4, 5}}), InvalidInputError);
  EXPECT_THROW(write_csv(dir_ / "nl.csv", {"a\nb"}, {{1}}), InvalidInputError);
}

TEST_F(CsvTest, missing_file_is_an_io_error) {
  EXPECT_THROW(read_csv(dir_ / "does_not_exist.csv"), IoError);
}

TEST_F(CsvTest, bad_content_names_file_and_line) {
  const fs::path p = dir_ / "broken.csv";
  write_text(p, "a,b\n1,2\n\n3,oops\n");
  try {
    read_csv(p);
    FAIL() << "expected InvalidInputError";
  } catch (const InvalidInputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("broken.csv"), std::string::npos) << msg;
    EXPECT_NE(msg.find("line 4"), std::string::npos) << msg;
    EXPECT_NE(msg.find("oops"), std::string::npos) << msg;
  }

  write_text(p, "a,b\n1,2,3\n");
  try {
    read_csv(p);
    FAIL() << "expected InvalidInputError";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
  }

  write_text(p, "");
  EXPECT_THROW(read_csv(p), InvalidInputError);
  write_text(p, "a\n1e\n");
  EXPECT_THROW(read_csv(p), InvalidInputError);
  write_text(p, "a,b\n1,\n");
  EXPECT_THROW(read_csv(p), InvalidInputError);
  write_text(p, "\"a,b\n1\n");
  EXPECT_THROW(read_csv(p), InvalidInputError);
}

TEST_F(CsvTest, reads_crlf_spaces_and_quoted_names) {
  const fs::path p = dir_ / "windows.csv";
  write_text(p, "\"x \"\"mm\"\"\", y\r\n 1 , +2.5\r\n-3e2,4\r\n");
  const CsvTable t = read_csv(p);
  EXPECT_EQ(t.header, (std::vector<std::string>{"x \"mm\"", "y"}));
  EXPECT_EQ(t.rows, (std::vector<std::vector<double>>{{1, 2.5}, {-300, 4}}));
}
