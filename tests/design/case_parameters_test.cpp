// The case file's table of parameters (design/case_parameters.h): every entry is written and read
// back, and every entry refuses a value outside its range in one line naming its key.
#include <gtest/gtest.h>

#include <cmath>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/case_file.h"
#include "socketsmith/design/case_parameters.h"

namespace socketsmith::design {
namespace {
using nlohmann::json;

/// A value well inside @p p's range that is not a round number (so the unit conversions are
/// exercised) and not the default (so it must be written to come back).
template <class Owner>
double inside_value(const Parameter<Owner>& p, const Owner& defaults) {
  if (p.is_flag) return p.get(defaults) != 0.0 ? 0.0 : 1.0;
  const InputLimit& l = p.limit;
  double v = l.min + 0.3137 * (l.max - l.min);
  if (l.is_integer) v = std::round(v);
  if (v == file_value(p, defaults)) v = l.min + 0.6173 * (l.max - l.min);
  return v;
}

/// A value outside @p p's range: below its lower end.
double outside_value(const InputLimit& l) { return l.min - 0.5 * (l.max - l.min) - 1.0; }

/// The document {"a": {"b": {name: value}}} for a key "a.b.name"; "design.spots[]" holds one spot of
/// a type that uses the field.
json document_with(std::string_view section, std::string_view name, const json& value) {
  json leaf{{std::string(name), value}};
  if (section == "design.spots[]") {
    SpotType type = SpotType::Cos2;
    for (SpotType t : {SpotType::Cos2, SpotType::Sig2, SpotType::CosSig, SpotType::Grad})
      if (spot_type_uses(t, name)) {
        type = t;
        break;
      }
    leaf["type"] = to_string(type);
    return json{{"design", {{"spots", json::array({leaf})}}}};
  }
  std::string path(section);
  for (size_t dot = path.rfind('.'); dot != std::string::npos; dot = path.rfind('.')) {
    leaf = json{{path.substr(dot + 1), leaf}};
    path.resize(dot);
  }
  return json{{path, leaf}};
}

TEST(CaseParameters, every_case_parameter_is_written_and_read_back) {
  const CaseFile defaults;
  for (const auto& p : case_parameters()) {
    SCOPED_TRACE(std::string(p.key()));
    CaseFile c;
    c.socket.attachment.enabled = true;  // written only with its platform
    const double v = inside_value(p, defaults);
    set_file_value(p, c, v, "test");
    ASSERT_NE(p.get(c), p.get(defaults));
    const json written = case_to_json(c);
    const CaseFile back = parse_case(written);
    EXPECT_DOUBLE_EQ(file_value(p, back), v);
    EXPECT_DOUBLE_EQ(p.get(back), p.get(c));
    EXPECT_EQ(case_to_json(back), written);  // read → write → read is the same document
  }
}

TEST(CaseParameters, every_spot_parameter_is_written_and_read_back) {
  const Spot defaults;
  for (const auto& p : spot_parameters()) {
    SCOPED_TRACE(std::string(p.key()));
    for (SpotType type : {SpotType::Cos2, SpotType::Sig2, SpotType::CosSig, SpotType::Grad}) {
      if (!spot_type_uses(type, p.name())) continue;
      CaseFile c;
      Spot s;
      s.name = "S";
      s.type = type;
      const double v = inside_value(p, defaults);
      set_file_value(p, s, v, "test");
      c.spots.push_back(s);
      const json written = case_to_json(c);
      const CaseFile back = parse_case(written);
      ASSERT_EQ(back.spots.size(), 1u);
      EXPECT_DOUBLE_EQ(file_value(p, back.spots[0]), v);
      EXPECT_EQ(case_to_json(back), written);
    }
  }
}

template <class Owner>
void expect_refused(const Parameter<Owner>& p, const json& value, const std::string& needle) {
  const json doc = document_with(p.section(), p.name(), value);
  try {
    parse_case(doc);
    ADD_FAILURE() << p.key() << ": no error for " << doc.dump();
  } catch (const InvalidInputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(needle), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << "one line: " << m;
  }
}

/// "design.spots[].h0_mm" as the message names it: "design.spots[0].h0_mm".
std::string named(std::string_view key) {
  std::string k(key);
  const size_t at = k.find("[]");
  return at == std::string::npos ? k : k.replace(at, 2, "[0]");
}

TEST(CaseParameters, every_parameter_refuses_a_value_outside_its_range_in_one_line_naming_it) {
  const auto check = [](const auto& table) {
    for (const auto& p : table) {
      SCOPED_TRACE(std::string(p.key()));
      if (p.is_flag) {
        expect_refused(p, "yes", "'" + named(p.key()) + "' must be true or false");
        continue;
      }
      const double below = outside_value(p.limit);
      expect_refused(p, below, fmt::format("case file: {} = {}", named(p.key()), below));
      expect_refused(p, p.limit.max * 2 + 1, fmt::format("case file: {} = ", named(p.key())));
      expect_refused(p, "1", "must be a number");
    }
  };
  check(case_parameters());
  check(spot_parameters());
}

TEST(CaseParameters, every_unit_is_one_the_conversion_knows) {
  // A unit the conversion does not know would be read as if it were SI; the table says which.
  const auto check = [](const auto& table) {
    for (const auto& p : table) {
      const std::string_view u = p.limit.unit;
      EXPECT_TRUE(u == "" || u == "kg" || u == "s" || u == "kg/m^3" || u == "mm" || u == "kPa" || u == "deg" ||
                  u == "1/deg" || u == "1/mm")
          << p.key() << ": unit '" << u << "'";
    }
  };
  check(case_parameters());
  check(spot_parameters());
  EXPECT_DOUBLE_EQ(file_to_si("mm", 5), 0.005);
  EXPECT_DOUBLE_EQ(file_to_si("kPa", 5), 5000);
  EXPECT_DOUBLE_EQ(file_to_si("deg", 90), 90 * units::deg);
  EXPECT_DOUBLE_EQ(file_to_si("1/mm", 0.4), 400);
  EXPECT_DOUBLE_EQ(si_to_file("1/deg", file_to_si("1/deg", 0.35)), 0.35);
}

TEST(CaseParameters, a_key_is_found_and_set_in_the_users_units) {
  CaseFile c;
  const CaseParameter* t = find_case_parameter("socket.thickness_mm");
  ASSERT_NE(t, nullptr);
  set_file_value(*t, c, 6, "socket panel: wall");
  EXPECT_DOUBLE_EQ(c.socket.thickness_m, 0.006);
  EXPECT_DOUBLE_EQ(file_value(*t, c), 6.0);
  EXPECT_EQ(find_case_parameter("socket.thickness"), nullptr);
  try {
    set_file_value(*t, c, 60, "socket panel: wall");
    ADD_FAILURE() << "no error";
  } catch (const InvalidInputError& e) {
    EXPECT_EQ(std::string(e.what()), "socket panel: wall = 60 mm is outside (0, 50] mm: the wall must be thicker than 0 "
                                     "and at most 50 mm (typical 4–8)");
  }
  Spot s;
  ASSERT_NE(find_spot_parameter("r_h_mm"), nullptr);
  set_file_value(*find_spot_parameter("r_h_mm"), s, 12, "set");
  EXPECT_DOUBLE_EQ(s.r_h, 0.012);
  EXPECT_EQ(find_spot_parameter("design.spots[].r_h_mm"), nullptr);  // a spot's field by its name
}

}  // namespace
}  // namespace socketsmith::design
