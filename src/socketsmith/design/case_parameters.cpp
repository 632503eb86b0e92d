#include "socketsmith/design/case_parameters.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <type_traits>

#include <fmt/format.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/case_file_detail.h"
#include "socketsmith/geometry/limb_frame.h"

namespace socketsmith::design {
namespace {
using nlohmann::json;

template <class T>
struct IsOptional : std::false_type {};
template <class T>
struct IsOptional<std::optional<T>> : std::true_type {};

template <class M>
struct MemberClass;
template <class C, class M>
struct MemberClass<M C::*> {
  using type = C;
};

/// A member reached through a chain of member pointers (&CaseFile::socket, &SocketOptions::thickness_m),
/// read and written as a double: an int is converted, a bool is 0 / 1, an unset optional is NaN.
template <auto First, auto... Rest>
struct MemberPath {
  using Owner = typename MemberClass<decltype(First)>::type;

  template <class O>
  static auto& in(O& o) {
    return ((o .* First) .* ... .* Rest);
  }
  static double get(const Owner& o) {
    const auto& v = in(o);
    if constexpr (IsOptional<std::decay_t<decltype(v)>>::value)
      return v ? *v : std::numeric_limits<double>::quiet_NaN();
    else
      return static_cast<double>(v);
  }
  static void set(Owner& o, double x) {
    auto& v = in(o);
    using T = std::decay_t<decltype(v)>;
    if constexpr (IsOptional<T>::value) {
      if (std::isnan(x)) v.reset();
      else v = x;
    } else if constexpr (std::is_same_v<T, bool>) {
      v = x != 0.0;
    } else {
      v = static_cast<T>(x);
    }
  }
};

/// A number: its key, unit and range are @p limit's.
template <auto... Path>
Parameter<typename MemberPath<Path...>::Owner> number(const InputLimit& limit, Written written = Written::Always,
                                                     bool is_zero_unset = false) {
  return {limit, false, written, is_zero_unset, &MemberPath<Path...>::get, &MemberPath<Path...>::set};
}

/// A flag (true / false) of @p key; @p help says what true means.
template <auto... Path>
Parameter<typename MemberPath<Path...>::Owner> flag(std::string_view key, std::string_view help,
                                                   Written written = Written::Always) {
  return {InputLimit{key, "", 0, 1, false, false, true, help}, true, written, false, &MemberPath<Path...>::get,
          &MemberPath<Path...>::set};
}

template <auto... Path>
using OwnerOf = typename MemberPath<Path...>::Owner;
/// The type of the member at the end of Path, as declared (std::optional<geometry::Side>).
template <auto... Path>
using HeldBy = std::decay_t<decltype(MemberPath<Path...>::in(std::declval<OwnerOf<Path...>&>()))>;
template <class T>
struct Unoptional {
  using type = T;
};
template <class T>
struct Unoptional<std::optional<T>> {
  using type = T;
};
/// The kind's value type: the member's, without its std::optional.
template <auto... Path>
using KindOf = typename Unoptional<HeldBy<Path...>>::type;

template <class E>
using Choices = std::vector<std::pair<std::string_view, E>>;

std::string listed(const std::vector<std::string_view>& names) {
  std::string out;
  for (size_t i = 0; i < names.size(); ++i)
    out += fmt::format("{}{}", i == 0 ? "" : i + 1 == names.size() ? " or " : ", ", names[i]);
  return out;
}

bool is_listed(const std::vector<std::string_view>& names, const std::string& text) {
  return std::find(names.begin(), names.end(), text) != names.end();
}

/// @p p not written while its value is that of a default-constructed owner.
template <class Owner>
TextParameter<Owner> unless_as_default(TextParameter<Owner> p) {
  p.is_default = [get = p.get](const Owner& o) {
    static const Owner kDefault{};
    return get(o) == get(kDefault);
  };
  return p;
}

/// A name of a kind held as an enum (or a std::optional of one): @p choices pairs each allowed name
/// with its value, in the order an error lists them. A name is read by @p parse, the kind's own
/// parser (its aliases, its message), or without one looked up in choices: "<name> 'x' is not
/// known (a, b or c)". The value is written as its name in choices.
template <auto... Path>
TextParameter<OwnerOf<Path...>> kind(std::string_view key, std::string_view help, Choices<KindOf<Path...>> choices,
                                     KindOf<Path...> (*parse)(const std::string&) = nullptr,
                                     Written written = Written::Always) {
  using P = MemberPath<Path...>;
  using E = KindOf<Path...>;
  TextParameter<OwnerOf<Path...>> p{key, help, {}, written, {}, {}, {}};
  for (const auto& c : choices) p.names.push_back(c.first);
  p.get = [choices](const OwnerOf<Path...>& o) -> std::string {
    const auto& held = P::in(o);
    const E* v = nullptr;
    if constexpr (IsOptional<HeldBy<Path...>>::value) v = held ? &*held : nullptr;
    else v = &held;
    for (const auto& [name, value] : choices)
      if (v && value == *v) return std::string(name);
    return "";
  };
  p.set = [choices, parse, names = p.names](OwnerOf<Path...>& o, const std::string& text, std::string_view name) {
    if (parse) {
      P::in(o) = parse(text);
      return;
    }
    for (const auto& [n, value] : choices)
      if (n == text) {
        P::in(o) = value;
        return;
      }
    fail("{} '{}' is not known ({})", name, text, listed(names));
  };
  return unless_as_default(p);
}

/// A name of a kind held as text (tissue.model "mss-cs"): one of @p names, checked by @p check (the
/// kind's own check and message) or, without one, against names as kind() does.
template <auto... Path>
TextParameter<OwnerOf<Path...>> kind_text(std::string_view key, std::string_view help,
                                          std::vector<std::string_view> names,
                                          void (*check)(const std::string&) = nullptr,
                                          Written written = Written::Always) {
  using P = MemberPath<Path...>;
  TextParameter<OwnerOf<Path...>> p{key, help, names, written, {}, {}, {}};
  p.get = [](const OwnerOf<Path...>& o) { return std::string(P::in(o)); };
  p.set = [check, names](OwnerOf<Path...>& o, const std::string& text, std::string_view name) {
    if (check) check(text);
    else require(is_listed(names, text), "{} '{}' is not known ({})", name, text, listed(names));
    P::in(o) = text;
  };
  return unless_as_default(p);
}

/// Free text; @p if_empty, when given, refuses an empty text: "<name> is empty: <if_empty>".
template <auto... Path>
TextParameter<OwnerOf<Path...>> free_text(std::string_view key, std::string_view help, Written written,
                                          std::string_view if_empty = {}) {
  using P = MemberPath<Path...>;
  TextParameter<OwnerOf<Path...>> p{key, help, {}, written, {}, {}, {}};
  p.get = [](const OwnerOf<Path...>& o) { return std::string(P::in(o)); };
  p.set = [if_empty](OwnerOf<Path...>& o, const std::string& text, std::string_view name) {
    require(!text.empty() || if_empty.empty(), "{} is empty: {}", name, if_empty);
    P::in(o) = text;
  };
  return unless_as_default(p);
}

using C = CaseFile;
using S = Spot;
using W = Written;
using geometry::LimbType;
using geometry::Side;
using Objective = OptimizerOptions::Objective;

/// tissue.solve is written only when it is not the tissue model's own (default_solve_mode), so that
/// a document whose model is edited (a replay case, a Python dict) gets the new model's solve, as a
/// hand-written one does.
CaseTextParameter solve_written_unless_the_models(CaseTextParameter p) {
  p.is_default = [](const CaseFile& c) { return c.solve_mode == default_solve_mode(c.model); };
  return p;
}

/// socket.attachment.bolt sets the bolt's diameter and its clearance hole by ISO 273 beside the
/// name (a hole_diameter_mm read after it overrides the hole).
CaseTextParameter bolt_sets_its_hole(CaseTextParameter p) {
  p.set = [set = p.set](CaseFile& c, const std::string& text, std::string_view name) {
    set(c, text, name);
    SocketAttachment& t = c.socket.attachment;
    t.bolt_diameter_m = bolt_diameter_m(t.bolt);
    t.hole_diameter_m = clearance_hole_diameter_m(t.bolt);
  };
  return p;
}
}  // namespace

// One line a parameter: the member, its limit (key, unit, range, hint — input_limits.h) and when
// it is written. Read in this order, so the first bad value of a section is the one reported.
const std::vector<CaseParameter>& case_parameters() {
  using namespace limits;
  static const std::vector<CaseParameter> table{
      number<&C::limb, &CaseLimb::scale>(kScale, W::UnlessDefault),
      number<&C::limb, &CaseLimb::cut_height_m>(kCutHeight, W::UnlessDefault),
      flag<&C::limb, &CaseLimb::force_size>("limb.force_size", "accept a limb outside its type's size range",
                                            W::UnlessDefault),
      number<&C::patient, &PatientLoad::body_mass_kg>(kBodyMass),
      number<&C::patient, &PatientLoad::prosthesis_mass_kg>(kProsthesisMass),
      number<&C::patient, &PatientLoad::friction>(kFriction),
      number<&C::patient, &PatientLoad::force_tolerance>(kForceTolerance),
      number<&C::patient, &PatientLoad::torque_tolerance>(kTorqueTolerance),
      number<&C::youngs_modulus_pa>(kYoungsModulus),
      number<&C::density_kg_m3>(kDensity),
      number<&C::target_nodes>(kTargetNodes),
      flag<&C::optimise>("design.optimise", "false: solve the spots as given"),
      flag<&C::follow_template>("design.follow_template", "aim at what the brim template means"),
      number<&C::model_pressure_limit>(kModelPressureLimit),
      number<&C::time_limit_s>(kTimeLimit, W::UnlessDefault),
      flag<&C::closed_loop>("design.closed_loop",
                            "don and stand on the socket, correct its wall (default: transtibial true, "
                            "transfemoral false)",
                            W::UnlessDefault),
      number<&C::closed_loop_donnings>(kClosedLoopDonnings),
      number<&C::closed_loop_max_brim_raise_m>(kClosedLoopBrimRaise, W::UnlessDefault),
      number<&C::closed_loop_max_roughness_m>(kClosedLoopRoughness, W::UnlessDefault),
      number<&C::closed_loop_step_m>(kClosedLoopStep, W::UnlessDefault),
      number<&C::brim_flare_m>(kBrimFlare, W::UnlessDefault),
      flag<&C::closed_loop_rigid_wall>("design.closed_loop_rigid_wall",
                                       "closed loop: no penetration of the socket wall (augmented Lagrangian "
                                       "contact; ~1.5x the loop's time)",
                                       W::UnlessDefault),
      flag<&C::closed_loop_drag_band>("design.closed_loop_drag_band",
                                      "closed loop: design again without pressure where donning drags skin out "
                                      "over the brim, keep the better-delivered design",
                                      W::UnlessDefault),
      number<&C::ischial_share_min>(kIschialShareMin, W::UnlessDefault),
      number<&C::socket, &SocketOptions::thickness_m>(kThickness),
      number<&C::socket, &SocketOptions::distal_thickness_m>(kDistalThickness, W::UnlessDefault, true),
      number<&C::socket, &SocketOptions::brim_thickness_m>(kBrimThickness, W::UnlessDefault, true),
      flag<&C::socket, &SocketOptions::distal_pad>("socket.distal_pad", "a flat disc under the distal end"),
      number<&C::socket, &SocketOptions::distal_pad_diameter_m>(kDistalPadDiameter),
      flag<&C::socket, &SocketOptions::round_brim>("socket.round_brim", "a half-round lip along the brim"),
      number<&C::socket, &SocketOptions::subdivisions>(kSubdivisions),
      number<&C::socket, &SocketOptions::alignment, &SocketAlignment::flexion_rad>(kFlexion),
      number<&C::socket, &SocketOptions::alignment, &SocketAlignment::adduction_rad>(kAdduction),
      number<&C::socket, &SocketOptions::attachment, &SocketAttachment::hole_diameter_m>(kHoleDiameter),
      number<&C::socket, &SocketOptions::attachment, &SocketAttachment::hole_spacing_m>(kHoleSpacing),
      number<&C::socket, &SocketOptions::attachment, &SocketAttachment::platform_diameter_m>(kPlatformDiameter),
      number<&C::socket, &SocketOptions::attachment, &SocketAttachment::platform_thickness_m>(kPlatformThickness),
      number<&C::socket, &SocketOptions::attachment, &SocketAttachment::rotation_rad>(kAttachmentRotation),
  };
  return table;
}

const std::vector<SpotParameter>& spot_parameters() {
  using namespace limits;
  static const std::vector<SpotParameter> table{
      number<&S::amplitude_pa>(kSpotAmplitude),
      number<&S::theta0>(kSpotTheta0, W::ForItsSpotType),
      number<&S::r_theta>(kSpotRTheta, W::ForItsSpotType),
      number<&S::h0>(kSpotH0, W::ForItsSpotType),
      number<&S::r_h>(kSpotRH, W::ForItsSpotType),
      number<&S::theta1>(kSpotTheta1, W::ForItsSpotType),
      number<&S::theta2>(kSpotTheta2, W::ForItsSpotType),
      number<&S::lambda_theta>(kSpotLambdaTheta, W::ForItsSpotType),
      number<&S::h1>(kSpotH1, W::ForItsSpotType),
      number<&S::h2>(kSpotH2, W::ForItsSpotType),
      number<&S::lambda_h>(kSpotLambdaH, W::ForItsSpotType),
      flag<&S::enabled>("design.spots[].enabled", "false: kept in the file but not applied", W::UnlessDefault),
      flag<&S::optimise_amplitude>("design.spots[].optimise_amplitude", "the optimiser may change the amplitude",
                                   W::UnlessDefault),
      flag<&S::optimise_position>("design.spots[].optimise_position", "the optimiser may move the spot",
                                  W::UnlessDefault),
      number<&S::max_amplitude_pa>(kMaxAmplitude, W::UnlessDefault),
  };
  return table;
}

// One line a name or text: the member, its key, its help, its names with their values (and the
// kind's own parser where it has one) and when it is written. Read in this order within a section.
const std::vector<CaseTextParameter>& case_text_parameters() {
  static const std::vector<CaseTextParameter> table{
      free_text<&C::limb, &CaseLimb::file>(
          "limb.file", "the scan: STL, OBJ, PLY or AOP, relative to the case file's folder; omitted: the generated "
          "sample limb", W::UnlessDefault,
          "give the scan's path (STL/OBJ/PLY), or remove 'file' to use the generated sample limb"),
      free_text<&C::limb, &CaseLimb::bones>(
          "limb.bones", "auto (bone shells in the file, else estimated) | estimate | none | a bone file", W::Always,
          "give auto, estimate, none or the path of a bone file"),
      kind_text<&C::limb, &CaseLimb::units>(
          "limb.units", "what the limb file's numbers are; omitted: guessed from the size", {"mm", "m"},
          [](const std::string& t) { if (!t.empty()) (void)units::parse_length_unit(t); }, W::UnlessDefault),
      kind<&C::limb, &CaseLimb::type>("limb.type", "the amputation level",
                                      {{"transtibial", LimbType::Transtibial}, {"transfemoral", LimbType::Transfemoral}},
                                      &geometry::parse_limb_type),
      kind<&C::limb, &CaseLimb::side>("limb.side", "the limb's side; omitted: from the fibula / hemipelvis, else estimated",
                                      {{"right", Side::Right}, {"left", Side::Left}}, &geometry::parse_side,
                                      W::UnlessDefault),
      free_text<&C::patient_id>("patient.id", "the patient's identifier, shown in the report", W::UnlessDefault),
      free_text<&C::patient_note>("patient.note", "free text, shown (escaped) in the report", W::UnlessDefault),
      kind_text<&C::model>("tissue.model", "the stump's tissue model (docs/tissue.md)",
                           {"mss-cs", "mss-cf", "mss", "fe", "neo-hookean"}),
      kind_text<&C::constants>("tissue.constants", "the MSS-CS corrective springs' constants",
                               {"cube-targets", "recommended", "thesis", "cube-fit"}),
      kind<&C::element>("tissue.element",
                        "the hexahedra: c3d8 (CalculiX's C3D8) or fbar (F-bar: no volumetric locking; neo-hookean only)",
                        {{"c3d8", tissue::HexFormulation::Full}, {"fbar", tissue::HexFormulation::FBar}},
                        &tissue::parse_hex_formulation, W::UnlessDefault),
      solve_written_unless_the_models(kind<&C::solve_mode>(
          "tissue.solve", "the design solve; omitted: the model's (nonlinear for neo-hookean, else linear)",
          {{"nonlinear", DesignSolveMode::Nonlinear}, {"linear", DesignSolveMode::Linear},
           {"auto", DesignSolveMode::Auto}},
          &parse_design_solve_mode, W::UnlessDefault)),
      kind<&C::objective>("design.objective",
                          "pressure: most even pressure; ratio: most even pressure / threshold; uniform: least CV",
                          {{"pressure", Objective::Pressure}, {"ratio", Objective::Ratio}, {"uniform", Objective::Uniform}}),
      kind<&C::brim>("brim.template", "the brim's shape; omitted: the limb type's (ptb transtibial, ics transfemoral)",
                     {{"ptb", BrimTemplate::Ptb}, {"ptb-sc", BrimTemplate::PtbSc}, {"ptb-scsp", BrimTemplate::PtbScsp},
                      {"kbm", BrimTemplate::Kbm}, {"tsb", BrimTemplate::Tsb}, {"quad", BrimTemplate::Quad},
                      {"ics", BrimTemplate::Ics}, {"custom", BrimTemplate::Custom}},
                     &parse_brim_template, W::UnlessDefault),
      bolt_sets_its_hole(kind_text<&C::socket, &SocketOptions::attachment, &SocketAttachment::bolt>(
          "socket.attachment.bolt", "the adapter's bolt; sets the clearance hole by ISO 273 (medium)",
          {"M4", "M5", "M6", "M8"}, [](const std::string& b) { (void)bolt_diameter_m(b); })),
  };
  return table;
}

const std::vector<SpotTextParameter>& spot_text_parameters() {
  static const std::vector<SpotTextParameter> table{
      free_text<&S::name>("design.spots[].name", "the spot's name", W::Always),
      kind<&S::type>("design.spots[].type", "the spot's shape (thesis Table 6)",
                     {{"cos2", SpotType::Cos2}, {"sig2", SpotType::Sig2}, {"cos-sig", SpotType::CosSig},
                      {"grad", SpotType::Grad}},
                     &parse_spot_type),
  };
  return table;
}

bool spot_type_uses(SpotType type, std::string_view name) {
  const auto any = [&](std::initializer_list<std::string_view> names) {
    for (auto n : names)
      if (n == name) return true;
    return false;
  };
  if (!any({"theta0_deg", "r_theta_deg", "h0_mm", "r_h_mm", "theta1_deg", "theta2_deg", "lambda_theta_per_deg",
            "h1_mm", "h2_mm", "lambda_h_per_mm"}))
    return true;  // the amplitude, the flags and the optimiser's bound
  switch (type) {
    case SpotType::Cos2: return any({"theta0_deg", "r_theta_deg", "h0_mm", "r_h_mm"});
    case SpotType::Sig2:
      return any({"theta1_deg", "theta2_deg", "lambda_theta_per_deg", "h1_mm", "h2_mm", "lambda_h_per_mm"});
    case SpotType::CosSig: return any({"theta0_deg", "r_theta_deg", "h1_mm", "h2_mm", "lambda_h_per_mm"});
    case SpotType::Grad: return any({"h1_mm", "h2_mm"});
  }
  return false;
}

// Read as the hand-written conversions they replace did (the same SI values to the last bit); written
// back by the inverse operation with the same constant, so that a value read, written and read again
// is the same (× 1e-3 then × 1e3 turned 9 mm into 9.000000000000002).
double file_to_si(std::string_view unit, double v) {
  if (unit == "mm") return v * 1e-3;
  if (unit == "kPa") return v * 1e3;
  if (unit == "deg") return v * units::deg;
  if (unit == "1/deg") return v / units::deg;
  if (unit == "1/mm") return v * 1e3;
  return v;
}

double si_to_file(std::string_view unit, double v) {
  if (unit == "mm") return v / 1e-3;
  if (unit == "kPa") return v / 1e3;
  if (unit == "deg") return v / units::deg;
  if (unit == "1/deg") return v * units::deg;
  if (unit == "1/mm") return v / 1e3;
  return v;
}

const CaseParameter* find_case_parameter(std::string_view key) {
  for (const auto& p : case_parameters())
    if (p.key() == key) return &p;
  return nullptr;
}

const SpotParameter* find_spot_parameter(std::string_view name) {
  for (const auto& p : spot_parameters())
    if (p.name() == name) return &p;
  return nullptr;
}

namespace {
template <class Table>
const typename Table::value_type* find_key(const Table& table, std::string_view key) {
  for (const auto& p : table)
    if (p.key == key) return &p;
  return nullptr;
}
}  // namespace

const CaseTextParameter* find_case_text_parameter(std::string_view key) {
  return find_key(case_text_parameters(), key);
}

const SpotTextParameter* find_spot_text_parameter(std::string_view name) {
  for (const auto& p : spot_text_parameters())
    if (p.name() == name) return &p;
  return nullptr;
}

template <class Owner>
std::string listed_names(const TextParameter<Owner>& p) {
  return listed(p.names);
}

void set_case_text(CaseFile& c, std::string_view key, const std::string& text, std::string_view name) {
  const CaseTextParameter* p = find_case_text_parameter(key);
  require(p != nullptr, "{}: '{}' is not a name or text of the case file (design/case_parameters.h)", name, key);
  p->set(c, text, name);
}

template <class Owner>
double file_value(const Parameter<Owner>& p, const Owner& owner) {
  return p.is_flag ? p.get(owner) : si_to_file(p.limit.unit, p.get(owner));
}

template <class Owner>
void set_file_value(const Parameter<Owner>& p, Owner& owner, double value, std::string_view name) {
  if (p.is_flag) return p.set(owner, value != 0.0 ? 1.0 : 0.0);
  if (p.is_zero_unset && value == 0.0) return p.set(owner, 0.0);
  const double v = p.limit.is_integer ? check_input_count(p.limit, value, name) : check_input(p.limit, value, name);
  p.set(owner, file_to_si(p.limit.unit, v));
}

void set_case_value(CaseFile& c, std::string_view key, double value, std::string_view name) {
  const CaseParameter* p = find_case_parameter(key);
  require(p != nullptr, "{}: '{}' is not a parameter of the case file (design/case_parameters.h)", name, key);
  set_file_value(*p, c, value, name);
}

namespace {
template <class Owner>
const std::vector<Parameter<Owner>>& parameters() {
  if constexpr (std::is_same_v<Owner, Spot>) return spot_parameters();
  else return case_parameters();
}

template <class Owner>
const std::vector<TextParameter<Owner>>& text_parameters() {
  if constexpr (std::is_same_v<Owner, Spot>) return spot_text_parameters();
  else return case_text_parameters();
}

bool same(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

template <class Owner>
bool is_written(const Parameter<Owner>& p, const Owner& owner) {
  static const Owner kDefault{};
  switch (p.written) {
    case Written::Always: return true;
    case Written::UnlessDefault: return !same(p.get(owner), p.get(kDefault));
    case Written::ForItsSpotType:
      if constexpr (std::is_same_v<Owner, Spot>) return spot_type_uses(owner.type, p.name());
      return true;
  }
  return true;
}
}  // namespace

template <class Owner>
void read_parameters(const json& j, std::string_view section, const std::string& where, Owner& owner) {
  for (const auto& p : parameters<Owner>()) {
    const std::string key(p.name());
    if (p.section() != section || !j.contains(key)) continue;
    if (p.is_flag) p.set(owner, detail::flag(j, key, where, false) ? 1.0 : 0.0);
    else set_file_value(p, owner, detail::number(j, key, where, 0.0), fmt::format("case file: {}.{}", where, key));
  }
}

template <class Owner>
void write_parameters(json& j, std::string_view section, const Owner& owner) {
  for (const auto& p : parameters<Owner>()) {
    if (p.section() != section || !is_written(p, owner)) continue;
    const std::string key(p.name());
    if (p.is_flag) j[key] = p.get(owner) != 0.0;
    else if (p.limit.is_integer) j[key] = static_cast<int>(p.get(owner));
    else j[key] = file_value(p, owner);
  }
}

template <class Owner>
void read_text_parameters(const json& j, std::string_view section, const std::string& where, Owner& owner) {
  for (const auto& p : text_parameters<Owner>()) {
    const std::string key(p.name());
    if (p.section() != section || !j.contains(key)) continue;
    p.set(owner, detail::text(j, key, where, ""), fmt::format("case file: {}.{}", where, key));
  }
}

template <class Owner>
void write_text_parameters(json& j, std::string_view section, const Owner& owner) {
  for (const auto& p : text_parameters<Owner>())
    if (p.section() == section && (p.written == Written::Always || !p.is_default(owner)))
      j[std::string(p.name())] = p.get(owner);
}

std::set<std::string> section_keys(std::string_view section, std::set<std::string> others) {
  const auto add = [&](const auto& table) {
    for (const auto& p : table)
      if (p.section() == section) others.emplace(p.name());
  };
  add(case_parameters());
  add(spot_parameters());
  add(case_text_parameters());
  add(spot_text_parameters());
  return others;
}

template double file_value(const CaseParameter&, const CaseFile&);
template double file_value(const SpotParameter&, const Spot&);
template void set_file_value(const CaseParameter&, CaseFile&, double, std::string_view);
template void set_file_value(const SpotParameter&, Spot&, double, std::string_view);
template void read_parameters(const json&, std::string_view, const std::string&, CaseFile&);
template void read_parameters(const json&, std::string_view, const std::string&, Spot&);
template void write_parameters(json&, std::string_view, const CaseFile&);
template void write_parameters(json&, std::string_view, const Spot&);
template std::string listed_names(const CaseTextParameter&);
template std::string listed_names(const SpotTextParameter&);
template void read_text_parameters(const json&, std::string_view, const std::string&, CaseFile&);
template void read_text_parameters(const json&, std::string_view, const std::string&, Spot&);
template void write_text_parameters(json&, std::string_view, const CaseFile&);
template void write_text_parameters(json&, std::string_view, const Spot&);

}  // namespace socketsmith::design
