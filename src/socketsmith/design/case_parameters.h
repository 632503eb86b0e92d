#pragma once
/// @file case_parameters.h
/// The case file's parameters in tables: for each, its key in the file, the member of CaseFile (or
/// of a Spot) that holds it, what it accepts and when it is written. The case file is read and
/// written through the tables (case_file.cpp); the GUI's fields and combo boxes, the design
/// session's edits and the command-line flags that override or name a case value read and set
/// values through them — so a new parameter is one line of a table plus its use
/// (docs/case_file.md, "Adding a parameter").
///
/// Two tables, one for each kind of value:
/// - numbers and flags (Parameter: a unit and a range, an InputLimit of input_limits.h; get and
///   set in SI): case_parameters(), spot_parameters();
/// - names and text (TextParameter): names of a kind — limb.type, limb.side, limb.units,
///   tissue.model, tissue.constants, tissue.solve, design.objective, brim.template, a spot's type,
///   socket.attachment.bolt: the allowed names, each with its value, and an unknown name refused
///   in one line that lists them — and free text: limb.file, limb.bones (a name or a file),
///   patient.id, patient.note, a spot's name: case_text_parameters(), spot_text_parameters().
///
/// Still read and written by hand in case_file.cpp, each for a reason a table line would hide:
/// the limb's directions limb.axis and limb.anterior (checked as the command line's --axis and
/// --anterior are, case_file.h) and socket.attachment.offset_mm (a pair with a range for each of
/// its two components); structured lists and maps — landmarks, design.spots as a list (or
/// "default"), brim.key_points, patient.thresholds_kpa — whose entries are keyed by the user;
/// limb.generate_seed (a 64-bit count, written only without a limb file); tissue.poisson (its
/// range depends on tissue.model); socket.attachment.enabled (its default depends on whether the
/// object is there); and what a value sets beside itself (a bolt's default clearance hole, a
/// tissue model's own solve when tissue.solve is not given).

#include <array>
#include <functional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "socketsmith/design/case_file.h"
#include "socketsmith/design/input_limits.h"

namespace socketsmith::design {

/// When case_to_json writes a parameter.
enum class Written {
  Always,          ///< every time
  UnlessDefault,   ///< only when it differs from a default-constructed owner's (0 = none, an unset optional, "")
  ForItsSpotType,  ///< a spot's shape field: only for the types that use it (thesis Table 6, spot_type_uses)
};

/// One scalar parameter of the case file. Values in the file are in the limit's unit (mm, kPa,
/// deg, kg, s, 1/deg, 1/mm); get and set speak SI (m, Pa, rad, 1/rad, 1/m).
template <class Owner>
struct Parameter {
  /// key: the dotted path in the file ("socket.thickness_mm", "design.spots[].h0_mm"); unit, range
  /// and hint (the help shown with an error and as a tooltip). A flag's has only key and hint.
  InputLimit limit;
  bool is_flag = false;           ///< true / false in the file; the range is not used
  Written written = Written::Always;
  bool is_zero_unset = false;     ///< 0 in the file means "not set" and is accepted without the range check
  double (*get)(const Owner&) = nullptr;  ///< the value in SI; NaN for an optional that is not set; a flag 0 / 1
  void (*set)(Owner&, double) = nullptr;  ///< from a value in SI; NaN clears an optional

  std::string_view key() const { return limit.key; }
  /// The object that holds the key: "socket.attachment" of "socket.attachment.bolt".
  std::string_view section() const { return key().substr(0, key().rfind('.')); }
  /// The key within its object: "thickness_mm".
  std::string_view name() const { return key().substr(key().rfind('.') + 1); }
};
using CaseParameter = Parameter<CaseFile>;
using SpotParameter = Parameter<Spot>;

/// One parameter of the case file held as text: a name of a kind (one of names) or free text
/// (names empty). A name is read as the kind's parser reads it (limb.type takes "TT", brim.template
/// "quadrilateral") and written as listed in names.
template <class Owner>
struct TextParameter {
  std::string_view key;   ///< the dotted path in the file ("tissue.model", "design.spots[].type")
  std::string_view help;  ///< what the value means: a tooltip, a flag's help
  /// The allowed names, in the order an unknown name's error lists them; empty: any text.
  std::vector<std::string_view> names;
  Written written = Written::Always;  ///< UnlessDefault: not written while is_default(owner)
  std::function<std::string(const Owner&)> get;  ///< the name or text; "" = not set
  /// Sets the value from @p text as the user wrote it; @p name says where it came from
  /// ("case file: tissue.model", "mesh --model"). @throws InvalidInputError, one line: an
  /// unknown name with the allowed ones, or an empty text the parameter refuses.
  std::function<void(Owner&, const std::string& text, std::string_view name)> set;
  /// Whether @p owner holds what the file means when the key is absent (for UnlessDefault).
  std::function<bool(const Owner&)> is_default;

