// User JSON: parse errors are one InvalidInputError line naming the place; a number too large
// for a double names the key that holds it (the GUI aborted and the CLI exited 70 on 1e400).
#include <gtest/gtest.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/json_input.h"

namespace socketsmith {
namespace {

std::string message_of(std::string_view text) {
  try {
    parse_json_input(text, "case file 'c.json'");
  } catch (const InvalidInputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(JsonInput, a_number_overflow_names_the_key_that_holds_it) {
  const std::string m = message_of(R"({"patient": {"id": "x", "body_mass_kg": 1e400}})");
  EXPECT_NE(m.find("case file 'c.json': the number 1e400 at 'patient.body_mass_kg' is out of range"), std::string::npos)
      << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
}

TEST(JsonInput, the_path_follows_arrays_and_nested_objects) {
  EXPECT_EQ(json_error_path(R"({"design": {"spots": [{"type": "cos2"}, {"h0_mm": 1e999}]}})"), "design.spots[1].h0_mm");
  EXPECT_EQ(json_error_path(R"({"a": [1, 2, -1e500]})"), "a[2]");
  EXPECT_EQ(json_error_path(R"({"a": {"b": 1}, "c": 1e400})"), "c");
  EXPECT_EQ(json_error_path("1e400"), "");
  const std::string m = message_of(R"({"landmarks": {"PT": [0, 1e400, 0]}})");
  EXPECT_NE(m.find("at 'landmarks.PT[1]'"), std::string::npos) << m;
}

TEST(JsonInput, text_that_is_not_json_says_where) {
  const std::string m = message_of("{\"patient\": {\"body_mass_kg\": 70,}}");
  EXPECT_NE(m.find("case file 'c.json' is not valid JSON (at 'patient"), std::string::npos) << m;
  EXPECT_NE(m.find("line 1"), std::string::npos) << m;
  EXPECT_EQ(m.find("[json.exception"), std::string::npos) << m;
  EXPECT_NE(message_of("").find("is not valid JSON"), std::string::npos);
  EXPECT_NO_THROW(parse_json_input(R"({"a": [1e300, -2.5, "x"]})", "x"));
}

}  // namespace
}  // namespace socketsmith
