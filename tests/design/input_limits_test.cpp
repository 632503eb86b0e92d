// One range per user value (design/input_limits.h), the same words wherever it is typed, and the
// ranges in docs/case_file.md the ones the code checks.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "socketsmith/core/errors.h"
#include "socketsmith/design/design_solver.h"
#include "socketsmith/design/input_limits.h"

namespace socketsmith::design {
namespace {

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InvalidInputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(InputLimits, a_value_out_of_range_or_not_finite_is_one_line_naming_it_and_the_range) {
  EXPECT_EQ(message_of([] { check_input(limits::kFriction, 3, "simulate donning: --friction"); }),
            "simulate donning: --friction = 3 is outside [0, 2]: the friction coefficient of skin on a socket, about 0.5");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(message_of([&] { check_input(limits::kFriction, nan, "x"); }).find("x = nan is not a finite number"),
            std::string::npos);
  EXPECT_NE(message_of([] { check_input(limits::kYoungsModulus, 0, "case file: tissue.youngs_kpa"); })
                .find("tissue.youngs_kpa = 0 kPa is outside [10, 10000] kPa"),
            std::string::npos);
  EXPECT_NE(message_of([] { check_input_count(limits::kTargetNodes, 1e20, "case file: mesh.target_nodes"); })
                .find("mesh.target_nodes = 1e+20 is outside [200, 200000] (whole numbers)"),
            std::string::npos);
  EXPECT_NE(message_of([] { check_input_count(limits::kTargetNodes, 2500.5, "n"); }).find("not a whole number"),
            std::string::npos);
  // Open and closed ends.
  EXPECT_NO_THROW(check_input(limits::kFriction, 0, "x"));
  EXPECT_NO_THROW(check_input(limits::kFriction, 2, "x"));
  EXPECT_THROW(check_input(limits::kBodyMass, 0, "x"), InvalidInputError);
  EXPECT_NO_THROW(check_input(limits::kForceTolerance, 0.1, "x"));
  EXPECT_THROW(check_input(limits::kForceTolerance, 0.1000001, "x"), InvalidInputError);
  EXPECT_THROW(check_input(limits::kFePoisson, 0.5, "x"), InvalidInputError);
  EXPECT_EQ(check_input_count(limits::kTargetNodes, 200, "x"), 200);
}

TEST(InputLimits, the_patient_check_bounds_the_tolerances_that_let_an_unbalanced_socket_pass) {
  PatientLoad p;
  EXPECT_NO_THROW(check_patient(p));
  p.force_tolerance = 1.0;  // 100 %: a socket carrying half the load would pass
  EXPECT_NE(message_of([&] { check_patient(p, "case file: "); })
                .find("case file: patient.force_tolerance = 1 is outside (0, 0.1]"),
            std::string::npos);
  p = PatientLoad{};
  p.torque_tolerance = 0.5;
  EXPECT_THROW(radar_targets(p, 0.15), InvalidInputError);  // the solver's targets use the same check
  p = PatientLoad{};
  p.body_mass_kg = 40;
  p.prosthesis_mass_kg = 45;
  EXPECT_NE(message_of([&] { check_patient(p); }).find("is not below the body mass"), std::string::npos);
}

TEST(InputLimits, docs_case_file_lists_every_range_the_code_checks) {
  std::ifstream in(std::string(SOCKETSMITH_SOURCE_DIR) + "/docs/case_file.md");
  ASSERT_TRUE(in.good());
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string doc = ss.str();
  for (const auto& l : all_input_limits()) {
    // A table row "| `key` | range | ..." with the same text as the messages.
    const std::string row = "| `" + std::string(l.key) + "` | " + describe(l) + " |";
    EXPECT_NE(doc.find(row), std::string::npos) << "docs/case_file.md has no row " << row;
  }
}

}  // namespace
}  // namespace socketsmith::design
