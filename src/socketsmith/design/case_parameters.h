#pragma once
/// @file case_parameters.h
/// The case file's scalar parameters in one table: for each, its key in the file, the member of
/// CaseFile (or of a Spot) that holds it, its unit and range (an InputLimit of input_limits.h) and
/// when it is written. The case file is read and written through the table (case_file.cpp), the
/// GUI's spot fields and the design session's edits set values through it, and a command-line
/// flag that overrides a case value can too — so a new number or flag of the case file is one line
/// of the table plus its use (docs/case_file.md, "Adding a parameter").
///
/// Not in the table, written by hand in case_file.cpp: text and file paths (limb.file,
/// limb.bones, limb.units, patient.id, patient.note), names of a kind (limb.type, limb.side,
/// tissue.model, tissue.constants, tissue.solve, design.objective, brim.template, a spot's type,
/// socket.attachment.bolt), vectors and lists (limb.axis, limb.anterior, landmarks, design.spots as
/// a list, brim.key_points, socket.attachment.offset_mm), maps (patient.thresholds_kpa),
/// limb.generate_seed (a 64-bit count), tissue.poisson (its range depends on tissue.model) and
/// socket.attachment.enabled (its default depends on whether the object is there).

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
  UnlessDefault,   ///< only when it differs from a default-constructed owner's (0 = none, an unset optional)
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

/// The table of CaseFile's parameters, in the order they are read.
const std::vector<CaseParameter>& case_parameters();
/// The table of a spot's parameters (keys "design.spots[].<name>").
const std::vector<SpotParameter>& spot_parameters();

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

/// Reads every parameter of @p section ("patient", "socket.attachment", "design.spots[]") that
/// @p j holds into @p owner; a key that is absent keeps the owner's value. @p where names the
/// object in messages ("design.spots[2]"). @throws InvalidInputError naming "<where>.<key>".
template <class Owner>
void read_parameters(const nlohmann::json& j, std::string_view section, const std::string& where, Owner& owner);

/// Writes the parameters of @p section of @p owner into the object @p j (see Written).
template <class Owner>
void write_parameters(nlohmann::json& j, std::string_view section, const Owner& owner);

/// The names of the parameters of @p section ("patient" → body_mass_kg, friction, ...) together
/// with @p others (the section's hand-written keys): what the section accepts.
std::set<std::string> section_keys(std::string_view section, std::set<std::string> others);

}  // namespace socketsmith::design
