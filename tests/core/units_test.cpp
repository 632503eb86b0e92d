#include "socketsmith/core/units.h"

#include <gtest/gtest.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"

namespace socketsmith {
namespace {

TEST(Units, converts_lengths_and_parses_unit_names) {
  EXPECT_DOUBLE_EQ(units::to_metres(units::LengthUnit::Millimetre) * 260.0, 0.26);
  EXPECT_EQ(units::parse_length_unit("MM"), units::LengthUnit::Millimetre);
  EXPECT_EQ(units::parse_length_unit("m"), units::LengthUnit::Metre);
  EXPECT_EQ(units::to_string(units::LengthUnit::Millimetre), "mm");
  EXPECT_THROW(units::parse_length_unit("inch"), InvalidInputError);
  EXPECT_DOUBLE_EQ(50 * units::kPa, 50e3);
}

TEST(Errors, require_throws_the_requested_type_with_the_formatted_message) {
  try {
    require(false, "f: value {} (expected > 0)", -2);
    FAIL();
  } catch (const InvalidInputError& e) {
    EXPECT_STREQ(e.what(), "f: value -2 (expected > 0)");
  }
  EXPECT_THROW(fail<SolverError>("x"), SolverError);
  EXPECT_NO_THROW(require(true, "never"));
}

TEST(Log, routes_messages_to_the_configured_sink_above_the_level) {
  std::vector<std::string> seen;
  log::set_sink([&](log::Level, std::string_view m) { seen.emplace_back(m); });
  log::set_level(log::Level::Warn);
  log::info("hidden {}", 1);
  log::warn("shown {}", 2);
  log::set_level(log::Level::Info);
  log::set_sink(nullptr);
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0], "shown 2");
  EXPECT_THROW(log::parse_level("loud"), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith
