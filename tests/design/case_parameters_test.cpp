// The case file's tables of parameters (design/case_parameters.h): every entry is written and read
// back, every number refuses a value outside its range and every name of a kind an unknown name, in
// one line naming its key; every key a written case holds is in a table or in the by-hand list.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

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
    if (name != "type") leaf["type"] = to_string(type);
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

template <class P>
void expect_refused(const P& p, const json& value, const std::string& needle) {
  const json doc = document_with(p.section(), p.name(), value);
  try {
    parse_case(doc);
    ADD_FAILURE() << "no error for " << doc.dump();
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

/// The value at @p p's key in a written case ("design.spots[]" → the first spot), or null.
template <class Owner>
json written_at(const json& doc, const TextParameter<Owner>& p) {
  json node = doc;
  std::string section(p.section());
  for (size_t start = 0;;) {
    const size_t dot = section.find('.', start);
    std::string part = section.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    const bool is_list = part.size() > 2 && part.compare(part.size() - 2, 2, "[]") == 0;
    if (is_list) part.resize(part.size() - 2);
    if (!node.contains(part)) return nullptr;
    node = is_list ? node[part][0] : node[part];
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  const std::string name(p.name());
  return node.contains(name) ? node[name] : json();
}

TEST(CaseParameters, every_name_of_every_kind_is_written_and_read_back) {
  for (const auto& p : case_text_parameters()) {
    SCOPED_TRACE(std::string(p.key));
    for (std::string_view name : p.names) {
      SCOPED_TRACE(std::string(name));
      CaseFile c;
      c.socket.attachment.enabled = true;  // the bolt is written only with its platform
      p.set(c, std::string(name), "test");
      EXPECT_EQ(p.get(c), name);
      const json written = case_to_json(c);
      if (p.written == Written::Always || !p.is_default(c)) {
        EXPECT_EQ(written_at(written, p), name);
      }
      const CaseFile back = parse_case(written);
      EXPECT_EQ(p.get(back), name);
      EXPECT_EQ(case_to_json(back), written);
    }
  }
  const SpotTextParameter& type = *find_spot_text_parameter("type");
  ASSERT_EQ(type.names.size(), 4u);
  for (std::string_view name : type.names) {
    CaseFile c;
    Spot s;
    type.set(s, std::string(name), "test");
    EXPECT_EQ(to_string(s.type), name);  // the name the rest of socketsmith gives the type
    c.spots.push_back(s);
    const json written = case_to_json(c);
    EXPECT_EQ(written_at(written, type), name);
    EXPECT_EQ(type.get(parse_case(written).spots.at(0)), name);
  }
}

TEST(CaseParameters, a_kinds_aliases_are_read_and_written_by_their_name) {
  CaseFile c;
  set_case_text(c, "limb.type", "TF", "test");
  set_case_text(c, "brim.template", "quadrilateral", "test");
  set_case_text(c, "limb.side", "l", "test");
  EXPECT_EQ(c.limb.type, geometry::LimbType::Transfemoral);
  const json written = case_to_json(c);
  EXPECT_EQ(written["limb"]["type"], "transfemoral");
  EXPECT_EQ(written["limb"]["side"], "left");
  EXPECT_EQ(written["brim"]["template"], "quad");
}

TEST(CaseParameters, an_unknown_name_is_refused_in_one_line_listing_the_allowed_ones) {
  const auto check = [](const auto& table) {
    for (const auto& p : table) {
      if (p.names.empty()) continue;
      SCOPED_TRACE(std::string(p.key));
      const json doc = document_with(p.section(), p.name(), "zz-unknown");
      try {
        parse_case(doc);
        ADD_FAILURE() << p.key << ": no error for " << doc.dump();
      } catch (const InvalidInputError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("'zz-unknown'"), std::string::npos) << m;
        for (std::string_view name : p.names) EXPECT_NE(m.find(name), std::string::npos) << name << " in " << m;
        EXPECT_EQ(m.find('\n'), std::string::npos) << "one line: " << m;
      }
      expect_refused(p, 3, "'" + named(p.key) + "' must be a string (got 3)");
    }
  };
  check(case_text_parameters());
  check(spot_text_parameters());
  // The generic message of a kind without a parser of its own (design.objective) and set_case_text's.
  CaseFile c;
  try {
    set_case_text(c, "design.objective", "comfort", "--objective");
    ADD_FAILURE() << "no error";
  } catch (const InvalidInputError& e) {
    EXPECT_EQ(std::string(e.what()), "--objective 'comfort' is not known (pressure, ratio or uniform)");
  }
  EXPECT_THROW(set_case_text(c, "design.objectives", "ratio", "test"), InvalidInputError);
}

TEST(CaseParameters, every_text_is_written_and_read_back_and_an_empty_one_refused_where_it_means_nothing) {
  const std::string text = "P-7 \"a\" ü\t<b>";
  for (const auto& p : case_text_parameters()) {
    if (!p.names.empty()) continue;
    SCOPED_TRACE(std::string(p.key));
    CaseFile c;
    p.set(c, text, "test");
    const json written = case_to_json(c);
    EXPECT_EQ(written_at(written, p), text);
    EXPECT_EQ(p.get(parse_case(written)), text);
    const bool is_empty_refused = p.key == "limb.file" || p.key == "limb.bones";
    if (is_empty_refused) expect_refused(p, "", "case file: " + std::string(p.key) + " is empty: give ");
    else EXPECT_EQ(p.get(parse_case(document_with(p.section(), p.name(), ""))), "");
  }
}

/// Every key of @p j as a dotted path (a list of objects as "a[].b"); a key by hand is not entered
/// unless it is a list of objects (design.spots: its entries are the spot tables').
void written_keys(const json& j, const std::string& prefix, std::set<std::string>& out) {
  const auto is_by_hand = [](const std::string& k) {
    return std::find(kKeysByHand.begin(), kKeysByHand.end(), k) != kKeysByHand.end();
  };
  for (const auto& [k, v] : j.items()) {
    const std::string key = prefix.empty() ? k : prefix + "." + k;
    if (v.is_array() && !v.empty() && v[0].is_object()) {
      out.insert(key);
      for (const auto& e : v) written_keys(e, key + "[]", out);
    } else if (v.is_object() && !is_by_hand(key)) {
      written_keys(v, key, out);  // a section
    } else {
      out.insert(key);
    }
  }
}

TEST(CaseParameters, every_key_a_written_case_holds_is_in_a_table_or_in_the_by_hand_list) {
  CaseFile c;
  c.limb.units = "mm";
  c.limb.side = geometry::Side::Left;
  c.limb.axis = Eigen::Vector3d(0, 0, 1);
  c.limb.anterior = Eigen::Vector3d(0, 1, 0);
  c.limb.cut_height_m = 0.18;
  c.patient_id = "P";
  c.patient_note = "N";
  c.thresholds["PT"] = 189e3;
  c.poisson_ratio = 0.45;
  c.solve_mode = DesignSolveMode::Auto;
  c.landmarks["PT"] = Eigen::Vector3d(0, -0.06, 0.01);
  for (SpotType t : {SpotType::Cos2, SpotType::Sig2, SpotType::CosSig, SpotType::Grad}) {
    Spot s;
    s.name = to_string(t);
    s.type = t;
    s.max_amplitude_pa = 50e3;
    c.spots.push_back(s);
  }
  c.brim = BrimTemplate::Kbm;
  c.brim_key_points.push_back({"anterior", 0.0, 0.16});
  c.socket.attachment.enabled = true;
  std::set<std::string> keys;
  written_keys(case_to_json(c), "", keys);
  written_keys(case_to_json(CaseFile{}), "", keys);  // limb.generate_seed: without a limb file
  std::set<std::string> tables, by_hand(kKeysByHand.begin(), kKeysByHand.end());
  for (const auto& p : case_parameters()) tables.emplace(p.key());
  for (const auto& p : spot_parameters()) tables.emplace(p.key());
  for (const auto& p : case_text_parameters()) tables.emplace(p.key);
  for (const auto& p : spot_text_parameters()) tables.emplace(p.key);
  for (const auto& k : keys) EXPECT_TRUE(tables.count(k) || by_hand.count(k)) << k << " is written by hand, unlisted";
  for (const auto& k : by_hand) {
    EXPECT_EQ(tables.count(k), 0u) << k << " is in a table and in the by-hand list";
    if (k != "socket.attachment.enabled") {
      EXPECT_EQ(keys.count(k), 1u) << k << " is listed by hand but not written";
    }
  }
}

}  // namespace
}  // namespace socketsmith::design
