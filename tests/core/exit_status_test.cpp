// Every exception type lands on a documented exit code (README: 0, 1, 2, 3, 4, 70) with one line.
#include <gtest/gtest.h>

#include <filesystem>
#include <ios>
#include <new>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/exit_status.h"

namespace socketsmith {
namespace {

template <class E>
ExitStatus status_of(E error) {
  try {
    throw error;
  } catch (...) {
    return exit_status(std::current_exception());
  }
}

TEST(ExitStatus, each_error_type_has_its_documented_code) {
  EXPECT_EQ(status_of(InvalidInputError("bad")).code, 1);
  EXPECT_EQ(status_of(IoError("io")).code, 2);
  EXPECT_EQ(status_of(SolverError("diverged")).code, 3);
  EXPECT_EQ(status_of(TopologyError("open")).code, 4);
  EXPECT_EQ(status_of(Error("internal invariant failed")).code, 70);
  EXPECT_EQ(status_of(std::logic_error("bug")).code, 70);
  EXPECT_EQ(status_of(std::bad_alloc()).code, 70);
  EXPECT_EQ(status_of(42).code, 70);
  EXPECT_EQ(exit_status(nullptr).code, 0);
}

TEST(ExitStatus, library_exceptions_of_bad_input_and_files_are_not_internal_errors) {
  // A JSON value of the wrong type in a user's file, an unreadable folder, a failed stream.
  try {
    (void)nlohmann::json::parse(R"({"a": "text"})").at("a").get<double>();
  } catch (...) {
    EXPECT_EQ(exit_status(std::current_exception()).code, 1);
  }
  const std::filesystem::filesystem_error fe("cannot open", std::filesystem::path("/x"),
                                              std::make_error_code(std::errc::permission_denied));
  EXPECT_EQ(status_of(fe).code, 2);
  EXPECT_EQ(status_of(std::ios_base::failure("stream")).code, 2);
}

TEST(ExitStatus, the_message_is_one_line_with_its_prefix) {
  const ExitStatus s = status_of(InvalidInputError("first line\nsecond line\n"));
  EXPECT_EQ(s.message, "first line; second line");
  EXPECT_EQ(s.line(), "error: first line; second line");
  EXPECT_EQ(status_of(std::logic_error("oops")).line(), "internal error: oops (please report it)");
  EXPECT_EQ(one_line("a  \n\n  b\r\n"), "a; b");
}

TEST(Errors, user_text_with_control_characters_keeps_a_message_on_one_line) {
  try {
    fail("unknown key '{}'", std::string("a\nb\r\x01"));
  } catch (const InvalidInputError& e) {
    EXPECT_EQ(std::string(e.what()), "unknown key 'a\\nb\\r\\x01'");
  }
  EXPECT_THROW(require<IoError>(false, "{}", "x"), IoError);
}

}  // namespace
}  // namespace socketsmith