  std::string_view section() const { return key.substr(0, key.rfind('.')); }
  std::string_view name() const { return key.substr(key.rfind('.') + 1); }
};
using CaseTextParameter = TextParameter<CaseFile>;
using SpotTextParameter = TextParameter<Spot>;

/// The table of CaseFile's parameters, in the order they are read.
const std::vector<CaseParameter>& case_parameters();
/// The table of a spot's parameters (keys "design.spots[].<name>").
const std::vector<SpotParameter>& spot_parameters();

/// The table of CaseFile's names and texts, in the order they are read.
const std::vector<CaseTextParameter>& case_text_parameters();
/// The table of a spot's names and texts (keys "design.spots[].name", "design.spots[].type").
const std::vector<SpotTextParameter>& spot_text_parameters();

/// The keys case_file.cpp reads and writes by hand, outside the tables (why: this file's comment);
/// "a[].b" is key b of each object in the list a. Every key case_to_json writes is in a table or
/// here (a test walks a written case); a nested object (socket.alignment) is a section, not a key.
/// socket.attachment.enabled is read, never written: the object's presence says it.
inline constexpr std::array<std::string_view, 14> kKeysByHand{
    "socketsmith_case",          "limb.generate_seed",          "limb.axis",
    "limb.anterior",             "patient.thresholds_kpa",      "tissue.poisson",
    "landmarks",                 "design.spots",                "brim.key_points",
    "brim.key_points[].theta_deg", "brim.key_points[].h_mm",    "brim.key_points[].label",
    "socket.attachment.enabled", "socket.attachment.offset_mm"};

/// Thesis Table 6: whether a spot of @p type uses the field @p name ("h0_mm"); the amplitude and
/// the spot's flags are used by every type.
bool spot_type_uses(SpotType type, std::string_view name);

/// A value in the file's @p unit ("mm", "kPa", "deg", "1/deg", "1/mm"; others are SI already) in SI, and back.
double file_to_si(std::string_view unit, double value);
double si_to_file(std::string_view unit, double value);

/// The parameter of @p key ("patient.friction"), or nullptr.
const CaseParameter* find_case_parameter(std::string_view key);
/// The spot parameter named @p name ("h0_mm", as the GUI and `set` name a spot's field), or nullptr.
const SpotParameter* find_spot_parameter(std::string_view name);

/// The name or text parameter of @p key ("tissue.model"), or nullptr.
const CaseTextParameter* find_case_text_parameter(std::string_view key);
/// The spot's name or text parameter named @p name ("type"), or nullptr.
const SpotTextParameter* find_spot_text_parameter(std::string_view name);

/// The names of @p p as an error lists them: "mss-cs, mss-cf, mss, fe or neo-hookean".
template <class Owner>
std::string listed_names(const TextParameter<Owner>& p);

/// @p p's value of @p owner in the file's units (a flag: 0 / 1).
template <class Owner>
double file_value(const Parameter<Owner>& p, const Owner& owner);

/// Sets @p p of @p owner from @p value in the file's units, checked against its range first (a flag:
/// value ≠ 0 is true). @p name says where the value came from, as the user wrote it
/// ("case file: patient.friction", "design --time-limit", "set: spot PT r_h_mm").
/// @throws InvalidInputError, one line: "<name> = <value> is outside <range>: <hint>".
template <class Owner>
void set_file_value(const Parameter<Owner>& p, Owner& owner, double value, std::string_view name);

/// set_file_value of the case parameter @p key ("design.time_limit_s"): a command-line flag or a
/// panel that overrides one value of the case. @throws InvalidInputError for a key not in the table
/// or a value outside its range.
void set_case_value(CaseFile& c, std::string_view key, double value, std::string_view name);

/// set of the name or text parameter @p key ("tissue.model") of the case: a command-line flag or
/// a panel that names one value of the case. @throws InvalidInputError for a key not in the table,
/// an unknown name (listing the allowed ones) or a refused text.
void set_case_text(CaseFile& c, std::string_view key, const std::string& text, std::string_view name);

/// Reads every parameter of @p section ("patient", "socket.attachment", "design.spots[]") that
/// @p j holds into @p owner; a key that is absent keeps the owner's value. @p where names the
/// object in messages ("design.spots[2]"). @throws InvalidInputError naming "<where>.<key>".
template <class Owner>
void read_parameters(const nlohmann::json& j, std::string_view section, const std::string& where, Owner& owner);

/// Writes the parameters of @p section of @p owner into the object @p j (see Written).
template <class Owner>
void write_parameters(nlohmann::json& j, std::string_view section, const Owner& owner);

/// read_parameters and write_parameters of the names and texts (TextParameter): a key that is
/// absent keeps the owner's value; a value that is not a string is refused naming "<where>.<key>".
template <class Owner>
void read_text_parameters(const nlohmann::json& j, std::string_view section, const std::string& where, Owner& owner);
template <class Owner>
void write_text_parameters(nlohmann::json& j, std::string_view section, const Owner& owner);

/// The names of the parameters of @p section in both tables ("patient" → id, note, body_mass_kg,
/// friction, ...) together with @p others (the section's hand-written keys): what it accepts.
std::set<std::string> section_keys(std::string_view section, std::set<std::string> others);

}  // namespace socketsmith::design
